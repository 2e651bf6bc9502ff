//! The EDMD "hold" pattern on both event queues: pop the earliest entry at `t`, reschedule
//! its key at `t + Exp(1)`, and reschedule a random other key at `t + Exp(1)` (a collision
//! partner whose events were invalidated). One iteration is one such hold operation.
//!
//! `cargo bench --bench queues`

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use densepack::queue::{CalendarQueue, EventQueue, HeapQueue};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::time::Duration;

/// Pre-drawn random numbers, cycled through so the benchmark times the queue, not the RNG.
struct Draws {
    increments: Vec<f64>,
    keys: Vec<usize>,
    next: usize,
}

impl Draws {
    fn new(n: usize, seed: u64) -> Self {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let len = 1 << 16;
        Self {
            increments: (0..len).map(|_| -(1.0 - rng.gen::<f64>()).ln()).collect(),
            keys: (0..len).map(|_| rng.gen_range(0..n)).collect(),
            next: 0,
        }
    }

    #[inline]
    fn draw(&mut self) -> (f64, f64, usize) {
        let mask = self.keys.len() - 1;
        let i = self.next;
        self.next = (i + 1) & mask;
        (
            self.increments[i],
            self.increments[(i + 7919) & mask],
            self.keys[i],
        )
    }
}

/// A queue holding `n` keys at `Exp(1)` times, reset to a window covering them.
fn filled<Q: EventQueue>(n: usize) -> Q {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(1);
    let mut q = Q::with_capacity(n);
    q.reset(0.0, 8.0, n);
    for k in 0..n {
        q.schedule(k, -(1.0 - rng.gen::<f64>()).ln());
    }
    q
}

#[inline]
fn hold<Q: EventQueue>(q: &mut Q, draws: &mut Draws) {
    let (dt, dt_partner, partner) = draws.draw();
    let (k, t) = q.pop().expect("the hold pattern keeps the queue full");
    q.schedule(k, t + dt);
    q.schedule(partner, t + dt_partner);
}

fn bench_queue<Q: EventQueue>(c: &mut Criterion, name: &str) {
    let mut group = c.benchmark_group(format!("hold/{name}"));
    group
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(2));
    for n in [1_000, 10_000, 100_000, 1_000_000] {
        let mut q: Q = filled(n);
        let mut draws = Draws::new(n, 2);
        // Reach the steady state before measuring.
        for _ in 0..2 * n {
            hold(&mut q, &mut draws);
        }
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            b.iter(|| hold(black_box(&mut q), &mut draws))
        });
    }
    group.finish();
}

fn queues(c: &mut Criterion) {
    bench_queue::<HeapQueue>(c, "heap");
    bench_queue::<CalendarQueue>(c, "calendar");
}

criterion_group!(benches, queues);
criterion_main!(benches);
