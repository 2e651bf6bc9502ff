//! Macro benchmarks of the EDMD kernel: whole scenes run through [`run_scene`] in release
//! mode, reported as markdown tables (stdout, and `--out FILE`).
//!
//! ```text
//! cargo bench --bench edmd -- [--quick] [--out FILE] [--only NAME[,NAME...]]
//! ```
//!
//! Every scene is a periodic cube of spheres seeded by RSA at packing fraction 0.3 (box edge
//! chosen so that the diameter is 1 at seeding), with seed 2026. Rates are relative growth
//! rates (1/time, `kT = 1`, mass 1). The studies:
//!
//! * `equilibrium` — hard-sphere fluid at φ = 0.50: grow at rate 0.1 (thermostat) to
//!   φ = 0.50, equilibrate without growth for 20 collisions per particle, then a measured
//!   stage without growth (100 collisions per particle; 20 with `--quick`). Reports the
//!   collisions/s and events/s of the measured stage only, and its time-averaged `Z` as a
//!   sanity check (Carnahan–Starling gives 13.0 at φ = 0.5). N = 10⁴, 10⁵ (quick: 10⁴).
//! * `jamming` — the default scene `examples/scenes/mono_periodic_jam.toml` (10⁴ spheres from
//!   φ = 0.3 to `Z = 1e12`) at its rate 0.02 and at 0.05 and 0.1, both queues: wall seconds,
//!   collisions, collisions/s, final φ. Quick: the same scene with 2000 spheres (box scaled
//!   to keep the diameter) at rate 0.02.
//! * `scaling` — cost per event against N (paper Fig. 4): grow at rate 0.1 from φ = 0.3 to
//!   φ = 0.60, then time a stage without growth of 10 collisions per particle (quick: 5),
//!   repeated back to back for small N (a single stage of 10⁴ events is too short to time)
//!   and summarised by the median; µs/event and the least-squares slope of µs/event
//!   against log₁₀ N per queue.
//!   N = 10³…10⁶ (quick: 10³, 10⁴). A bidisperse variant (diameters 1.0 and 1.6, 50/50 by
//!   count) grows to φ = 0.58 instead, N = 10³…10⁵ (quick: 10³, 10⁴).
//! * `tuning` — justifies the defaults of `neighbour_skin` (0.1) and
//!   `events_per_particle_per_interval` (4): each swept alone on the calendar queue, measured
//!   on the `equilibrium` protocol (events/s, collisions/s) and on growth from φ = 0.3 to
//!   `Z = 1e8` at rate 0.05 (wall seconds). N = 10⁴ (quick: 2000). Events include
//!   neighbour-list updates, whose number depends on the skin, so collisions/s is the fair
//!   comparison across skins.
//! * `memory` — peak resident memory per particle: a child process (this binary, re-invoked
//!   with the hidden `--child-memory N QUEUE`) seeds N spheres at φ = 0.3 and grows them to
//!   φ = 0.4, then reports `VmHWM` from `/proc/self/status`. N = 10⁵, 10⁶ (quick: 10⁵).
//!
//! * `fuller`, `gap`, `gapmax`, `concrete-jam` — the concrete experiments of paper 001, §6
//!   (see `benches/studies/concrete.rs`).
//!
//! As with criterion, the binary benchmarks only when cargo passes `--bench`
//! (`cargo bench`); run by `cargo test --benches` it runs one tiny scene as a smoke test.

#[path = "studies/concrete.rs"]
mod concrete;

use densepack::io::scene::Scene;
use densepack::kernel::StageReport;
use densepack::run::run_scene;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::{Command, ExitCode};
use std::time::Instant;

/// Seed of every scene.
const SEED: u64 = 2026;
/// Packing fraction of the RSA seeding.
const SEED_FRACTION: f64 = 0.3;
/// The default scene of the `jamming` study.
const JAM_SCENE: &str = include_str!("../examples/scenes/mono_periodic_jam.toml");
/// Both event queues, by their scene names.
const QUEUES: [&str; 2] = ["heap", "calendar"];
/// The studies, in the order they run.
const STUDIES: [&str; 9] = [
    "equilibrium",
    "jamming",
    "scaling",
    "tuning",
    "memory",
    "fuller",
    "gap",
    "gapmax",
    "concrete-jam",
];

/// Command-line options.
struct Options {
    quick: bool,
    out: Option<PathBuf>,
    only: Option<Vec<String>>,
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--child-memory") {
        return child_memory(&args[1..]);
    }
    if !args.iter().any(|a| a == "--bench") {
        smoke_test();
        return ExitCode::SUCCESS;
    }
    let options = match parse_options(&args) {
        Ok(o) => o,
        Err(message) => {
            eprintln!("edmd: {message}");
            eprintln!("usage: cargo bench --bench edmd -- [--quick] [--out FILE] [--only NAME]");
            eprintln!("studies: {}", STUDIES.join(", "));
            return ExitCode::from(2);
        }
    };
    let started = Instant::now();
    let mut report = Report::new(options.out.clone());
    report.push(&machine_info(options.quick));
    let selected = |name: &str| {
        options
            .only
            .as_ref()
            .is_none_or(|only| only.iter().any(|o| o == name))
    };
    type Study = fn(bool) -> String;
    let studies: [(&str, Study); 9] = [
        ("equilibrium", equilibrium),
        ("jamming", jamming),
        ("scaling", scaling),
        ("tuning", tuning),
        ("memory", memory),
        ("fuller", concrete::fuller),
        ("gap", concrete::gap),
        ("gapmax", concrete::gapmax),
        ("concrete-jam", concrete::jam),
    ];
    for (name, study) in studies {
        if selected(name) {
            let t = Instant::now();
            eprintln!("== {name}");
            let mut section = study(options.quick);
            let _ = writeln!(section, "\n_{name}: {:.1} s_\n", t.elapsed().as_secs_f64());
            report.push(&section);
        }
    }
    report.push(&format!(
        "_Total: {:.1} s_\n",
        started.elapsed().as_secs_f64()
    ));
    ExitCode::SUCCESS
}

fn parse_options(args: &[String]) -> Result<Options, String> {
    let mut options = Options {
        quick: false,
        out: None,
        only: None,
    };
    let mut it = args.iter();
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--bench" => {}
            "--quick" => options.quick = true,
            "--out" => {
                let file = it.next().ok_or("--out needs a file name")?;
                options.out = Some(PathBuf::from(file));
            }
            "--only" => {
                let names = it.next().ok_or("--only needs a study name")?;
                let names: Vec<String> = names.split(',').map(str::to_owned).collect();
                if let Some(bad) = names.iter().find(|n| !STUDIES.contains(&n.as_str())) {
                    return Err(format!("unknown study `{bad}`"));
                }
                options.only.get_or_insert_with(Vec::new).extend(names);
            }
            other => return Err(format!("unknown argument `{other}`")),
        }
    }
    Ok(options)
}

/// The markdown output: printed as it grows and rewritten to the `--out` file after every
/// section, so a long run that is interrupted keeps its finished tables.
struct Report {
    out: Option<PathBuf>,
    text: String,
}

impl Report {
    fn new(out: Option<PathBuf>) -> Self {
        Self {
            out,
            text: String::new(),
        }
    }

    fn push(&mut self, section: &str) {
        print!("{section}");
        self.text.push_str(section);
        if let Some(path) = &self.out {
            if let Err(e) = std::fs::write(path, &self.text) {
                eprintln!("edmd: cannot write {}: {e}", path.display());
            }
        }
    }
}

/// CPU model, core counts, load and the command line.
fn machine_info(quick: bool) -> String {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = cpuinfo
        .lines()
        .find_map(|l| l.strip_prefix("model name"))
        .and_then(|l| l.split_once(':'))
        .map_or("unknown", |(_, m)| m.trim());
    let logical = cpuinfo
        .lines()
        .filter(|l| l.starts_with("processor"))
        .count();
    let available = std::thread::available_parallelism().map_or(0, |n| n.get());
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let command: Vec<String> = std::env::args().collect();
    format!(
        "# densepack EDMD benchmarks{}\n\n\
         - CPU: {model}\n\
         - cores: {logical} logical ({available} available to this process)\n\
         - load average at start: {}\n\
         - command: `{}`\n\n",
        if quick { " (quick)" } else { "" },
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" "),
        command.join(" ")
    )
}

// ---------------------------------------------------------------------------------------
// Scenes

/// The particles of a generated scene.
#[derive(Clone, Copy)]
enum Particles {
    /// `n` equal spheres.
    Mono(usize),
    /// `n` spheres, half of diameter 1.0 and half of 1.6.
    Bidisperse(usize),
}

impl Particles {
    /// The `[particles]` table, and the box edge giving the seeding fraction with the
    /// diameters as written.
    fn toml(self) -> (String, f64) {
        let sphere = |d: f64| std::f64::consts::PI / 6.0 * d.powi(3);
        let (table, volume) = match self {
            Self::Mono(n) => (
                format!("count = {n}\ndiameter = 1.0\n"),
                n as f64 * sphere(1.0),
            ),
            Self::Bidisperse(n) => {
                let small = n / 2;
                let large = n - small;
                (
                    format!(
                        "components = [{{ count = {small}, diameter = 1.0 }}, \
                         {{ count = {large}, diameter = 1.6 }}]\n"
                    ),
                    small as f64 * sphere(1.0) + large as f64 * sphere(1.6),
                )
            }
        };
        (table, (volume / SEED_FRACTION).cbrt())
    }
}

/// Kernel settings swept by the `tuning` study.
#[derive(Clone, Copy)]
struct Tuning {
    neighbour_skin: f64,
    events_per_particle_per_interval: f64,
}

impl Default for Tuning {
    /// The scene defaults.
    fn default() -> Self {
        Self {
            neighbour_skin: 0.1,
            events_per_particle_per_interval: 4.0,
        }
    }
}

/// A `[[stage]]` growing at relative `rate` until the packing fraction reaches `phi`.
fn grow_to_fraction(rate: f64, phi: f64) -> String {
    format!(
        "[[stage]]\ngrowth = \"relative\"\nrate = {rate:?}\n\
         until = {{ packing_fraction = {phi:?} }}\n"
    )
}

/// A `[[stage]]` growing at relative `rate` until the reduced pressure reaches `z`.
fn grow_to_pressure(rate: f64, z: f64) -> String {
    format!(
        "[[stage]]\ngrowth = \"relative\"\nrate = {rate:?}\n\
         until = {{ reduced_pressure = {z:?} }}\n"
    )
}

/// A `[[stage]]` without growth running `cpp` collisions per particle.
fn hold(cpp: f64) -> String {
    format!("[[stage]]\ngrowth = \"none\"\nuntil = {{ collisions_per_particle = {cpp:?} }}\n")
}

/// A periodic-cube scene seeded by RSA at φ = 0.3, then the given stages.
fn scene(queue: &str, particles: Particles, tuning: Tuning, stages: &[String]) -> Scene {
    let (table, edge) = particles.toml();
    let text = format!(
        "seed = {SEED}\nqueue = \"{queue}\"\n\
         neighbour_skin = {:?}\nevents_per_particle_per_interval = {:?}\n\
         [container]\ntype = \"box\"\nsize = [{edge:?}, {edge:?}, {edge:?}]\n\
         periodic = [true, true, true]\n\
         [particles]\n{table}packing_fraction = {SEED_FRACTION:?}\n{}",
        tuning.neighbour_skin,
        tuning.events_per_particle_per_interval,
        stages.concat()
    );
    Scene::from_toml(&text).unwrap_or_else(|e| panic!("generated scene is invalid: {e}\n{text}"))
}

/// Runs a scene, logging each stage to stderr; the stage reports, or the run error as text
/// (a failed stage or a rejected packing is a kernel problem the tables must show).
fn run(label: &str, scene: &Scene) -> Result<Vec<StageReport>, String> {
    eprintln!("-- {label}");
    let mut log = |k: usize, r: &StageReport| {
        eprintln!(
            "   stage {k}: {} after {} events ({} collisions) in {:.2} s, φ = {:.5}, Z = {:.4e}",
            r.stop_reason.as_str(),
            r.counts.events,
            r.counts.collisions,
            r.wall_seconds,
            r.packing_fraction,
            r.reduced_pressure
        );
    };
    run_scene(scene, &mut log)
        .map(|outcome| outcome.stages)
        .map_err(|e| {
            eprintln!("   FAILED: {e}");
            format!("FAILED: {e}")
        })
}

/// The `equilibrium` protocol: the measured (last) stage at φ = 0.50.
fn equilibrium_run(
    queue: &str,
    n: usize,
    measured_cpp: f64,
    tuning: Tuning,
) -> Result<StageReport, String> {
    let stages = [grow_to_fraction(0.1, 0.5), hold(20.0), hold(measured_cpp)];
    let scene = scene(queue, Particles::Mono(n), tuning, &stages);
    let label = format!(
        "equilibrium {queue} N = {n}, skin {}, events/particle/interval {}",
        tuning.neighbour_skin, tuning.events_per_particle_per_interval
    );
    run(&label, &scene).map(|mut stages| stages.pop().expect("the scene has three stages"))
}

/// The `tuning` jamming protocol: growth at rate 0.05 from φ = 0.3 to `Z = 1e8`.
fn near_jamming_run(n: usize, tuning: Tuning) -> Result<StageReport, String> {
    let scene = scene(
        "calendar",
        Particles::Mono(n),
        tuning,
        &[grow_to_pressure(0.05, 1e8)],
    );
    let label = format!(
        "near jamming N = {n}, skin {}, events/particle/interval {}",
        tuning.neighbour_skin, tuning.events_per_particle_per_interval
    );
    run(&label, &scene).map(|mut stages| stages.pop().expect("the scene has one stage"))
}

// ---------------------------------------------------------------------------------------
// Tables

/// A markdown table with a bold title and a caption line giving its exact parameters.
struct Table {
    title: String,
    caption: String,
    header: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Table {
    fn new(title: &str, caption: &str, header: &[&str]) -> Self {
        Self {
            title: title.into(),
            caption: caption.into(),
            header: header.iter().map(|&h| h.into()).collect(),
            rows: Vec::new(),
        }
    }

    fn row(&mut self, cells: Vec<String>) {
        self.rows.push(cells);
    }

    /// A row whose run failed: the leading cells, then the error across the rest.
    fn failed_row(&mut self, mut lead: Vec<String>, error: &str) {
        lead.push(error.replace('|', "\\|").replace('\n', " "));
        lead.resize(self.header.len(), String::new());
        self.rows.push(lead);
    }

    fn markdown(&self) -> String {
        let mut s = format!("**{}**\n\n{}\n\n", self.title, self.caption);
        let line = |cells: &[String]| format!("| {} |\n", cells.join(" | "));
        s += &line(&self.header);
        s += &line(&vec!["---".to_string(); self.header.len()]);
        for r in &self.rows {
            s += &line(r);
        }
        s.push('\n');
        s
    }
}

/// Engineering formatting: three significant digits with a k/M/G suffix.
fn si(x: f64) -> String {
    let (v, suffix) = match x.abs() {
        a if a >= 1e9 => (x / 1e9, "G"),
        a if a >= 1e6 => (x / 1e6, "M"),
        a if a >= 1e3 => (x / 1e3, "k"),
        _ => (x, ""),
    };
    format!("{v:.3}{suffix}")
}

fn per_second(count: u64, r: &StageReport) -> f64 {
    count as f64 / r.wall_seconds.max(1e-12)
}

fn micros_per_event(r: &StageReport) -> f64 {
    1e6 * r.wall_seconds / r.counts.events.max(1) as f64
}

/// How often the `scaling` study repeats its timed stage at `n` particles: a stage of
/// 10⁴ events lasts about 10 ms, too short to time alone.
fn repeats(n: usize) -> usize {
    (200_000 / n).clamp(1, 50)
}

/// Median of a non-empty sample.
fn median(mut xs: Vec<f64>) -> f64 {
    xs.sort_by(f64::total_cmp);
    let m = xs.len() / 2;
    if xs.len() % 2 == 0 {
        0.5 * (xs[m - 1] + xs[m])
    } else {
        xs[m]
    }
}

/// Least-squares slope of `y` against `x`, if at least two points.
fn slope(points: &[(f64, f64)]) -> Option<f64> {
    if points.len() < 2 {
        return None;
    }
    let n = points.len() as f64;
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    Some(sxy / sxx)
}

// ---------------------------------------------------------------------------------------
// Studies

/// Study 1: throughput of the equilibrium fluid at φ = 0.50.
fn equilibrium(quick: bool) -> String {
    let sizes: &[usize] = if quick { &[10_000] } else { &[10_000, 100_000] };
    let cpp = if quick { 20.0 } else { 100.0 };
    let mut table = Table::new(
        "equilibrium: hard-sphere fluid at φ = 0.50",
        &format!(
            "Periodic cube, monodisperse, RSA at φ = 0.3, growth rate 0.1 (thermostat) to \
             φ = 0.50, 20 collisions/particle without growth, then the measured stage without \
             growth: {cpp} collisions/particle. Rates are of the measured stage only. \
             Z: time average ± standard error (Carnahan–Starling: 13.0)."
        ),
        &[
            "N",
            "queue",
            "collisions/s",
            "events/s",
            "NL updates/collision",
            "stale/event",
            "wall s",
            "Z",
        ],
    );
    for &n in sizes {
        for queue in QUEUES {
            let lead = vec![n.to_string(), queue.into()];
            match equilibrium_run(queue, n, cpp, Tuning::default()) {
                Ok(r) => table.row(
                    [
                        lead,
                        vec![
                            si(per_second(r.counts.collisions, &r)),
                            si(per_second(r.counts.events, &r)),
                            format!(
                                "{:.3}",
                                r.counts.neighbour_list_updates as f64
                                    / r.counts.collisions.max(1) as f64
                            ),
                            format!(
                                "{:.3}",
                                r.counts.stale as f64 / r.counts.events.max(1) as f64
                            ),
                            format!("{:.2}", r.wall_seconds),
                            format!(
                                "{:.3} ± {:.3}",
                                r.reduced_pressure,
                                r.reduced_pressure_stderr.unwrap_or(f64::NAN)
                            ),
                        ],
                    ]
                    .concat(),
                ),
                Err(e) => table.failed_row(lead, &e),
            }
        }
    }
    table.markdown()
}

/// Study 2: the default jamming scene.
fn jamming(quick: bool) -> String {
    let base =
        Scene::from_toml(JAM_SCENE).expect("examples/scenes/mono_periodic_jam.toml is valid");
    let (n, rates): (usize, &[f64]) = if quick {
        (2000, &[0.02])
    } else {
        (
            base.particles
                .count
                .expect("the jamming scene is monodisperse"),
            &[0.02, 0.05, 0.1],
        )
    };
    let mut table = Table::new(
        "jamming: examples/scenes/mono_periodic_jam.toml",
        &format!(
            "The default scene (periodic cube, monodisperse, RSA at φ = 0.3, relative growth \
             until Z = 1e12, thermostat, max 600 wall s) with N = {n}{}; queue and rate varied.",
            if quick {
                " (box edge scaled by (N/10⁴)^⅓ so the diameter is that of the scene)"
            } else {
                ""
            }
        ),
        &[
            "rate",
            "queue",
            "wall s",
            "collisions",
            "collisions/particle",
            "collisions/s",
            "final φ",
            "final Z",
        ],
    );
    for &rate in rates {
        for queue in QUEUES {
            let mut scene = base.clone();
            scene.queue = match queue {
                "heap" => densepack::queue::QueueKind::Heap,
                _ => densepack::queue::QueueKind::Calendar,
            };
            scene.stages[0].rate = Some(rate);
            if quick {
                let full = base
                    .particles
                    .count
                    .expect("the jamming scene is monodisperse");
                let factor = (n as f64 / full as f64).cbrt();
                scene.particles.count = Some(n);
                if let densepack::io::scene::ContainerSpec::Box { size, .. } = &mut scene.container
                {
                    for s in size {
                        *s *= factor;
                    }
                }
            }
            scene
                .validate()
                .expect("the rescaled jamming scene is valid");
            let lead = vec![format!("{rate}"), queue.to_string()];
            match run(&format!("jamming {queue} N = {n} rate {rate}"), &scene) {
                Ok(stages) => {
                    let r = stages.last().expect("the scene has a stage");
                    let collisions: u64 = stages.iter().map(|s| s.counts.collisions).sum();
                    let wall: f64 = stages.iter().map(|s| s.wall_seconds).sum();
                    table.row(
                        [
                            lead,
                            vec![
                                format!("{wall:.2}"),
                                collisions.to_string(),
                                format!("{:.0}", collisions as f64 / n as f64),
                                si(collisions as f64 / wall.max(1e-12)),
                                format!("{:.5}", r.packing_fraction),
                                format!("{:.2e}", r.reduced_pressure),
                            ],
                        ]
                        .concat(),
                    );
                }
                Err(e) => table.failed_row(lead, &e),
            }
        }
    }
    table.markdown()
}

/// Study 3: µs per event against N in a dense system.
fn scaling(quick: bool) -> String {
    let cpp = if quick { 5.0 } else { 10.0 };
    let mono: &[usize] = if quick {
        &[1_000, 10_000]
    } else {
        &[1_000, 10_000, 100_000, 1_000_000]
    };
    let poly: &[usize] = if quick {
        &[1_000, 10_000]
    } else {
        &[1_000, 10_000, 100_000]
    };
    let mut s = scaling_table(
        "scaling: cost per event against N, monodisperse",
        Particles::Mono,
        mono,
        0.60,
        cpp,
    );
    s += &scaling_table(
        "scaling: cost per event against N, bidisperse 1.0/1.6",
        Particles::Bidisperse,
        poly,
        0.58,
        cpp,
    );
    s
}

fn scaling_table(
    title: &str,
    particles: fn(usize) -> Particles,
    sizes: &[usize],
    phi: f64,
    cpp: f64,
) -> String {
    let mut table = Table::new(
        title,
        &format!(
            "Periodic cube, RSA at φ = 0.3, growth rate 0.1 (thermostat) to φ = {phi}, then \
             the timed stage without growth: {cpp} collisions/particle, run `repeats` times \
             in a row (max(1, min(50, 2·10⁵/N))); µs/event and events/s are the medians \
             over the repeats."
        ),
        &[
            "N",
            "repeats",
            "heap µs/event",
            "calendar µs/event",
            "heap events/s",
            "calendar events/s",
        ],
    );
    let mut fits: [Vec<(f64, f64)>; 2] = [Vec::new(), Vec::new()];
    let mut errors = String::new();
    for &n in sizes {
        let repeats = repeats(n);
        let mut stages = vec![grow_to_fraction(0.1, phi)];
        stages.extend(std::iter::repeat_n(hold(cpp), repeats));
        let mut micros = vec![String::new(); 2];
        let mut rates = vec![String::new(); 2];
        for (q, queue) in QUEUES.iter().enumerate() {
            let scene = scene(queue, particles(n), Tuning::default(), &stages);
            match run(&format!("{title}: {queue} N = {n}"), &scene) {
                Ok(reports) => {
                    let us = median(reports[1..].iter().map(micros_per_event).collect());
                    fits[q].push(((n as f64).log10(), us));
                    micros[q] = format!("{us:.3}");
                    rates[q] = si(median(
                        reports[1..]
                            .iter()
                            .map(|r| per_second(r.counts.events, r))
                            .collect(),
                    ));
                }
                Err(e) => {
                    micros[q] = "failed".into();
                    let _ = writeln!(errors, "- {queue}, N = {n}: {e}");
                }
            }
        }
        table.row([vec![n.to_string(), repeats.to_string()], micros, rates].concat());
    }
    let fitted = |k: usize| slope(&fits[k]).map_or("n/a".into(), |s| format!("{s:+.4}"));
    table.row(vec![
        "slope per decade".into(),
        String::new(),
        fitted(0),
        fitted(1),
        String::new(),
        String::new(),
    ]);
    let mut s = table.markdown();
    if !errors.is_empty() {
        s = s + "Failures:\n\n" + &errors + "\n";
    }
    s
}

/// Study 4: sweeps of the neighbour-list skin and of the barrier interval target.
fn tuning(quick: bool) -> String {
    let n = if quick { 2000 } else { 10_000 };
    let cpp = if quick { 20.0 } else { 100.0 };
    let caption = format!(
        "N = {n}, calendar queue, one parameter varied, the other at its default. Equilibrium: \
         the `equilibrium` protocol at φ = 0.50 ({cpp} measured collisions/particle), rates of \
         the measured stage. Near jamming: growth rate 0.05 from φ = 0.3 until Z = 1e8, whole \
         run."
    );
    let header = [
        "",
        "equilibrium events/s",
        "equilibrium collisions/s",
        "NL updates/collision",
        "near-jamming wall s",
        "near-jamming collisions",
    ];
    let skins = [0.05, 0.1, 0.2, 0.4];
    let intervals = [1.0, 2.0, 4.0, 8.0, 16.0];
    let mut skin_table = Table::new(
        "tuning: neighbour_skin",
        &caption,
        &[&["neighbour_skin"], &header[1..]].concat(),
    );
    for skin in skins {
        let tuning = Tuning {
            neighbour_skin: skin,
            ..Tuning::default()
        };
        skin_table.row(tuning_row(format!("{skin}"), n, cpp, tuning));
    }
    let mut interval_table = Table::new(
        "tuning: events_per_particle_per_interval",
        &caption,
        &[&["events_per_particle_per_interval"], &header[1..]].concat(),
    );
    for epi in intervals {
        let tuning = Tuning {
            events_per_particle_per_interval: epi,
            ..Tuning::default()
        };
        interval_table.row(tuning_row(format!("{epi}"), n, cpp, tuning));
    }
    skin_table.markdown() + &interval_table.markdown()
}

/// One row of a tuning table: the equilibrium and near-jamming runs with `tuning`.
fn tuning_row(label: String, n: usize, cpp: f64, tuning: Tuning) -> Vec<String> {
    let mut row = vec![label];
    match equilibrium_run("calendar", n, cpp, tuning) {
        Ok(r) => row.extend([
            si(per_second(r.counts.events, &r)),
            si(per_second(r.counts.collisions, &r)),
            format!(
                "{:.3}",
                r.counts.neighbour_list_updates as f64 / r.counts.collisions.max(1) as f64
            ),
        ]),
        Err(e) => row.extend([e, String::new(), String::new()]),
    }
    match near_jamming_run(n, tuning) {
        Ok(r) => row.extend([
            format!("{:.2}", r.wall_seconds),
            r.counts.collisions.to_string(),
        ]),
        Err(e) => row.extend([e, String::new()]),
    }
    row.iter().map(|c| c.replace('|', "\\|")).collect()
}

/// Study 5: peak resident memory per particle, measured in child processes.
fn memory(quick: bool) -> String {
    let sizes: &[usize] = if quick {
        &[100_000]
    } else {
        &[100_000, 1_000_000]
    };
    let mut table = Table::new(
        "memory: peak resident set per particle",
        "A child process seeds N monodisperse spheres by RSA at φ = 0.3 in a periodic cube and \
         grows them at rate 0.1 to φ = 0.4 (seeding, kernel, verification and packing record \
         included). Peak = VmHWM of the child; baseline = its VmHWM before the run.",
        &[
            "N",
            "queue",
            "peak MiB",
            "baseline MiB",
            "peak bytes/particle",
            "(peak − baseline) bytes/particle",
        ],
    );
    let exe = std::env::current_exe().expect("the path of the benchmark binary is known");
    for &n in sizes {
        for queue in QUEUES {
            eprintln!("-- memory {queue} N = {n} (child process)");
            let lead = vec![n.to_string(), queue.to_string()];
            let output = Command::new(&exe)
                .args(["--child-memory", &n.to_string(), queue])
                .output();
            let measured = match output {
                Ok(o) if o.status.success() => {
                    let stdout = String::from_utf8_lossy(&o.stdout);
                    let field = |key: &str| {
                        stdout
                            .lines()
                            .find_map(|l| l.strip_prefix(key))
                            .and_then(|v| v.trim().parse::<u64>().ok())
                    };
                    match (field("peak_kib"), field("baseline_kib")) {
                        (Some(p), Some(b)) => Ok((p * 1024, b * 1024)),
                        _ => Err(format!("unexpected child output: {stdout}")),
                    }
                }
                Ok(o) => Err(format!(
                    "child failed ({}): {}",
                    o.status,
                    String::from_utf8_lossy(&o.stderr).trim()
                )),
                Err(e) => Err(format!("cannot start child: {e}")),
            };
            match measured {
                Ok((peak, baseline)) => {
                    let mib = |b: u64| format!("{:.1}", b as f64 / (1024.0 * 1024.0));
                    table.row(
                        [
                            lead,
                            vec![
                                mib(peak),
                                mib(baseline),
                                format!("{:.0}", peak as f64 / n as f64),
                                format!("{:.0}", (peak - baseline) as f64 / n as f64),
                            ],
                        ]
                        .concat(),
                    );
                }
                Err(e) => table.failed_row(lead, &e),
            }
        }
    }
    table.markdown()
}

/// `VmHWM` (peak resident set) of this process in KiB.
fn vm_hwm_kib() -> Option<u64> {
    std::fs::read_to_string("/proc/self/status")
        .ok()?
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// The child side of the `memory` study: `--child-memory N QUEUE`.
fn child_memory(args: &[String]) -> ExitCode {
    let (Some(n), Some(queue)) = (
        args.first().and_then(|a| a.parse::<usize>().ok()),
        args.get(1).filter(|q| QUEUES.contains(&q.as_str())),
    ) else {
        eprintln!("usage: edmd --child-memory N heap|calendar");
        return ExitCode::from(2);
    };
    let Some(baseline) = vm_hwm_kib() else {
        eprintln!("edmd: cannot read VmHWM from /proc/self/status");
        return ExitCode::FAILURE;
    };
    let scene = scene(
        queue,
        Particles::Mono(n),
        Tuning::default(),
        &[grow_to_fraction(0.1, 0.4)],
    );
    if let Err(e) = run_scene(&scene, &mut |_, _| {}) {
        eprintln!("{e}");
        return ExitCode::FAILURE;
    }
    let Some(peak) = vm_hwm_kib() else {
        eprintln!("edmd: cannot read VmHWM from /proc/self/status");
        return ExitCode::FAILURE;
    };
    println!("baseline_kib {baseline}\npeak_kib {peak}");
    ExitCode::SUCCESS
}

/// What `cargo test --benches` runs: one tiny equilibrium scene on each queue.
fn smoke_test() {
    for queue in QUEUES {
        let r = equilibrium_run(queue, 200, 2.0, Tuning::default())
            .unwrap_or_else(|e| panic!("smoke test on the {queue} queue: {e}"));
        assert!(
            r.stop_reason.is_success(),
            "smoke test on the {queue} queue"
        );
    }
    eprintln!("edmd: smoke test passed (benchmarks run with `cargo bench --bench edmd`)");
}
