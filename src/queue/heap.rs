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
/// the heap's index map hashes a key with one multiplication by 2^64 / golden ratio
/// (Fibonacci hashing). The key itself would not do: hashbrown, under the index map, takes
/// each slot's tag from the top 7 bits of the hash, which are zero for every small key, so
/// every probe matches every occupied slot; with the identity hash the hold pattern cost
/// grew about linearly with the queue size (7 µs per hold at 10^5 keys instead of 0.9 µs).
#[derive(Default)]
struct KeyHasher(u64);

impl Hasher for KeyHasher {
    fn finish(&self) -> u64 {
        self.0.wrapping_mul(0x9E37_79B9_7F4A_7C15)
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
    heap: PriorityQueue<usize, Reverse<Stamp>, BuildHasherDefault<KeyHasher>>,
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
