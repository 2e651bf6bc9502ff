//! Concrete studies: the experiments of paper 001 (Titscher & Unger), §6, with the paper's
//! numbers beside densepack's. Lengths in mm; the scenes are those of
//! `examples/scenes/` with the parameter of each row substituted.
//!
//! * [`fuller`] (Fig. 7) — Fuller q = 0.5, grains 2–16 mm, walled cube of edge 32 mm and 80 mm:
//!   success rate ψ and CPU time per success t_ψ against φ_eff for RSA (N^F = 10⁵; full run
//!   also 10⁶) and EDMD (`fuller_80mm_walls.toml`, first stage to φ_eff − 0.05). Quick: the
//!   32 mm cube at two φ_eff, two seeds (seconds); full: 32 mm at 0.55–0.70 (10 seeds) and
//!   80 mm at 0.60–0.70 (5 seeds) in steps of 0.025, about 20 CPU minutes.
//! * [`gap`] (Fig. 9) — A16, 80 mm walled cube, d_min = 2 mm, Δd = 1 mm
//!   (`a16_80mm_gap1.toml`): success rate and time per success against φ_M for RSA of the
//!   coated grains and EDMD, 0.5 % steps, 50 seeds (quick: one φ_M each, one seed).
//! * [`gapmax`] (Fig. 10–11) — Δd maximisation (`b16_150mm_gapmax.toml`): A16 and B16 at
//!   φ_M = 60 % and 70 %, d_min = 4 and 2 mm, the gap kept to the walls or not, three
//!   seeds each; 150 mm cube (quick: 80 mm, d_min = 4 mm, one seed). [`gapmax_fine`]: the
//!   same at d_min = 1 mm (1.8–2.3·10⁵ grains per run, 15–20 CPU minutes each).
//! * [`jam`] — jamming speed: A16 (φ_M = 0.535) and Fuller q = 0.5 (φ_eff = 0.60) in
//!   the 80 mm walled cube, RSA at true size, grown (relative rate 0.05) to reduced pressure
//!   10¹²: events/s, and the smallest gaps to pairs and walls by the independent check.

use super::{mean_sd, Figure, Journal, Series, StudyContext, StudyOutput, Table};
use densepack::io::scene::Scene;
use densepack::run::run_scene;
use std::time::Instant;

const FULLER_SCENE: &str = include_str!("../../../examples/scenes/fuller_80mm_walls.toml");
const GAP_SCENE: &str = include_str!("../../../examples/scenes/a16_80mm_gap1.toml");
const GAPMAX_SCENE: &str = include_str!("../../../examples/scenes/b16_150mm_gapmax.toml");

/// Replaces the line starting with `key =` (first occurrence) by `key = value`.
fn set(scene: &str, key: &str, value: &str) -> String {
    let prefix = format!("{key} =");
    let mut done = false;
    scene
        .lines()
        .map(|l| {
            if !done && l.starts_with(&prefix) {
                done = true;
                format!("{key} = {value}")
            } else {
                l.to_owned()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
        + "\n"
}

/// Outcome of one run: success, CPU seconds, events, the packing's min_gap. Recorded in the
/// [`Journal`] (a failed run's NaN gap as `null`).
#[derive(serde::Serialize, serde::Deserialize)]
struct Run {
    ok: bool,
    /// CPU seconds of this thread (the machine may be shared).
    cpu_seconds: f64,
    events: u64,
    #[serde(deserialize_with = "nan_from_null")]
    min_gap: f64,
    message: String,
}

/// Reads a float written by `serde_json`, which writes NaN as `null`.
fn nan_from_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    use serde::Deserialize as _;
    Option::<f64>::deserialize(d).map(|v| v.unwrap_or(f64::NAN))
}

fn run(text: &str) -> Run {
    let scene = Scene::from_toml(text).unwrap_or_else(|e| panic!("bench scene: {e}\n{text}"));
    let cpu = cpu_time::ThreadTime::now();
    let outcome = run_scene(&scene, &mut |_, _| {});
    let cpu_seconds = cpu.elapsed().as_secs_f64();
    match outcome {
        Ok(o) => Run {
            ok: true,
            cpu_seconds,
            events: o.packing.stats.events,
            min_gap: o.packing.min_gap,
            message: o.packing.stats.stop_reason.clone(),
        },
        Err(e) => Run {
            ok: false,
            cpu_seconds,
            events: 0,
            min_gap: f64::NAN,
            message: e.to_string(),
        },
    }
}

/// Success rate ψ and time per success t_ψ (total `clock` time / successes) over `runs`.
fn success_row(runs: &[Run], clock: fn(&Run) -> f64) -> (f64, f64) {
    let successes = runs.iter().filter(|r| r.ok).count();
    let total: f64 = runs.iter().map(clock).sum();
    let psi = successes as f64 / runs.len().max(1) as f64;
    let t_psi = if successes > 0 {
        total / successes as f64
    } else {
        f64::INFINITY
    };
    (psi, t_psi)
}

/// The φ_eff values `from, from + step, …` up to `to` (inclusive, to rounding).
fn steps(from: f64, to: f64, step: f64) -> Vec<f64> {
    let n = ((to - from) / step + 1e-9).floor() as usize;
    (0..=n)
        .map(|k| ((from + k as f64 * step) * 1e4).round() / 1e4)
        .collect()
}

/// What paper 001 states of Fig. 7 in its text (§6.2), per cube edge: the break-even point
/// (φ_eff, t_ψ) after which its EDMD is faster than its RSA, and the highest φ_eff reached.
fn fuller_paper(edge: f64) -> &'static str {
    if edge < 50.0 {
        "break-even φ_eff ≈ 60 %, t_ψ ≈ 0.2 s; both reach less than in the 80 mm cube"
    } else {
        "break-even φ_eff ≈ 62.5 %, t_ψ ≈ 4 s; EDMD reaches 70 %, RSA 66.5 %"
    }
}

/// The Fuller scene as EDMD at `phi`: seeded at δ = 0.9, grown at relative rate 0.02 to
/// φ − 0.05, then at 0.0005 to full size (the shipped scene's protocol, which has φ = 0.70).
fn edmd_variant(scene: &str, phi: f64) -> String {
    set(
        scene,
        "until",
        &format!("{{ packing_fraction = {:.4} }}", phi - 0.05),
    )
}

/// One cube of the Fuller study: its edge, the seeds per step, the step of φ_eff, the last
/// φ_eff tried and, per method, the first φ_eff of its sweep.
struct FullerCube {
    edge: f64,
    seeds: u64,
    step: f64,
    last: f64,
    /// `(RSA N^F = 10⁵, RSA N^F = 10⁶, EDMD)` first fractions; `None` leaves the method out.
    first: [Option<f64>; 3],
}

impl FullerCube {
    /// The cube of edge `edge` with `seeds` seeds per step of `step` up to `last`, each
    /// method from its `first` fraction.
    fn new(edge: f64, seeds: u64, (step, last): (f64, f64), first: [Option<f64>; 3]) -> Self {
        Self {
            edge,
            seeds,
            step,
            last,
            first,
        }
    }
}

/// Case 1 (Fig. 7): success rate ψ and CPU time per success t_ψ against φ_eff for RSA
/// (N^F = 10⁵, 10⁶) and EDMD, per cube, on a coarse grid (steps of 2.5 %, 10 and 5 seeds;
/// about 20 CPU minutes). Quick: the 32 mm cube, RSA N^F = 10⁵ and EDMD from 0.60 in steps
/// of 5 %, 2 seeds.
pub fn fuller(ctx: &StudyContext) -> StudyOutput {
    let cubes = if ctx.quick {
        vec![FullerCube::new(
            32.0,
            2,
            (0.05, 0.65),
            [Some(0.60), None, Some(0.60)],
        )]
    } else {
        vec![
            FullerCube::new(32.0, 10, (0.025, 0.70), [Some(0.55); 3]),
            FullerCube::new(80.0, 5, (0.025, 0.70), [Some(0.60); 3]),
        ]
    };
    fuller_rows(ctx, &cubes)
}

/// Case 1 on the paper's grid: steps of 0.5 % and 50 size distributions per step, both cubes
/// (many hours on two cores; `--resume` runs it in parts). Each sweep starts a little below
/// the highest φ_eff at which the coarse grid of [`fuller`] gives ψ = 1 for that method and
/// cube (BENCHMARKS.md, case 1); the paper's rows below it, from 55 %, are all successes.
/// Quick: the 32 mm cube, EDMD at 0.62 and 0.625, 2 seeds.
pub fn fuller_fine(ctx: &StudyContext) -> StudyOutput {
    let cubes = if ctx.quick {
        vec![FullerCube::new(
            32.0,
            2,
            (0.005, 0.625),
            [None, None, Some(0.62)],
        )]
    } else {
        let paper = (0.005, 0.72);
        vec![
            FullerCube::new(32.0, 50, paper, [Some(0.585), Some(0.61), Some(0.62)]),
            FullerCube::new(80.0, 50, paper, [Some(0.61), Some(0.635), Some(0.68)]),
        ]
    };
    fuller_rows(ctx, &cubes)
}

/// The Fuller sweeps of `cubes`: per cube and method, φ_eff from the method's first fraction
/// in the cube's steps until no run succeeds ([`sweep`]); seeds 1…runs are the size
/// distributions, the same for every method.
fn fuller_rows(ctx: &StudyContext, cubes: &[FullerCube]) -> StudyOutput {
    let mut table = Table::new(
        "Concrete case 1: Fuller q = 0.5, 2–16 mm, walled cube (paper 001, Fig. 7)",
        "ψ = successful runs / runs, t_ψ = CPU seconds of all runs / successes (∞: none; each \
         run's own thread, runs in parallel, one per core), seeds 1…runs. Each method steps \
         φ_eff from its first fraction until no run succeeds. RSA at true size, N^F \
         consecutive rejections of one grain fail it. EDMD: RSA at δ = 0.9, relative rate 0.02 \
         to φ_eff − 0.05, then 0.0005 to full size; fails on Δt < 10⁻⁶ over 1000 events or \
         after 1200 s (`fuller_80mm_walls.toml`).",
        &[
            "cube mm",
            "φ_eff",
            "method",
            "runs",
            "ψ",
            "t_ψ s (CPU)",
            "failures",
        ],
    );
    let mut summary = Table::new(
        "Concrete case 1: highest φ_eff with ψ ≥ 0.5, against paper 001's text",
        "From the table above (its φ_eff grid); the paper's Fig. 7 is read from its text only.",
        &[
            "cube mm",
            "method",
            "highest φ_eff, ψ ≥ 0.5",
            "paper (§6.2)",
        ],
    );
    let mut series: Vec<Series> = Vec::new();
    for cube in cubes {
        let edge = cube.edge;
        let sized = |phi: f64| {
            set(
                &set(FULLER_SCENE, "effective_fraction", &format!("{phi}")),
                "size",
                &format!("[{edge:?}, {edge:?}, {edge:?}]"),
            )
        };
        // Each method with its RSA rejection limit N^F (`None`: EDMD).
        let methods = [
            ("RSA N^F = 1e5", Some(100_000)),
            ("RSA N^F = 1e6", Some(1_000_000)),
            ("EDMD", None),
        ];
        for ((method, limit), first) in methods.into_iter().zip(cube.first) {
            let Some(first) = first else { continue };
            let scene_at = |phi: f64| match limit {
                Some(limit) => rsa_variant(&sized(phi), limit),
                None => edmd_variant(&sized(phi), phi),
            };
            let tag = format!("fuller {edge} {method}");
            let mut points = Vec::new();
            let mut highest = None;
            let grid = (first, cube.last, cube.step);
            let journal = ctx.journal.as_deref();
            for (phi, runs) in sweep(journal, grid, cube.seeds, scene_at, &tag) {
                let (psi, t) = success_row(&runs, |r| r.cpu_seconds);
                table.row(vec![
                    format!("{edge}"),
                    format!("{phi}"),
                    method.into(),
                    cube.seeds.to_string(),
                    format!("{psi:.2}"),
                    format!("{t:.2}"),
                    failure_kinds(&runs),
                ]);
                if psi >= 0.5 {
                    highest = Some(phi);
                }
                points.push((phi, psi));
            }
            if let Some(phi) = highest {
                summary.row(vec![
                    format!("{edge}"),
                    method.into(),
                    format!("{phi}"),
                    fuller_paper(edge).into(),
                ]);
            }
            series.push(Series::line(format!("{edge} mm, {method}"), points));
        }
    }
    let mut figure = Figure::new("Fuller q = 0.5: success rate", "φ_eff", "success rate ψ");
    figure.series = series;
    StudyOutput {
        markdown: table.markdown() + "\n" + &summary.markdown(),
        csv: table,
        figure,
    }
}

/// The runs of a success-rate sweep: the scenes `scene_at(φ)` with seeds 1…`seeds`, all runs
/// of a step in parallel ([`run_parallel`], recorded in `journal`), at φ = `first`,
/// `first + step`, … up to `last`, ending after the first step where no run succeeds. Prints
/// each step's ψ and t_ψ after `tag` on stderr.
fn sweep(
    journal: Option<&Journal>,
    (first, last, step): (f64, f64, f64),
    seeds: u64,
    scene_at: impl Fn(f64) -> String,
    tag: &str,
) -> Vec<(f64, Vec<Run>)> {
    let mut rows = Vec::new();
    for phi in steps(first, last, step) {
        let scene = scene_at(phi);
        let scenes: Vec<String> = (1..=seeds)
            .map(|seed| set(&scene, "seed", &seed.to_string()))
            .collect();
        let runs = run_parallel(journal, &scenes);
        let (psi, t) = success_row(&runs, |r| r.cpu_seconds);
        eprintln!("{tag} {phi}: ψ {psi:.2} t {t:.2}");
        rows.push((phi, runs));
        if psi == 0.0 {
            break;
        }
    }
    rows
}

/// The distinct [`failure_kind`]s of the failed runs of `runs`, sorted and joined, or "—".
fn failure_kinds(runs: &[Run]) -> String {
    let mut kinds: Vec<&str> = runs
        .iter()
        .filter(|r| !r.ok)
        .map(|r| failure_kind(&r.message))
        .collect();
    kinds.sort_unstable();
    kinds.dedup();
    if kinds.is_empty() {
        "—".into()
    } else {
        kinds.join(", ")
    }
}

/// A short name for why a run failed: the RSA rejection limit or the stage's stop reason.
fn failure_kind(message: &str) -> &'static str {
    [
        "stalled",
        "jammed_before_goal",
        "wall_clock_limit",
        "event_limit",
        "pressure_reached",
    ]
    .into_iter()
    .find(|k| message.contains(k))
    .unwrap_or(if message.contains("consecutive rejections") {
        "N^F rejections"
    } else {
        "other"
    })
}

/// A concrete scene as RSA alone at true size with rejection limit `limit`.
fn rsa_variant(scene: &str, limit: u64) -> String {
    let head = scene.split("[[stage]]").next().expect("scene text");
    let head = set(head, "seed_scale", "1.0");
    let head = head.replacen("seed = ", "method = \"rsa\"\nseed = ", 1);
    head.replacen(
        "[particles]\n",
        &format!("[particles]\nrsa_max_failures = {limit}\n"),
        1,
    )
}

/// Case 2 (Fig. 9): success rate ψ and CPU time per success t_ψ against φ_M for A16 with
/// Δd = 1 mm in the 80 mm cube, by RSA of the coated grains (diameters d + Δd, grains at
/// true size may touch the walls, N^F = 10⁶) and by EDMD (`a16_80mm_gap1.toml`: RSA at
/// true size, absolute growth until Δd/2 is gained, Eq. 31). Each method steps φ_M by the
/// paper's 0.5 % from a fraction every run reaches until no run succeeds, seeds 1…50 (the
/// paper's 50 size distributions per step), all runs of a step in parallel. Quick: RSA at
/// 0.40 and EDMD at 0.535, one seed each.
pub fn gap(ctx: &StudyContext) -> StudyOutput {
    // (method, first φ_M, last φ_M tried)
    let sweeps: [(&str, f64, f64); 2] = if ctx.quick {
        [("RSA", 0.40, 0.40), ("EDMD", 0.535, 0.535)]
    } else {
        [("RSA", 0.44, 0.60), ("EDMD", 0.525, 0.60)]
    };
    // The paper's 50 size distributions per step: about an hour on two cores.
    let seeds: u64 = if ctx.quick { 1 } else { 50 };
    let mut table = Table::new(
        "Concrete case 2: A16, 80 mm walled cube, d_min = 2 mm, Δd = 1 mm (paper 001, Fig. 9)",
        &format!(
            "Seeds 1…{seeds} per step, ψ = successes / runs, t_ψ = CPU seconds of all runs / \
             successes (each run's own thread). RSA places the coated grains (d + Δd; at their \
             true size they may touch the walls) and fails a run after N^F = 10⁶ consecutive \
             rejections of one grain. EDMD: \
             `a16_80mm_gap1.toml` with φ_M varied. Paper: EDMD succeeds in 90 % of the runs at \
             φ_M = 53.5 % with ~4 million events and 135 s per run (one 2 GHz Xeon core; \
             speed-up = 135 s / t_ψ); the highest φ_M are 53.5 % (EDMD) and 48 % (RSA)."
        ),
        &[
            "method",
            "φ_M",
            "runs",
            "ψ",
            "t_ψ s (CPU)",
            "speed-up vs paper",
            "mean events (successes)",
            "failures",
        ],
    );
    let mut summary = Table::new(
        "Concrete case 2: highest φ_M with ψ ≥ 0.5, against paper 001",
        "From the table above (its 0.5 % grid).",
        &["method", "highest φ_M, ψ ≥ 0.5", "paper (§6.3)"],
    );
    let mut series = Vec::new();
    for (method, first, last) in sweeps {
        let mut points = Vec::new();
        let mut highest = None;
        let scene_at = |phi: f64| {
            let edmd = set(GAP_SCENE, "mixture_fraction", &format!("{phi}"));
            if method == "RSA" {
                rsa_variant(&edmd, 1_000_000).replacen(
                    "[particles]\n",
                    "[particles]\ngap = 1.0\nwall_gap = 0.0\n",
                    1,
                )
            } else {
                edmd
            }
        };
        for (phi, runs) in sweep(
            ctx.journal.as_deref(),
            (first, last, 0.005),
            seeds,
            scene_at,
            &format!("gap {method}"),
        ) {
            let (psi, t) = success_row(&runs, |r| r.cpu_seconds);
            let ok: Vec<&Run> = runs.iter().filter(|r| r.ok).collect();
            let events = ok.iter().map(|r| r.events as f64).sum::<f64>() / ok.len().max(1) as f64;
            points.push((phi, psi));
            if psi >= 0.5 {
                highest = Some(phi);
            }
            table.row(vec![
                method.into(),
                format!("{phi}"),
                seeds.to_string(),
                format!("{psi:.2}"),
                format!("{t:.2}"),
                if method == "EDMD" && t.is_finite() {
                    format!("{:.1}", 135.0 / t)
                } else {
                    "—".into()
                },
                if method == "EDMD" && !ok.is_empty() {
                    format!("{events:.3e}")
                } else {
                    "—".into()
                },
                failure_kinds(&runs),
            ]);
        }
        summary.row(vec![
            method.into(),
            highest.map_or("none".into(), |p| format!("{p}")),
            if method == "RSA" { "0.48" } else { "0.535" }.into(),
        ]);
        series.push(Series::line(method, points));
    }
    let mut figure = Figure::new("A16 with Δd = 1 mm: success rate", "φ_M", "success rate ψ");
    figure.series = series;
    figure = figure.with(Series::points("paper: EDMD ψ = 0.9", vec![(0.535, 0.9)]));
    StudyOutput {
        markdown: table.markdown() + "\n" + &summary.markdown(),
        csv: table,
        figure,
    }
}

/// Runs every scene of `scenes`, one per core at a time, and returns their outcomes in the
/// same order. Each run gets a one-thread rayon pool of its own, so that its seeding (which
/// otherwise fans out over the global pool) stays on the thread whose CPU time [`run`]
/// measures. Scenes whose outcome `journal` already holds (from an interrupted attempt) are
/// not run again; each new outcome is recorded there as it finishes.
fn run_parallel(journal: Option<&Journal>, scenes: &[String]) -> Vec<Run> {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Mutex;
    let recorded: Vec<Option<Run>> = scenes
        .iter()
        .map(|text| journal.and_then(|j| j.get(text)))
        .collect();
    let pending: Vec<usize> = (0..scenes.len())
        .filter(|&k| recorded[k].is_none())
        .collect();
    let results = Mutex::new(recorded);
    let next = AtomicUsize::new(0);
    let workers = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(pending.len());
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                let pool = rayon::ThreadPoolBuilder::new()
                    .num_threads(1)
                    .build()
                    .expect("a one-thread pool");
                while let Some(&k) = pending.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let r = pool.install(|| run(&scenes[k]));
                    if let Some(j) = journal {
                        j.record(&scenes[k], &r);
                    }
                    results.lock().expect("no worker panicked")[k] = Some(r);
                }
            });
        }
    });
    results
        .into_inner()
        .expect("no worker panicked")
        .into_iter()
        .map(|r| r.expect("every scene ran"))
        .collect()
}

/// Reduced pressure at which the Δd maximisation study stops: Δd has settled to about
/// 10⁻⁵ mm by then (BENCHMARKS.md, case 3), at under half the events of Z = 10¹².
const GAPMAX_PRESSURE: &str = "1e6";

/// Case 3 (Fig. 10–11): Δd_max against d_min = 4 and 2 mm for A16 and B16 at φ_M = 60 % and
/// 70 %, with the gap kept to the walls (λ = 0.5) and with the walls seeing the grains at
/// their true size (λ = 0), seeds 1…3 (about 40 CPU minutes). Quick: the 80 mm cube,
/// d_min = 4 mm, λ = 0.5, one seed.
pub fn gapmax(ctx: &StudyContext) -> StudyOutput {
    if ctx.quick {
        gapmax_rows(ctx, 80.0, &[4.0], &[0.5], 1)
    } else {
        gapmax_rows(ctx, 150.0, &[4.0, 2.0], &[0.5, 0.0], 3)
    }
}

/// Case 3 at d_min = 1 mm: the rows of [`gapmax`] with 1.8–2.3·10⁵ grains each (15–20
/// CPU minutes per run, about 7 CPU hours in all).
/// Quick: a 30 mm cube, λ = 0.5, one seed.
pub fn gapmax_fine(ctx: &StudyContext) -> StudyOutput {
    if ctx.quick {
        gapmax_rows(ctx, 30.0, &[1.0], &[0.5], 1)
    } else {
        gapmax_rows(ctx, 150.0, &[1.0], &[0.5, 0.0], 3)
    }
}

/// The Δd maximisation rows: every wall treatment λ of `walls`, curve, φ_M and d_min of
/// `d_mins` in a cube of edge `edge`, seeds 1…`seeds`, all runs in parallel.
fn gapmax_rows(
    ctx: &StudyContext,
    edge: f64,
    d_mins: &[f64],
    walls: &[f64],
    seeds: u64,
) -> StudyOutput {
    let mut table = Table::new(
        &format!(
            "Concrete case 3: Δd maximisation against d_min, {edge} mm walled cube \
             (paper 001, Fig. 10–11)"
        ),
        &format!(
            "`b16_150mm_gapmax.toml` with curve, φ_M, d_min, edge, seed and the wall treatment \
             substituted, stopped at Z = {GAPMAX_PRESSURE}; seeds 1…{seeds}, mean ± sample \
             deviation. λ is `wall_gap_fraction`: 0.5 keeps Δd/2 to the walls, 0 lets the \
             walls see the grains at their true size. The paper (150 mm cube, d_min = 2 mm) \
             reaches 2Δd ≥ d_min with B16 at φ_M = 60 % and 70 %, not with A16. CPU s: the \
             run's own thread (runs in parallel, one per core)."
        ),
        &[
            "curve",
            "φ_M",
            "d_min mm",
            "λ",
            "grains",
            "runs ok",
            "Δd_max mm",
            "2Δd_max/d_min",
            "runs with 2Δd ≥ d_min",
            "events",
            "CPU s",
        ],
    );
    let mut cases = Vec::new();
    let mut scenes = Vec::new();
    for &lambda in walls {
        for curve in ["A16", "B16"] {
            for phi in [0.60, 0.70] {
                for &d_min in d_mins {
                    let mut scene = GAPMAX_SCENE.to_owned();
                    for (key, value) in [
                        ("mixture_fraction", format!("{phi}")),
                        (
                            "grading",
                            format!("{{ kind = \"din\", name = \"{curve}\" }}"),
                        ),
                        ("size", format!("[{edge:?}, {edge:?}, {edge:?}]")),
                        ("d_min", format!("{d_min:?}")),
                        ("max_wall_seconds", "86400".to_owned()),
                        (
                            "until",
                            format!(
                                "{{ max_gap = true, reduced_pressure = {GAPMAX_PRESSURE} }}\n\
                                 wall_gap_fraction = {lambda:?}"
                            ),
                        ),
                    ] {
                        scene = set(&scene, key, &value);
                    }
                    let grains = Scene::from_toml(&scene)
                        .expect("bench scene")
                        .take_phase()
                        .expect("graded")
                        .expect("valid")
                        .expected_count();
                    cases.push((lambda, curve, phi, d_min, grains));
                    for seed in 1..=seeds {
                        scenes.push(set(&scene, "seed", &seed.to_string()));
                    }
                }
            }
        }
    }
    let runs = run_parallel(ctx.journal.as_deref(), &scenes);
    let mut series: Vec<Series> = Vec::new();
    for (k, &(lambda, curve, phi, d_min, grains)) in cases.iter().enumerate() {
        let of_case = &runs[k * seeds as usize..(k + 1) * seeds as usize];
        let ok: Vec<&Run> = of_case.iter().filter(|r| r.ok).collect();
        let gaps: Vec<f64> = ok.iter().map(|r| r.min_gap).collect();
        let (gap, sd) = mean_sd(&gaps);
        let mean_of = |f: fn(&Run) -> f64| ok.iter().map(|r| f(r)).sum::<f64>() / ok.len() as f64;
        for r in of_case.iter().filter(|r| !r.ok) {
            eprintln!(
                "gapmax {curve} {phi} d_min {d_min} λ {lambda}: {}",
                r.message
            );
        }
        let label = format!("{curve}, φ_M {phi}, λ {lambda}");
        if !ok.is_empty() {
            match series.iter_mut().find(|s| s.label == label) {
                Some(s) => s.points.push((d_min, gap)),
                None => series.push(Series::line(label, vec![(d_min, gap)])),
            }
        }
        table.row(vec![
            curve.into(),
            format!("{phi}"),
            format!("{d_min}"),
            format!("{lambda}"),
            format!("{grains:.0}"),
            format!("{}/{seeds}", ok.len()),
            if ok.is_empty() {
                "failed".into()
            } else if ok.len() == 1 {
                format!("{gap:.4}")
            } else {
                format!("{gap:.4} ± {sd:.4}")
            },
            format!("{:.3}", 2.0 * gap / d_min),
            format!(
                "{}/{}",
                gaps.iter().filter(|&&g| 2.0 * g >= d_min).count(),
                ok.len()
            ),
            format!("{:.3e}", mean_of(|r| r.events as f64)),
            format!("{:.1}", mean_of(|r| r.cpu_seconds)),
        ]);
    }
    let mut figure = Figure::new(
        "Largest minimum gap Δd_max against d_min",
        "d_min (mm)",
        "Δd_max (mm)",
    );
    figure.series = series;
    figure = figure.with(Series::points(
        "2Δd = d_min",
        d_mins.iter().map(|&d| (d, d / 2.0)).collect(),
    ));
    StudyOutput {
        markdown: table.markdown(),
        csv: table,
        figure,
    }
}

/// Case 4: jamming speed.
pub fn jam(ctx: &StudyContext) -> StudyOutput {
    let mut table = Table::new(
        "Concrete case 4: jamming speed, 80 mm walled cube, RSA at true size → Z = 10¹²",
        "Relative growth 0.05. The authors' public code takes 295–400 s here (51–61 k \
         events/s; speed-up = 295 s / wall, against the fastest of their runs) and lets spheres grow into the walls by up to \
         3e-3 mm. Gaps are from the independent check (`densepack::verify`); negative would be \
         an overlap.",
        &[
            "grading",
            "grains",
            "events",
            "wall s",
            "M events/s",
            "speed-up vs public code",
            "φ_eff at jamming",
            "smallest pair gap mm",
            "smallest wall gap mm",
        ],
    );
    let mut scenes = vec![(
        "A16, φ_M = 0.535",
        set(GAP_SCENE, "grading", "{ kind = \"din\", name = \"A16\" }"),
    )];
    if !ctx.quick {
        scenes.push((
            "Fuller q = 0.5, φ_eff = 0.60",
            set(
                &set(
                    &GAP_SCENE.replace("mixture_fraction = 0.535", "effective_fraction = 0.60"),
                    "grading",
                    "{ kind = \"fuller\", q = 0.5, d_max = 16.0 }",
                ),
                "seed",
                "1",
            ),
        ));
    }
    let mut points = Vec::new();
    for (name, scene) in scenes {
        let head = scene.split("[[stage]]").next().expect("scene text");
        let text = format!(
            "{head}[[stage]]\ngrowth = \"relative\"\nrate = 0.05\nuntil = {{ reduced_pressure = 1e12 }}\n"
        );
        let parsed = Scene::from_toml(&text).expect("bench scene");
        let t = Instant::now();
        match run_scene(&parsed, &mut |_, _| {}) {
            Ok(o) => {
                let st = &o.packing.stats;
                let v = &o.verification;
                points.push((
                    o.packing.particles.len() as f64,
                    st.events as f64 / st.wall_seconds,
                ));
                table.row(vec![
                    name.into(),
                    o.packing.particles.len().to_string(),
                    st.events.to_string(),
                    format!("{:.1}", st.wall_seconds),
                    format!("{:.2}", st.events as f64 / st.wall_seconds / 1e6),
                    format!("{:.0}", 295.0 / st.wall_seconds),
                    format!("{:.4}", st.packing_fraction),
                    format!("{:.2e}", v.min_pair_gap.unwrap_or(f64::NAN)),
                    v.min_wall_gap.map_or("—".into(), |g| format!("{g:.2e}")),
                ]);
            }
            Err(e) => table.failed_row(vec![name.into()], &e.to_string()),
        }
        eprintln!("concrete-jam {name}: {:.1} s", t.elapsed().as_secs_f64());
    }
    StudyOutput {
        markdown: table.markdown(),
        csv: table,
        figure: Figure::new("Concrete jamming speed", "grains", "events per second")
            .with(Series::points("densepack", points)),
    }
}
