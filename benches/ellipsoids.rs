//! Ellipsoid pair prediction (criterion): time per prediction of the two predictors
//! (certified separating-axis steps, and the paper's η1 roots with Brent's method for the
//! final approach) on random moving, rotating pairs of prolate spheroids. The accuracy table
//! (agreement, largest overlap by the independent check) is the `ellipsoid-predictor` study
//! of `densepack bench`, printed first; the pairs are the same
//! ([`studies::ellipsoid::pairs`], `src/cli/studies/ellipsoid.rs`).
//!
//! `cargo bench --bench ellipsoids`

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use std::time::Duration;
use studies::ellipsoid::{pairs, predictor, PREDICTORS};
use studies::StudyContext;

// The studies belong to the `densepack` binary, not to the library (which builds without
// plotters and cpu-time); this target compiles the binary's one copy of their source. It
// uses only some of them (`dead_code`), and their unit tests run with the binary's, not in
// this target without a test harness (their `use super::*` is unused here).
#[path = "../src/cli/studies/mod.rs"]
#[allow(dead_code, unused_imports)]
mod studies;

fn bench(c: &mut Criterion) {
    let context = StudyContext {
        quick: false,
        memory_child: Vec::new(),
        journal: None,
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
