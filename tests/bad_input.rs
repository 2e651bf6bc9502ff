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
            vec!["temperature", "= 0", "[1e-6, 1e6]"],
        ),
        (
            "NaN temperature",
            Parts::top("seed = 1\ntemperature = nan"),
            vec!["temperature", "NaN", "[1e-6, 1e6]"],
        ),
        (
            "neighbour skin above its range",
            Parts::top("seed = 1\nneighbour_skin = 3.0"),
            vec!["neighbour_skin", "(0, 0.5]"],
        ),
        (
            "infinite events per interval",
            Parts::top("seed = 1\nevents_per_particle_per_interval = inf"),
            vec!["events_per_particle_per_interval", "= inf", "[1e-2, 1e3]"],
        ),
        (
            "events per interval 1e300 (no barrier before the wall-clock limit)",
            Parts::top("seed = 1\nevents_per_particle_per_interval = 1e300"),
            vec!["events_per_particle_per_interval", "= 1e300", "[1e-2, 1e3]"],
        ),
        (
            "events per interval 1e-300",
            Parts::top("seed = 1\nevents_per_particle_per_interval = 1e-300"),
            vec!["events_per_particle_per_interval", "[1e-2, 1e3]"],
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
            vec!["stage[0].rate", "= -0.1", "[1e-6, 1e6]"],
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

/// A valid packing of two spheres in a periodic box, 2 apart (radius 0.5).
const PACKING: &str = r#"{"format": "densepack-packing", "version": 1,
 "container": {"type": "box", "min": [0,0,0], "max": [10,10,10], "periodic": [true,true,true]},
 "particles": [{"type": "sphere", "center": [2, 5, 5], "radius": 0.5},
               {"type": "sphere", "center": [4, 5, 5], "radius": 0.5}],
 "min_gap": 0.0, "seed": 1,
 "stats": {"packing_fraction": 0.001, "reduced_pressure": 1.0, "events": 0, "collisions": 0,
           "wall_seconds": 0.0, "stop_reason": "pressure_reached"}}"#;

/// A small scene that runs in milliseconds.
const QUICK: &str = "seed = 1\n[container]\ntype = \"box\"\nsize = [10.0, 10.0, 10.0]\n\
    periodic = [true, true, true]\n[particles]\ncount = 20\ndiameter = 1.0\n\
    packing_fraction = 0.1\n[[stage]]\ngrowth = \"relative\"\nrate = 0.1\n\
    until = { packing_fraction = 0.2 }\n";

/// A mixture scene with `[mixture]` lines `extra`.
fn mixture(extra: &str) -> Vec<u8> {
    format!(
        "seed = 1\n[mixture]\nmethod = \"rsa\"\nsphere_fraction = 0.05\ncylinder_fraction = 0.3\n\
         spheres = 50\ncylinders = 50\naspect_ratio = 5.0\n{extra}\n"
    )
    .into_bytes()
}

/// Longest a case may take before it counts as hung (every case needs well under a second;
/// this only turns a hang into a failure instead of a stuck test run).
const HANG: std::time::Duration = std::time::Duration::from_secs(300);

/// One hostile input: the files of a fresh directory, a command line (`{dir}` stands for
/// the directory), and what must come out.
struct Case {
    name: &'static str,
    /// Files written before the run; every one must be untouched after it.
    files: Vec<(&'static str, Vec<u8>)>,
    args: Vec<&'static str>,
    /// Expected exit code.
    code: i32,
    /// Substrings of stderr.
    needles: Vec<&'static str>,
    /// Run with stdout a pipe whose reading end is closed (`densepack … | head`).
    closed_stdout: bool,
    /// Files a successful command creates.
    creates: Vec<&'static str>,
}

impl Case {
    /// `densepack run scene.toml --out out.json` on a bad scene: exit 2.
    fn scene(name: &'static str, scene: Vec<u8>, needles: Vec<&'static str>) -> Self {
        Self::run(name, scene, &[], needles)
    }
    /// `densepack run scene.toml --out out.json EXTRA…`: exit 2.
    fn run(
        name: &'static str,
        scene: Vec<u8>,
        extra: &[&'static str],
        needles: Vec<&'static str>,
    ) -> Self {
        let mut args = vec!["run", "{dir}/scene.toml", "--out", "{dir}/out.json"];
        args.extend(extra);
        Self::command(name, vec![("scene.toml", scene)], args, needles)
    }
    /// Any command: exit 2.
    fn command(
        name: &'static str,
        files: Vec<(&'static str, Vec<u8>)>,
        args: Vec<&'static str>,
        needles: Vec<&'static str>,
    ) -> Self {
        Case {
            name,
            files,
            args,
            code: 2,
            needles,
            closed_stdout: false,
            creates: Vec::new(),
        }
    }
    /// A command that succeeds with its stdout closed, creating `creates`.
    fn closed_pipe(
        name: &'static str,
        files: Vec<(&'static str, Vec<u8>)>,
        args: Vec<&'static str>,
        creates: Vec<&'static str>,
    ) -> Self {
        Case {
            name,
            files,
            args,
            code: 0,
            needles: Vec::new(),
            closed_stdout: true,
            creates,
        }
    }
}

/// `MemAvailable` of this machine in bytes, read here independently of `densepack::memory`
/// (`None` where unknown: the memory cases then cannot be refused and are left out).
fn available_memory() -> Option<f64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024.0)
}

/// The cases beyond malformed scenes: magnitudes, memory, outputs, durations, closed pipes.
fn hostile_cases() -> Vec<Case> {
    let good = || GOOD.text();
    let packing = || vec![("p.json", PACKING.as_bytes().to_vec())];
    let mut cases = vec![
        // Magnitudes the kernel cannot turn into a run.
        Case::scene(
            "temperature 1e8 (10⁴ times the events)",
            Parts::top("seed = 1\ntemperature = 1e8"),
            vec!["temperature", "= 1e8", "[1e-6, 1e6]"],
        ),
        Case::scene(
            "temperature 1e308",
            Parts::top("seed = 1\ntemperature = 1e308"),
            vec!["temperature", "= 1e308", "[1e-6, 1e6]"],
        ),
        Case::scene(
            "temperature 1e-9",
            Parts::top("seed = 1\ntemperature = 1e-9"),
            vec!["temperature", "[1e-6, 1e6]"],
        ),
        Case::scene(
            "relative rate 1e308",
            Parts::stage(
                "growth = \"relative\"\nrate = 1e308\nuntil = { reduced_pressure = 1e12 }",
            ),
            vec!["stage[0].rate", "= 1e308", "[1e-6, 1e6]", "relative"],
        ),
        Case::scene(
            "relative rate 1e7",
            Parts::stage("growth = \"relative\"\nrate = 1e7\nuntil = { reduced_pressure = 1e12 }"),
            vec!["stage[0].rate", "= 1e7", "[1e-6, 1e6]"],
        ),
        Case::scene(
            "relative rate 1e-9",
            Parts::stage("growth = \"relative\"\nrate = 1e-9\nuntil = { reduced_pressure = 1e12 }"),
            vec!["stage[0].rate", "[1e-6, 1e6]"],
        ),
        Case::scene(
            "absolute rate 1e308",
            Parts::stage("growth = \"absolute\"\nrate = 1e308\nuntil = { time = 1.0 }"),
            vec!["stage[0].rate", "= 1e308", "absolute", "smallest diameter"],
        ),
        Case::scene(
            "absolute rate of 1e-7 diameters per unit time",
            Parts {
                particles: "count = 100\ndiameter = 0.1",
                stage: "growth = \"absolute\"\nrate = 1e-8\nuntil = { time = 1.0 }",
                ..GOOD
            }
            .text(),
            vec!["stage[0].rate", "[1e-7, 1e5]", "smallest diameter 0.1"],
        ),
        Case::scene(
            "infinite rate",
            Parts::stage("growth = \"relative\"\nrate = inf\nuntil = { reduced_pressure = 1e12 }"),
            vec!["stage[0].rate", "= inf", "[1e-6, 1e6]"],
        ),
        // Durations beyond what the clock holds.
        Case::scene(
            "wall-clock limit 1e300 s",
            Parts::stage("growth = \"none\"\nuntil = { time = 1.0 }\nmax_wall_seconds = 1e300"),
            vec!["stage[0].max_wall_seconds", "= 1e300", "(0, 1e9]"],
        ),
        Case::scene(
            "wall-clock limit 1e10 s",
            Parts::stage("growth = \"none\"\nuntil = { time = 1.0 }\nmax_wall_seconds = 1e10"),
            vec!["stage[0].max_wall_seconds", "(0, 1e9]"],
        ),
        Case::scene(
            "infinite wall-clock limit",
            Parts::stage("growth = \"none\"\nuntil = { time = 1.0 }\nmax_wall_seconds = inf"),
            vec!["stage[0].max_wall_seconds", "(0, 1e9]"],
        ),
        Case::scene(
            "mixture time limit 1e300 s",
            mixture("time_limit_seconds = 1e300"),
            vec!["mixture.time_limit_seconds", "= 1e300", "(0, 1e9]"],
        ),
        Case::scene(
            "negative mixture time limit",
            mixture("time_limit_seconds = -1.0"),
            vec!["mixture.time_limit_seconds", "(0, 1e9]"],
        ),
        Case::run(
            "checkpoint interval 1e20 s",
            good(),
            &["--checkpoint-every", "1e20"],
            vec!["--checkpoint-every", "[0, 1e9]"],
        ),
        Case::run(
            "infinite checkpoint interval",
            good(),
            &["--checkpoint-every", "inf"],
            vec!["--checkpoint-every", "[0, 1e9]"],
        ),
        // Outputs that name an input, each other, or nothing writable.
        Case::command(
            "--out is the scene",
            vec![("scene.toml", good())],
            vec!["run", "{dir}/scene.toml", "--out", "{dir}/scene.toml"],
            vec!["--out", "is the scene"],
        ),
        Case::command(
            "--out is the scene, spelt differently",
            vec![("scene.toml", good())],
            vec!["run", "{dir}/scene.toml", "--out", "{dir}/./scene.toml"],
            vec!["--out", "is the scene"],
        ),
        Case::run(
            "--run-log is the scene",
            good(),
            &["--run-log", "{dir}/scene.toml"],
            vec!["--run-log", "is the scene"],
        ),
        Case::run(
            "--checkpoint is the scene",
            good(),
            &["--checkpoint", "{dir}/scene.toml"],
            vec!["--checkpoint", "is the scene"],
        ),
        Case::run(
            "--run-log is --out",
            good(),
            &["--run-log", "{dir}/out.json"],
            vec!["--run-log", "is also --out"],
        ),
        Case::run(
            "--checkpoint is --out",
            good(),
            &["--checkpoint", "{dir}/out.json"],
            vec!["--checkpoint", "is also --out"],
        ),
        Case::command(
            "--out is the checkpoint resumed from",
            vec![("run.ckpt", PREVIOUS.to_vec())],
            vec![
                "run",
                "--resume",
                "{dir}/run.ckpt",
                "--out",
                "{dir}/run.ckpt",
            ],
            vec!["--resume", "--out"],
        ),
        Case::command(
            "--out is the checkpoint resumed from, checkpoints elsewhere",
            vec![("run.ckpt", PREVIOUS.to_vec())],
            vec![
                "run",
                "--resume",
                "{dir}/run.ckpt",
                "--checkpoint",
                "{dir}/next.ckpt",
                "--out",
                "{dir}/run.ckpt",
            ],
            vec!["--out", "is the --resume"],
        ),
        Case::command(
            "--out is a directory",
            vec![("scene.toml", good())],
            vec!["run", "{dir}/scene.toml", "--out", "{dir}"],
            vec!["--out", "is a directory"],
        ),
        Case::command(
            "--out is a device",
            vec![("scene.toml", good())],
            vec!["run", "{dir}/scene.toml", "--out", "/dev/null"],
            vec!["--out", "not a regular file"],
        ),
        Case::command(
            "--out in a directory that takes no files",
            vec![("scene.toml", good())],
            vec![
                "run",
                "{dir}/scene.toml",
                "--out",
                "/proc/densepack-out.json",
            ],
            vec!["--out", "cannot create a file in directory /proc"],
        ),
        Case::run(
            "--run-log in a directory that takes no files",
            good(),
            &["--run-log", "/proc/self/densepack.log"],
            vec!["--run-log", "cannot create a file"],
        ),
        Case::run(
            "--checkpoint in a directory that takes no files",
            good(),
            &["--checkpoint", "/proc/densepack.ckpt"],
            vec!["--checkpoint", "cannot create a file"],
        ),
        Case::command(
            "--out below a regular file",
            vec![("scene.toml", good())],
            vec![
                "run",
                "{dir}/scene.toml",
                "--out",
                "{dir}/scene.toml/out.json",
            ],
            vec!["--out", "does not exist"],
        ),
        Case::command(
            "export --out is the packing",
            packing(),
            vec![
                "export",
                "{dir}/p.json",
                "--format",
                "csv",
                "--out",
                "{dir}/p.json",
            ],
            vec!["--out", "is the packing"],
        ),
        Case::command(
            "export sidecar is the packing",
            packing(),
            vec![
                "export",
                "{dir}/p.json",
                "--format",
                "raw",
                "--out",
                "{dir}/p",
            ],
            vec!["sidecar", "is the packing"],
        ),
        Case::command(
            "export --out in a directory that takes no files",
            packing(),
            vec![
                "export",
                "{dir}/p.json",
                "--format",
                "csv",
                "--out",
                "/proc/p.csv",
            ],
            vec!["--out", "cannot create a file"],
        ),
        Case::command(
            "plot --out is the packing",
            packing(),
            vec!["plot", "sizes", "{dir}/p.json", "--out", "{dir}/p.json"],
            vec!["--out", "is the packing"],
        ),
        Case::command(
            "take --sizes is the curve file",
            vec![(
                "curve.toml",
                b"grading = { kind = \"fuller\", q = 0.5, d_max = 16.0 }\n".to_vec(),
            )],
            vec![
                "take",
                "{dir}/curve.toml",
                "--phi-m",
                "0.7",
                "--d-min",
                "4",
                "--volume",
                "125000",
                "--sizes",
                "{dir}/curve.toml",
            ],
            vec!["--sizes", "is the curve file"],
        ),
        Case::command(
            "take --scene in a directory that takes no files",
            Vec::new(),
            vec![
                "take",
                "B16",
                "--phi-m",
                "0.7",
                "--d-min",
                "4",
                "--box",
                "50,50,50",
                "--scene",
                "/proc/s.toml",
            ],
            vec!["--scene", "cannot create a file"],
        ),
        Case::command(
            "init --out in a missing directory",
            Vec::new(),
            vec!["init", "--out", "{dir}/no-such-dir/s.toml"],
            vec!["--out", "does not exist"],
        ),
        // A closed stdout is not an error: the work is done, the exit code is the usual one.
        Case::closed_pipe(
            "verify on a closed pipe",
            packing(),
            vec!["verify", "{dir}/p.json"],
            Vec::new(),
        ),
        Case::closed_pipe(
            "verify --json on a closed pipe",
            packing(),
            vec!["verify", "{dir}/p.json", "--json"],
            Vec::new(),
        ),
        Case::closed_pipe(
            "take on a closed pipe",
            Vec::new(),
            vec![
                "take", "B16", "--phi-m", "0.7", "--d-min", "4", "--volume", "125000",
            ],
            Vec::new(),
        ),
        Case::closed_pipe(
            "init on a closed pipe",
            Vec::new(),
            vec!["init", "ellipsoids"],
            Vec::new(),
        ),
        Case::closed_pipe(
            "run on a closed pipe still writes its packing",
            vec![("scene.toml", QUICK.as_bytes().to_vec())],
            vec!["run", "{dir}/scene.toml", "--out", "{dir}/out.json"],
            vec!["out.json"],
        ),
        Case::closed_pipe(
            "export on a closed pipe still writes its file",
            packing(),
            vec![
                "export",
                "{dir}/p.json",
                "--format",
                "csv",
                "--out",
                "{dir}/p.csv",
            ],
            vec!["p.csv"],
        ),
        Case::closed_pipe(
            "--help on a closed pipe",
            Vec::new(),
            vec!["--help"],
            Vec::new(),
        ),
    ];
    // Memory: refused before any allocation, with the estimate, the limit and the override.
    // Each case is refused only where the machine has less memory available than it needs.
    let available = available_memory().unwrap_or(f64::INFINITY);
    let memory = [
        (
            4e9 * 300.0,
            Case::scene(
                "4·10⁹ spheres (1.2 TB)",
                Parts::particles("count = 4000000000\ndiameter = 1e-3\npacking_fraction = 0.3"),
                vec![
                    "needs about",
                    "spheres",
                    "MemAvailable",
                    "--ignore-memory-check",
                ],
            ),
        ),
        (
            1e9 * 300.0,
            Case::scene(
                "10⁹ spheres in components (300 GB)",
                Parts::particles(
                    "components = [{ count = 500000000, diameter = 1e-3 }, \
                     { count = 500000000, diameter = 2e-3 }]\npacking_fraction = 0.3",
                ),
                vec!["needs about", "1.0000e9 spheres", "MemAvailable"],
            ),
        ),
        (
            1e9 * 750.0,
            Case::scene(
                "10⁹ ellipsoids (750 GB)",
                Parts::particles(
                    "count = 1000000000\ndiameter = 1e-3\npacking_fraction = 0.05\n\
                     [particles.ellipsoid]\naspect_ratios = [1.5, 1.5]",
                ),
                vec!["needs about", "ellipsoids", "DENSEPACK_IGNORE_MEMORY_CHECK"],
            ),
        ),
        (
            2e9 * 600.0,
            Case::scene(
                "mixture of 2·10⁹ bodies (1.2 TB)",
                b"seed = 1\n[mixture]\nmethod = \"rsa\"\nsphere_fraction = 0.05\n\
                  cylinder_fraction = 0.3\nspheres = 1000000000\ncylinders = 1000000000\n\
                  aspect_ratio = 5.0\n"
                    .to_vec(),
                vec!["needs about", "bodies", "MemAvailable"],
            ),
        ),
        (
            1.7e10 * 4.0,
            Case::command(
                "voxel image of 1.7·10¹⁰ particle labels (68 GB)",
                packing(),
                vec![
                    "export",
                    "{dir}/p.json",
                    "--format",
                    "raw",
                    "--labels",
                    "particle",
                    "--voxels",
                    "2580",
                    "--out",
                    "{dir}/v.raw",
                ],
                vec!["--voxels", "needs about", "MemAvailable"],
            ),
        ),
        (
            7e10 * 33.0,
            Case::command(
                "take drawing ~10¹¹ diameters (3 TB)",
                Vec::new(),
                vec![
                    "take",
                    "B16",
                    "--phi-m",
                    "0.7",
                    "--d-min",
                    "0.25",
                    "--box",
                    "5000,5000,5000",
                    "--sizes",
                    "{dir}/sizes.txt",
                ],
                vec!["drawing the diameters", "needs about", "MemAvailable"],
            ),
        ),
    ];
    for (needed, case) in memory {
        if needed > available {
            cases.push(case);
        } else {
            eprintln!("left out (this machine has the memory): {}", case.name);
        }
    }
    cases
}

fn files_in(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names
}

/// Runs `args` with stdout and stderr to files in `logs` (or stdout to a closed pipe);
/// the exit code (`None`: killed by a signal, or hung and killed after [`HANG`]) and
/// stderr.
fn run_guarded(args: &[String], logs: &Path, closed_stdout: bool) -> (Option<i32>, String) {
    let stdout_file = logs.join("stdout");
    let stderr_file = logs.join("stderr");
    let mut command = std::process::Command::new(env!("CARGO_BIN_EXE_densepack"));
    command
        .args(args)
        .stderr(std::fs::File::create(&stderr_file).unwrap());
    if closed_stdout {
        let (reader, writer) = std::io::pipe().unwrap();
        drop(reader);
        command.stdout(writer);
    } else {
        command.stdout(std::fs::File::create(&stdout_file).unwrap());
    }
    let mut child = command.spawn().unwrap();
    drop(command);
    let started = std::time::Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break Some(status);
        }
        if started.elapsed() > HANG {
            let _ = child.kill();
            let _ = child.wait();
            break None;
        }
        std::thread::sleep(std::time::Duration::from_millis(5));
    };
    let stderr = String::from_utf8_lossy(&std::fs::read(&stderr_file).unwrap()).into_owned();
    (status.and_then(|s| s.code()), stderr)
}

#[test]
fn hostile_inputs_end_with_a_documented_code_and_touch_no_input_or_output() {
    let root = temp_dir("table");
    let logs = root.join("logs");
    let dir = root.join("case");
    std::fs::create_dir_all(&logs).unwrap();
    let mut cases: Vec<Case> = cases()
        .into_iter()
        .map(|(name, bytes, needles)| Case::scene(name, bytes, needles))
        .collect();
    let scenes = cases.len();
    cases.extend(hostile_cases());
    assert!(
        cases.len() >= 100,
        "the table should hold at least 100 cases, has {}",
        cases.len()
    );
    let mut failures = Vec::new();
    for case in &cases {
        let name = case.name;
        // First without an output file, then with one that must survive byte for byte
        // (unless the command succeeds and writes it).
        for existing in [false, true] {
            let _ = std::fs::remove_dir_all(&dir);
            std::fs::create_dir_all(&dir).unwrap();
            let mut files = case.files.clone();
            if existing && !files.iter().any(|(f, _)| *f == "out.json") {
                files.push(("out.json", PREVIOUS.to_vec()));
            }
            for (file, bytes) in &files {
                std::fs::write(dir.join(file), bytes).unwrap();
            }
            let args: Vec<String> = case
                .args
                .iter()
                .map(|a| a.replace("{dir}", dir.to_str().unwrap()))
                .collect();
            let (code, stderr) = run_guarded(&args, &logs, case.closed_stdout);
            if code != Some(case.code) {
                failures.push(format!(
                    "{name}: exit {code:?} (None: signal or hung), expected {}: {stderr}",
                    case.code
                ));
            }
            if stderr.contains("panicked") {
                failures.push(format!("{name}: panicked: {stderr}"));
            }
            for needle in &case.needles {
                if !stderr.contains(needle) {
                    failures.push(format!("{name}: message {stderr:?} lacks {needle:?}"));
                }
            }
            for (file, bytes) in &files {
                if case.creates.contains(file) {
                    continue;
                }
                if std::fs::read(dir.join(file)).ok().as_ref() != Some(bytes) {
                    failures.push(format!("{name}: {file} was changed"));
                }
            }
            let mut expected: Vec<String> = files.iter().map(|(f, _)| f.to_string()).collect();
            expected.extend(case.creates.iter().map(|f| f.to_string()));
            expected.sort();
            expected.dedup();
            let left = files_in(&dir);
            if left != expected {
                failures.push(format!("{name}: files {left:?}, expected {expected:?}"));
            }
        }
    }
    for file in ["densepack-out.json", "densepack.ckpt", "p.csv", "s.toml"] {
        assert!(!Path::new("/proc").join(file).exists());
    }
    assert!(
        failures.is_empty(),
        "{} failures in {} cases ({scenes} malformed scenes):\n{}",
        failures.len(),
        cases.len(),
        failures.join("\n")
    );
}

/// Every scene shipped in `examples/scenes` passes validation (the ranges above refuse no
/// real scene).
#[test]
fn shipped_scenes_are_valid() {
    let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/examples/scenes"));
    let mut count = 0;
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        let text = std::fs::read_to_string(&path).unwrap();
        if let Err(e) = densepack::io::scene::AnyScene::from_toml(&text) {
            panic!("{}: {e}", path.display());
        }
        count += 1;
    }
    assert!(count >= 20, "only {count} scenes found");
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
    let stats = r#""stats": {"packing_fraction": 0.0, "reduced_pressure": 1.0, "events": 0, "collisions": 0, "wall_seconds": 0.0, "stop_reason": "pressure_reached"}"#;
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
