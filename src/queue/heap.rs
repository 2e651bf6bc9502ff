//! Indexed binary heap on top of the `priority-queue` crate.

use super::EventQueue;
use priority_queue::PriorityQueue;
use std::cmp::{Ordering, Reverse};
use std::hash::{BuildHasherDefault, Hasher};

/// Event time with the total order of `f64::total_cmp`, ties broken by the key.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Stamp {
    time: f64,
    key: usize,
}

impl Eq for Stamp {}

impl PartialOrd for Stamp {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Stamp {
    fn cmp(&self, other: &Self) -> Ordering {
        self.time
            .total_cmp(&other.time)
            .then(self.key.cmp(&other.key))
    }
}

/// Keys are dense particle indices: hashing them through SipHash would only cost time, so
/// the heap's index map uses the key itself as its hash.
#[derive(Default)]
struct IdentityHasher(u64);

impl Hasher for IdentityHasher {
    fn finish(&self) -> u64 {
        self.0
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 << 8) | u64::from(b);
        }
    }
    fn write_usize(&mut self, i: usize) {
        self.0 = i as u64;
    }
}

/// Indexed binary heap: `O(log n)` schedule, cancel and pop, `O(1)` peek.
pub struct HeapQueue {
    heap: PriorityQueue<usize, Reverse<Stamp>, BuildHasherDefault<IdentityHasher>>,
}

impl EventQueue for HeapQueue {
    fn with_capacity(capacity: usize) -> Self {
        Self {
            heap: PriorityQueue::with_capacity_and_default_hasher(capacity),
        }
    }

    fn reset(&mut self, _start: f64, _end: f64, _expected_len: usize) {
        self.heap.clear();
    }

    fn schedule(&mut self, key: usize, time: f64) {
        self.heap.push(key, Reverse(Stamp { time, key }));
    }

    fn cancel(&mut self, key: usize) {
        self.heap.remove(&key);
    }

    fn peek(&mut self) -> Option<(usize, f64)> {
        self.heap.peek().map(|(&k, p)| (k, p.0.time))
    }

    fn pop(&mut self) -> Option<(usize, f64)> {
        self.heap.pop().map(|(k, p)| (k, p.0.time))
    }

    fn len(&self) -> usize {
        self.heap.len()
    }
}
