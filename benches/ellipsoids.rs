//! Ellipsoid pair prediction (criterion): time per prediction of the two predictors
//! (certified separating-axis steps, and the paper's η1 roots with Brent's method for the
//! final approach) on random moving, rotating pairs of prolate spheroids. The accuracy table
//! (agreement, largest overlap by the independent check) is the `ellipsoid-predictor` study
//! of `densepack bench`, printed first; the pairs are the same
//! ([`densepack::bench::ellipsoid::pairs`]).
//!
//! `cargo bench --bench ellipsoids`

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use densepack::bench::ellipsoid::{pairs, predictor, PREDICTORS};
use densepack::bench::StudyContext;
use std::time::Duration;

fn bench(c: &mut Criterion) {
    let context = StudyContext {
        quick: false,
        memory_child: Vec::new(),
    };
    println!("{}", predictor(&context).markdown);
    let mut group = c.benchmark_group("ellipsoid_pair_prediction");
    group.measurement_time(Duration::from_secs(3));
    for ratio in [1.5, 5.0, 20.0, 50.0] {
        let set = pairs(ratio, 256);
        for (mode, name) in PREDICTORS {
            group.bench_with_input(BenchmarkId::new(name, ratio), &set, |b, set| {
                let mut i = 0;
                b.iter(|| {
                    i = (i + 1) % set.len();
                    black_box(set[i].predict(mode))
                })
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
