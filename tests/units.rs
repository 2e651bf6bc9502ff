//! Decimal changes of unit (issue 8, scale invariance): a scene rewritten with every length
//! ×10⁻³ or ×10³ — written as decimal literals, as a user converting millimetres to metres
//! would — runs the same: the same events and stop reasons, the same packing fraction at
//! every time barrier bit for bit, and the reference packing ×10^±3 to within one rounding
//! per number. Each case runs `densepack run` on the three scenes.

mod common;

use common::{densepack, temp_dir};
use densepack::io::packing::{ContainerRecord, Packing, ParticleRecord};
use densepack::io::record::{EllipsoidRecord, SphereRecord};
use serde_json::Value;

/// The decimal literal `text` (digits, an optional point, no exponent) times `10^k`, by
/// moving the decimal point: `shift_literal("40.0", -3) == "0.0400"`.
fn shift_literal(text: &str, k: i32) -> String {
    let (sign, body) = match text.strip_prefix('-') {
        Some(rest) => ("-", rest),
        None => ("", text),
    };
    let (int, frac) = body.split_once('.').unwrap_or((body, ""));
    assert!(
        (int.to_owned() + frac).chars().all(|c| c.is_ascii_digit()),
        "{text}: not a plain decimal literal"
    );
    let digits = format!("{int}{frac}");
    let point = int.len() as i32 + k;
    let (int, frac) = if point <= 0 {
        (
            "0".to_owned(),
            "0".repeat((-point) as usize) + digits.as_str(),
        )
    } else if point as usize >= digits.len() {
        (
            digits.clone() + &"0".repeat(point as usize - digits.len()),
            "0".to_owned(),
        )
    } else {
        let (i, f) = digits.split_at(point as usize);
        (i.to_owned(), f.to_owned())
    };
    // TOML forbids leading zeros in the integer part.
    let int = int.trim_start_matches('0');
    let int = if int.is_empty() { "0" } else { int };
    format!("{sign}{int}.{frac}")
}

#[test]
fn literals_shift_by_moving_the_point() {
    assert_eq!(shift_literal("40.0", -3), "0.0400");
    assert_eq!(shift_literal("40.0", 3), "40000.0");
    assert_eq!(shift_literal("0.25", 3), "250.0");
    assert_eq!(shift_literal("2", -3), "0.002");
    assert_eq!(shift_literal("-250.5", -3), "-0.2505");
    assert_eq!(shift_literal("1.35", 1), "13.5");
}

/// `template` with every length written `L(literal)` replaced by the literal ×10^k.
fn scene_at(template: &str, k: i32) -> String {
    let mut out = String::new();
    let mut rest = template;
    while let Some(start) = rest.find("L(") {
        out += &rest[..start];
        let end = start + rest[start..].find(')').expect("L(..) is closed");
        out += &shift_literal(&rest[start + 2..end], k);
        rest = &rest[end + 1..];
    }
    out + rest
}

/// What a run wrote: the packing and the `--run-log` records.
struct Written {
    packing: Packing,
    log: Vec<Value>,
}

fn run(name: &str, scene: &str) -> Written {
    let dir = temp_dir(name);
    let scene_path = dir.join("scene.toml");
    std::fs::write(&scene_path, scene).unwrap();
    let out = dir.join("packing.json");
    let log = dir.join("run.jsonl");
    let run = densepack(&[
        "run",
        scene_path.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--run-log",
        log.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        run.status.success(),
        "{name}: {}\n{scene}",
        String::from_utf8_lossy(&run.stderr)
    );
    let log = std::fs::read_to_string(&log)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    Written {
        packing: Packing::read(&out).unwrap(),
        log,
    }
}

/// Every length of a particle record, in a fixed order.
fn lengths(p: &ParticleRecord) -> Vec<f64> {
    match p {
        ParticleRecord::Sphere(SphereRecord { center, radius }) => {
            [&center[..], &[*radius]].concat()
        }
        ParticleRecord::Ellipsoid(EllipsoidRecord {
            center, semi_axes, ..
        }) => [&center[..], &semi_axes[..]].concat(),
        ParticleRecord::Cylinder(_) => panic!("no cylinders in these scenes"),
    }
}

fn container_lengths(c: &ContainerRecord) -> Vec<f64> {
    match c {
        ContainerRecord::Box { min, max, .. } => [&min[..], &max[..]].concat(),
        ContainerRecord::Cylinder {
            base_center,
            radius,
            height,
        } => [&base_center[..], &[*radius, *height]].concat(),
    }
}

/// `a` equals `b·10^k` to within `1e-12` relative to `size` (the scene's extent at the
/// scale of `a`: a coordinate near 0 is compared at the resolution of the container).
fn assert_scaled(a: f64, b: f64, k: i32, size: f64, what: &str) {
    let expected = b * 10f64.powi(k);
    assert!(
        (a - expected).abs() <= 1e-12 * size.max(expected.abs()),
        "{what}: {a} vs {b}·10^{k} = {expected}"
    );
}

/// The packing fraction at every barrier of a run log, and the gap where reported.
fn trajectory(log: &[Value]) -> (Vec<f64>, Vec<f64>) {
    let progress = log.iter().filter(|r| r["type"] == "progress");
    let phi = progress
        .clone()
        .map(|r| r["packing_fraction"].as_f64().unwrap())
        .collect();
    let gap = progress.filter_map(|r| r["gap"].as_f64()).collect();
    (phi, gap)
}

/// Runs `template` at 10⁻³, 1 and 10³ and compares the scaled runs with the unscaled one.
fn assert_scale_invariant(name: &str, template: &str) {
    let reference = run(&format!("{name}-1"), &scene_at(template, 0));
    let (ref_phi, ref_gap) = trajectory(&reference.log);
    assert!(ref_phi.len() >= 3, "{name}: too few barriers to compare");
    let r = &reference.packing;
    let extent = container_lengths(&r.container)
        .iter()
        .fold(0.0f64, |m, x| m.max(x.abs()));
    for k in [-3, 3] {
        let what = format!("{name} ×10^{k}");
        let scaled = run(&format!("{name}-{k}"), &scene_at(template, k));
        let s = &scaled.packing;
        assert_eq!(s.stats.stop_reason, r.stats.stop_reason, "{what}");
        assert_eq!(s.stats.events, r.stats.events, "{what}: events");
        assert_eq!(s.stats.collisions, r.stats.collisions, "{what}: collisions");
        assert_eq!(
            s.stats.packing_fraction.to_bits(),
            r.stats.packing_fraction.to_bits(),
            "{what}: φ {} vs {}",
            s.stats.packing_fraction,
            r.stats.packing_fraction
        );
        assert_eq!(
            s.stats.reduced_pressure.map(f64::to_bits),
            r.stats.reduced_pressure.map(f64::to_bits),
            "{what}: reduced pressure"
        );
        // Times are in units of ℓ·√(m/kT): the same numbers at every scale.
        let times = |p: &Packing| -> Vec<u64> {
            p.stats.extra.get("stages").map_or(Vec::new(), |stages| {
                stages
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|st| st["simulated_time"].as_f64().unwrap().to_bits())
                    .collect()
            })
        };
        assert_eq!(times(s), times(r), "{what}: stage times");
        let (phi, gap) = trajectory(&scaled.log);
        assert_eq!(phi.len(), ref_phi.len(), "{what}: barriers");
        for (a, b) in phi.iter().zip(&ref_phi) {
            assert!((a - b).abs() <= 1e-9 * b, "{what}: φ {a} vs {b}");
            assert_eq!(
                a.to_bits(),
                b.to_bits(),
                "{what}: φ {a} vs {b} not bit-identical"
            );
        }
        assert_eq!(gap.len(), ref_gap.len(), "{what}: gap samples");
        for (a, b) in gap.iter().zip(&ref_gap) {
            assert_scaled(*a, *b, k, 0.0, &format!("{what}: gap"));
        }
        let size = extent * 10f64.powi(k);
        for (a, b) in container_lengths(&s.container)
            .iter()
            .zip(container_lengths(&r.container))
        {
            assert_scaled(*a, b, k, size, &format!("{what}: container"));
        }
        assert_scaled(s.min_gap, r.min_gap, k, 0.0, &format!("{what}: min_gap"));
        assert_eq!(s.wall_gap.is_some(), r.wall_gap.is_some(), "{what}");
        if let (Some(a), Some(b)) = (s.wall_gap, r.wall_gap) {
            assert_scaled(a, b, k, 0.0, &format!("{what}: wall_gap"));
        }
        assert_eq!(s.particles.len(), r.particles.len(), "{what}: particles");
        for (i, (p, q)) in s.particles.iter().zip(&r.particles).enumerate() {
            if let (
                ParticleRecord::Ellipsoid(EllipsoidRecord { orientation: a, .. }),
                ParticleRecord::Ellipsoid(EllipsoidRecord { orientation: b, .. }),
            ) = (p, q)
            {
                assert_eq!(a, b, "{what}: orientation of particle {i}");
            }
            for (a, b) in lengths(p).iter().zip(lengths(q)) {
                assert_scaled(*a, b, k, size, &format!("{what}: particle {i}"));
            }
        }
    }
}

/// Equal spheres in a periodic box jammed to Z = 10¹², the box's corner off the origin; the
/// smallest diameter 1.3 gives ℓ = 1 at scale 1 and 10^±3 scaled.
#[test]
fn a_periodic_sphere_jam_is_the_same_in_every_decimal_unit() {
    assert_scale_invariant(
        "periodic-jam",
        r#"
seed = 3
[container]
type = "box"
min = [L(0.65), L(-2.6), L(1000.0)]
size = [L(11.7), L(11.7), L(11.7)]
periodic = [true, true, true]
[particles]
count = 400
diameter = L(1.3)
packing_fraction = 0.3
[[stage]]
growth = "relative"
rate = 0.05
until = { reduced_pressure = 1e12 }
"#,
    );
}

/// A walled concrete scene: a sieve table (mm), grown to full size, then a 0.53 mm gap
/// between grains and 0.14 mm to the walls (the walls step back), the box corner at 10⁶ mm.
const CONCRETE: &str = r#"
seed = 5
mass = "volume"
[container]
type = "box"
min = [L(1000000.0), L(0.0), L(-250.5)]
size = [L(39.3), L(39.3), L(39.3)]
periodic = [false, false, false]
[particles]
grading = { kind = "table", sizes = [L(2.01), L(4.02), L(8.04), L(11.2)], passing = [0.0, 35.0, 70.0, 100.0] }
mixture_fraction = 0.4
d_min = L(2.45)
[[stage]]
growth = "relative"
rate = 0.05
until = { full_size = true }
[[stage]]
growth = "absolute"
rate = L(0.021)
until = { gap = L(0.53) }
wall_gap = L(0.14)
"#;

#[test]
fn a_walled_concrete_gap_scene_is_the_same_in_every_decimal_unit() {
    assert_scale_invariant("concrete-gap", CONCRETE);
}

/// The concrete scene in metres (ℓ = 10⁻³ m) resumed from a checkpoint in its gap stage
/// writes the packing of the uninterrupted run, bit for bit.
#[test]
fn a_scaled_scene_resumes_to_the_same_packing() {
    use densepack::io::checkpoint::CheckpointFile;
    use densepack::io::scene::{AnyScene, Scene};
    use densepack::run::{resume_run, run, run_scene, CheckpointPlan, RunOptions};
    let dir = temp_dir("resume");
    let text = scene_at(CONCRETE, -3);
    let scene = Scene::from_toml(&text).unwrap();
    let straight = run_scene(&scene, &mut |_, _| {}).unwrap().packing;
    let plan = CheckpointPlan {
        path: dir.join("scaled.ckpt"),
        every: std::time::Duration::ZERO,
    };
    let options = RunOptions {
        checkpoints: Some(plan.clone()),
        ..RunOptions::default()
    };
    run(&AnyScene::Spheres(Box::new(scene)), options).unwrap();
    let file = CheckpointFile::read(&plan.path).unwrap();
    assert_eq!(
        file.header.stage, 1,
        "the last checkpoint is in the gap stage"
    );
    let resumed = resume_run(&file, RunOptions::default()).unwrap().packing;
    assert_eq!(resumed.particles, straight.particles);
    assert_eq!(resumed.min_gap.to_bits(), straight.min_gap.to_bits());
    assert_eq!(resumed.container, straight.container);
    assert_eq!(resumed.stats.events, straight.stats.events);
}

/// Prolate ellipsoids (volume-equivalent diameter 0.45, so ℓ = 0.1 at scale 1) grown from a
/// dilute seeding in a walled box, then equilibrated.
#[test]
fn an_ellipsoid_scene_is_the_same_in_every_decimal_unit() {
    assert_scale_invariant(
        "ellipsoids",
        r#"
seed = 8
[container]
type = "box"
size = [L(2.7), L(2.7), L(3.15)]
periodic = [true, true, false]
[particles]
count = 80
diameter = L(0.45)
packing_fraction = 0.05
[particles.ellipsoid]
aspect_ratios = [2.0, 2.0]
[[stage]]
growth = "relative"
rate = 0.05
until = { packing_fraction = 0.4 }
[[stage]]
growth = "none"
until = { collisions_per_particle = 5 }
"#,
    );
}

/// Random sequential addition with a gap (no dynamics): the same draws, the same packing.
#[test]
fn an_rsa_scene_is_the_same_in_every_decimal_unit() {
    let template = r#"
seed = 11
method = "rsa"
[container]
type = "cylinder"
base_center = [L(-7.5), L(0.0), L(12.25)]
radius = L(15.3)
height = L(40.7)
[particles]
components = [{ count = 60, diameter = L(4.02) }, { count = 200, diameter = L(2.2) }]
gap = L(0.56)
wall_gap = L(0.13)
"#;
    let reference = run("rsa-1", &scene_at(template, 0)).packing;
    for k in [-3, 3] {
        let scaled = run(&format!("rsa-{k}"), &scene_at(template, k)).packing;
        assert_eq!(
            scaled.stats.packing_fraction.to_bits(),
            reference.stats.packing_fraction.to_bits()
        );
        assert_scaled(scaled.min_gap, reference.min_gap, k, 0.0, "min_gap");
        for (p, q) in scaled.particles.iter().zip(&reference.particles) {
            for (a, b) in lengths(p).iter().zip(lengths(q)) {
                assert_scaled(*a, b, k, 40.7 * 10f64.powi(k), "rsa particle");
            }
        }
    }
}
