//! Sphere studies of the EDMD kernel: whole scenes through [`run_scene`].
//!
//! One module (about 950 lines): each study is a function of at most about a hundred lines
//! writing one table of BENCHMARKS.md, and they share the scene builders and the row
//! formatting here.
//!
//! Every generated scene is a periodic cube seeded by RSA at packing fraction 0.3 (box edge
//! chosen so that the diameters are as written at seeding) with seed 2026 unless a study
//! varies it. Rates are relative growth rates (1/time, `kT = 1`, mass 1). The studies:
//!
//! * [`equilibrium`] — hard-sphere fluid at φ = 0.50: grow at rate 0.1 (thermostat) to
//!   φ = 0.50, equilibrate without growth for 20 collisions per particle, then a measured
//!   stage without growth (100 collisions per particle; 20 quick). Collisions/s and events/s
//!   of the measured stage, and its time-averaged `Z` as a sanity check (Carnahan–Starling
//!   gives 13.0 at φ = 0.5). N = 10⁴, 10⁵ (quick: 10⁴).
//! * [`jamming`] — `examples/scenes/mono_periodic_jam.toml` (10⁴ spheres, φ = 0.3 to
//!   `Z = 1e12`): its pressure-adaptive protocol and the fixed rate it replaced, both queues,
//!   with the rattlers and the backbone's contact number. Quick: 1000 spheres.
//! * [`scaling`] — cost per event against N (paper 001, Fig. 4): grow at rate 0.1 to a dense
//!   state, then time stages without growth, repeated back to back for small N; median
//!   µs/event and its spread, and the least-squares slope of µs/event against log₁₀ N per
//!   queue. Monodisperse (dense state φ = 0.60) N = 10³…10⁶ (quick 10³, 10⁴); Fuller q = 0.5,
//!   d = 2–16 (dense state φ = 0.65) N ≈ 10³…10⁵ (quick 10³, 10⁴).
//! * [`tuning`] — `neighbour_skin` and `events_per_particle_per_interval` swept alone.
//! * [`growth_rate`] — the Lubachevsky–Stillinger growth rate against φ at Z = 10¹² and the
//!   wall time (Pareto), over seeds.
//! * [`memory`] — peak resident memory per particle, measured in a child process.

use super::{median, si, slope, spread, Figure, Series, StudyContext, StudyOutput, Table};
use densepack::analysis::jamming::{jamming_report, DEFAULT_CUTOFF};
use densepack::io::scene::{ContainerSpec, Scene, StageSpec};
use densepack::kernel::StageReport;
use densepack::queue::QueueKind;
use densepack::run::{run_scene, RunOutcome};
use std::process::Command;

/// Seed of every scene unless a study varies it.
const SEED: u64 = 2026;
/// Packing fraction of the RSA seeding.
const SEED_FRACTION: f64 = 0.3;
/// The default scene of the `jamming` study.
const JAM_SCENE: &str = include_str!("../../../examples/scenes/mono_periodic_jam.toml");
/// The default scene's particles grown with a slow finish (its stages only are used).
const SLOW_JAM_SCENE: &str = include_str!("../../../examples/scenes/mono_periodic_jam_slow.toml");
/// Both event queues, by their scene names.
pub const QUEUES: [&str; 2] = ["heap", "calendar"];

// ---------------------------------------------------------------------------------------
// Scenes

/// The particles of a generated scene.
#[derive(Clone, Copy, Debug)]
pub enum Particles {
    /// `n` equal spheres of diameter 1.
    Mono(usize),
    /// About `n` spheres drawn from Fuller's curve q = 0.5, d = 2–16 (paper 001, Eq. 1): the
    /// box edge is chosen so that the take phase expects `n` grains.
    Fuller(usize),
}

/// Fuller's curve of the polydisperse variant: the `[particles]` keys (mm).
const FULLER: &str = "grading = { kind = \"fuller\", q = 0.5, d_max = 16.0 }\n\
                      d_min = 2.0\neffective_fraction = 0.6\n";

impl Particles {
    /// The `[particles]` table and the box edge.
    fn toml(self) -> (String, f64) {
        match self {
            Self::Mono(n) => {
                let volume = n as f64 * std::f64::consts::PI / 6.0;
                (
                    format!("count = {n}\ndiameter = 1.0\n"),
                    (volume / SEED_FRACTION).cbrt(),
                )
            }
            Self::Fuller(n) => {
                // The expected count scales with the box volume.
                let reference = 100.0;
                let expected = fuller_expected_count(reference);
                (FULLER.to_owned(), reference * (n as f64 / expected).cbrt())
            }
        }
    }

    fn name(self) -> &'static str {
        match self {
            Self::Mono(_) => "monodisperse",
            Self::Fuller(_) => "Fuller q = 0.5, d = 2–16",
        }
    }
}

/// Expected grain count of [`FULLER`] in a periodic cube of edge `edge` mm.
fn fuller_expected_count(edge: f64) -> f64 {
    let text = format!(
        "seed = 1\n[container]\ntype = \"box\"\nsize = [{edge:?}, {edge:?}, {edge:?}]\n\
         periodic = [true, true, true]\n[particles]\n{FULLER}packing_fraction = 0.3\n\
         [[stage]]\ngrowth = \"relative\"\nrate = 0.1\nuntil = {{ packing_fraction = 0.5 }}\n"
    );
    Scene::from_toml(&text)
        .expect("the Fuller scene is valid")
        .take_phase()
        .expect("the Fuller scene is graded")
        .expect("the Fuller take phase is valid")
        .expected_count()
}

/// Kernel settings swept by the `tuning` study.
#[derive(Clone, Copy, Debug)]
pub struct Tuning {
    /// `neighbour_skin` of the scene.
    pub neighbour_skin: f64,
    /// `events_per_particle_per_interval` of the scene.
    pub events_per_particle_per_interval: f64,
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
         until = {{ reduced_pressure = {z:?} }}\nmax_wall_seconds = 900\n"
    )
}

/// A `[[stage]]` without growth running `cpp` collisions per particle.
fn hold(cpp: f64) -> String {
    format!("[[stage]]\ngrowth = \"none\"\nuntil = {{ collisions_per_particle = {cpp:?} }}\n")
}

/// A periodic-cube scene seeded by RSA at φ = 0.3, then the given stages.
fn scene(queue: &str, seed: u64, particles: Particles, tuning: Tuning, stages: &[String]) -> Scene {
    let (table, edge) = particles.toml();
    let text = format!(
        "seed = {seed}\nqueue = \"{queue}\"\n\
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
    run_outcome(label, scene).map(|outcome| outcome.stages)
}

/// Runs `scene` under `label` on stderr with a line per finished stage; the whole outcome
/// (stages and packing), or the failure as a table cell.
fn run_outcome(label: &str, scene: &Scene) -> Result<RunOutcome, String> {
    eprintln!("-- {label}");
    let mut log = |k: usize, r: &StageReport| {
        eprintln!("   stage {k}: {}", r.summary());
    };
    run_scene(scene, &mut log).map_err(|e| {
        eprintln!("   FAILED: {e}");
        format!("FAILED: {e}")
    })
}

/// The `equilibrium` protocol: the measured (last) stage at φ = 0.50.
pub fn equilibrium_run(
    queue: &str,
    n: usize,
    measured_cpp: f64,
    tuning: Tuning,
) -> Result<StageReport, String> {
    let stages = [grow_to_fraction(0.1, 0.5), hold(20.0), hold(measured_cpp)];
    let scene = scene(queue, SEED, Particles::Mono(n), tuning, &stages);
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
        SEED,
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

fn per_second(count: u64, r: &StageReport) -> f64 {
    count as f64 / r.wall_seconds.max(1e-12)
}

fn micros_per_event(r: &StageReport) -> f64 {
    1e6 * r.wall_seconds / r.counts.events.max(1) as f64
}

/// How often the `scaling` study repeats its timed stage at `n` particles: a stage of
/// 10⁴ events lasts about 10 ms, too short to time alone.
fn repeats(n: usize, quick: bool) -> usize {
    if quick {
        (100_000 / n).clamp(3, 20)
    } else {
        (200_000 / n).clamp(3, 50)
    }
}

/// [`repeats`] as a formula for the captions.
fn repeats_formula(quick: bool) -> &'static str {
    if quick {
        "max(3, min(20, 10⁵/N))"
    } else {
        "max(3, min(50, 2·10⁵/N))"
    }
}

/// A study whose plot has one line per queue (x on a log axis).
fn per_queue(table: Table, figure: Figure, [heap, calendar]: [Vec<(f64, f64)>; 2]) -> StudyOutput {
    StudyOutput {
        markdown: table.markdown(),
        csv: table,
        figure: figure
            .log(true, false)
            .with(Series::line("heap", heap))
            .with(Series::line("calendar", calendar)),
    }
}

// ---------------------------------------------------------------------------------------
// Studies

/// Throughput of the equilibrium fluid at φ = 0.50.
pub fn equilibrium(ctx: &StudyContext) -> StudyOutput {
    let sizes: &[usize] = if ctx.quick {
        &[5_000]
    } else {
        &[10_000, 100_000]
    };
    let cpp = if ctx.quick { 20.0 } else { 100.0 };
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
    let mut points: [Vec<(f64, f64)>; 2] = [Vec::new(), Vec::new()];
    for &n in sizes {
        for (q, queue) in QUEUES.iter().enumerate() {
            let lead = vec![n.to_string(), queue.to_string()];
            match equilibrium_run(queue, n, cpp, Tuning::default()) {
                Ok(r) => {
                    let rate = per_second(r.counts.collisions, &r);
                    points[q].push((n as f64, rate));
                    table.row(
                        [
                            lead,
                            vec![
                                format!("{rate:.0}"),
                                format!("{:.0}", per_second(r.counts.events, &r)),
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
                    );
                }
                Err(e) => table.failed_row(lead, &e),
            }
        }
    }
    per_queue(
        table,
        Figure::new("Equilibrium fluid, φ = 0.50", "N", "collisions per second"),
        points,
    )
}

/// The default jamming scene (a fixed rate) beside the same scene grown with a rate that falls
/// with the pressure and a slow finish (the stages of `mono_periodic_jam_slow.toml`): time
/// against the quality of the contact network.
pub fn jamming(ctx: &StudyContext) -> StudyOutput {
    let base =
        Scene::from_toml(JAM_SCENE).expect("examples/scenes/mono_periodic_jam.toml is valid");
    let slow = Scene::from_toml(SLOW_JAM_SCENE)
        .expect("examples/scenes/mono_periodic_jam_slow.toml is valid");
    let full = base
        .particles
        .count
        .expect("the jamming scene is monodisperse");
    let n = if ctx.quick { 125 } else { full };
    let mut table = Table::new(
        "jamming: examples/scenes/mono_periodic_jam.toml",
        &format!(
            "The default scene (periodic cube, monodisperse, RSA at φ = 0.3, relative growth \
             until Z = 1e12, thermostat) with N = {n}{}: its fixed rate, and a rate falling \
             with the pressure followed by a slow finish, both queues; then the slow stages \
             followed by `[jam]` (sequential linear programming; \
             examples/scenes/mono_periodic_jam_slow.toml) at N ≤ {LP_MAX_N}, calendar queue. \
             Contact network by `densepack analyse` at cut-off 1e-9: rattlers (not locally \
             jammed) removed iteratively, backbone mean contact number (isostatic: 6 − 4/N_b \
             over the N_b spheres of the backbone); the LP test of collective jamming at \
             N ≤ {LP_MAX_N}.",
            if ctx.quick {
                " (box edge scaled by (N/10⁴)^⅓ so the diameter is that of the scene)"
            } else {
                ""
            }
        ),
        &[
            "protocol",
            "queue",
            "N",
            "wall s",
            "collisions",
            "collisions/particle",
            "collisions/s",
            "final φ",
            "final Z",
            "rattlers %",
            "backbone Z",
            "LP test",
        ],
    );
    let mut points: [Vec<(f64, f64)>; 2] = [Vec::new(), Vec::new()];
    // The fixed rate, the slow stages, the slow stages then `[jam]`.
    for (stages, jam) in [(false, false), (true, false), (true, true)] {
        let (queues, n) = if jam {
            (&QUEUES[1..], n.min(LP_MAX_N))
        } else {
            (&QUEUES[..], n)
        };
        for (q, queue) in queues.iter().enumerate() {
            let mut scene = base.clone();
            scene.queue = match *queue {
                "heap" => QueueKind::Heap,
                _ => QueueKind::Calendar,
            };
            if stages {
                scene.stages = slow.stages.clone();
            }
            if jam {
                scene.jam = slow.jam;
            }
            let protocol = format!(
                "{}{}",
                protocol_label(&scene.stages),
                if jam { "; then [jam]" } else { "" }
            );
            if n != full {
                let factor = (n as f64 / full as f64).cbrt();
                scene.particles.count = Some(n);
                if let ContainerSpec::Box { size, .. } = &mut scene.container {
                    for s in size {
                        *s *= factor;
                    }
                }
            }
            scene
                .validate()
                .expect("the rescaled jamming scene is valid");
            let lead = vec![protocol.clone(), queue.to_string(), n.to_string()];
            match run_outcome(&format!("jamming {queue} N = {n}, {protocol}"), &scene) {
                Ok(outcome) => {
                    let stages = &outcome.stages;
                    let r = stages.last().expect("the scene has a stage");
                    let collisions: u64 = stages.iter().map(|s| s.counts.collisions).sum();
                    let wall: f64 = stages.iter().map(|s| s.wall_seconds).sum();
                    let lp = n <= LP_MAX_N;
                    let network =
                        jamming_report(&outcome.packing, DEFAULT_CUTOFF, lp, 1, LP_SECONDS)
                            .expect("a sphere packing");
                    let rattlers = 100.0 * network.at_cutoff.rattler_fraction;
                    if !jam {
                        points[q].push((wall, rattlers));
                    }
                    table.row(
                        [
                            lead,
                            vec![
                                format!("{wall:.2}"),
                                collisions.to_string(),
                                format!("{:.0}", collisions as f64 / n as f64),
                                format!("{:.0}", collisions as f64 / wall.max(1e-12)),
                                format!("{:.5}", r.packing_fraction),
                                format!("{:.2e}", r.reduced_pressure),
                                format!("{rattlers:.2}"),
                                network
                                    .at_cutoff
                                    .backbone_mean_contacts
                                    .map_or("none".into(), |z| format!("{z:.4}")),
                                network.lp.map_or("not run".into(), |c| {
                                    if c.jammed { "jammed" } else { "not jammed" }.into()
                                }),
                            ],
                        ]
                        .concat(),
                    );
                }
                Err(e) => table.failed_row(lead, &e),
            }
        }
    }
    per_queue(
        table,
        Figure::new(
            format!("Jamming {n} spheres, φ 0.3 → Z = 1e12: time against rattlers"),
            "wall seconds",
            "rattlers (%)",
        ),
        points,
    )
}

/// Largest N at which the `jamming` study runs `[jam]` and the LP test: a linear program
/// of 10³ spheres takes seconds, of 10⁴ minutes.
const LP_MAX_N: usize = 1000;

/// Seconds each program of the LP test may take in the studies.
const LP_SECONDS: f64 = 600.0;

/// A chain of growth stages in words: `0.05 (falling as (1e2/Z)^1 to 0.005) → Z 1e9; …`.
fn protocol_label(stages: &[StageSpec]) -> String {
    stages
        .iter()
        .map(|s| {
            let rate = s.rate.map_or("no growth".into(), |r| format!("{r}"));
            let law = s.adaptive.map_or(String::new(), |a| {
                format!(
                    " (falling as ({:e}/Z)^{} to {})",
                    a.onset_pressure, a.exponent, a.min_rate
                )
            });
            let goal = s
                .until
                .reduced_pressure
                .map_or(String::new(), |z| format!(" → Z {z:e}"));
            format!("{rate}{law}{goal}")
        })
        .collect::<Vec<_>>()
        .join("; ")
}

/// µs per event against N in a dense system, monodisperse and Fuller (paper 001, Fig. 4).
pub fn scaling(ctx: &StudyContext) -> StudyOutput {
    let cpp = if ctx.quick { 5.0 } else { 10.0 };
    let mono: &[usize] = if ctx.quick {
        &[1_000, 4_000]
    } else {
        &[1_000, 10_000, 100_000, 1_000_000]
    };
    let poly: &[usize] = if ctx.quick {
        &[1_000, 4_000]
    } else {
        &[1_000, 10_000, 100_000]
    };
    let mut csv = Table::new(
        "scaling",
        "",
        &[
            "particles",
            "N",
            "queue",
            "repeats",
            "median µs/event",
            "spread",
            "median events/s",
            "dense φ",
        ],
    );
    let mut figure = Figure::new(
        "Cost per event against N (dense, no growth)",
        "N",
        "µs per event (median)",
    )
    .log(true, false);
    let mut markdown = String::new();
    for (particles, sizes, phi) in [
        (Particles::Mono as fn(usize) -> Particles, mono, 0.60),
        (Particles::Fuller as fn(usize) -> Particles, poly, 0.65),
    ] {
        let (s, series) = scaling_table(particles, sizes, phi, cpp, ctx.quick, &mut csv);
        markdown += &s;
        for s in series {
            figure = figure.with(s);
        }
    }
    StudyOutput {
        markdown,
        csv,
        figure,
    }
}

/// One particle family of [`scaling`]: its markdown table and plot series; rows go to `csv`.
fn scaling_table(
    particles: fn(usize) -> Particles,
    sizes: &[usize],
    phi: f64,
    cpp: f64,
    quick: bool,
    csv: &mut Table,
) -> (String, Vec<Series>) {
    let name = particles(0).name();
    let mut table = Table::new(
        &format!("scaling: cost per event against N, {name}"),
        &format!(
            "Periodic cube, RSA at φ = 0.3, growth rate 0.1 (thermostat) to φ = {phi}, then \
             the timed stage without growth: {cpp} collisions/particle, run `repeats` times \
             in a row ({}); µs/event and events/s are the medians \
             over the repeats, spread = (max − min)/median of µs/event.{}",
            repeats_formula(quick),
            if matches!(particles(0), Particles::Fuller(_)) {
                " N is the drawn grain count (box edge set for the take phase to expect the \
                 nominal N); diameters scaled at seeding, relative growth keeps their ratios."
            } else {
                ""
            }
        ),
        &[
            "N",
            "repeats",
            "heap µs/event",
            "heap spread",
            "calendar µs/event",
            "calendar spread",
            "heap events/s",
            "calendar events/s",
        ],
    );
    let mut fits: [Vec<(f64, f64)>; 2] = [Vec::new(), Vec::new()];
    let mut errors = String::new();
    for &nominal in sizes {
        let repeats = repeats(nominal, quick);
        let mut stages = vec![grow_to_fraction(0.1, phi)];
        stages.extend(std::iter::repeat_n(hold(cpp), repeats));
        let mut cells = vec![String::new(); 6];
        let mut n_drawn = nominal;
        for (q, queue) in QUEUES.iter().enumerate() {
            let scene = scene(queue, SEED, particles(nominal), Tuning::default(), &stages);
            match run_outcome(&format!("scaling {name}: {queue} N ≈ {nominal}"), &scene)
                .map(|o| (o.packing.particles.len(), o.stages))
            {
                Ok((n, reports)) => {
                    n_drawn = n;
                    let micros: Vec<f64> = reports[1..].iter().map(micros_per_event).collect();
                    let us = median(micros.clone());
                    let rate = median(
                        reports[1..]
                            .iter()
                            .map(|r| per_second(r.counts.events, r))
                            .collect(),
                    );
                    fits[q].push(((n as f64).log10(), us));
                    cells[2 * q] = format!("{us:.3}");
                    cells[2 * q + 1] = format!("{:.2}", spread(&micros));
                    cells[4 + q] = si(rate);
                    csv.row(vec![
                        name.into(),
                        n.to_string(),
                        queue.to_string(),
                        repeats.to_string(),
                        format!("{us:.4}"),
                        format!("{:.3}", spread(&micros)),
                        format!("{rate:.0}"),
                        format!("{phi}"),
                    ]);
                }
                Err(e) => {
                    cells[2 * q] = "failed".into();
                    errors += &format!("- {queue}, N ≈ {nominal}: {e}\n");
                }
            }
        }
        table.row([vec![n_drawn.to_string(), repeats.to_string()], cells].concat());
    }
    let fitted = |k: usize| slope(&fits[k]).map_or("n/a".into(), |s| format!("{s:+.4}"));
    table.row(vec![
        "slope µs per decade of N".into(),
        String::new(),
        fitted(0),
        String::new(),
        fitted(1),
    ]);
    let mut s = table.markdown();
    if !errors.is_empty() {
        s = s + "Failures:\n\n" + &errors + "\n";
    }
    let [heap, calendar] = fits;
    let unlog = |v: Vec<(f64, f64)>| v.into_iter().map(|(x, y)| (10f64.powf(x), y)).collect();
    (
        s,
        vec![
            Series::line(format!("{name}, heap"), unlog(heap)),
            Series::line(format!("{name}, calendar"), unlog(calendar)),
        ],
    )
}

/// Sweeps of the neighbour-list skin and of the barrier interval target.
pub fn tuning(ctx: &StudyContext) -> StudyOutput {
    let n = if ctx.quick { 1000 } else { 10_000 };
    let cpp = if ctx.quick { 20.0 } else { 100.0 };
    let mut table = Table::new(
        "tuning: neighbour_skin and events_per_particle_per_interval",
        &format!(
            "N = {n}, calendar queue, one parameter varied, the other at its default (skin 0.1, \
             4 events/particle/interval; the kernel adapts the skin from this start). \
             Equilibrium: the `equilibrium` protocol at φ = 0.50 ({cpp} measured \
             collisions/particle), rates of the measured stage. Near jamming: growth rate 0.05 \
             from φ = 0.3 until Z = 1e8, whole run."
        ),
        &[
            "parameter",
            "value",
            "equilibrium events/s",
            "equilibrium collisions/s",
            "NL updates/collision",
            "near-jamming wall s",
            "near-jamming collisions",
        ],
    );
    let skins: &[f64] = if ctx.quick {
        &[0.1, 0.4]
    } else {
        &[0.05, 0.1, 0.2, 0.4]
    };
    let intervals: &[f64] = if ctx.quick {
        &[4.0, 16.0]
    } else {
        &[1.0, 2.0, 4.0, 8.0, 16.0]
    };
    let mut skin_points = Vec::new();
    let mut interval_points = Vec::new();
    for &skin in skins {
        let tuning = Tuning {
            neighbour_skin: skin,
            ..Tuning::default()
        };
        let (row, wall) = tuning_row("neighbour_skin", skin, n, cpp, tuning);
        table.row(row);
        skin_points.extend(wall.map(|w| (skin, w)));
    }
    for &epi in intervals {
        let tuning = Tuning {
            events_per_particle_per_interval: epi,
            ..Tuning::default()
        };
        let (row, wall) = tuning_row("events_per_particle_per_interval", epi, n, cpp, tuning);
        table.row(row);
        interval_points.extend(wall.map(|w| (epi, w)));
    }
    StudyOutput {
        markdown: table.markdown(),
        csv: table,
        figure: Figure::new(
            format!("Tuning, {n} spheres: near-jamming wall time"),
            "parameter value",
            "wall seconds, φ 0.3 → Z = 1e8",
        )
        .log(true, false)
        .with(Series::line("neighbour_skin", skin_points))
        .with(Series::line(
            "events_per_particle_per_interval",
            interval_points,
        )),
    }
}

/// One row of the tuning table and the near-jamming wall seconds.
fn tuning_row(
    parameter: &str,
    value: f64,
    n: usize,
    cpp: f64,
    tuning: Tuning,
) -> (Vec<String>, Option<f64>) {
    let mut row = vec![parameter.to_owned(), format!("{value}")];
    match equilibrium_run("calendar", n, cpp, tuning) {
        Ok(r) => row.extend([
            format!("{:.0}", per_second(r.counts.events, &r)),
            format!("{:.0}", per_second(r.counts.collisions, &r)),
            format!(
                "{:.3}",
                r.counts.neighbour_list_updates as f64 / r.counts.collisions.max(1) as f64
            ),
        ]),
        Err(e) => row.extend([e, String::new(), String::new()]),
    }
    let mut wall = None;
    match near_jamming_run(n, tuning) {
        Ok(r) => {
            wall = Some(r.wall_seconds);
            row.extend([
                format!("{:.2}", r.wall_seconds),
                r.counts.collisions.to_string(),
            ])
        }
        Err(e) => row.extend([e, String::new()]),
    }
    (row, wall)
}

/// Lubachevsky–Stillinger growth rate against the jammed packing fraction and the wall time.
pub fn growth_rate(ctx: &StudyContext) -> StudyOutput {
    let (n, rates, seeds): (usize, &[f64], u64) = if ctx.quick {
        (500, &[0.2, 0.05, 0.02], 2)
    } else {
        (10_000, &[0.5, 0.2, 0.1, 0.05, 0.02, 0.01], 3)
    };
    let mut table = Table::new(
        "growth rate: φ at Z = 1e12 against wall time",
        &format!(
            "N = {n} equal spheres, periodic cube, RSA at φ = 0.3, relative growth (thermostat \
             at every barrier) until Z = 1e12, calendar queue, seeds 1…{seeds}: medians over \
             the seeds, spread = max − min. A slower rate packs denser (closer to random close \
             packing, φ ≈ 0.64) and costs more collisions. A fixed rate does not make the \
             contact network rigid (the `jamming` study): this is density against time only."
        ),
        &[
            "rate",
            "runs",
            "median φ",
            "φ spread",
            "median wall s",
            "wall spread",
            "median collisions/particle",
        ],
    );
    let mut all = Vec::new();
    let mut medians = Vec::new();
    for &rate in rates {
        let mut phis = Vec::new();
        let mut walls = Vec::new();
        let mut cpps = Vec::new();
        let mut failures = Vec::new();
        for seed in 1..=seeds {
            let scene = scene(
                "calendar",
                seed,
                Particles::Mono(n),
                Tuning::default(),
                &[grow_to_pressure(rate, 1e12)],
            );
            match run(&format!("growth rate {rate}, seed {seed}"), &scene) {
                Ok(reports) => {
                    let r = reports.last().expect("one stage");
                    phis.push(r.packing_fraction);
                    walls.push(r.wall_seconds);
                    cpps.push(r.counts.collisions as f64 / n as f64);
                    all.push((r.wall_seconds, r.packing_fraction));
                }
                Err(e) => failures.push(e),
            }
        }
        let range = |v: &[f64]| {
            v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
                - v.iter().copied().fold(f64::INFINITY, f64::min)
        };
        if phis.is_empty() {
            table.failed_row(vec![format!("{rate}"), "0".into()], &failures.join("; "));
            continue;
        }
        let (phi, wall) = (median(phis.clone()), median(walls.clone()));
        medians.push((rate, wall, phi));
        table.row(vec![
            format!("{rate}"),
            phis.len().to_string(),
            format!("{phi:.5}"),
            format!("{:.5}", range(&phis)),
            format!("{wall:.2}"),
            format!("{:.2}", range(&walls)),
            format!("{:.0}", median(cpps)),
        ]);
    }
    let mut markdown = table.markdown();
    let default_rate = 0.05;
    if let Some(&(_, t0, phi0)) = medians.iter().find(|m| m.0 == default_rate) {
        markdown += &format!(
            "Against rate {default_rate} (the fast first rate of the shipped jamming scene, \
             `mono_periodic_jam.toml`; median φ {phi0:.5}, {t0:.2} s):"
        );
        for &(rate, t, phi) in medians.iter().filter(|m| m.0 != default_rate) {
            markdown += &format!(
                " rate {rate}: Δφ = {:+.4} for {:.2}× the time;",
                phi - phi0,
                t / t0
            );
        }
        markdown.pop();
        markdown += ". A slower rate buys density at a growing cost in time (the Pareto \
                     front in the plot).\n\n";
    }
    let front: Vec<(f64, f64)> =
        Series::pareto_front("", &all.iter().map(|&(t, p)| (t, -p)).collect::<Vec<_>>())
            .points
            .into_iter()
            .map(|(t, p)| (t, -p))
            .collect();
    let mut figure = Figure::new(
        format!("Growth rate: time against φ at Z = 1e12, {n} spheres"),
        "wall seconds to Z = 1e12",
        "jammed packing fraction",
    )
    .log(true, false);
    for &(rate, wall, phi) in &medians {
        figure = figure.with(Series::points(
            format!("rate {rate} (median)"),
            vec![(wall, phi)],
        ));
    }
    figure = figure
        .with(Series::points("every run", all))
        .with(Series::line("Pareto front (runs)", front));
    StudyOutput {
        markdown,
        csv: table,
        figure,
    }
}

/// Peak resident memory per particle, measured in child processes.
pub fn memory(ctx: &StudyContext) -> StudyOutput {
    let sizes: &[usize] = if ctx.quick {
        &[100_000]
    } else {
        &[100_000, 1_000_000]
    };
    let mut table = Table::new(
        "memory: peak resident set per particle",
        "A child process (this binary re-run) seeds N monodisperse spheres by RSA at φ = 0.3 \
         in a periodic cube and grows them at rate 0.1 to φ = 0.33 (seeding, kernel, \
         verification and packing record included). Peak = VmHWM of the child; baseline = its \
         VmHWM before the run.",
        &[
            "N",
            "queue",
            "peak MiB",
            "baseline MiB",
            "peak bytes/particle",
            "(peak − baseline) bytes/particle",
        ],
    );
    let mut points: [Vec<(f64, f64)>; 2] = [Vec::new(), Vec::new()];
    // Quick: the default queue only.
    let queues = if ctx.quick { &QUEUES[1..] } else { &QUEUES[..] };
    for &n in sizes {
        for (q, queue) in queues.iter().enumerate() {
            let q = q + QUEUES.len() - queues.len();
            eprintln!("-- memory {queue} N = {n} (child process)");
            let lead = vec![n.to_string(), queue.to_string()];
            match measure_child(&ctx.memory_child, n, queue) {
                Ok((peak, baseline)) => {
                    let mib = |b: u64| format!("{:.1}", b as f64 / (1024.0 * 1024.0));
                    let per = (peak - baseline) as f64 / n as f64;
                    points[q].push((n as f64, per));
                    table.row(
                        [
                            lead,
                            vec![
                                mib(peak),
                                mib(baseline),
                                format!("{:.0}", peak as f64 / n as f64),
                                format!("{per:.0}"),
                            ],
                        ]
                        .concat(),
                    );
                }
                Err(e) => table.failed_row(lead, &e),
            }
        }
    }
    per_queue(
        table,
        Figure::new(
            "Peak memory per particle",
            "N",
            "(peak − baseline) bytes/particle",
        ),
        points,
    )
}

/// Runs the memory child `N QUEUE`; its peak and baseline resident bytes.
fn measure_child(command: &[String], n: usize, queue: &str) -> Result<(u64, u64), String> {
    let (program, args) = command.split_first().ok_or("no child command configured")?;
    let output = Command::new(program)
        .args(args)
        .args([n.to_string(), queue.to_owned()])
        .output()
        .map_err(|e| format!("cannot start child: {e}"))?;
    if !output.status.success() {
        return Err(format!(
            "child failed ({}): {}",
            output.status,
            String::from_utf8_lossy(&output.stderr).trim()
        ));
    }
    let stdout = String::from_utf8_lossy(&output.stdout);
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

/// `VmHWM` (peak resident set) of this process in KiB.
fn vm_hwm_kib() -> Result<u64, String> {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))?
                .split_whitespace()
                .next()?
                .parse()
                .ok()
        })
        .ok_or_else(|| "cannot read VmHWM from /proc/self/status".to_owned())
}

/// The child side of [`memory`]: runs the memory scene for `args = [N, QUEUE]` in this
/// process and returns the lines to print (`baseline_kib K`, `peak_kib K`).
pub fn child_memory(args: &[String]) -> Result<String, String> {
    let (Some(n), Some(queue)) = (
        args.first().and_then(|a| a.parse::<usize>().ok()),
        args.get(1).filter(|q| QUEUES.contains(&q.as_str())),
    ) else {
        return Err("arguments: N heap|calendar".into());
    };
    let baseline = vm_hwm_kib()?;
    let scene = scene(
        queue,
        SEED,
        Particles::Mono(n),
        Tuning::default(),
        &[grow_to_fraction(0.1, 0.33)],
    );
    run_scene(&scene, &mut |_, _| {}).map_err(|e| e.to_string())?;
    let peak = vm_hwm_kib()?;
    Ok(format!("baseline_kib {baseline}\npeak_kib {peak}\n"))
}
