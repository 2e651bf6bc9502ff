//! The sorter: the event queue of the EDMD kernel.
//!
//! The kernel keeps every particle's predicted events in that particle's own *local event
//! list* and puts only the earliest of them into the global queue, keyed by the particle
//! index. A queue therefore stores at most one entry per key `0..capacity`, and the kernel
//! changes an entry whenever a particle's local list changes. Invalidating a particle's
//! events is `cancel(key)` or a new `schedule(key, t)`: the queue is never scanned.
//!
//! Ordering is total and deterministic: entries are ordered by time (`f64::total_cmp`) and
//! ties are broken by the smaller key, so every implementation yields the same trajectory for
//! the same seed.
//!
//! Two implementations: [`HeapQueue`], an indexed binary heap built on the `priority-queue`
//! crate, and [`CalendarQueue`], a calendar queue after Paul (2007), *J. Comput. Phys.* 221:615.

mod calendar;
mod heap;

pub use calendar::CalendarQueue;
pub use heap::HeapQueue;

/// Length of [`EventQueue::upcoming`]'s hint.
pub const UPCOMING: usize = 4;

/// A priority queue of at most one pending time per key, keys in `0..capacity`.
///
/// Contract every implementation must honour (checked by the conformance tests against a
/// reference queue built on `std::collections::BinaryHeap`):
/// - `schedule(k, t)` inserts key `k` with time `t`, or replaces the time `k` already had;
/// - `cancel(k)` removes `k` if present and is a no-op otherwise;
/// - `peek()` returns the entry with the smallest `(time, key)` pair, times compared with
///   `f64::total_cmp`; `pop()` returns the same entry and removes it;
/// - times are finite; scheduled times are never earlier than the time of the last popped
///   entry minus rounding (the kernel only schedules events in the present or future),
///   and never later than the `end` of the current [`EventQueue::reset`] by more than
///   rounding; implementations must stay correct (if slower) when these are violated.
pub trait EventQueue {
    /// An empty queue for keys `0..capacity`.
    fn with_capacity(capacity: usize) -> Self
    where
        Self: Sized;
    /// Empties the queue and prepares it for events in the time window `[start, end]`
    /// (the kernel calls it at every time barrier before re-predicting all events).
    /// `expected_len` is the number of entries about to be scheduled. A queue that does not
    /// need the hint ignores it.
    fn reset(&mut self, start: f64, end: f64, expected_len: usize);
    /// Inserts `key` at `time` or moves it there.
    fn schedule(&mut self, key: usize, time: f64);
    /// Removes `key` if it is present.
    fn cancel(&mut self, key: usize);
    /// The entry with the smallest `(time, key)`, if any.
    fn peek(&mut self) -> Option<(usize, f64)>;
    /// Removes and returns the entry with the smallest `(time, key)`, if any.
    fn pop(&mut self) -> Option<(usize, f64)>;
    /// Keys likely to be peeked soon after the current earliest one, the likeliest next first
    /// and the candidates for the event after that in the other places: a hint (the kernel
    /// asks the memory system for their data while it processes the current event), with no
    /// guarantee of order or presence. None by default.
    fn upcoming(&self) -> [Option<usize>; UPCOMING] {
        [None; UPCOMING]
    }
    /// Asks the memory system for what the queue keeps of `key`, which the caller is about to
    /// `schedule` or `cancel` (a hint; a no-op by default).
    fn prefetch(&self, _key: usize) {}
    /// Number of entries.
    fn len(&self) -> usize;
    /// Whether the queue holds no entry.
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Which event queue the kernel uses; chosen in the scene file (`queue = "heap" | "calendar"`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum QueueKind {
    /// [`HeapQueue`].
    Heap,
    /// [`CalendarQueue`].
    #[default]
    Calendar,
}
