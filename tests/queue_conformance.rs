//! Conformance of the event queues: [`HeapQueue`] and [`CalendarQueue`] run in lockstep with
//! a reference queue (a `BTreeSet` ordered by `(time via total_cmp, key)`), and every `peek`,
//! `pop` and `len` must agree exactly (times compared bit for bit).

use densepack::queue::{CalendarQueue, EventQueue, HeapQueue};
use proptest::prelude::*;
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::cmp::Ordering;
use std::collections::BTreeSet;

/// A time ordered by `f64::total_cmp`.
#[derive(Clone, Copy, Debug)]
struct Time(f64);

impl PartialEq for Time {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}
impl Eq for Time {}
impl PartialOrd for Time {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}
impl Ord for Time {
    fn cmp(&self, other: &Self) -> Ordering {
        self.0.total_cmp(&other.0)
    }
}

/// Reference queue: the obvious implementation of the `EventQueue` contract.
struct Reference {
    time: Vec<Option<f64>>,
    set: BTreeSet<(Time, usize)>,
}

impl Reference {
    fn new(capacity: usize) -> Self {
        Self {
            time: vec![None; capacity],
            set: BTreeSet::new(),
        }
    }
    fn reset(&mut self) {
        self.time.iter_mut().for_each(|t| *t = None);
        self.set.clear();
    }
    fn schedule(&mut self, key: usize, t: f64) {
        self.cancel(key);
        self.time[key] = Some(t);
        self.set.insert((Time(t), key));
    }
    fn cancel(&mut self, key: usize) {
        if let Some(t) = self.time[key].take() {
            assert!(self.set.remove(&(Time(t), key)));
        }
    }
    fn peek(&self) -> Option<(usize, f64)> {
        self.set.first().map(|&(t, k)| (k, t.0))
    }
    fn pop(&mut self) -> Option<(usize, f64)> {
        let (t, k) = self.set.pop_first()?;
        self.time[k] = None;
        Some((k, t.0))
    }
    fn len(&self) -> usize {
        self.set.len()
    }
    fn contains(&self, key: usize) -> bool {
        self.time[key].is_some()
    }
}

/// One queue operation.
#[derive(Clone, Copy, Debug)]
enum Op {
    Schedule(usize, f64),
    Cancel(usize),
    Pop,
    Peek,
    Reset(f64, f64, usize),
}

/// The reference and both queues under test, driven in lockstep.
struct Lockstep {
    reference: Reference,
    heap: HeapQueue,
    calendar: CalendarQueue,
    step: usize,
}

/// Compares entries bit for bit (`-0.0` differs from `0.0`).
fn bits(e: Option<(usize, f64)>) -> Option<(usize, u64)> {
    e.map(|(k, t)| (k, t.to_bits()))
}

impl Lockstep {
    fn new(capacity: usize) -> Self {
        Self {
            reference: Reference::new(capacity),
            heap: HeapQueue::with_capacity(capacity),
            calendar: CalendarQueue::with_capacity(capacity),
            step: 0,
        }
    }

    fn check_len(&self) {
        let n = self.reference.len();
        assert_eq!(self.heap.len(), n, "heap len, step {}", self.step);
        assert_eq!(self.calendar.len(), n, "calendar len, step {}", self.step);
        assert_eq!(self.calendar.is_empty(), n == 0);
    }

    fn compare(
        &self,
        what: &str,
        want: Option<(usize, f64)>,
        heap: Option<(usize, f64)>,
        cal: Option<(usize, f64)>,
    ) {
        assert_eq!(bits(heap), bits(want), "heap {what}, step {}", self.step);
        assert_eq!(bits(cal), bits(want), "calendar {what}, step {}", self.step);
    }

    fn apply(&mut self, op: Op) -> Option<(usize, f64)> {
        self.step += 1;
        let out = match op {
            Op::Schedule(k, t) => {
                self.reference.schedule(k, t);
                self.heap.schedule(k, t);
                self.calendar.schedule(k, t);
                None
            }
            Op::Cancel(k) => {
                self.reference.cancel(k);
                self.heap.cancel(k);
                self.calendar.cancel(k);
                None
            }
            Op::Pop => {
                let want = self.reference.pop();
                let (h, c) = (self.heap.pop(), self.calendar.pop());
                self.compare("pop", want, h, c);
                want
            }
            Op::Peek => {
                let want = self.reference.peek();
                let (h, c) = (self.heap.peek(), self.calendar.peek());
                self.compare("peek", want, h, c);
                want
            }
            Op::Reset(start, end, n) => {
                self.reference.reset();
                self.heap.reset(start, end, n);
                self.calendar.reset(start, end, n);
                None
            }
        };
        self.check_len();
        out
    }

    fn drain(&mut self) {
        while self.apply(Op::Pop).is_some() {}
        assert!(self.calendar.is_empty() && self.heap.is_empty());
    }
}

fn exp(rng: &mut Xoshiro256PlusPlus, mean: f64) -> f64 {
    -(1.0 - rng.gen::<f64>()).ln() * mean
}

/// A time for a window `[a, b]`: mostly inside, with many exact ties, some outside.
fn window_time(rng: &mut Xoshiro256PlusPlus, a: f64, b: f64, hostile: bool) -> f64 {
    let w = b - a;
    match rng.gen_range(0..100) {
        0..=44 => a + w * rng.gen::<f64>(),
        // Exact ties on a coarse grid.
        45..=64 => a + w * f64::from(rng.gen_range(0u8..8)) / 8.0,
        65..=69 => a,
        70..=77 => b + w * rng.gen::<f64>(),
        78..=83 => a - 0.1 * w * rng.gen::<f64>(),
        84..=87 => a + w * 1e3 * rng.gen::<f64>(),
        88..=91 => (rng.gen::<f64>() - 0.5) * 1e9,
        _ if !hostile => a + w * 1e-9 * rng.gen::<f64>(),
        92 => f64::INFINITY,
        93 => f64::NEG_INFINITY,
        94 => -0.0,
        95 => 0.0,
        96 => f64::MIN_POSITIVE / 4.0,
        97 => f64::MAX,
        98 => -f64::MAX,
        _ => 1e300 * rng.gen::<f64>(),
    }
}

/// Random operations generated online (reschedules pick present keys), with or without
/// resets.
fn random_run(seed: u64, capacity: usize, steps: usize, resets: bool, hostile: bool) {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mut q = Lockstep::new(capacity);
    let (mut a, mut b) = (0.0, 100.0);
    let mut now = 0.0;
    for _ in 0..steps {
        let op = match rng.gen_range(0..1000) {
            0..=349 => Op::Schedule(
                rng.gen_range(0..capacity),
                window_time(&mut rng, a, b, hostile),
            ),
            350..=499 => {
                // Reschedule a present key, typically into the near future of `now`.
                let k = rng.gen_range(0..capacity);
                if q.reference.contains(k) {
                    Op::Schedule(k, now + exp(&mut rng, (b - a) / capacity as f64))
                } else {
                    Op::Peek
                }
            }
            500..=599 => Op::Cancel(rng.gen_range(0..capacity)),
            600..=849 => Op::Pop,
            850..=994 => Op::Peek,
            _ if resets => {
                a = now + 10.0 * rng.gen::<f64>();
                b = a + 10f64.powf(rng.gen_range(-3.0..3.0));
                let expected = match rng.gen_range(0..4) {
                    0 => 0,
                    1 => capacity * 10,
                    _ => capacity,
                };
                match rng.gen_range(0..10) {
                    0 => Op::Reset(a, a, expected),
                    1 => Op::Reset(b, a, expected),
                    2 => Op::Reset(a, f64::INFINITY, expected),
                    _ => Op::Reset(a, b, expected),
                }
            }
            _ => Op::Pop,
        };
        if let Some((_, t)) = q.apply(op) {
            if matches!(op, Op::Pop) && t.is_finite() {
                now = t;
            }
        }
    }
    q.drain();
}

#[test]
fn random_ops_with_resets_match_reference() {
    for (seed, capacity) in [(1, 4), (2, 16), (3, 100), (4, 1000), (5, 5000)] {
        random_run(seed, capacity, 200_000, true, false);
    }
}

#[test]
fn random_ops_without_reset_match_reference() {
    for (seed, capacity) in [(11, 4), (12, 16), (13, 100), (14, 1000), (15, 5000)] {
        random_run(seed, capacity, 200_000, false, false);
    }
}

#[test]
fn hostile_times_match_reference() {
    for (seed, capacity) in [(21, 8), (22, 100), (23, 2000)] {
        random_run(seed, capacity, 100_000, true, true);
        random_run(seed + 100, capacity, 100_000, false, true);
    }
}

/// Fill with exact ties only: the order is decided by the keys alone.
#[test]
fn all_ties_are_broken_by_key() {
    let n = 3000;
    let mut q = Lockstep::new(n);
    q.apply(Op::Reset(0.0, 1.0, n));
    for k in (0..n).rev() {
        q.apply(Op::Schedule(k, 0.5));
    }
    for k in (0..n).step_by(7) {
        q.apply(Op::Cancel(k));
    }
    q.drain();
    // And without a reset, with two tie levels.
    let mut q = Lockstep::new(n);
    for k in 0..n {
        q.apply(Op::Schedule(
            (k * 7919) % n,
            if k % 3 == 0 { 2.0 } else { 1.0 },
        ));
    }
    q.drain();
}

/// The kernel's pattern: pop the earliest event at `t`, schedule the popped key and a few
/// partners at `t` plus small positive increments (sometimes zero, sometimes a rounding
/// error below `t`); a barrier every few thousand events resets the queue.
fn edmd_run(seed: u64, n: usize, events: usize, barriers: bool) {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let tau = 1.0 / n as f64; // mean time between events
    let period = 2000.0 * tau;
    let mut q = Lockstep::new(n);
    let barrier = |q: &mut Lockstep, rng: &mut Xoshiro256PlusPlus, t: f64| {
        q.apply(Op::Reset(t, t + period, n));
        for k in 0..n {
            q.apply(Op::Schedule(k, t + exp(rng, 1.0)));
        }
    };
    if barriers {
        barrier(&mut q, &mut rng, 0.0);
    } else {
        for k in 0..n {
            q.apply(Op::Schedule(k, exp(&mut rng, 1.0)));
        }
    }
    for i in 1..=events {
        let (k, t) = q.apply(Op::Pop).expect("queue never runs empty");
        if barriers && i % 5000 == 0 {
            barrier(&mut q, &mut rng, t);
            continue;
        }
        let dt = match rng.gen_range(0..20) {
            0 => 0.0,
            1 => -1e-14 * t.abs(),
            2 => f64::from(rng.gen_range(1u8..4)) * tau, // ties between events
            _ => exp(&mut rng, 1.0),
        };
        q.apply(Op::Schedule(k, t + dt));
        for _ in 0..rng.gen_range(0..4) {
            let partner = rng.gen_range(0..n);
            if rng.gen_bool(0.2) {
                q.apply(Op::Cancel(partner));
            } else {
                q.apply(Op::Schedule(partner, t + exp(&mut rng, 1.0)));
            }
        }
        if q.reference.len() < n / 2 {
            // Keep the population up: reinsert cancelled keys.
            for p in 0..n {
                if !q.reference.contains(p) {
                    q.apply(Op::Schedule(p, t + exp(&mut rng, 1.0)));
                }
            }
        }
    }
    q.drain();
}

#[test]
fn edmd_pattern_with_barriers_matches_reference() {
    edmd_run(31, 1000, 100_000, true);
    edmd_run(32, 20_000, 100_000, true);
}

#[test]
fn edmd_pattern_without_reset_matches_reference() {
    edmd_run(41, 1000, 100_000, false);
    edmd_run(42, 20_000, 100_000, false);
}

const KEYS: usize = 24;

fn time_strategy() -> impl Strategy<Value = f64> {
    prop_oneof![
        4 => 0.0..100.0f64,
        4 => (0u8..6).prop_map(|j| f64::from(j) * 12.5),
        1 => -1e3..0.0f64,
        1 => 100.0..1e4f64,
        1 => prop::num::f64::NORMAL | prop::num::f64::ZERO,
    ]
}

fn op_strategy() -> impl Strategy<Value = Op> {
    prop_oneof![
        6 => (0..KEYS, time_strategy()).prop_map(|(k, t)| Op::Schedule(k, t)),
        1 => (0..KEYS).prop_map(Op::Cancel),
        4 => Just(Op::Pop),
        2 => Just(Op::Peek),
        1 => (time_strategy(), 0.0..200.0f64, 0usize..64)
            .prop_map(|(s, w, n)| Op::Reset(s, s + w, n)),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    #[test]
    fn proptest_ops_match_reference(ops in prop::collection::vec(op_strategy(), 0..400)) {
        let mut q = Lockstep::new(KEYS);
        for op in ops {
            q.apply(op);
        }
        q.drain();
    }
}
