//! Per-particle local event lists of constant length (paper 001, §5.4 step 4).

use crate::boundary::WallId;

/// Events kept per particle. A particle's predictions beyond the earliest few are dropped and
/// recomputed when the kept ones are used up (the list remembers that it was truncated).
/// Measured: see BENCHMARKS.md.
pub(super) const LOCAL_CAPACITY: usize = 3;

/// What an event does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum EventKind {
    /// Collision with the partner, valid while the partner's counter equals the stored one.
    Collision { partner: u32, partner_count: u32 },
    /// Contact with a wall of the container.
    Wall(WallId),
    /// The particle reaches the surface of its neighbour-list sphere.
    NeighbourList,
}

/// One predicted event, packed into 16 bytes: the time, and either a partner with its
/// counter or (for the particle's own events) a tag in the counter slot with
/// `partner = OWN`.
#[derive(Clone, Copy, Debug)]
pub(super) struct LocalEvent {
    pub(super) time: f64,
    partner: u32,
    tag: u32,
}

const OWN: u32 = u32::MAX;
const NEIGHBOUR_TAG: u32 = u32::MAX;

impl LocalEvent {
    pub(super) fn new(time: f64, kind: EventKind) -> Self {
        let (partner, tag) = match kind {
            EventKind::Collision {
                partner,
                partner_count,
            } => (partner, partner_count),
            EventKind::Wall(w) => (OWN, u32::from(w)),
            EventKind::NeighbourList => (OWN, NEIGHBOUR_TAG),
        };
        Self { time, partner, tag }
    }

    #[inline]
    pub(super) fn kind(&self) -> EventKind {
        match (self.partner, self.tag) {
            (OWN, NEIGHBOUR_TAG) => EventKind::NeighbourList,
            (OWN, w) => EventKind::Wall(w as WallId),
            (partner, partner_count) => EventKind::Collision {
                partner,
                partner_count,
            },
        }
    }
}

/// The earliest [`LOCAL_CAPACITY`] events predicted for one particle since its list was last
/// cleared.
///
/// Invariant: every event predicted since the last clear that is not in the list is later
/// than every event in the list. So when the list runs empty while `truncated` is set, the
/// particle must be predicted afresh; when it runs empty otherwise, it has no event before the
/// barrier.
#[derive(Clone, Copy, Debug)]
pub(super) struct LocalList {
    events: [LocalEvent; LOCAL_CAPACITY],
    len: u8,
    truncated: bool,
}

impl Default for LocalList {
    fn default() -> Self {
        Self {
            events: [LocalEvent {
                time: 0.0,
                partner: OWN,
                tag: 0,
            }; LOCAL_CAPACITY],
            len: 0,
            truncated: false,
        }
    }
}

impl LocalList {
    #[inline]
    pub(super) fn clear(&mut self) {
        self.len = 0;
        self.truncated = false;
    }

    #[inline]
    pub(super) fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Whether predictions were dropped since the last clear.
    #[inline]
    pub(super) fn truncated(&self) -> bool {
        self.truncated
    }

    /// Adds an event; when full, the latest event (this one or a kept one) is dropped.
    #[inline]
    pub(super) fn push(&mut self, event: LocalEvent) {
        let len = self.len as usize;
        if len < LOCAL_CAPACITY {
            self.events[len] = event;
            self.len += 1;
            return;
        }
        self.truncated = true;
        let mut latest = 0;
        for k in 1..LOCAL_CAPACITY {
            if self.events[k].time > self.events[latest].time {
                latest = k;
            }
        }
        if event.time < self.events[latest].time {
            self.events[latest] = event;
        }
    }

    /// Index and copy of the earliest event (the first one on ties).
    #[inline]
    pub(super) fn earliest(&self) -> Option<(usize, LocalEvent)> {
        let events = &self.events[..self.len as usize];
        let mut best: Option<(usize, LocalEvent)> = None;
        for (k, e) in events.iter().enumerate() {
            if best.is_none_or(|(_, b)| e.time < b.time) {
                best = Some((k, *e));
            }
        }
        best
    }

    /// Removes the event at `index`.
    #[inline]
    pub(super) fn remove(&mut self, index: usize) {
        let last = self.len as usize - 1;
        self.events[index] = self.events[last];
        self.len -= 1;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn full_list_keeps_the_earliest_events() {
        let mut list = LocalList::default();
        for t in [5.0, 1.0, 7.0, 3.0, 2.0, 9.0] {
            list.push(LocalEvent::new(t, EventKind::NeighbourList));
        }
        assert!(list.truncated());
        let mut kept = Vec::new();
        while let Some((k, e)) = list.earliest() {
            kept.push(e.time);
            list.remove(k);
        }
        assert_eq!(kept, [1.0, 2.0, 3.0, 5.0][..LOCAL_CAPACITY]);
    }

    #[test]
    fn kinds_round_trip_through_the_packed_form() {
        for kind in [
            EventKind::Collision {
                partner: 7,
                partner_count: 42,
            },
            EventKind::Wall(3),
            EventKind::NeighbourList,
        ] {
            assert_eq!(LocalEvent::new(1.0, kind).kind(), kind);
        }
        assert_eq!(std::mem::size_of::<LocalEvent>(), 16);
    }
}
