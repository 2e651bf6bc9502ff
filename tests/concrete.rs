//! Concrete mesostructures (paper 001, §2–6): grading-curve scenes packed by RSA with a gap,
//! grown to full size by EDMD, given a minimum gap Δd or the largest one, in walled boxes,
//! periodic boxes and cylinder specimens. Every packing is checked by the brute-force gap and
//! containment check of `tests/common`, independent of the kernel and of `densepack::verify`.

mod common;

use common::{assert_gap_and_containment, recomputed_phi, run_toml};
use densepack::io::packing::{Packing, ParticleRecord};
use densepack::io::record::SphereRecord;
use densepack::io::scene::{Scene, SceneError};
use densepack::protocol::take_phase::{DinCurve, GradingCurve, TakeParams, TakePhase};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

fn diameters(packing: &Packing) -> Vec<f64> {
    let mut d: Vec<f64> = packing
        .particles
        .iter()
        .map(|p| match p {
            ParticleRecord::Sphere(SphereRecord { radius, .. }) => 2.0 * radius,
            other => panic!("a sphere packing was expected, got {other:?}"),
        })
        .collect();
    d.sort_by(|a, b| b.total_cmp(a));
    d
}

fn volume_fraction(diameters: &[f64], volume: f64) -> f64 {
    diameters
        .iter()
        .map(|d| std::f64::consts::PI / 6.0 * d.powi(3))
        .sum::<f64>()
        / volume
}

#[test]
fn rsa_keeps_the_gap_in_a_cylinder_specimen() {
    let packing = run_toml(
        r#"
seed = 3
method = "rsa"
[container]
type = "cylinder"
radius = 40.0
height = 80.0
[particles]
grading = { kind = "din", name = "A16" }
mixture_fraction = 0.35
d_min = 4.0
gap = 1.0
"#,
    )
    .packing;
    assert_eq!(packing.min_gap, 1.0);
    assert_eq!(packing.stats.stop_reason, "rsa_complete");
    assert!(packing.stats.reduced_pressure.is_none());
    let smallest = assert_gap_and_containment(&packing);
    assert!(smallest >= 1.0 - 1e-9, "{smallest}");
    // The sample fills φ_eff = φ_M (1 − F(4 mm)) = 0.35 · (1 − 0.36), overshooting by less
    // than one grain of the smallest class (4 mm in ≈ 0.4 · 10⁶ mm³: 8e-5).
    let phi = recomputed_phi(&packing);
    assert!((phi - 0.35 * 0.64).abs() < 1e-4, "φ = {phi}");
}

#[test]
fn edmd_grows_a16_to_full_size_then_opens_a_one_millimetre_gap() {
    let text = r#"
seed = 5
mass = "volume"
[container]
type = "box"
size = [40.0, 40.0, 40.0]
periodic = [false, false, false]
[particles]
grading = { kind = "din", name = "A16" }
mixture_fraction = 0.45
d_min = 2.0
[[stage]]
growth = "relative"
rate = 0.05
until = { full_size = true }
[[stage]]
growth = "absolute"
rate = 0.02
until = { gap = 1.0 }
"#;
    let outcome = run_toml(text);
    let packing = &outcome.packing;
    // The written gap is exactly the one asked for: the stage runs 10⁻⁹ longer than the gap
    // rule's time, so every radius gained at least 0.5 mm despite rounding, and the
    // independent check finds every pair at least that far apart.
    assert_eq!(packing.min_gap, 1.0);
    assert_eq!(packing.stats.stop_reason, "gap_reached");
    let smallest = assert_gap_and_containment(packing);
    assert!(smallest >= 1.0, "{smallest}");
    // Particles are written at their true sizes: exactly the take phase's draw for the seed
    // (the run's generator draws the diameters first), not the inflated ones.
    let take = TakePhase::new(
        &GradingCurve::din(DinCurve::A16),
        TakeParams {
            volume: 40.0_f64.powi(3),
            phi_m: 0.45,
            d_min: 2.0,
        },
    )
    .unwrap();
    let expected = take.sample(&mut Xoshiro256PlusPlus::seed_from_u64(5));
    let written = diameters(packing);
    assert_eq!(written.len(), expected.len());
    for (w, e) in written.iter().zip(&expected) {
        assert!((w - e).abs() <= 1e-12 * e, "{w} vs {e}");
    }
    // φ_eff = 0.45 · (1 − 0.21) to within one smallest grain.
    assert!((recomputed_phi(packing) - 0.45 * 0.79).abs() < 1e-3);
    assert_eq!(outcome.stages.len(), 2);
}

#[test]
fn gap_maximisation_ends_with_the_gap_tight() {
    let text = r#"
seed = 9
[container]
type = "box"
size = [64.0, 64.0, 64.0]
periodic = [true, true, true]
[particles]
grading = { kind = "din", name = "B16" }
mixture_fraction = 0.6
d_min = 4.0
seed_scale = 1.0
[[stage]]
growth = "absolute"
rate = 0.02
until = { max_gap = true }
"#;
    let outcome = run_toml(text);
    let packing = &outcome.packing;
    let gap = packing.min_gap;
    assert!(gap > 0.5, "Δd_max = {gap}");
    assert_eq!(packing.stats.stop_reason, "pressure_reached");
    // At jamming the inflated spheres touch: the smallest surface gap is Δd_max itself (the
    // kernel stops at reduced pressure 1e12, so contacts are closed to ~1e-11 of a diameter).
    let smallest = assert_gap_and_containment(packing);
    assert!(
        (smallest - gap).abs() < 1e-6 * gap,
        "smallest gap {smallest}, Δd_max {gap}"
    );
    // Δd over time (paper 001, Fig. 10): rising with the events, ending at Δd_max.
    let history = packing.stats.extra["gap_history"].as_array().unwrap();
    assert!(history.len() > 10, "{} samples", history.len());
    let value = |s: &serde_json::Value, k: &str| s[k].as_f64().unwrap();
    for w in history.windows(2) {
        assert!(value(&w[1], "gap") > value(&w[0], "gap"));
        assert!(value(&w[1], "events") >= value(&w[0], "events"));
    }
    let last = value(history.last().unwrap(), "gap");
    assert!(
        (last - gap).abs() < 1e-9 * gap,
        "last sample {last}, Δd_max {gap}"
    );
}

#[test]
fn fuller_grains_grow_to_full_size_in_a_cylinder_specimen() {
    let outcome = run_toml(
        r#"
seed = 2
mass = "volume"
[container]
type = "cylinder"
radius = 30.0
height = 60.0
[particles]
grading = { kind = "fuller", q = 0.5, d_max = 16.0 }
effective_fraction = 0.55
d_min = 4.0
[[stage]]
growth = "relative"
rate = 0.05
until = { full_size = true }
"#,
    );
    let packing = &outcome.packing;
    assert_eq!(packing.stats.stop_reason, "packing_fraction_reached");
    assert_eq!(packing.min_gap, 0.0);
    assert_gap_and_containment(packing);
    let v = std::f64::consts::PI * 30.0 * 30.0 * 60.0;
    let phi = volume_fraction(&diameters(packing), v);
    assert!((phi - 0.55).abs() < 2e-3, "φ_eff = {phi}");
    assert!((packing.stats.packing_fraction - phi).abs() < 1e-12);
}

fn scene_error(text: &str) -> (String, String) {
    match Scene::from_toml(text) {
        Err(SceneError::Invalid { field, message }) => (field, message),
        other => panic!("expected a field error, got {other:?}"),
    }
}

const BOX: &str = "seed = 1\n[container]\ntype = \"box\"\nsize = [80.0, 80.0, 80.0]\nperiodic = [false, false, false]\n";

#[test]
fn impossible_concrete_requests_fail_fast_naming_what_to_change() {
    let stage_full =
        "[[stage]]\ngrowth = \"relative\"\nrate = 0.05\nuntil = { full_size = true }\n";
    let cases: [(String, &str, &str); 7] = [
        (
            format!("{BOX}[particles]\ngrading = {{ kind = \"din\", name = \"A16\" }}\nmixture_fraction = 1.2\nd_min = 2.0\n{stage_full}"),
            "particles.mixture_fraction",
            "(0, 1)",
        ),
        (
            format!("{BOX}[particles]\ngrading = {{ kind = \"fuller\", q = 0.5, d_max = 16.0 }}\neffective_fraction = 1.0\nd_min = 2.0\n{stage_full}"),
            "particles.effective_fraction",
            "(0, 1)",
        ),
        (
            format!("{BOX}[particles]\ngrading = {{ kind = \"table\", sizes = [2.0, 8.0, 4.0], passing = [0.0, 50.0, 100.0] }}\nmixture_fraction = 0.6\nd_min = 2.0\n{stage_full}"),
            "particles.grading",
            "strictly increasing",
        ),
        (
            format!("{BOX}[particles]\ngrading = {{ kind = \"din\", name = \"B16\" }}\nmixture_fraction = 0.6\nd_min = 32.0\n{stage_full}"),
            "particles.d_min",
            "d_max",
        ),
        (
            // Box smaller than the largest grain.
            "seed = 1\n[container]\ntype = \"box\"\nsize = [12.0, 80.0, 80.0]\nperiodic = [false, false, false]\n[particles]\ngrading = { kind = \"din\", name = \"A16\" }\nmixture_fraction = 0.3\nd_min = 2.0\n[[stage]]\ngrowth = \"relative\"\nrate = 0.05\nuntil = { full_size = true }\n".into(),
            "particles",
            "does not fit",
        ),
        (
            // Δd too large: ~5000 grains of ≥ 2 mm plus 4 mm cannot fit 80³ mm³.
            format!("{BOX}[particles]\ngrading = {{ kind = \"din\", name = \"A16\" }}\nmixture_fraction = 0.535\nd_min = 2.0\n{stage_full}[[stage]]\ngrowth = \"absolute\"\nrate = 0.01\nuntil = {{ gap = 4.0 }}\n"),
            "stage[1].until.gap",
            "lower the gap",
        ),
        (
            // A gap stage needs the true sizes first.
            format!("{BOX}[particles]\ngrading = {{ kind = \"din\", name = \"A16\" }}\nmixture_fraction = 0.5\nd_min = 2.0\nseed_scale = 0.9\n[[stage]]\ngrowth = \"absolute\"\nrate = 0.01\nuntil = {{ gap = 1.0 }}\n"),
            "stage[0].until.gap",
            "full_size",
        ),
    ];
    for (text, field, needle) in cases {
        let (f, m) = scene_error(&text);
        assert_eq!(f, field, "{m}");
        assert!(m.contains(needle), "{field}: {m}");
    }
}

#[test]
fn a_gap_between_grains_only_lets_grains_touch_the_walls() {
    // wall_gap = 0: the gap is kept between grains, and grains may reach the walls.
    let text = r#"
seed = 6
mass = "volume"
[container]
type = "box"
size = [40.0, 40.0, 40.0]
periodic = [false, false, true]
[particles]
grading = { kind = "din", name = "A16" }
mixture_fraction = 0.45
d_min = 2.0
[[stage]]
growth = "absolute"
rate = 0.02
until = { gap = 1.0 }
wall_gap = 0.0
"#;
    let packing = run_toml(text).packing;
    assert!((packing.min_gap - 1.0).abs() < 1e-9);
    assert!(packing.wall_gap.is_some_and(|w| w.abs() < 1e-9));
    assert_gap_and_containment(&packing);
    // Some grain sits closer to a wall than half the gap (else the option did nothing).
    let closest = closest_wall(&packing, |c| {
        (0..2)
            .map(|k| c[k].min(40.0 - c[k]))
            .fold(f64::INFINITY, f64::min)
    });
    assert!(closest < 0.5, "closest wall gap {closest}");
}

/// A `max_gap` scene of `count` spheres of diameter 1 at their true size in a walled cube of
/// edge 4, keeping the fraction `lambda` of the gap to the walls.
fn walled_cube_max_gap(count: usize, lambda: f64) -> String {
    format!(
        "seed = 3\n[container]\ntype = \"box\"\nsize = [4.0, 4.0, 4.0]\n\
         periodic = [false, false, false]\n[particles]\ncount = {count}\ndiameter = 1.0\n\
         [[stage]]\ngrowth = \"absolute\"\nrate = 0.01\nuntil = {{ max_gap = true }}\n\
         wall_gap_fraction = {lambda:?}\n"
    )
}

/// Smallest distance from a sphere's surface to a wall, `wall_distance` giving the distance
/// from a centre to the nearest wall.
fn closest_wall(packing: &Packing, wall_distance: impl Fn(&[f64; 3]) -> f64) -> f64 {
    packing
        .particles
        .iter()
        .map(|p| match p {
            ParticleRecord::Sphere(SphereRecord { center, radius }) => {
                wall_distance(center) - radius
            }
            other => panic!("a sphere packing was expected, got {other:?}"),
        })
        .fold(f64::INFINITY, f64::min)
}

#[test]
fn gap_maximisation_with_a_wall_gap_fraction_meets_the_exact_cubes() {
    // Edge a = 4, diameter d = 1, wall gap λ·Δd. One sphere jams when its coat as the walls
    // see it fills the cube: d/2 + λ·Δd = a/2, so Δd_max = (a − d)/(2λ) (a − d = 3 for the
    // default λ = 1/2). Eight spheres jam on the simple cubic lattice: neighbours d + Δd
    // apart and each λ·Δd from its three walls, 2·(d/2 + λ·Δd) + d + Δd = a, so
    // Δd_max = (a − 2d)/(1 + 2λ).
    let cases = [
        (1, 0.5, 3.0),
        (1, 0.25, 6.0),
        (8, 0.5, 1.0),
        (8, 0.25, 4.0 / 3.0),
        (8, 0.0, 2.0),
    ];
    for (count, lambda, exact) in cases {
        let packing = run_toml(&walled_cube_max_gap(count, lambda)).packing;
        let gap = packing.min_gap;
        let case = format!("{count} spheres, λ = {lambda}: Δd_max = {gap}, exact {exact}");
        // Jammed at reduced pressure 1e12: contacts closed to ~1e-12 of a diameter.
        assert!((gap - exact).abs() < 1e-9 * exact, "{case}");
        assert_eq!(packing.stats.stop_reason, "pressure_reached", "{case}");
        let expected_wall_gap = (lambda != 0.5).then_some(lambda * gap);
        assert_eq!(packing.wall_gap, expected_wall_gap, "{case}");
        assert_gap_and_containment(&packing);
        // The walls hold the grains at exactly the requested share of the gap.
        let wall = closest_wall(&packing, |c| {
            (0..3)
                .map(|k| c[k].min(4.0 - c[k]))
                .fold(f64::INFINITY, f64::min)
        });
        assert!(
            (wall - lambda * gap).abs() < 1e-9,
            "{case}: wall gap {wall}"
        );
    }
}

#[test]
fn a_smaller_wall_gap_fraction_lets_the_gap_grow_larger() {
    // B16 grains above 4 mm in a 50 mm walled cube (260 grains), Δd maximised keeping
    // λ·Δd_max to the walls: the less the walls take, the larger the gap between grains.
    let scene = |lambda: f64| {
        format!(
            "seed = 1\nmass = \"volume\"\n[container]\ntype = \"box\"\nsize = [50.0, 50.0, 50.0]\n\
             periodic = [false, false, false]\n[particles]\n\
             grading = {{ kind = \"din\", name = \"B16\" }}\nmixture_fraction = 0.7\nd_min = 4.0\n\
             [[stage]]\ngrowth = \"relative\"\nrate = 0.05\nuntil = {{ full_size = true }}\n\
             [[stage]]\ngrowth = \"absolute\"\nrate = 0.01\nuntil = {{ max_gap = true }}\n\
             wall_gap_fraction = {lambda:?}\n"
        )
    };
    let mut previous = 0.0;
    for lambda in [0.5, 0.25, 0.0] {
        let outcome = run_toml(&scene(lambda));
        let packing = &outcome.packing;
        let gap = packing.min_gap;
        assert!(
            gap > previous,
            "λ = {lambda}: Δd_max = {gap} after {previous}"
        );
        previous = gap;
        assert_gap_and_containment(packing);
        let wall = outcome.verification.min_wall_gap.expect("walled box");
        assert!(
            wall >= lambda * gap - 1e-9,
            "λ = {lambda}: wall gap {wall} < λ·Δd_max = {}",
            lambda * gap
        );
        if lambda == 0.0 {
            // Grains may touch the walls: some grain rests on one.
            assert!(wall < 1e-6, "λ = 0: closest wall gap {wall}");
        }
    }
}

#[test]
fn a_gap_stage_keeps_a_fraction_of_the_gap_to_a_cylinder_wall() {
    let packing = run_toml(
        r#"
seed = 4
mass = "volume"
[container]
type = "cylinder"
radius = 25.0
height = 50.0
[particles]
grading = { kind = "din", name = "A16" }
mixture_fraction = 0.4
d_min = 4.0
[[stage]]
growth = "absolute"
rate = 0.02
until = { gap = 1.0 }
wall_gap_fraction = 0.2
"#,
    )
    .packing;
    assert!((packing.min_gap - 1.0).abs() < 1e-9, "{}", packing.min_gap);
    assert!(
        packing.wall_gap.is_some_and(|w| (w - 0.2).abs() < 1e-9),
        "{:?}",
        packing.wall_gap
    );
    assert_gap_and_containment(&packing);
    // Some grain sits closer to the mantle or a cap than Δd/2 (else the option did nothing).
    let closest = closest_wall(&packing, |c| {
        (25.0 - c[0].hypot(c[1])).min(c[2]).min(50.0 - c[2])
    });
    assert!(closest < 0.5, "closest wall gap {closest}");
}
