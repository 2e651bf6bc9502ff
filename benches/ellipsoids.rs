//! Ellipsoid pair prediction: time per prediction of the two predictors (certified
//! separating-axis steps, and the paper's η1 roots with Brent's method for the final
//! approach) on random moving, rotating pairs of prolate spheroids, and the accuracy table:
//! agreement of the two and the largest overlap the independent Perram–Wertheim check finds
//! at the predicted contacts.
//!
//! `cargo bench --bench ellipsoids`

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use densepack::shape::{predict_ellipsoid_pair, Ellipsoid, Predictor, Spin, Vec3};
use densepack::verify::contact_scale;
use nalgebra::{Matrix3, UnitQuaternion};
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::time::{Duration, Instant};

struct Pair {
    a: Ellipsoid,
    sa: Spin,
    sb: Spin,
    dr: Vec3,
    dv: Vec3,
}

fn normal3<R: Rng>(rng: &mut R) -> Vec3 {
    Vec3::new(
        rng.sample(StandardNormal),
        rng.sample(StandardNormal),
        rng.sample(StandardNormal),
    )
}

fn m_of(q: &UnitQuaternion<f64>, axes: &Vec3) -> [[f64; 3]; 3] {
    let r = q.to_rotation_matrix();
    let m = r.matrix() * Matrix3::from_diagonal(&axes.component_mul(axes)) * r.matrix().transpose();
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

impl Pair {
    fn scale_at(&self, tau: f64) -> f64 {
        let rot = |s: &Spin| UnitQuaternion::from_scaled_axis(s.omega * tau) * s.orientation;
        let d = self.dr + self.dv * tau;
        let axes = self.a.semi_axes(tau);
        contact_scale(
            &m_of(&rot(&self.sa), &axes),
            &m_of(&rot(&self.sb), &axes),
            &[d.x, d.y, d.z],
        )
    }

    fn predict(&self, predictor: Predictor) -> Option<f64> {
        let a = Ellipsoid {
            predictor,
            ..self.a
        };
        predict_ellipsoid_pair(&a, &a, &self.sa, &self.sb, &self.dr, &self.dv, 0.0, 2.0)
    }
}

/// Random non-overlapping pairs of prolate spheroids (largest semi-axis 1) whose bounding
/// spheres meet within the window, the only pairs that reach the ellipsoid predictor.
fn pairs(ratio: f64, n: usize) -> Vec<Pair> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(17);
    let a = Ellipsoid::new(Vec3::new(1.0, 1.0 / ratio, 1.0 / ratio));
    let mut out = Vec::new();
    while out.len() < n {
        let dir = normal3(&mut rng).normalize();
        let pair = Pair {
            a,
            sa: Spin {
                orientation: UnitQuaternion::from_scaled_axis(normal3(&mut rng)),
                omega: normal3(&mut rng),
            },
            sb: Spin {
                orientation: UnitQuaternion::from_scaled_axis(normal3(&mut rng)),
                omega: normal3(&mut rng),
            },
            dr: dir * rng.gen_range(0.3..2.0),
            dv: -dir * rng.gen_range(0.0..1.5) + normal3(&mut rng) * 0.5,
        };
        if pair.scale_at(0.0) > 1.001 {
            out.push(pair);
        }
    }
    out
}

const RATIOS: [f64; 4] = [1.5, 5.0, 20.0, 50.0];
const MODES: [(Predictor, &str); 2] = [
    (Predictor::SeparatingAxis, "separating_axis"),
    (Predictor::Characteristic, "characteristic"),
];

fn accuracy_table() {
    println!("| aspect ratio | predictor | µs / prediction | contacts | agree with separating_axis (1e-6) | worst contact scale (< 1: overlap) |");
    println!("|---|---|---|---|---|---|");
    for ratio in RATIOS {
        let set = pairs(ratio, 2000);
        let reference: Vec<Option<f64>> = set
            .iter()
            .map(|p| p.predict(Predictor::SeparatingAxis))
            .collect();
        for (mode, name) in MODES {
            let start = Instant::now();
            let got: Vec<Option<f64>> = set.iter().map(|p| p.predict(mode)).collect();
            let micros = start.elapsed().as_secs_f64() * 1e6 / set.len() as f64;
            let mut worst = f64::INFINITY;
            let (mut contacts, mut agree) = (0, 0);
            for ((p, g), r) in set.iter().zip(&got).zip(&reference) {
                if let Some(tau) = g {
                    contacts += 1;
                    worst = worst.min(p.scale_at(*tau));
                }
                match (g, r) {
                    (Some(x), Some(y)) if (x - y).abs() <= 1e-6 * (1.0 + y) => agree += 1,
                    (None, None) => agree += 1,
                    _ => {}
                }
            }
            println!(
                "| {ratio} | {name} | {micros:.2} | {contacts} | {agree}/{} | {:.3e} |",
                set.len(),
                worst - 1.0
            );
        }
    }
}

fn bench(c: &mut Criterion) {
    accuracy_table();
    let mut group = c.benchmark_group("ellipsoid_pair_prediction");
    group.measurement_time(Duration::from_secs(3));
    for ratio in RATIOS {
        let set = pairs(ratio, 256);
        for (mode, name) in MODES {
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
