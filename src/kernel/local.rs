//! Per-particle local event lists of constant length (paper 001, §5.4 step 4).

use crate::boundary::WallId;

/// Events kept per particle. A particle's predictions beyond the earliest few are dropped and
/// recomputed when the kept ones are used up (the list remembers that it was truncated).
/// Two keep a list in 32 bytes (48 with three), for 1.9 % of events re-predicting a
/// particle in the φ = 0.5 fluid at 10⁵ spheres (0.17 % with three) and 0.46 % on the way
/// to jamming (0.02 %): about 1 % more prediction passes for 16 B less per particle, at
/// equal speed (BENCHMARKS.md, "Defaults").
pub(super) const LOCAL_CAPACITY: usize = 2;

/// What an event does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum EventKind {
    /// Collision with the partner, predicted during event `predicted_in` of the barrier
    /// interval: valid while the partner's trajectory has not changed in a later event
    /// (`Edmd::changed_in`).
    Collision { partner: u32, predicted_in: u32 },
    /// Contact with a wall of the container.
    Wall(WallId),
    /// The particle reaches the surface of its neighbour-list sphere.
    NeighbourList,
}

/// One predicted event, packed into 16 bytes: the time, and either a partner with the
/// number of the event that predicted it or (for the particle's own events) a tag in that
/// slot with `partner = OWN`.
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
                predicted_in,
            } => (partner, predicted_in),
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
            (partner, predicted_in) => EventKind::Collision {
                partner,
                predicted_in,
            },
        }
    }
}

/// The earliest [`LOCAL_CAPACITY`] events predicted for one particle since its list was last
/// cleared: a working copy of one entry of [`LocalLists`]. A slot whose time is `+∞` is
/// empty (no prediction is ever that late: every one lies before the barrier).
///
/// Invariant: every event predicted since the last clear that is not in the list is later
/// than every event in the list. So when the list runs empty while `truncated` is set, the
/// particle must be predicted afresh; when it runs empty otherwise, it has no event before the
/// barrier.
#[derive(Clone, Copy, Debug)]
pub(super) struct LocalList {
    events: [LocalEvent; LOCAL_CAPACITY],
    truncated: bool,
}

/// An empty slot.
const EMPTY: LocalEvent = LocalEvent {
    time: f64::INFINITY,
    partner: OWN,
    tag: 0,
};

impl Default for LocalList {
    fn default() -> Self {
        Self {
            events: [EMPTY; LOCAL_CAPACITY],
            truncated: false,
        }
    }
}

impl LocalList {
    /// Adds an event to the first empty slot; when none is left, the latest event (this one
    /// or a kept one) is dropped.
    #[inline]
    pub(super) fn push(&mut self, event: LocalEvent) {
        if let Some(slot) = self.events.iter_mut().find(|e| e.time == f64::INFINITY) {
            *slot = event;
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

    /// Records that predictions were dropped: the list must be predicted afresh when it runs
    /// empty.
    #[inline]
    pub(super) fn mark_truncated(&mut self) {
        self.truncated = true;
    }
}

/// Whether every slot of `events` is empty.
#[inline]
fn all_empty(events: &[LocalEvent; LOCAL_CAPACITY]) -> bool {
    events.iter().all(|e| e.time == f64::INFINITY)
}

/// Index and copy of the earliest event of `events` (the first slot on ties), `None` if all
/// slots are empty.
#[inline]
fn earliest_of(events: &[LocalEvent; LOCAL_CAPACITY]) -> Option<(usize, LocalEvent)> {
    let mut best = 0;
    for k in 1..LOCAL_CAPACITY {
        if events[k].time < events[best].time {
            best = k;
        }
    }
    let event = events[best];
    (event.time < f64::INFINITY).then_some((best, event))
}

/// The stored events of one list, aligned to their size so that a list never straddles a
/// cache line (one line fetched per list popped or pushed).
#[derive(Clone, Copy, Debug)]
#[repr(align(32))]
struct Slots([LocalEvent; LOCAL_CAPACITY]);

/// The local event lists of all particles, stored as two arrays: the events (32 bytes per
/// particle) and the truncation flags (one byte). One array of [`LocalList`] would pad each
/// entry to 40 bytes for its flag; at 10⁶ particles the split saves 7 bytes per particle of
/// peak memory (the target is 250 B per particle).
#[derive(Clone, Debug)]
pub(super) struct LocalLists {
    events: Vec<Slots>,
    truncated: Vec<bool>,
}

impl LocalLists {
    /// The events of list `i`, empty slots included (tests).
    #[cfg(test)]
    pub(super) fn events(&self, i: usize) -> &[LocalEvent; LOCAL_CAPACITY] {
        &self.events[i].0
    }

    /// `n` empty lists.
    pub(super) fn new(n: usize) -> Self {
        Self {
            events: vec![Slots([EMPTY; LOCAL_CAPACITY]); n],
            truncated: vec![false; n],
        }
    }

    /// Stores `list` as list `i`.
    #[inline]
    pub(super) fn set(&mut self, i: usize, list: LocalList) {
        self.events[i] = Slots(list.events);
        self.truncated[i] = list.truncated;
    }

    /// Index and copy of the earliest event of list `i` ([`LocalList::earliest`]).
    #[inline]
    pub(super) fn earliest(&self, i: usize) -> Option<(usize, LocalEvent)> {
        // The events alone: the flag array is another cache line, not needed to pop.
        earliest_of(&self.events[i].0)
    }

    /// Asks the memory system for the events of list `i` ([`crate::prefetch`]).
    #[inline]
    pub(super) fn prefetch(&self, i: usize) {
        crate::prefetch(&self.events[i]);
    }

    /// Removes the event at `index` of list `i`.
    #[inline]
    pub(super) fn remove(&mut self, i: usize, index: usize) {
        self.events[i].0[index] = EMPTY;
    }

    /// Whether list `i` ran empty after predictions were dropped (the particle must be
    /// predicted afresh).
    #[inline]
    pub(super) fn exhausted(&self, i: usize) -> bool {
        // The events first (just written or read by the caller); the flag only when empty.
        all_empty(&self.events[i].0) && self.truncated[i]
    }

    /// Whether list `i` was truncated (tests).
    #[cfg(test)]
    pub(super) fn truncated(&self, i: usize) -> bool {
        self.truncated[i]
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
        assert!(list.truncated);
        let mut lists = LocalLists::new(2);
        lists.set(1, list);
        let mut kept = Vec::new();
        while let Some((k, e)) = lists.earliest(1) {
            kept.push(e.time);
            lists.remove(1, k);
        }
        assert_eq!(kept, [1.0, 2.0, 3.0, 5.0][..LOCAL_CAPACITY]);
        assert!(lists.exhausted(1), "emptied after dropping predictions");
        assert!(!lists.exhausted(0), "never truncated");
        lists.set(1, LocalList::default());
        assert!(!lists.exhausted(1));
        assert!(lists.earliest(1).is_none());
    }

    #[test]
    fn kinds_round_trip_through_the_packed_form() {
        for kind in [
            EventKind::Collision {
                partner: 7,
                predicted_in: 42,
            },
            EventKind::Wall(3),
            EventKind::NeighbourList,
        ] {
            assert_eq!(LocalEvent::new(1.0, kind).kind(), kind);
        }
        assert_eq!(std::mem::size_of::<LocalEvent>(), 16);
        // The stored part of a list is its events alone (the flag lives in its own array).
        assert_eq!(std::mem::size_of::<Slots>(), 32);
        assert_eq!(std::mem::align_of::<Slots>(), 32);
    }
}
