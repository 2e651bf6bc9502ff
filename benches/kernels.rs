//! Criterion micro-benchmarks of the per-pair and per-cell kernels, fixed seeds:
//!
//! * `pair_prediction/sphere_sphere` — [`predict_sphere_sphere`] on random approaching or
//!   receding pairs of growing unit spheres (the EDMD kernel's sphere collision time);
//! * `intersection/sphere_cylinder`, `intersection/cylinder_cylinder/a` — the exact
//!   intersection tests of paper 000 (Alg. 1–4) on random pairs whose bounding spheres
//!   overlap, aspect ratios a = 3 and 10;
//! * `cells/transfer/N` — moving one body to a neighbouring cell of a [`CellGrid`] holding N
//!   bodies (remove + insert; cell width 1, density 1 body per cell).
//!
//! The ellipsoid predictors are in `benches/ellipsoids.rs`, the event queues (pop, schedule,
//! reschedule of a queued key at 10³–10⁶ entries) in `benches/queues.rs`.
//!
//! `cargo bench --bench kernels`

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion};
use densepack::geometry::cylinder::{
    intersect_cylinder_cylinder, intersect_sphere_cylinder, Cylinder, Sphere,
};
use densepack::shape::{predict_sphere_sphere, Vec3};
use densepack::spatial::CellGrid;
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::time::Duration;

fn normal3<R: Rng>(rng: &mut R) -> Vector3<f64> {
    Vector3::new(
        rng.sample(StandardNormal),
        rng.sample(StandardNormal),
        rng.sample(StandardNormal),
    )
}

/// A random cylinder of radius 0.5 and aspect ratio `a` (length / diameter) centred at `c`.
fn cylinder<R: Rng>(rng: &mut R, c: Vector3<f64>, a: f64) -> Cylinder {
    Cylinder::new(c, normal3(rng).normalize() * (0.5 * a), 0.5)
}

fn pair_prediction(c: &mut Criterion) {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let pairs: Vec<(Vec3, Vec3)> = (0..1024)
        .map(|_| {
            let dir = normal3(&mut rng).normalize();
            let dr = dir * rng.gen_range(1.01..1.6);
            (dr, normal3(&mut rng))
        })
        .collect();
    let mut group = c.benchmark_group("pair_prediction");
    group.measurement_time(Duration::from_secs(2));
    group.bench_function("sphere_sphere", |b| {
        let mut i = 0;
        b.iter(|| {
            i = (i + 1) & 1023;
            let (dr, dv) = &pairs[i];
            black_box(predict_sphere_sphere(1.0, 0.01, dr, dv, 10.0))
        })
    });
    group.finish();
}

fn intersection(c: &mut Criterion) {
    let mut group = c.benchmark_group("intersection");
    group.measurement_time(Duration::from_secs(2));
    for a in [3.0, 10.0] {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(6);
        let reach = 0.5 * (a * a + 1.0f64).sqrt();
        let sphere_cyl: Vec<(Sphere, Cylinder)> = (0..1024)
            .map(|_| {
                let cyl = cylinder(&mut rng, Vector3::zeros(), a);
                let s = Sphere::new(
                    normal3(&mut rng).normalize() * rng.gen_range(0.0..reach + 0.5),
                    0.5,
                );
                (s, cyl)
            })
            .collect();
        let cyl_cyl: Vec<(Cylinder, Cylinder)> = (0..1024)
            .map(|_| {
                let p = normal3(&mut rng).normalize() * rng.gen_range(0.0..2.0 * reach);
                (
                    cylinder(&mut rng, Vector3::zeros(), a),
                    cylinder(&mut rng, p, a),
                )
            })
            .collect();
        group.bench_with_input(
            BenchmarkId::new("sphere_cylinder", a),
            &sphere_cyl,
            |b, set| {
                let mut i = 0;
                b.iter(|| {
                    i = (i + 1) & 1023;
                    black_box(intersect_sphere_cylinder(&set[i].0, &set[i].1).is_some())
                })
            },
        );
        group.bench_with_input(
            BenchmarkId::new("cylinder_cylinder", a),
            &cyl_cyl,
            |b, set| {
                let mut i = 0;
                b.iter(|| {
                    i = (i + 1) & 1023;
                    black_box(intersect_cylinder_cylinder(&set[i].0, &set[i].1).is_some())
                })
            },
        );
    }
    group.finish();
}

fn cell_transfers(c: &mut Criterion) {
    let mut group = c.benchmark_group("cells/transfer");
    group
        .sample_size(20)
        .measurement_time(Duration::from_secs(2));
    for n in [1_000usize, 100_000, 1_000_000] {
        let edge = (n as f64).cbrt();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        let mut grid = CellGrid::new(Vec3::zeros(), Vec3::repeat(edge), [true; 3], 1.0, n);
        let mut positions: Vec<Vec3> = (0..n)
            .map(|_| Vec3::new(rng.gen(), rng.gen(), rng.gen()) * edge)
            .collect();
        for (i, p) in positions.iter().enumerate() {
            let cell = grid.cell_at(0, p);
            grid.insert(i, cell);
        }
        // Pre-drawn moves: a body and a step of one cell along an axis.
        let moves: Vec<(usize, usize, f64)> = (0..1 << 16)
            .map(|_| {
                (
                    rng.gen_range(0..n),
                    rng.gen_range(0..3),
                    if rng.gen() { 1.0 } else { -1.0 },
                )
            })
            .collect();
        group.bench_with_input(BenchmarkId::from_parameter(n), &n, |b, _| {
            let mut k = 0;
            b.iter(|| {
                k = (k + 1) & 0xffff;
                let (i, axis, step) = moves[k];
                let p = &mut positions[i];
                p[axis] = (p[axis] + step).rem_euclid(edge);
                let cell = grid.cell_at(0, p);
                grid.remove(i);
                grid.insert(i, black_box(cell));
            })
        });
    }
    group.finish();
}

criterion_group!(benches, pair_prediction, intersection, cell_transfers);
criterion_main!(benches);
