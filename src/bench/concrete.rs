//! Concrete studies: the experiments of paper 001 (Titscher & Unger), §6, with the paper's
//! numbers beside densepack's. Lengths in mm; the scenes are those of
//! `examples/scenes/` with the parameter of each row substituted.
//!
//! * [`fuller`] (Fig. 7) — Fuller q = 0.5, grains 2–16 mm, walled cube of edge 32 mm and 80 mm:
//!   success rate ψ and time per success t_ψ against φ_eff for RSA (N^F = 10⁵; full run also
//!   10⁶) and EDMD (`fuller_80mm_walls.toml`). Slow even with `--quick`: the RSA rows near
//!   saturation reject up to N^F candidates per sphere (no row finished within 10 minutes
//!   in the one attempt); run it alone, and budget hours for the full table.
//! * [`gap`] (Fig. 9) — A16, 80 mm walled cube, d_min = 2 mm, Δd = 1 mm
//!   (`a16_80mm_gap1.toml`): success rate, time and events per run against φ_M.
//! * [`gapmax`] (Fig. 10–11) — Δd maximisation (`b16_150mm_gapmax.toml`): A16 and B16 at
//!   φ_M = 60 % and 70 %, d_min = 2 mm; 150 mm cube (quick: 80 mm).
//! * [`jam`] — jamming speed: A16 (φ_M = 0.535) and Fuller q = 0.5 (φ_eff = 0.60) in
//!   the 80 mm walled cube, RSA at true size, grown (relative rate 0.05) to reduced pressure
//!   10¹²: events/s, and the smallest gaps to pairs and walls by the independent check.

use super::{Figure, Series, StudyContext, StudyOutput, Table};
use crate::io::scene::Scene;
use crate::run::run_scene;
use std::time::Instant;

const FULLER_SCENE: &str = include_str!("../../examples/scenes/fuller_80mm_walls.toml");
const GAP_SCENE: &str = include_str!("../../examples/scenes/a16_80mm_gap1.toml");
const GAPMAX_SCENE: &str = include_str!("../../examples/scenes/b16_150mm_gapmax.toml");

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

/// Outcome of one run: success, wall seconds, events, the packing's min_gap.
struct Run {
    ok: bool,
    seconds: f64,
    events: u64,
    min_gap: f64,
    message: String,
}

fn run(text: &str) -> Run {
    let scene = Scene::from_toml(text).unwrap_or_else(|e| panic!("bench scene: {e}\n{text}"));
    let t = Instant::now();
    match run_scene(&scene, &mut |_, _| {}) {
        Ok(o) => Run {
            ok: true,
            seconds: t.elapsed().as_secs_f64(),
            events: o.packing.stats.events,
            min_gap: o.packing.min_gap,
            message: o.packing.stats.stop_reason.clone(),
        },
        Err(e) => Run {
            ok: false,
            seconds: t.elapsed().as_secs_f64(),
            events: 0,
            min_gap: f64::NAN,
            message: e.to_string(),
        },
    }
}

/// Success rate and time per success (total time / successes) over `seeds`.
fn success_row(runs: &[Run]) -> (f64, f64) {
    let successes = runs.iter().filter(|r| r.ok).count();
    let total: f64 = runs.iter().map(|r| r.seconds).sum();
    let psi = successes as f64 / runs.len().max(1) as f64;
    let t_psi = if successes > 0 {
        total / successes as f64
    } else {
        f64::INFINITY
    };
    (psi, t_psi)
}

/// Case 1 (Fig. 7).
pub fn fuller(ctx: &StudyContext) -> StudyOutput {
    let quick = ctx.quick;
    let edges: &[f64] = if quick { &[32.0] } else { &[32.0, 80.0] };
    let fractions: &[f64] = if quick {
        &[0.65, 0.70]
    } else {
        &[0.60, 0.65, 0.675, 0.70]
    };
    let seeds = if quick { 3 } else { 10 };
    let rsa_limits: &[u64] = if quick {
        &[100_000]
    } else {
        &[100_000, 1_000_000]
    };
    let mut table = Table::new(
        "Concrete case 1: Fuller q = 0.5, 2–16 mm, walled cube (paper 001, Fig. 7)",
        "ψ = successful runs / runs, t_ψ = total time / successes, seeds 1…runs. Paper \
         (80 mm cube): EDMD reaches φ_eff = 70 %, RSA 66.5 % (N^F = 10⁶).",
        &["cube mm", "φ_eff", "method", "runs", "ψ", "t_ψ s"],
    );
    let mut series: Vec<Series> = Vec::new();
    for &edge in edges {
        for &phi in fractions {
            let sized = set(
                &set(FULLER_SCENE, "effective_fraction", &format!("{phi}")),
                "size",
                &format!("[{edge:?}, {edge:?}, {edge:?}]"),
            );
            let mut methods: Vec<(String, Vec<Run>)> = rsa_limits
                .iter()
                .map(|&limit| {
                    let runs = (1..=seeds)
                        .map(|seed| {
                            run(&rsa_variant(&set(&sized, "seed", &seed.to_string()), limit))
                        })
                        .collect();
                    (format!("RSA N^F = {limit:.0e}"), runs)
                })
                .collect();
            methods.push((
                "EDMD".into(),
                (1..=seeds)
                    .map(|seed| run(&set(&sized, "seed", &seed.to_string())))
                    .collect(),
            ));
            for (method, runs) in methods {
                let (psi, t) = success_row(&runs);
                table.row(vec![
                    format!("{edge}"),
                    format!("{phi}"),
                    method.clone(),
                    seeds.to_string(),
                    format!("{psi:.2}"),
                    format!("{t:.2}"),
                ]);
                eprintln!("fuller {edge} {phi} {method}: ψ {psi:.2} t {t:.2}");
                let label = format!("{edge} mm, {method}");
                match series.iter_mut().find(|s| s.label == label) {
                    Some(s) => s.points.push((phi, psi)),
                    None => series.push(Series::line(label, vec![(phi, psi)])),
                }
            }
        }
    }
    let mut figure = Figure::new("Fuller q = 0.5: success rate", "φ_eff", "success rate ψ");
    figure.series = series;
    StudyOutput {
        markdown: table.markdown(),
        csv: table,
        figure,
    }
}

/// The Fuller scene as RSA alone at true size with rejection limit `limit`.
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

/// Case 2 (Fig. 9).
pub fn gap(ctx: &StudyContext) -> StudyOutput {
    let fractions: &[f64] = if ctx.quick {
        &[0.535]
    } else {
        &[0.50, 0.52, 0.535]
    };
    let seeds = if ctx.quick { 1 } else { 10 };
    let mut table = Table::new(
        "Concrete case 2: A16, 80 mm walled cube, d_min = 2 mm, Δd = 1 mm (paper 001, Fig. 9)",
        &format!(
            "`a16_80mm_gap1.toml` with φ_M varied, seeds 1…{seeds}. Paper: EDMD succeeds in 90 % \
             of the runs at φ_M = 53.5 %, ~5 000 grains, ~4 million events, 135 s per run (one \
             2 GHz Xeon core); speed-up = 135 s / t_ψ."
        ),
        &[
            "φ_M",
            "runs",
            "ψ",
            "t_ψ s",
            "speed-up vs paper",
            "mean events (successes)",
            "failures",
        ],
    );
    let mut points = Vec::new();
    for &phi in fractions {
        let scene = set(GAP_SCENE, "mixture_fraction", &format!("{phi}"));
        let runs: Vec<Run> = (1..=seeds)
            .map(|seed| run(&set(&scene, "seed", &seed.to_string())))
            .collect();
        let (psi, t) = success_row(&runs);
        let ok: Vec<&Run> = runs.iter().filter(|r| r.ok).collect();
        let events = ok.iter().map(|r| r.events as f64).sum::<f64>() / ok.len().max(1) as f64;
        let failures: Vec<&str> = runs
            .iter()
            .filter(|r| !r.ok)
            .map(|r| r.message.split(':').nth(1).unwrap_or("").trim())
            .collect();
        points.push((phi, t));
        table.row(vec![
            format!("{phi}"),
            seeds.to_string(),
            format!("{psi:.2}"),
            format!("{t:.1}"),
            format!("{:.1}", 135.0 / t),
            format!("{events:.3e}"),
            if failures.is_empty() {
                "—".to_owned()
            } else {
                failures.join("; ")
            },
        ]);
        eprintln!("gap {phi}: ψ {psi:.2} t {t:.1}");
    }
    StudyOutput {
        markdown: table.markdown(),
        csv: table,
        figure: Figure::new("A16 with Δd = 1 mm: time per success", "φ_M", "t_ψ (s)")
            .with(Series::line("densepack", points))
            .with(Series::points("paper (φ_M = 0.535)", vec![(0.535, 135.0)])),
    }
}

/// Case 3 (Fig. 10–11).
pub fn gapmax(ctx: &StudyContext) -> StudyOutput {
    let edge = if ctx.quick { 80.0 } else { 150.0 };
    let mut table = Table::new(
        &format!(
            "Concrete case 3: Δd maximisation, {edge} mm walled cube, d_min = 2 mm \
             (paper 001, Fig. 10–11)"
        ),
        "`b16_150mm_gapmax.toml` with curve, φ_M and edge substituted. Paper (150 mm cube): \
         B16 reaches Δd ≥ d_min/2 = 1 mm at φ_M = 60 % and 70 %, A16 does not.",
        &["curve", "φ_M", "grains", "Δd_max mm", "events", "wall s"],
    );
    let mut series = Vec::new();
    for curve in ["A16", "B16"] {
        let mut points = Vec::new();
        for phi in [0.60, 0.70] {
            let scene = set(
                &set(
                    &set(GAPMAX_SCENE, "mixture_fraction", &format!("{phi}")),
                    "grading",
                    &format!("{{ kind = \"din\", name = \"{curve}\" }}"),
                ),
                "size",
                &format!("[{edge:?}, {edge:?}, {edge:?}]"),
            );
            let parsed = Scene::from_toml(&scene).expect("bench scene");
            let grains = parsed
                .take_phase()
                .expect("graded")
                .expect("valid")
                .expected_count();
            let r = run(&scene);
            if r.ok {
                points.push((phi, r.min_gap));
            }
            table.row(vec![
                curve.into(),
                format!("{phi}"),
                format!("{grains:.0}"),
                if r.ok {
                    format!("{:.3}", r.min_gap)
                } else {
                    format!("failed: {}", r.message)
                },
                format!("{:.3e}", r.events as f64),
                format!("{:.1}", r.seconds),
            ]);
            eprintln!(
                "gapmax {curve} {phi}: Δd {:.3} in {:.1} s",
                r.min_gap, r.seconds
            );
        }
        series.push(Series::line(curve, points));
    }
    let mut figure = Figure::new("Largest minimum gap Δd_max", "φ_M", "Δd_max (mm)");
    figure.series = series;
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
