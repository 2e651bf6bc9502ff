//! Physics of the EDMD kernel against exact results and literature values.
//! Run in release mode (`cargo test --release`); each test takes a few seconds.

mod common;

use common::{assert_no_overlap, carnahan_starling, kolafa, recomputed_phi, run_toml};
use densepack::boundary::PeriodicBox;
use densepack::io::record::SphereRecord;
use densepack::kernel::{Edmd, KernelConfig, Limits, RateSchedule, Stage, StopReason, Until};
use densepack::protocol::rsa::rsa_spheres;
use densepack::queue::CalendarQueue;
use densepack::shape::{Growth, Sphere, Vec3};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// A hard-sphere fluid of 2000 spheres at packing fraction `phi`: seeded at min(φ, 0.3),
/// grown if needed, equilibrated for 100 collisions per particle, then measured.
fn fluid_scene(phi: f64, seed: u64, measured_collisions: f64) -> String {
    let seed_phi = phi.min(0.3);
    let grow = if phi > seed_phi {
        format!(
            "[[stage]]\ngrowth = \"relative\"\nrate = 0.1\nuntil = {{ packing_fraction = {phi} }}\n"
        )
    } else {
        String::new()
    };
    format!(
        r#"seed = {seed}
[container]
type = "box"
size = [15.0, 15.0, 15.0]
periodic = [true, true, true]
[particles]
count = 2000
diameter = 1.0
packing_fraction = {seed_phi}
{grow}
[[stage]]
growth = "none"
until = {{ collisions_per_particle = 100 }}
[[stage]]
growth = "none"
until = {{ collisions_per_particle = {measured_collisions} }}
"#
    )
}

fn check_fluid_pressure(phi: f64, expected_cs: f64) {
    let cs = carnahan_starling(phi);
    assert!((cs - expected_cs).abs() < 1e-4, "CS({phi}) = {cs}");
    let outcome = run_toml(&fluid_scene(phi, 11, 600.0));
    let stats = &outcome.packing.stats;
    assert!((recomputed_phi(&outcome.packing) - phi).abs() < 1e-9);
    let z = stats.reduced_pressure.expect("dynamics ran");
    let err = outcome
        .stages
        .last()
        .unwrap()
        .reduced_pressure_stderr
        .unwrap();
    let rel = (z - cs) / cs;
    eprintln!(
        "φ = {phi}: Z = {z:.5} ± {err:.5}, Carnahan–Starling {cs:.5}, relative deviation {rel:+.4}"
    );
    assert!(
        rel.abs() < 0.01,
        "Z = {z} deviates {rel} from Carnahan–Starling {cs}"
    );
    // The more accurate reference: within 0.3 % (about three standard errors at N = 2000).
    let k = kolafa(phi);
    assert!(
        ((z - k) / k).abs() < 0.003,
        "Z = {z} deviates from Kolafa's equation of state {k}"
    );
    assert_no_overlap(&outcome.packing);
}

#[test]
fn fluid_pressure_matches_carnahan_starling_at_030() {
    check_fluid_pressure(0.30, 3.9738);
}

#[test]
fn fluid_pressure_matches_carnahan_starling_at_045() {
    check_fluid_pressure(0.45, 9.3847);
}

#[test]
fn equilibrium_run_conserves_momentum_and_energy_over_a_million_collisions() {
    let n = 2000;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let boundary = PeriodicBox {
        min: Vec3::zeros(),
        len: Vec3::new(14.0, 14.0, 14.0),
    };
    // φ = 0.4 is above what RSA reaches comfortably: seed at 0.3 and grow.
    let r = 0.5 * (0.3 * 14.0f64.powi(3) / (n as f64 * std::f64::consts::PI / 6.0)).cbrt();
    let radii = vec![r; n];
    let centres = rsa_spheres(&boundary, &radii, 0.0, 0.0, 1_000_000, None, &mut rng).unwrap();
    let shapes = radii.iter().map(|&r| Sphere::new(r)).collect();
    let mut kernel: Edmd<Sphere, PeriodicBox, CalendarQueue> =
        Edmd::new(centres, shapes, boundary, KernelConfig::default(), &mut rng);
    let grow = Stage {
        growth: Growth::Relative(0.1),
        schedule: RateSchedule::Fixed,
        until: Until {
            packing_fraction: Some(0.4),
            ..Until::default()
        },
        limits: Limits::default(),
        thermostat: true,
        wall_growth: 1.0,
    };
    assert_eq!(
        kernel.run_stage(&grow).stop_reason,
        StopReason::PackingFractionReached
    );
    let p0 = kernel.momentum();
    let k0 = kernel.kinetic_twice();
    let scale: f64 = kernel.particles().iter().map(|p| p.vel.norm()).sum();
    let equilibrium = Stage {
        growth: Growth::None,
        schedule: RateSchedule::Fixed,
        until: Until {
            collisions_per_particle: Some(500.0),
            ..Until::default()
        },
        limits: Limits::default(),
        thermostat: false,
        wall_growth: 1.0,
    };
    let report = kernel.run_stage(&equilibrium);
    assert_eq!(report.stop_reason, StopReason::CollisionsReached);
    assert!(report.counts.collisions >= 1_000_000);
    let dp = (kernel.momentum() - p0).norm();
    let dk = (kernel.kinetic_twice() - k0).abs() / k0;
    eprintln!("|ΔP| = {dp:.3e} (Σ|p| = {scale:.1}), |ΔK|/K = {dk:.3e}");
    assert!(dp <= 1e-12 * scale, "momentum drift {dp}");
    assert!(dk <= 1e-10, "kinetic energy drift {dk}");
}

fn jam_scene(rate: f64, seed: u64) -> String {
    format!(
        r#"seed = {seed}
[container]
type = "box"
size = [13.0, 13.0, 13.0]
periodic = [true, true, true]
[particles]
count = 2000
diameter = 1.0
packing_fraction = 0.3
[[stage]]
growth = "relative"
rate = {rate}
until = {{ reduced_pressure = 1e12 }}
"#
    )
}

#[test]
fn fast_compression_jams_near_random_close_packing_and_slower_goes_denser() {
    let fast = run_toml(&jam_scene(0.05, 3));
    let slow = run_toml(&jam_scene(0.005, 3));
    let (phi_fast, phi_slow) = (recomputed_phi(&fast.packing), recomputed_phi(&slow.packing));
    eprintln!("jammed φ: fast {phi_fast:.5}, 10× slower {phi_slow:.5}");
    assert_eq!(fast.packing.stats.stop_reason, "pressure_reached");
    assert!(
        (0.630..=0.650).contains(&phi_fast),
        "fast growth jammed at {phi_fast}"
    );
    assert!(
        phi_slow > phi_fast,
        "slower growth {phi_slow} not denser than {phi_fast}"
    );
    assert!(fast
        .packing
        .stats
        .reduced_pressure
        .is_some_and(|z| z >= 1e12));
    assert_no_overlap(&fast.packing);
    assert_no_overlap(&slow.packing);
}

fn walled_cube(count: usize, seed: u64) -> String {
    format!(
        r#"seed = {seed}
[container]
type = "box"
size = [2.0, 2.0, 2.0]
periodic = [false, false, false]
[particles]
count = {count}
diameter = 1.0
packing_fraction = 0.1
[[stage]]
growth = "relative"
rate = 0.01
until = {{ reduced_pressure = 1e12 }}
"#
    )
}

#[test]
fn one_sphere_in_a_walled_cube_jams_at_pi_over_6() {
    let out = run_toml(&walled_cube(1, 1));
    let phi = recomputed_phi(&out.packing);
    assert!((phi - std::f64::consts::PI / 6.0).abs() < 1e-3, "φ = {phi}");
    assert!(out.verification.min_wall_gap.unwrap() >= -1e-9);
}

#[test]
fn eight_spheres_in_a_walled_cube_jam_as_a_simple_cubic_lattice() {
    let out = run_toml(&walled_cube(8, 2));
    let phi = recomputed_phi(&out.packing);
    assert!((phi - std::f64::consts::PI / 6.0).abs() < 1e-3, "φ = {phi}");
    // Paper 001, Fig. 5: the eight spheres sit at the centres of the eight sub-cubes.
    for p in &out.packing.particles {
        let densepack::io::packing::ParticleRecord::Sphere(SphereRecord { center, .. }) = p else {
            panic!("spheres expected");
        };
        for x in center {
            assert!(
                (x - 0.5).abs() < 1e-3 || (x - 1.5).abs() < 1e-3,
                "centre {center:?}"
            );
        }
    }
    assert_no_overlap(&out.packing);
}

/// Paper 001, Fig. 5 ("for two particles, the densest arrangement is the placement in
/// opposite corners"): each sphere touches the three walls of its corner and the other
/// along the body diagonal, √3 (L − d) = d, so d = √3 L / (1 + √3) and
/// φ = 2 (π/6) d³ / L³ = (π/3) (√3 / (1 + √3))³ ≈ 0.26683.
#[test]
fn two_spheres_in_a_walled_cube_jam_in_opposite_corners() {
    let edge = 2.0;
    let ratio = 3f64.sqrt() / (1.0 + 3f64.sqrt());
    let exact = std::f64::consts::PI / 3.0 * ratio.powi(3);
    for seed in [3, 4, 5] {
        let out = run_toml(&walled_cube(2, seed));
        let phi = recomputed_phi(&out.packing);
        assert!(
            (phi - exact).abs() < 1e-3,
            "seed {seed}: φ = {phi}, exact {exact}"
        );
        let d = edge * ratio;
        let centres: Vec<[f64; 3]> = out
            .packing
            .particles
            .iter()
            .map(|p| match p {
                densepack::io::packing::ParticleRecord::Sphere(SphereRecord { center, .. }) => {
                    *center
                }
                _ => panic!("spheres expected"),
            })
            .collect();
        // Every coordinate at d/2 from one wall, and the two spheres on opposite sides of
        // the cube along every axis.
        for k in 0..3 {
            let (a, b) = (centres[0][k], centres[1][k]);
            for x in [a, b] {
                assert!(
                    (x - d / 2.0).abs() < 1e-3 || (x - (edge - d / 2.0)).abs() < 1e-3,
                    "seed {seed}: centres {centres:?}"
                );
            }
            assert!(
                ((a - b).abs() - (edge - d)).abs() < 1e-3,
                "seed {seed}: centres {centres:?}"
            );
        }
        assert_no_overlap(&out.packing);
    }
}

#[test]
fn heap_and_calendar_queues_give_bit_identical_packings() {
    let scene = |queue: &str| {
        format!(
            r#"seed = 99
queue = "{queue}"
[container]
type = "box"
size = [9.0, 9.0, 9.0]
periodic = [true, false, true]
[particles]
components = [{{ count = 300, diameter = 1.0 }}, {{ count = 100, diameter = 1.5 }}]
packing_fraction = 0.3
[[stage]]
growth = "relative"
rate = 0.05
until = {{ reduced_pressure = 1e9 }}
"#
        )
    };
    let heap = run_toml(&scene("heap"));
    let calendar = run_toml(&scene("calendar"));
    assert_eq!(heap.packing.particles, calendar.packing.particles);
    assert_eq!(heap.packing.stats.events, calendar.packing.stats.events);
    assert!(recomputed_phi(&heap.packing) > 0.6);
    assert_no_overlap(&heap.packing);
}

#[test]
fn cylinder_specimen_with_absolute_growth_stays_inside_and_overlap_free() {
    // A bidisperse load in a cylinder (axis z), grown at an absolute rate until jammed.
    let out = run_toml(
        r#"seed = 4
[container]
type = "cylinder"
base_center = [1.0, -2.0, 0.5]
radius = 4.0
height = 10.0
[particles]
components = [{ count = 150, diameter = 1.0 }, { count = 40, diameter = 2.0 }]
packing_fraction = 0.25
[[stage]]
growth = "absolute"
rate = 0.01
until = { reduced_pressure = 1e10 }
"#,
    );
    let stats = &out.packing.stats;
    assert_eq!(stats.stop_reason, "pressure_reached");
    // Absolute growth adds the same length to every radius: the size ratio shrinks below 2.
    let radii: Vec<f64> = out
        .packing
        .particles
        .iter()
        .map(|p| match p {
            densepack::io::packing::ParticleRecord::Sphere(SphereRecord { radius, .. }) => *radius,
            other => panic!("spheres expected, got {other:?}"),
        })
        .collect();
    let (small, big) = (radii[0], radii[150]);
    let seed_scale = (0.25 * std::f64::consts::PI * 16.0 * 10.0
        / (std::f64::consts::PI / 6.0 * (150.0 + 40.0 * 8.0)))
        .cbrt();
    let grown = small - 0.5 * seed_scale;
    assert!(grown > 0.0);
    assert!(
        ((big - small) - 0.5 * seed_scale).abs() < 1e-9,
        "big {big} small {small}"
    );
    let phi = recomputed_phi(&out.packing);
    assert!(phi > 0.5, "φ = {phi}");
    assert!(out.verification.min_wall_gap.unwrap() >= -1e-9 * big);
    // Containment checked here again, independently of `verify`.
    for p in &out.packing.particles {
        let densepack::io::packing::ParticleRecord::Sphere(SphereRecord { center, radius }) = p
        else {
            panic!("spheres expected");
        };
        let rho = (center[0] - 1.0).hypot(center[1] + 2.0);
        assert!(
            rho + radius <= 4.0 * (1.0 + 1e-12),
            "pokes through the mantle"
        );
        assert!(center[2] - radius >= 0.5 - 1e-12 && center[2] + radius <= 10.5 + 1e-12);
    }
    assert_no_overlap(&out.packing);
}

#[test]
fn polydisperse_size_ratio_8_jams_densely_without_overlap() {
    // Four size classes (diameters 4, 2, 1, 0.5): the cell grid uses several levels and
    // large particles keep thin neighbour shells.
    let out = run_toml(
        r#"seed = 6
[container]
type = "box"
size = [12.0, 12.0, 12.0]
periodic = [true, false, true]
[particles]
components = [{ count = 8, diameter = 4.0 }, { count = 40, diameter = 2.0 },
              { count = 300, diameter = 1.0 }, { count = 2000, diameter = 0.5 }]
packing_fraction = 0.3
# Time is in units of ℓ·√(m/kT) with ℓ = 0.1 here (the power of ten below the smallest
# diameter, `io::units`): 0.01 per unit is the growth of 0.1 per unit of 1·√(m/kT).
[[stage]]
growth = "relative"
rate = 0.01
until = { reduced_pressure = 1e8 }
"#,
    );
    let stats = &out.packing.stats;
    assert_eq!(stats.stop_reason, "pressure_reached");
    // Polydisperse mixtures pack denser than equal spheres (φ_RCP ≈ 0.64).
    let phi = recomputed_phi(&out.packing);
    assert!(phi > 0.68, "φ = {phi}");
    assert!(out.verification.min_wall_gap.unwrap() >= -1e-9);
    assert_no_overlap(&out.packing);
}
