//! Helpers shared by the integration tests.
#![allow(dead_code)] // each test file uses a subset

use densepack::io::packing::{Packing, ParticleRecord};
use densepack::io::record::{CylinderRecord, EllipsoidRecord, SphereRecord};
use std::path::PathBuf;

/// Runs the `densepack` binary with `args`. The binary exists with the `cli` feature only; the
/// tests that call this declare `required-features = ["cli"]` in Cargo.toml.
#[cfg(feature = "cli")]
pub fn densepack(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_densepack"))
        .args(args)
        .output()
        .expect("densepack runs")
}

/// A fresh, empty directory for one test, removed with everything in it when the value is
/// dropped (at the end of the test, passed or failed): named after the test binary, `name`
/// and the process, so parallel tests and test binaries never share one.
pub fn temp_dir(name: &str) -> TempDir {
    let dir = std::env::temp_dir().join(format!(
        "densepack-{}-{name}-{}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    TempDir(dir)
}

/// A test's directory ([`temp_dir`]); it reads as its path.
pub struct TempDir(PathBuf);

impl std::ops::Deref for TempDir {
    type Target = PathBuf;
    fn deref(&self) -> &PathBuf {
        &self.0
    }
}

impl AsRef<std::path::Path> for TempDir {
    fn as_ref(&self) -> &std::path::Path {
        &self.0
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
use densepack::io::scene::Scene;
use densepack::run::{run_scene, RunOutcome};

/// Runs a scene given as TOML text; panics with the error if the run fails.
pub fn run_toml(text: &str) -> RunOutcome {
    let scene = Scene::from_toml(text).expect("valid test scene");
    run_scene(&scene, &mut |_, _| {}).unwrap_or_else(|e| panic!("run failed: {e}"))
}

/// Brute-force pairwise overlap check over all pairs and 27 periodic images, written for
/// the tests and independent of the kernel and of `densepack::verify`: no pair may be closer
/// than (1 − 1e-9)·(r_i + r_j). Returns the smallest ratio distance / (r_i + r_j).
pub fn assert_no_overlap(packing: &Packing) -> f64 {
    let (lo, hi, periodic) = match &packing.container {
        densepack::io::packing::ContainerRecord::Box { min, max, periodic } => {
            (*min, *max, *periodic)
        }
        densepack::io::packing::ContainerRecord::Cylinder {
            base_center,
            radius,
            height,
        } => (
            [
                base_center[0] - radius,
                base_center[1] - radius,
                base_center[2],
            ],
            [
                base_center[0] + radius,
                base_center[1] + radius,
                base_center[2] + height,
            ],
            [false; 3],
        ),
    };
    let balls: Vec<([f64; 3], f64)> = packing
        .particles
        .iter()
        .map(|p| match p {
            ParticleRecord::Sphere(SphereRecord { center, radius }) => (*center, *radius),
            other => panic!("a sphere packing was expected, got {other:?}"),
        })
        .collect();
    let mut worst = f64::INFINITY;
    for i in 0..balls.len() {
        for j in i + 1..balls.len() {
            let (ci, ri) = balls[i];
            let (cj, rj) = balls[j];
            let mut best = f64::INFINITY;
            for sx in -1..=1 {
                for sy in -1..=1 {
                    for sz in -1..=1 {
                        let s = [sx, sy, sz];
                        if (0..3).any(|k| s[k] != 0 && !periodic[k]) {
                            continue;
                        }
                        let d2: f64 = (0..3)
                            .map(|k| {
                                let d = ci[k] - cj[k] + s[k] as f64 * (hi[k] - lo[k]);
                                d * d
                            })
                            .sum();
                        best = best.min(d2.sqrt());
                    }
                }
            }
            let ratio = best / (ri + rj);
            assert!(
                ratio >= 1.0 - 1e-9,
                "particles {i} and {j} overlap: distance/(r_i + r_j) = {ratio}"
            );
            worst = worst.min(ratio);
        }
    }
    worst
}

/// Carnahan–Starling equation of state of the hard-sphere fluid, Z(φ).
pub fn carnahan_starling(phi: f64) -> f64 {
    (1.0 + phi + phi * phi - phi.powi(3)) / (1.0 - phi).powi(3)
}

/// Kolafa's correction of the Carnahan–Starling equation,
/// `Z = (1 + φ + φ² − (2/3)φ³(1 + φ)) / (1 − φ)³` (Boublík and Nezbeda 1986; it matches the
/// high-precision molecular dynamics data of Kolafa, Labík and Malijevský 2004 to about
/// 1e-4 over the stable fluid), more accurate than Carnahan–Starling (which is 0.26 % low at
/// φ = 0.3).
pub fn kolafa(phi: f64) -> f64 {
    (1.0 + phi + phi * phi - 2.0 / 3.0 * phi.powi(3) * (1.0 + phi)) / (1.0 - phi).powi(3)
}

/// Brute-force check of a packing's promised gap and containment, written for the tests and
/// independent of the kernel and of `densepack::verify`: every pair (minimum image on periodic
/// axes, all pairs) at least `(1 − 1e-9)·(r_i + r_j) + min_gap` apart, and every sphere at
/// least `(1 − 1e-9)·r + wall_gap` inside each wall (box faces that are not periodic, or the
/// cylinder's mantle and caps). Returns the smallest surface gap `|c_i − c_j| − r_i − r_j`.
pub fn assert_gap_and_containment(packing: &Packing) -> f64 {
    use densepack::io::packing::ContainerRecord;
    let gap = packing.min_gap;
    let wall_gap = packing.wall_gap();
    let balls: Vec<([f64; 3], f64)> = packing
        .particles
        .iter()
        .map(|p| match p {
            ParticleRecord::Sphere(SphereRecord { center, radius }) => (*center, *radius),
            other => panic!("a sphere packing was expected, got {other:?}"),
        })
        .collect();
    let (len, periodic) = match &packing.container {
        ContainerRecord::Box { min, max, periodic } => {
            for (i, (c, r)) in balls.iter().enumerate() {
                for k in 0..3 {
                    if periodic[k] {
                        continue;
                    }
                    let inside = (c[k] - min[k]).min(max[k] - c[k]);
                    assert!(
                        inside >= (1.0 - 1e-9) * r + wall_gap,
                        "sphere {i} (r = {r}) is {inside} from a wall on axis {k}, less than r + wall_gap"
                    );
                }
            }
            (
                [max[0] - min[0], max[1] - min[1], max[2] - min[2]],
                *periodic,
            )
        }
        ContainerRecord::Cylinder {
            base_center,
            radius,
            height,
        } => {
            for (i, (c, r)) in balls.iter().enumerate() {
                let radial =
                    ((c[0] - base_center[0]).powi(2) + (c[1] - base_center[1]).powi(2)).sqrt();
                let axial = (c[2] - base_center[2]).min(base_center[2] + height - c[2]);
                let inside = (radius - radial).min(axial);
                assert!(
                    inside >= (1.0 - 1e-9) * r + wall_gap,
                    "sphere {i} (r = {r}) is {inside} from the cylinder wall, less than r + wall_gap"
                );
            }
            ([0.0; 3], [false; 3])
        }
    };
    let mut smallest = f64::INFINITY;
    for i in 0..balls.len() {
        for j in i + 1..balls.len() {
            let (ci, ri) = balls[i];
            let (cj, rj) = balls[j];
            let d2: f64 = (0..3)
                .map(|k| {
                    let mut d = ci[k] - cj[k];
                    if periodic[k] {
                        d -= len[k] * (d / len[k]).round();
                    }
                    d * d
                })
                .sum();
            let d = d2.sqrt();
            assert!(
                d >= (1.0 - 1e-9) * (ri + rj) + gap,
                "spheres {i} and {j} are {} apart at the surfaces, less than the gap {gap}",
                d - ri - rj
            );
            smallest = smallest.min(d - ri - rj);
        }
    }
    smallest
}

/// The packing fraction of a packing recomputed from its particles and its container, written
/// for the tests and independent of the run's statistics and of `densepack::verify`: the
/// volumes `4/3 π r³` (sphere), `4/3 π abc` (ellipsoid), `π r² · 2|half_axis|` (cylinder) over
/// the box `Π (max − min)` or the cylinder `π R² H`. Also asserts that the statistics the run
/// wrote agree with it to 1e-12 relative (their φ is the same sum in the kernel's units).
pub fn recomputed_phi(packing: &Packing) -> f64 {
    use densepack::io::packing::ContainerRecord;
    use std::f64::consts::PI;
    let solid: f64 = packing
        .particles
        .iter()
        .map(|p| match p {
            ParticleRecord::Sphere(SphereRecord { radius, .. }) => 4.0 / 3.0 * PI * radius.powi(3),
            ParticleRecord::Ellipsoid(EllipsoidRecord { semi_axes, .. }) => {
                4.0 / 3.0 * PI * semi_axes[0] * semi_axes[1] * semi_axes[2]
            }
            ParticleRecord::Cylinder(CylinderRecord {
                radius, half_axis, ..
            }) => {
                let length = 2.0 * half_axis.iter().map(|x| x * x).sum::<f64>().sqrt();
                PI * radius * radius * length
            }
        })
        .sum();
    let volume = match &packing.container {
        ContainerRecord::Box { min, max, .. } => (0..3).map(|k| max[k] - min[k]).product(),
        ContainerRecord::Cylinder { radius, height, .. } => PI * radius * radius * height,
    };
    let phi = solid / volume;
    let written = packing.stats.packing_fraction;
    assert!(
        (written - phi).abs() <= 1e-12 * phi,
        "the run wrote φ = {written}, its particles fill {phi}"
    );
    phi
}
