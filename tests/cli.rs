//! The command line: scenes in, packings out, clear errors for bad input.

mod common;

use common::{densepack, temp_dir};

use std::path::Path;

fn scenes() -> &'static Path {
    Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/scenes"))
}

#[test]
fn walls_scene_runs_writes_a_packing_and_verify_accepts_it() {
    let dir = temp_dir("walls");
    let out = dir.join("walls.json");
    let scene = scenes().join("walls_8_spheres.toml");
    let run = densepack(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let packing = densepack::io::packing::Packing::read(&out).unwrap();
    assert_eq!(packing.format, "densepack-packing");
    assert_eq!(packing.particles.len(), 8);
    assert_eq!(packing.stats.stop_reason, "pressure_reached");
    common::assert_no_overlap(&packing);
    let verify = densepack(&["verify", out.to_str().unwrap()]);
    assert!(verify.status.success());
    // Same scene and seed: identical particles, bit for bit.
    let again = dir.join("again.json");
    let run = densepack(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        again.to_str().unwrap(),
    ]);
    assert!(run.status.success());
    let second = densepack::io::packing::Packing::read(&again).unwrap();
    assert_eq!(packing.particles, second.particles);
}

#[test]
fn verify_rejects_an_overlapping_packing_with_exit_code_1() {
    let dir = temp_dir("overlap");
    let path = dir.join("bad.json");
    std::fs::write(
        &path,
        r#"{"format": "densepack-packing", "version": 1,
            "container": {"type": "box", "min": [0,0,0], "max": [10,10,10], "periodic": [true,true,true]},
            "particles": [{"type": "sphere", "center": [0.2, 5, 5], "radius": 0.5},
                          {"type": "sphere", "center": [9.5, 5, 5], "radius": 0.5}],
            "min_gap": 0.0, "seed": 1,
            "stats": {"packing_fraction": 0.0, "reduced_pressure": 1.0, "events": 0,
                      "collisions": 0, "wall_seconds": 0.0, "stop_reason": "pressure_reached"}}"#,
    )
    .unwrap();
    let verify = densepack(&["verify", path.to_str().unwrap()]);
    assert_eq!(verify.status.code(), Some(1));
    let text = String::from_utf8_lossy(&verify.stdout);
    assert!(text.contains("particles 0 and 1"), "{text}");
}

/// Malformed scenes: each must fail with exit code 2, a message naming the problem, and no
/// output file.
#[test]
fn bad_scenes_fail_with_exit_code_2_name_the_field_and_write_nothing() {
    let base = |container: &str, particles: &str, stage: &str| {
        format!(
            "seed = 1\n[container]\n{container}\n[particles]\n{particles}\n[[stage]]\n{stage}\n"
        )
    };
    let good_box = "type = \"box\"\nsize = [10.0, 10.0, 10.0]\nperiodic = [true, true, true]";
    let good_particles = "count = 100\ndiameter = 1.0";
    let good_stage = "growth = \"relative\"\nrate = 0.1\nuntil = { reduced_pressure = 1e12 }";
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "negative diameter",
            base(good_box, "count = 100\ndiameter = -1.0", good_stage),
            "particles.diameter",
        ),
        (
            "packing fraction ≥ 1",
            base(
                good_box,
                "count = 100\ndiameter = 1.0\npacking_fraction = 1.2",
                good_stage,
            ),
            "particles.packing_fraction",
        ),
        (
            "particle larger than the box",
            base(
                "type = \"box\"\nsize = [10.0, 10.0, 10.0]\nperiodic = [false, false, false]",
                "count = 1\ndiameter = 12.0",
                good_stage,
            ),
            "does not fit",
        ),
        (
            "periodic box too small for the minimum image",
            base(good_box, "count = 2\ndiameter = 4.0", good_stage),
            "container.size",
        ),
        (
            "unknown key",
            base(
                good_box,
                "count = 100\ndiameter = 1.0\ncolour = \"red\"",
                good_stage,
            ),
            "unknown field `colour`",
        ),
        (
            "negative box size",
            base(
                "type = \"box\"\nsize = [10.0, -1.0, 10.0]\nperiodic = [true, true, true]",
                good_particles,
                good_stage,
            ),
            "container.size[1]",
        ),
        (
            "growth without rate",
            base(
                good_box,
                good_particles,
                "growth = \"relative\"\nuntil = { reduced_pressure = 1e12 }",
            ),
            "stage[0].rate",
        ),
        (
            "stage without goal",
            base(good_box, good_particles, "growth = \"none\"\nuntil = {}"),
            "stage[0].until",
        ),
        (
            "packing fraction goal without growth",
            base(
                good_box,
                good_particles,
                "growth = \"none\"\nuntil = { packing_fraction = 0.5 }",
            ),
            "cannot be reached without growth",
        ),
        (
            "not TOML at all",
            "\u{0}\u{1}binary garbage \u{7f}".to_string(),
            "TOML",
        ),
        ("empty file", String::new(), "missing field"),
    ];
    let dir = temp_dir("bad");
    for (name, text, needle) in cases {
        let scene = dir.join("scene.toml");
        std::fs::write(&scene, &text).unwrap();
        let out = dir.join("out.json");
        let run = densepack(&[
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{name}: {stderr}");
        assert!(
            stderr.contains(needle),
            "{name}: message {stderr:?} lacks {needle:?}"
        );
        assert!(!out.exists(), "{name}: an output file was written");
    }
}

#[test]
fn a_run_that_cannot_reach_its_goal_fails_and_leaves_an_existing_output_untouched() {
    let dir = temp_dir("fail");
    let scene = dir.join("scene.toml");
    std::fs::write(
        &scene,
        "seed = 1\n[container]\ntype = \"box\"\nsize = [10.0, 10.0, 10.0]\nperiodic = [true, true, true]\n\
         [particles]\ncount = 500\ndiameter = 1.0\npacking_fraction = 0.3\n\
         [[stage]]\ngrowth = \"relative\"\nrate = 0.1\nuntil = { reduced_pressure = 1e12 }\nmax_events = 1000\n",
    )
    .unwrap();
    let out = dir.join("out.json");
    std::fs::write(&out, "previous result").unwrap();
    let run = densepack(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(run.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(stderr.contains("event_limit"), "{stderr}");
    assert_eq!(std::fs::read_to_string(&out).unwrap(), "previous result");
}
