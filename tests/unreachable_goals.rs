//! Every shipped scene, its goal made unreachable, ends with exit 1 and a verdict.
//!
//! Each scene of `examples/scenes/` that runs growth stages is rewritten so that its last
//! stage asks for a packing fraction its particles cannot reach by growth (equal spheres:
//! 0.74, just below the densest packing's 0.7405, far above random jamming near 0.64; size
//! distributions and ellipsoids: 0.95, above the densest known ellipsoid packing's 0.7707
//! and far above what these size ranges jam at), and is
//! run through the binary. The run must end by the jamming guard (`jammed_before_goal`), or
//! by a scene's own stall criterion in an earlier stage, within the stage's `max_events`,
//! which the test sets: a run that spins on would end by `event_limit` instead, and fail the
//! test. Large scenes are shrunk first (fewer particles, a
//! smaller specimen, a coarser cut-off `d_min`) so the test stays quick; what is checked — that
//! a stage whose goal lies beyond jamming stops at jamming — does not depend on the size.
//! Sphere + cylinder mixtures have no growth stages (their fractions are refused or fail in
//! random sequential addition, `tests/mixture.rs`) and are skipped, and so are the ellipsoid
//! scenes of aspect ratio above [`MAX_ASPECT`] (paper 004's Table 2 needles and discs): the
//! guard is the same code for every shape, but jamming needles to `Z = 10¹²` takes minutes.

mod common;

use common::{densepack, temp_dir};
use std::sync::atomic::{AtomicUsize, Ordering};
use toml::Value;

/// Largest ellipsoid aspect ratio among the scenes this test runs.
const MAX_ASPECT: f64 = 2.5;

/// Events a shrunk scene may take before the test calls it endless.
const MAX_EVENTS: i64 = 100_000_000;

/// The scene with its size bounded and its last stage's goal unreachable, or `None` for a
/// scene without growth stages. `widen` multiplies the container's edges by 2 and the
/// particle count by 8 that many times (same particle sizes): at a fraction of 0.95, long
/// ellipsoids would outgrow a small periodic box, which validation refuses.
fn unreachable_variant(text: &str, widen: u32) -> Option<String> {
    let mut scene: Value = toml::from_str(text).expect("a shipped scene parses");
    let table = scene.as_table_mut().expect("a scene is a table");
    table.get("stage")?;
    let aspect = table["particles"]
        .get("ellipsoid")
        .and_then(|e| e.get("aspect_ratios").or(e.get("aspect_ratio_ranges")))
        .map_or(1.0, |a| {
            let text = a.to_string();
            text.split(|c: char| !(c.is_ascii_digit() || c == '.'))
                .filter_map(|x| x.parse::<f64>().ok())
                .fold(1.0, f64::max)
        });
    if aspect > MAX_ASPECT {
        return None;
    }
    let stages = table.get_mut("stage")?.as_array_mut()?;
    // The stages before the last keep their goals (they are reachable); all get the bound.
    for stage in stages.iter_mut() {
        let stage = stage.as_table_mut().expect("a stage is a table");
        stage.insert("max_events".into(), Value::Integer(MAX_EVENTS));
        stage.remove("max_wall_seconds");
    }
    // Equal spheres: just below Kepler's bound π/√18 = 0.7405 (validation refuses more), far
    // above random jamming (0.64). Other particles: 0.95.
    let equal_spheres = !table["particles"].as_table().is_some_and(|p| {
        ["grading", "components", "ellipsoid"]
            .iter()
            .any(|k| p.contains_key(*k))
    });
    let target = if equal_spheres { 0.74 } else { 0.95 };
    let stages = table.get_mut("stage")?.as_array_mut()?;
    let last = stages.last_mut().expect("at least one stage");
    let mut goal = toml::map::Map::new();
    goal.insert("packing_fraction".into(), Value::Float(target));
    let last = last.as_table_mut().unwrap();
    for key in ["wall_gap", "wall_gap_fraction", "thermostat"] {
        last.remove(key);
    }
    last.insert("until".into(), Value::Table(goal));
    last.insert("growth".into(), Value::String("relative".into()));
    last.insert("rate".into(), Value::Float(0.2));
    let particles = table["particles"].as_table_mut().unwrap();
    if particles.get("count").and_then(Value::as_integer) > Some(2000) {
        particles.insert("count".into(), Value::Integer(2000));
    }
    for _ in 0..widen {
        let particles = table["particles"].as_table_mut().unwrap();
        let count = particles["count"]
            .as_integer()
            .expect("ellipsoid scenes give a count");
        particles.insert("count".into(), Value::Integer(8 * count));
        let size = table["container"]["size"].as_array().unwrap().clone();
        let wider = size
            .iter()
            .map(|x| Value::Float(2.0 * x.as_float().unwrap()));
        table["container"]
            .as_table_mut()
            .unwrap()
            .insert("size".into(), Value::Array(wider.collect()));
    }
    let particles = table["particles"].as_table_mut().unwrap();
    if particles.contains_key("grading") {
        // A 40 mm specimen with grains from 4 mm: a few hundred grains.
        let d_min = particles
            .get("d_min")
            .and_then(Value::as_float)
            .unwrap_or(0.0);
        particles.insert("d_min".into(), Value::Float(d_min.max(4.0)));
        let container = table["container"].as_table_mut().unwrap();
        if container.get("type").and_then(Value::as_str) == Some("cylinder") {
            container.insert("radius".into(), Value::Float(25.0));
            container.insert("height".into(), Value::Float(50.0));
        } else {
            container.insert("size".into(), Value::Array(vec![Value::Float(40.0); 3]));
        }
    }
    Some(toml::to_string(&scene).expect("serialisable"))
}

/// Runs the unreachable variant of one shipped scene and checks its verdict; `false` for a
/// scene without growth stages (not run).
fn fails_with_a_verdict(path: &std::path::Path, dir: &std::path::Path) -> bool {
    let text = std::fs::read_to_string(path).unwrap();
    let name = path.file_name().unwrap().to_string_lossy().to_string();
    let scene = dir.join(&name);
    let out = dir.join(format!("{name}.json"));
    let mut widen = 0;
    let (variant, result) = loop {
        let Some(variant) = unreachable_variant(&text, widen) else {
            return false;
        };
        std::fs::write(&scene, &variant).unwrap();
        let result = densepack(&[
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        let refused = String::from_utf8_lossy(&result.stderr)
            .contains("a periodic box edge must exceed the largest bounding diameter");
        if refused && widen < 2 {
            widen += 1;
            continue;
        }
        break (variant, result);
    };
    let stderr = String::from_utf8_lossy(&result.stderr);
    assert_eq!(
        result.status.code(),
        Some(1),
        "{name}: expected exit 1, got {:?}\n{stderr}\nscene:\n{variant}",
        result.status.code()
    );
    // The last stage ends by the jamming guard; an earlier stage of a shrunk concrete
    // scene may already fail by its own stall criterion (`stall_epsilon`), also a verdict.
    let by_guard = stderr.contains("jammed_before_goal after")
        && stderr.contains("the particles jammed first")
        && (stderr.contains("packing_fraction = 0.95")
            || stderr.contains("packing_fraction = 0.74"));
    let stalled = stderr.contains("stalled after");
    assert!(
        stderr.contains("stopped without reaching its goal (") && (by_guard || stalled),
        "{name}: the run must end at jamming (or stall) and name the goal it missed:\n{stderr}"
    );
    assert!(
        !out.exists(),
        "{name}: a failed run wrote {}",
        out.display()
    );
    true
}

#[test]
fn every_shipped_scene_with_an_unreachable_goal_fails_with_a_verdict() {
    let dir = temp_dir("unreachable");
    let mut scenes: Vec<_> = std::fs::read_dir("examples/scenes")
        .expect("examples/scenes")
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    scenes.sort();
    // The scenes are independent single-threaded runs: one worker per core takes the next.
    // A failed check panics in its worker, which fails the scope (the message is printed).
    let next = AtomicUsize::new(0);
    let ran = AtomicUsize::new(0);
    let workers = std::thread::available_parallelism().map_or(1, |n| n.get());
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                while let Some(path) = scenes.get(next.fetch_add(1, Ordering::Relaxed)) {
                    if fails_with_a_verdict(path, &dir) {
                        ran.fetch_add(1, Ordering::Relaxed);
                    }
                }
            });
        }
    });
    let ran = ran.into_inner();
    assert!(ran >= 10, "only {ran} shipped scenes have growth stages");
}
