//! Bad input through the real binary: every malformed scene fails with exit code 2 and a
//! message that names the problem (the field and, for a value out of range, the allowed
//! range), and no output file is created or overwritten.
//!
//! The table is the place to add cases for new scene keys (ellipsoid axes, cylinder
//! particles, grading curves and sieve tables): one row each, built with [`Parts`].

mod common;

use common::{densepack, temp_dir};

use std::path::Path;

/// The sections of a valid scene; a case replaces one of them.
#[derive(Clone)]
struct Parts {
    top: &'static str,
    container: &'static str,
    particles: &'static str,
    stage: &'static str,
}

const GOOD: Parts = Parts {
    top: "seed = 1",
    container: "type = \"box\"\nsize = [10.0, 10.0, 10.0]\nperiodic = [true, true, true]",
    particles: "count = 100\ndiameter = 1.0",
    stage: "growth = \"relative\"\nrate = 0.1\nuntil = { reduced_pressure = 1e12 }",
};

impl Parts {
    fn text(&self) -> Vec<u8> {
        format!(
            "{}\n[container]\n{}\n[particles]\n{}\n[[stage]]\n{}\n",
            self.top, self.container, self.particles, self.stage
        )
        .into_bytes()
    }
    fn top(top: &'static str) -> Vec<u8> {
        Parts { top, ..GOOD }.text()
    }
    fn container(container: &'static str) -> Vec<u8> {
        Parts { container, ..GOOD }.text()
    }
    fn particles(particles: &'static str) -> Vec<u8> {
        Parts { particles, ..GOOD }.text()
    }
    fn stage(stage: &'static str) -> Vec<u8> {
        Parts { stage, ..GOOD }.text()
    }
}

const WALLED: &str = "type = \"box\"\nsize = [10.0, 10.0, 10.0]\nperiodic = [false, false, false]";

/// `(name, scene bytes, substrings the error message must contain)`.
fn cases() -> Vec<(&'static str, Vec<u8>, Vec<&'static str>)> {
    vec![
        // Not a scene at all.
        ("empty file", Vec::new(), vec!["missing field `seed`"]),
        (
            "binary garbage (not UTF-8)",
            vec![0xff, 0xfe, 0x00, 0x13, 0x80, 0x7f, 0xc3],
            vec!["UTF-8"],
        ),
        (
            "binary garbage (UTF-8 control characters)",
            b"\x00\x01\x02seed\x7f=\x1b[1m".to_vec(),
            vec!["TOML parse error"],
        ),
        (
            "JSON instead of TOML",
            br#"{"seed": 1, "container": {"type": "box"}}"#.to_vec(),
            vec!["TOML parse error"],
        ),
        (
            "duplicate key",
            Parts::top("seed = 1\nseed = 2"),
            vec!["duplicate key"],
        ),
        // Top level.
        (
            "negative seed",
            Parts::top("seed = -1"),
            vec!["seed = -1", "u64"],
        ),
        (
            "seed of the wrong type",
            Parts::top("seed = \"abc\""),
            vec!["seed", "expected u64"],
        ),
        (
            "unknown top-level key",
            Parts::top("seed = 1\ncolour = \"red\""),
            vec!["unknown field `colour`"],
        ),
        (
            "unknown queue",
            Parts::top("seed = 1\nqueue = \"fibonacci\""),
            vec!["queue", "unknown variant `fibonacci`", "calendar", "heap"],
        ),
        (
            "unknown mass rule",
            Parts::top("seed = 1\nmass = \"heavy\""),
            vec!["mass", "unknown variant `heavy`", "equal", "volume"],
        ),
        (
            "zero temperature",
            Parts::top("seed = 1\ntemperature = 0.0"),
            vec!["temperature", "> 0"],
        ),
        (
            "NaN temperature",
            Parts::top("seed = 1\ntemperature = nan"),
            vec!["temperature", "NaN", "> 0"],
        ),
        (
            "neighbour skin above its range",
            Parts::top("seed = 1\nneighbour_skin = 3.0"),
            vec!["neighbour_skin", "(0, 0.5]"],
        ),
        (
            "infinite events per interval",
            Parts::top("seed = 1\nevents_per_particle_per_interval = inf"),
            vec!["events_per_particle_per_interval", "finite", "> 0"],
        ),
        // Container.
        (
            "unknown container type",
            Parts::container("type = \"sphere\"\nradius = 3.0"),
            vec!["container", "unknown variant `sphere`", "box", "cylinder"],
        ),
        (
            "container without type",
            Parts::container("size = [10.0, 10.0, 10.0]\nperiodic = [true, true, true]"),
            vec!["container.type", "missing"],
        ),
        (
            "container type not a string",
            Parts::container("type = 3\nsize = [10.0, 10.0, 10.0]\nperiodic = [true, true, true]"),
            vec!["container.type", "expected a string"],
        ),
        (
            "box size of the wrong type",
            Parts::container(
                "type = \"box\"\nsize = [10.0, \"x\", 10.0]\nperiodic = [true, true, true]",
            ),
            vec!["container.size[1]", "invalid type", "expected f64"],
        ),
        (
            "box size of two numbers",
            Parts::container("type = \"box\"\nsize = [10.0, 10.0]\nperiodic = [true, true, true]"),
            vec!["container.size", "length 3"],
        ),
        (
            "periodic flags of the wrong type",
            Parts::container("type = \"box\"\nsize = [10.0, 10.0, 10.0]\nperiodic = [1, 1, 1]"),
            vec!["container.periodic[0]", "expected a boolean"],
        ),
        (
            "unknown key in the container",
            Parts::container(
                "type = \"box\"\nsize = [10.0, 10.0, 10.0]\nperiodic = [true, true, true]\nradius = 2.0",
            ),
            vec!["container", "unknown field `radius`"],
        ),
        (
            "negative box size",
            Parts::container(
                "type = \"box\"\nsize = [10.0, -1.0, 10.0]\nperiodic = [true, true, true]",
            ),
            vec!["container.size[1]", "= -1", "> 0"],
        ),
        (
            "NaN box size",
            Parts::container(
                "type = \"box\"\nsize = [nan, 10.0, 10.0]\nperiodic = [true, true, true]",
            ),
            vec!["container.size[0]", "NaN", "> 0"],
        ),
        (
            "infinite box corner",
            Parts::container(
                "type = \"box\"\nmin = [0.0, 0.0, -inf]\nsize = [10.0, 10.0, 10.0]\nperiodic = [true, true, true]",
            ),
            vec!["container.min[2]", "finite"],
        ),
        (
            "box whose upper corner overflows",
            Parts::container(
                "type = \"box\"\nmin = [1.7e308, 0.0, 0.0]\nsize = [1.7e308, 10.0, 10.0]\nperiodic = [true, true, true]",
            ),
            vec!["container.size[0]", "overflows"],
        ),
        (
            "box whose volume overflows",
            Parts::container(
                "type = \"box\"\nsize = [1e200, 1e200, 1e200]\nperiodic = [false, false, false]",
            ),
            vec!["container", "volume", "finite"],
        ),
        (
            "cylinder with negative radius",
            Parts::container("type = \"cylinder\"\nradius = -5.0\nheight = 10.0"),
            vec!["container.radius", "> 0"],
        ),
        (
            "cylinder without height",
            Parts::container("type = \"cylinder\"\nradius = 5.0"),
            vec!["container", "missing field `height`"],
        ),
        (
            "cylinder with NaN base centre",
            Parts::container(
                "type = \"cylinder\"\nbase_center = [0.0, nan, 0.0]\nradius = 5.0\nheight = 10.0",
            ),
            vec!["container.base_center", "finite"],
        ),
        // Particles.
        (
            "both count and components",
            Parts::particles(
                "count = 100\ndiameter = 1.0\ncomponents = [{ count = 1, diameter = 1.0 }]",
            ),
            vec!["particles", "exactly one of", "`count` and `diameter`", "`components`"],
        ),
        (
            "no particles given",
            Parts::particles("packing_fraction = 0.3"),
            vec!["particles", "exactly one of", "`count` and `diameter`", "`components`"],
        ),
        (
            "zero count",
            Parts::particles("count = 0\ndiameter = 1.0"),
            vec!["particles.count", "≥ 1"],
        ),
        (
            "negative count",
            Parts::particles("count = -5\ndiameter = 1.0"),
            vec!["count = -5", "usize"],
        ),
        (
            "more particles than the kernel can index",
            Parts::particles("count = 10000000000\ndiameter = 1e-4"),
            vec!["particles", "4294967294"],
        ),
        (
            "component counts that overflow",
            Parts::particles(
                "components = [{ count = 9223372036854775807, diameter = 1e-9 }, { count = 9223372036854775807, diameter = 1e-9 }, { count = 9223372036854775807, diameter = 1e-9 }]",
            ),
            vec!["particles", "4294967294"],
        ),
        (
            "negative diameter",
            Parts::particles("count = 100\ndiameter = -1.0"),
            vec!["particles.diameter", "= -1", "> 0"],
        ),
        (
            "zero diameter",
            Parts::particles("count = 100\ndiameter = 0.0"),
            vec!["particles.diameter", "> 0"],
        ),
        (
            "NaN diameter",
            Parts::particles("count = 100\ndiameter = nan"),
            vec!["particles.diameter", "NaN", "> 0"],
        ),
        (
            "diameter of the wrong type",
            Parts::particles("count = 100\ndiameter = \"large\""),
            vec!["diameter", "expected f64"],
        ),
        (
            "diameters whose volume underflows",
            Parts::particles("count = 100\ndiameter = 1e-120"),
            vec!["particles", "too small"],
        ),
        (
            "packing fraction of 1",
            Parts::particles("count = 100\ndiameter = 1.0\npacking_fraction = 1.0"),
            vec!["particles.packing_fraction", "(0, 1)"],
        ),
        (
            "packing fraction above 1",
            Parts::particles("count = 100\ndiameter = 1.0\npacking_fraction = 1.2"),
            vec!["particles.packing_fraction", "= 1.2", "(0, 1)"],
        ),
        (
            "negative packing fraction",
            Parts::particles("count = 100\ndiameter = 1.0\npacking_fraction = -0.1"),
            vec!["particles.packing_fraction", "(0, 1)"],
        ),
        (
            "NaN packing fraction",
            Parts::particles("count = 100\ndiameter = 1.0\npacking_fraction = nan"),
            vec!["particles.packing_fraction", "NaN", "(0, 1)"],
        ),
        (
            "spheres that overfill the container",
            Parts {
                container: WALLED,
                particles: "count = 2000\ndiameter = 1.0",
                ..GOOD
            }
            .text(),
            vec!["particles", "fill", "< 1"],
        ),
        (
            "particle larger than the box",
            Parts {
                container: WALLED,
                particles: "count = 1\ndiameter = 12.0",
                ..GOOD
            }
            .text(),
            vec!["particles", "does not fit", "smallest extent 10"],
        ),
        (
            "particle larger than the cylinder",
            Parts {
                container: "type = \"cylinder\"\nradius = 2.0\nheight = 10.0",
                particles: "count = 1\ndiameter = 4.5",
                ..GOOD
            }
            .text(),
            vec!["particles", "does not fit", "smallest extent 4"],
        ),
        (
            "periodic box too small for the minimum image",
            Parts::particles("count = 2\ndiameter = 4.0"),
            vec!["container.size", "twice the largest diameter"],
        ),
        (
            "unknown key among the particles",
            Parts::particles("count = 100\ndiameter = 1.0\nshape = \"cube\""),
            vec!["unknown field `shape`"],
        ),
        (
            "empty component table",
            Parts::particles("components = []"),
            vec!["particles.components", "at least one"],
        ),
        (
            "component of zero count",
            Parts::particles(
                "components = [{ count = 10, diameter = 1.0 }, { count = 0, diameter = 2.0 }]",
            ),
            vec!["particles.components[1].count", "≥ 1"],
        ),
        (
            "component of negative diameter",
            Parts::particles("components = [{ count = 10, diameter = -2.0 }]"),
            vec!["particles.components[0].diameter", "> 0"],
        ),
        (
            "component table with a sieve column",
            Parts::particles("components = [{ count = 10, diameter = 1.0, passing = 0.3 }]"),
            vec!["unknown field `passing`"],
        ),
        (
            "components that are not tables",
            Parts::particles("components = [1.0, 2.0]"),
            vec!["components", "invalid type"],
        ),
        (
            "zero RSA rejection limit",
            Parts::particles("count = 100\ndiameter = 1.0\nrsa_max_failures = 0"),
            vec!["particles.rsa_max_failures", "≥ 1"],
        ),
        (
            "seed scale above 1",
            Parts::particles("count = 100\ndiameter = 1.0\nseed_scale = 1.5"),
            vec!["particles.seed_scale", "= 1.5", "(0, 1]"],
        ),
        (
            "cut-off diameter without a grading curve",
            Parts::particles("count = 100\ndiameter = 1.0\nd_min = 0.5"),
            vec!["particles.d_min", "only with `grading`"],
        ),
        (
            "Fuller exponent above 1",
            Parts::particles(
                "grading = { kind = \"fuller\", q = 1.5, d_max = 4.0 }\nmixture_fraction = 0.6\nd_min = 1.0",
            ),
            vec!["particles.grading", "1.5"],
        ),
        // Stages.
        (
            "no stage",
            b"seed = 1\n[container]\ntype = \"box\"\nsize = [10.0, 10.0, 10.0]\nperiodic = [true, true, true]\n[particles]\ncount = 100\ndiameter = 1.0\n".to_vec(),
            vec!["stage", "at least one [[stage]]"],
        ),
        (
            "empty stage list",
            b"seed = 1\nstage = []\n[container]\ntype = \"box\"\nsize = [10.0, 10.0, 10.0]\nperiodic = [true, true, true]\n[particles]\ncount = 100\ndiameter = 1.0\n".to_vec(),
            vec!["stage", "at least one [[stage]]"],
        ),
        (
            "unknown growth",
            Parts::stage("growth = \"exponential\"\nrate = 0.1\nuntil = { time = 1.0 }"),
            vec!["growth", "unknown variant `exponential`", "relative"],
        ),
        (
            "growth without rate",
            Parts::stage("growth = \"relative\"\nuntil = { reduced_pressure = 1e12 }"),
            vec!["stage[0].rate", "required"],
        ),
        (
            "rate without growth",
            Parts::stage("growth = \"none\"\nrate = 0.1\nuntil = { time = 1.0 }"),
            vec!["stage[0].rate", "not allowed"],
        ),
        (
            "negative rate",
            Parts::stage("growth = \"absolute\"\nrate = -0.1\nuntil = { time = 1.0 }"),
            vec!["stage[0].rate", "> 0"],
        ),
        (
            "stage without goal",
            Parts::stage("growth = \"none\"\nuntil = {}"),
            vec!["stage[0].until", "needs a goal"],
        ),
        (
            "unknown goal",
            Parts::stage("growth = \"none\"\nuntil = { energy = 3.0 }"),
            vec!["unknown field `energy`", "packing_fraction"],
        ),
        (
            "packing fraction goal of 1",
            Parts::stage("growth = \"relative\"\nrate = 0.1\nuntil = { packing_fraction = 1.0 }"),
            vec!["stage[0].until.packing_fraction", "(0, 1)"],
        ),
        (
            "packing fraction goal beyond Kepler for equal spheres",
            Parts::stage("growth = \"relative\"\nrate = 0.1\nuntil = { packing_fraction = 0.76 }"),
            vec!["stage[0].until.packing_fraction", "cannot be reached", "0.740480"],
        ),
        (
            "packing fraction goal without growth",
            Parts::stage("growth = \"none\"\nuntil = { packing_fraction = 0.5 }"),
            vec!["stage[0].until.packing_fraction", "without growth"],
        ),
        (
            "reduced pressure goal of 1",
            Parts::stage("growth = \"relative\"\nrate = 0.1\nuntil = { reduced_pressure = 1.0 }"),
            vec!["stage[0].until.reduced_pressure", "> 1"],
        ),
        (
            "negative time goal",
            Parts::stage("growth = \"none\"\nuntil = { time = -1.0 }"),
            vec!["stage[0].until.time", "> 0"],
        ),
        (
            "zero event limit",
            Parts::stage("growth = \"none\"\nuntil = { time = 1.0 }\nmax_events = 0"),
            vec!["stage[0].max_events", "≥ 1"],
        ),
        (
            "negative event limit",
            Parts::stage("growth = \"none\"\nuntil = { time = 1.0 }\nmax_events = -3"),
            vec!["max_events = -3", "u64"],
        ),
        (
            "NaN wall-clock limit",
            Parts::stage("growth = \"none\"\nuntil = { time = 1.0 }\nmax_wall_seconds = nan"),
            vec!["stage[0].max_wall_seconds", "NaN", "(0, 1e9]"],
        ),
        (
            // Finite, but no `Duration` holds it: refused instead of panicking later.
            "wall-clock limit of 1e300 s",
            Parts::stage("growth = \"none\"\nuntil = { time = 1.0 }\nmax_wall_seconds = 1e300"),
            vec!["stage[0].max_wall_seconds", "(0, 1e9]"],
        ),
        (
            "negative stall epsilon",
            Parts::stage("growth = \"none\"\nuntil = { time = 1.0 }\nstall_epsilon = -1e-9"),
            vec!["stage[0].stall_epsilon", "≥ 0"],
        ),
        (
            "thermostat of the wrong type",
            Parts::stage("growth = \"none\"\nuntil = { time = 1.0 }\nthermostat = \"yes\""),
            vec!["thermostat", "expected a boolean"],
        ),
        (
            "gap goal with relative growth",
            Parts::stage("growth = \"relative\"\nrate = 0.1\nuntil = { gap = 0.1 }"),
            vec!["stage[0].until.gap", "growth = \"absolute\""],
        ),
        (
            "wall gap as a length with max_gap",
            Parts::stage(
                "growth = \"absolute\"\nrate = 0.1\nuntil = { max_gap = true }\nwall_gap = 0.1",
            ),
            vec!["stage[0].wall_gap", "wall_gap_fraction", "[0, 0.5]"],
        ),
        (
            "wall gap fraction above one half",
            Parts::stage(
                "growth = \"absolute\"\nrate = 0.1\nuntil = { max_gap = true }\nwall_gap_fraction = 0.6",
            ),
            vec!["stage[0].wall_gap_fraction", "[0, 0.5]"],
        ),
        (
            "wall gap given twice",
            Parts::stage(
                "growth = \"absolute\"\nrate = 0.1\nuntil = { gap = 0.1 }\nwall_gap = 0.0\nwall_gap_fraction = 0.0",
            ),
            vec!["stage[0].wall_gap_fraction", "either"],
        ),
        (
            "wall gap fraction outside a gap stage",
            Parts::stage(
                "growth = \"relative\"\nrate = 0.1\nuntil = { reduced_pressure = 1e12 }\nwall_gap_fraction = 0.5",
            ),
            vec!["stage[0].wall_gap_fraction", "gap stage"],
        ),
        (
            "error in the second stage",
            format!(
                "{}[[stage]]\ngrowth = \"none\"\nuntil = {{ collisions_per_particle = -2.0 }}\n",
                String::from_utf8(GOOD.text()).unwrap()
            )
            .into_bytes(),
            vec!["stage[1].until.collisions_per_particle", "> 0"],
        ),
    ]
}

/// Content of a pre-existing output file: not JSON, not UTF-8, so any rewrite shows.
const PREVIOUS: &[u8] = b"previous result \xff\x00 keep me";

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

#[test]
fn malformed_scenes_exit_2_name_the_problem_and_touch_no_output() {
    let dir = temp_dir("table");
    let cases = cases();
    assert!(cases.len() >= 30, "the table should hold at least 30 cases");
    let mut failures = Vec::new();
    for (name, bytes, needles) in &cases {
        let scene = dir.join("scene.toml");
        std::fs::write(&scene, bytes).unwrap();
        // First without an output file, then with one that must survive byte for byte.
        for existing in [false, true] {
            let out = dir.join("out.json");
            let _ = std::fs::remove_file(&out);
            if existing {
                std::fs::write(&out, PREVIOUS).unwrap();
            }
            let run = densepack(&[
                "run",
                scene.to_str().unwrap(),
                "--out",
                out.to_str().unwrap(),
            ]);
            let stderr = String::from_utf8_lossy(&run.stderr);
            if run.status.code() != Some(2) {
                failures.push(format!("{name}: exit {:?}: {stderr}", run.status.code()));
            }
            for needle in needles {
                if !stderr.contains(needle) {
                    failures.push(format!("{name}: message {stderr:?} lacks {needle:?}"));
                }
            }
            if existing {
                if std::fs::read(&out).ok().as_deref() != Some(PREVIOUS) {
                    failures.push(format!("{name}: the existing output was changed"));
                }
            } else if out.exists() {
                failures.push(format!("{name}: an output file was created"));
            }
            let left = files_in(&dir);
            let expected: Vec<String> = if existing {
                vec!["out.json".into(), "scene.toml".into()]
            } else {
                vec!["scene.toml".into()]
            };
            if left != expected {
                failures.push(format!("{name}: files left behind: {left:?}"));
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} cases failed:\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

#[test]
fn unreadable_scene_paths_exit_2() {
    let dir = temp_dir("paths");
    let out = dir.join("out.json");
    for (name, scene) in [
        ("missing file", dir.join("nope.toml")),
        ("a directory", dir.clone()),
    ] {
        let run = densepack(&[
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{name}: {stderr}");
        assert!(stderr.contains(scene.to_str().unwrap()), "{name}: {stderr}");
        assert!(!out.exists());
    }
}

/// An output path whose directory does not exist is bad input: refused before the run, not
/// after it.
#[test]
fn output_in_a_missing_directory_is_refused_before_running() {
    let dir = temp_dir("outdir");
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, GOOD.text()).unwrap();
    let out = dir.join("no-such-dir").join("out.json");
    let run = densepack(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(run.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--out") && stderr.contains("no-such-dir"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("stage 0"),
        "the run started before the output was checked: {stderr}"
    );
}

/// Bad checkpoint options are refused before the run.
#[test]
fn bad_checkpoint_options_exit_2() {
    let dir = temp_dir("ckopts");
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, GOOD.text()).unwrap();
    let out = dir.join("out.json");
    let missing = dir.join("no-such-dir").join("run.ckpt");
    for (name, extra, needle) in [
        (
            "checkpoint in a missing directory",
            vec!["--checkpoint", missing.to_str().unwrap()],
            "--checkpoint",
        ),
        (
            "negative interval",
            vec!["--checkpoint-every=-1"],
            "--checkpoint-every",
        ),
        (
            "interval no Duration holds",
            vec!["--checkpoint-every", "1e300"],
            "[0, 1e9]",
        ),
        (
            "NaN interval",
            vec!["--checkpoint-every", "nan"],
            "not a number of seconds",
        ),
    ] {
        let mut args = vec![
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend(extra);
        let run = densepack(&args);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{name}: {stderr}");
        assert!(
            stderr.contains(needle),
            "{name}: {stderr:?} lacks {needle:?}"
        );
        assert!(!out.exists(), "{name}: ran anyway");
    }
}

/// Malformed packings given to `verify`: exit code 2 and a message naming the problem.
#[test]
fn malformed_packings_exit_2() {
    let dir = temp_dir("packings");
    let good_container = r#""container": {"type": "box", "min": [0,0,0], "max": [10,10,10], "periodic": [true,true,true]}"#;
    let stats = r#""stats": {"packing_fraction": 0.0, "reduced_pressure": 1.0, "events": 0, "collisions": 0, "wall_seconds": 0.0, "stop_reason": "jammed"}"#;
    let cases: Vec<(&str, String, &str)> = vec![
        ("empty file", String::new(), "EOF"),
        ("not JSON", "particles: 3".into(), "expected value"),
        (
            "wrong format name",
            format!(
                r#"{{"format": "other", "version": 1, {good_container}, "particles": [], "min_gap": 0.0, "seed": 1, {stats}}}"#
            ),
            "format \"other\"",
        ),
        (
            "future version",
            format!(
                r#"{{"format": "densepack-packing", "version": 7, {good_container}, "particles": [], "min_gap": 0.0, "seed": 1, {stats}}}"#
            ),
            "version 7",
        ),
        (
            "unknown particle type",
            format!(
                r#"{{"format": "densepack-packing", "version": 1, {good_container}, "particles": [{{"type": "cube", "center": [1,1,1], "radius": 1}}], "min_gap": 0.0, "seed": 1, {stats}}}"#
            ),
            "unknown variant `cube`",
        ),
        (
            "centre of two numbers",
            format!(
                r#"{{"format": "densepack-packing", "version": 1, {good_container}, "particles": [{{"type": "sphere", "center": [1,1], "radius": 1}}], "min_gap": 0.0, "seed": 1, {stats}}}"#
            ),
            "invalid length 2",
        ),
    ];
    for (name, text, needle) in cases {
        let path = dir.join("p.json");
        std::fs::write(&path, &text).unwrap();
        let run = densepack(&["verify", path.to_str().unwrap()]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{name}: {stderr}");
        assert!(
            stderr.contains(needle),
            "{name}: {stderr:?} lacks {needle:?}"
        );
    }
}
