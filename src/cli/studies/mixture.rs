//! Sphere + cylinder RVEs (Salnikov, Choï & Karamian-Surville 2014, paper 000): the paper's
//! Tables II–VI (RSA) and VII–XI (MD relaxer) beside densepack's times ([`tables`],
//! [`paper_tables`]), the relaxer's time step and force rescaling against time and
//! residual overlap ([`relaxer`]), and the timing figures: RSA placement orders (Fig. 4,
//! [`order`]), the sphere share of a fixed total (Figs. 7–8, [`split`]) and the total
//! fraction for each composition (Figs. 9–11, [`fraction`]).
//!
//! Every packing counted as a success is accepted by the independent check
//! ([`densepack::verify::verify`]: GJK separating-plane certificates over all periodic images).

use super::{median, Figure, Series, StudyContext, StudyOutput, Table};
use densepack::protocol::mixture::relax::{random_rve, relax, RelaxError, RelaxSettings};
use densepack::protocol::mixture::rsa::{rsa_mixture, RsaLimits};
use densepack::protocol::mixture::{GenerationOrder, MixtureSpec};
use densepack::verify::verify;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::time::{Duration, Instant};

/// The paper's tables II–XI: per table, rows `f_s:cell,cell,…` (cells for f_c = 0.05, 0.10, …;
/// each `t_a3|t_a5` in seconds, one value when the paper gives one).
const PAPER: [&str; 10] = [
    "0.05:0.0002|0.0003,0.0003|0.0005,0.0005|0.0012,0.0011|0.0044,0.005|0.021,0.015|1.02;0.1:0.0002|0.0003,0.0004|0.0006,0.0007|0.0026,0.0018|0.0059,0.01|0.057,;0.15:0.0003|0.0004,0.0009|0.0027,0.0034|0.023,0.008|0.21,,;0.2:0.0013|0.0019,0.017|0.088,0.22,,,;0.25:0.022|0.029,8.49,,,,;0.3:0.015|1.49,,,,,",
    "0.05:0.0004|0.0006,0.0007|0.0013,0.0012|0.0031,0.0027|0.012,0.012|0.068,0.062|2.4;0.1:0.0004|0.0007,0.001|0.0017,0.0021|0.0042,0.0052|0.017,0.023|0.14,;0.15:0.0008|0.0011,0.0024|0.005,0.0094|0.077,2.7|7.7,,;0.2:0.0017|0.003,0.12|0.82,5.8|16.55,,,;0.25:0.086|0.17,2.86,,,,",
    "0.05:0.0007|0.0014,0.0015|0.0023,0.0026|0.0056,0.0047|0.018,0.017|0.14,0.17|3.36;0.1:0.001|0.0014,0.0018|0.0034,0.0041|0.0096,0.01|0.037,0.037|0.68,;0.15:0.0014|0.0021,0.0044|0.0095,0.021|0.099,2.6|13,,;0.2:0.0027|0.0061,0.21|0.99,6.49,,,;0.25:0.14|1.49,,,,,",
    "0.05:0.0012|0.0016,0.002|0.0037,0.0034|0.0079,0.0077|0.029,0.034|0.24,0.26|6.74;0.1:0.0015|0.0021,0.0027|0.005,0.0058|0.014,0.016|0.057,0.079|0.58,;0.15:0.0024|0.0035,0.0064|0.013,0.035|0.2,1.78|17.2,,;0.2:0.0064|0.011,0.14|1.18,10.6,,,;0.25:0.5|1.6,,,,,",
    "0.05:0.0017|0.0023,0.0027|0.0045,0.0045|0.012,0.011|0.038,0.043|0.38,0.29|8.38;0.1:0.0021|0.0029,0.0043|0.0067,0.0082|0.019,0.025|0.08,0.11|0.69,1.44|32;0.15:0.0035|0.0042,0.0086|0.017,0.057|0.29,3.85,,;0.2:0.0092|0.015,0.21|4.94,21.8,,,;0.25:0.21|4.02,,,,,",
    "0.05:0.06|0.07,0.09|0.12,0.12|0.16,0.14|0.19,0.19|0.37,0.27|0.52,0.38|0.82,0.66|1.62,0.74|2.17;0.1:0.07|0.1,0.12|0.12,0.11|0.16,0.18|0.22,0.21|0.33,0.29|0.7,0.38|1.0,0.63|2.08,;0.15:0.08|0.1,0.12|0.13,0.13|0.22,0.16|0.3,0.27|0.44,0.31|0.72,0.56|2.0,,;0.2:0.09|0.1,0.12|0.16,0.16|0.21,0.23|0.39,0.28|0.54,0.49|0.9,,,;0.25:0.1|0.14,0.14|0.18,0.19|0.25,0.29|0.43,0.5|0.93,,,,;0.3:0.12|0.14,0.15|0.21,0.20|0.35,0.35|0.65,,,,,;0.35:0.13|0.14,0.2|0.25,0.26|0.48,,,,,,;0.4:0.15|0.16,0.21|0.3,,,,,,,;0.45:0.17|0.22,,,,,,,,",
    "0.05:0.2|0.25,0.29|0.35,0.38|0.51,0.49|0.69,0.66|1.12,0.84|1.7,0.14|4.1,2.13|8.07,4.3|7.07;0.1:0.22|0.27,0.32|0.4,0.41|0.53,0.53|0.84,0.7|1.37,1.07|1.96,1.67|5.6,2.6|10.5,;0.15:0.23|0.29,0.35|0.4,0.45|0.59,0.64|0.87,0.79|1.52,1.21|3,2.08|8.75,,;0.2:0.31|0.33,0.39|0.47,0.47|0.62,0.65|1.11,0.9|1.59,1.86|5.51,,,;0.25:0.31|0.39,0.4|0.49,0.53|0.73,0.79|1.22,1.18|4.29,,,,;0.3:0.39|0.44,0.5|0.54,0.68|0.89,1.07|2.56,,,,,;0.35:0.42|0.48,0.62|0.66,0.85|1.39,,,,,,;0.4:0.45|0.57,0.72|0.81,,,,,,,;0.45:0.55|0.66,,,,,,,,",
    "0.05:0.39|0.5,0.59|0.73,0.75|1.06,0.96|1.33,1.15|1.92,1.62|3.57,2.19|8.85,4.01|16.94,7.36;0.1:0.47|0.62,0.59|0.92,0.81|1.1,0.99|1.57,1.22|2.63,1.77|4.4,3.22|9.6,5.77|17.8,;0.15:0.51|0.61,0.68|0.84,0.88|1.17,1.13|1.63,1.53|3.26,2.3|5.62,4.17|15.2,,;0.2:0.59|0.67,0.75|0.96,0.97|1.3,1.29|2.21,1.94|4.7,3.02|11.2,,,;0.25:0.66|0.74,0.86|1.06,1.13|1.72,1.51|2.81,2.55|7.85,,,,;0.3:0.74|0.81,1.01|1.19,1.29|1.88,2.1|4.03,,,,,;0.35:0.86|0.96,1.13|1.37,1.7|2.56,,,,,,;0.4:0.94|1.01,1.38|1.9,,,,,,,;0.45:1.1|1.32,,,,,,,,",
    "0.05:0.76|0.81,0.94|1.17,1.23|1.69,1.61|2.55,2.1|3.14,2.52|6.23,4.23|14,6.47|25,12.2;0.1:0.81|0.82,1.09|1.15,1.37|1.57,1.83|2.21,2.24|3.48,3.4|8.18,5.08|20.7,8.94|24.9,;0.15:0.9|0.98,1.16|1.31,1.42|1.72,1.85|2.83,2.53|4.86,3.96|10.3,6.33|26.7,,;0.2:0.97|1.1,1.33|1.5,1.61|2.06,2.17|3.31,3.29|7.21,5.42|16.3,,,;0.25:1.1|1.14,1.39|1.62,1.89|2.44,2.54|4.38,4.27|6.39,,,,;0.3:1.21|1.27,1.62|1.87,2.21|2.96,3.47|6.39,,,,,;0.35:1.44|1.43,1.94|2.32,2.87|3.91,,,,,,;0.4:1.59|1.67,2.25|2.94,,,,,,,;0.45:2.01|2.15,,,,,,,,",
    "0.05:1.15|1.18,1.38|1.77,1.93|2.37,2.36|3.24,3.04|5.32,3.99|9.01,6.47|20.2,8.8|31.4,15.6;0.1:1.2|1.24,1.56|1.73,1.87|2.42,2.58|3.22,3.41|5.65,4.7|11.5,7.36|22.7,14.3|39.2,;0.15:1.34|1.38,1.67|1.97,2.18|2.5,2.91|4.37,3.81|7.09,5.54|16.2,10.2|44.4,,;0.2:1.5|1.48,1.92|2.11,2.39|3.06,3.31|4.38,4.6|8.27,8.34|25.2,,,;0.25:1.61|1.7,2.14|2.36,2.69|3.5,3.84|6.96,6.39|17.3,,,,;0.3:1.77|1.85,2.3|2.66,3.3|4.37,4.99|9.89,,,,,;0.35:2.08|2.14,2.8|3.28,4.28|5.79,,,,,,;0.4:2.27|2.64,3.47|4.02,,,,,,,;0.45:2.69|3.33,,,,,,,,",
];

/// Paper time for table `method`, `n` bodies of each kind, cell (row, col), aspect index.
fn paper_time(method: &str, n: usize, row: usize, col: usize, aspect: usize) -> Option<f64> {
    let table = PAPER[(n / 10 - 1) + if method == "md" { 5 } else { 0 }];
    let r = table.split(';').nth(row)?;
    let cell = r.split(':').nth(1)?.split(',').nth(col)?;
    cell.split('|').nth(aspect)?.parse().ok()
}

/// Why one generation gave no packing.
#[derive(Clone, Debug, PartialEq)]
pub enum GenerationFailure {
    /// Refused: `N_cyl < 4 f_c a²/π` (a cylinder longer than the box).
    Bound,
    /// The method gave up (limit, stagnation); the message, and for the relaxer the deepest
    /// remaining intersection in `ℓ`.
    GaveUp {
        /// The error.
        message: String,
        /// Deepest remaining intersection (relaxer only).
        max_depth: Option<f64>,
    },
    /// A packing the independent check rejected (a bug; the tables show it).
    Rejected(String),
}

/// A generation that produced a packing the independent check accepts.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Generated {
    /// Wall seconds of the generation (not of the check).
    pub seconds: f64,
    /// CPU seconds of the generating thread (an RSA run under `SHORT_RUN`: the mean of
    /// repeated runs of its seed, see [`generate`]): on a shared machine the wall clock also counts
    /// the time the thread waited for a core, which the paper's dedicated machine did not.
    pub cpu_seconds: f64,
    /// Smallest surface gap between two bodies found by the check (box units).
    pub min_gap: Option<f64>,
}

/// CPU seconds below which an RSA run is timed as the mean of repeated runs of its seed.
const SHORT_RUN: f64 = 1e-3;

/// One generation by `method` (`"rsa"` or `"md"`) with seed `seed`, limited to `limit`
/// wall seconds; `order` is the RSA placement order (the relaxer's random start uses it too),
/// `settings` tune the relaxer (ignored by RSA).
pub fn generate(
    method: &str,
    spec: &MixtureSpec,
    order: GenerationOrder,
    seed: u64,
    limit: f64,
    settings: &RelaxSettings,
) -> Result<Generated, GenerationFailure> {
    spec.validate().map_err(|_| GenerationFailure::Bound)?;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let boundary = spec.boundary();
    let sizes = spec.sizes(order);
    // The paper's protocol for RSA: relaunch until the time limit. A start is abandoned
    // when a body is proven jammed (no free centre) or after 10⁶ uniform draws of one body.
    let limits = RsaLimits {
        time_limit: Some(Duration::from_secs_f64(limit)),
        max_attempts_per_body: 1_000_000,
        max_restarts: u32::MAX,
    };
    let start = Instant::now();
    let cpu_start = cpu_time::ThreadTime::now();
    let rve = if method == "rsa" {
        rsa_mixture(&boundary, &sizes, &limits, None, &mut rng)
            .map_err(|e| GenerationFailure::GaveUp {
                message: e.to_string(),
                max_depth: None,
            })?
            .rve
    } else {
        let mut rve = random_rve(&boundary, &sizes, &mut rng);
        let settings = RelaxSettings {
            time_limit: Some(Duration::from_secs_f64(limit)),
            ..*settings
        };
        relax(&mut rve, &settings, None).map_err(|e| GenerationFailure::GaveUp {
            message: e.to_string(),
            max_depth: match e {
                RelaxError::GaveUp(f) => Some(f.max_depth),
                RelaxError::Cancelled => None,
            },
        })?;
        rve
    };
    let seconds = start.elapsed().as_secs_f64();
    let mut cpu_seconds = cpu_start.elapsed().as_secs_f64();
    if method == "rsa" && cpu_seconds < SHORT_RUN {
        // A run this short is as long as the clock reads and the cold caches of its first
        // call: repeat the same seed (the same packing, no limit strikes) until the batch
        // lasts about ten times SHORT_RUN and report the mean.
        let repeats = ((10.0 * SHORT_RUN / cpu_seconds.max(1e-7)) as u32).clamp(1, 1000);
        let batch = cpu_time::ThreadTime::now();
        for _ in 0..repeats {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
            std::hint::black_box(rsa_mixture(&boundary, &sizes, &limits, None, &mut rng).is_ok());
        }
        cpu_seconds = batch.elapsed().as_secs_f64() / f64::from(repeats);
    }
    let packing =
        densepack::run::mixture_packing(&rve, seed, seconds, method, serde_json::Map::new());
    let v = verify(&packing);
    if !v.ok() {
        return Err(GenerationFailure::Rejected(format!("{:?}", v.violations)));
    }
    Ok(Generated {
        seconds,
        cpu_seconds,
        min_gap: v.min_pair_gap,
    })
}

/// Which cells of the paper's tables [`paper_tables`] runs.
#[derive(Clone, Debug)]
pub struct TablesConfig {
    /// `"rsa"`, `"md"` or both.
    pub methods: Vec<String>,
    /// Bodies of each kind: 10, 20, 30, 40, 50 (one table each).
    pub counts: Vec<usize>,
    /// Runs per cell.
    pub runs: usize,
    /// Wall seconds per run.
    pub limit: f64,
    /// Only these `(f_s, f_c)` cells (`None`: all the paper has).
    pub cells: Option<Vec<(f64, f64)>>,
    /// Report the CPU time of the generating thread instead of the wall time.
    pub cpu: bool,
}

/// The paper's tables for `config`: markdown matrices (paper s / densepack mean s), a summary
/// of the speed-ups, the long-format CSV and a log-log plot of densepack's time against the
/// paper's.
pub fn paper_tables(config: &TablesConfig) -> StudyOutput {
    let mut csv = Table::new(
        "mixture tables",
        "",
        &[
            "method",
            "bodies of each kind",
            "aspect ratio",
            "f_s",
            "f_c",
            "paper s",
            "densepack mean s",
            "runs",
            "failed runs",
            "speed-up",
        ],
    );
    let mut summary = Table::new(
        "Speed-up over the paper, per table",
        &format!(
            "Speed-up = paper mean time (C++, i7-960 @ 3.2 GHz, 20 runs) / densepack mean {} time \
             over the runs that produced a packing accepted by the independent check, in the \
             cells where both have a number; {} run(s) per cell, {} s per run, cylinders-first \
             order, periodic unit cube, a different Xoshiro256++ seed per run (CPU: an RSA run \
             under 1 ms is timed as the mean of up to 1000 repeats of its seed). `bound`: \
             refused, N_cyl < 4 f_c a²/π.",
            if config.cpu { "CPU" } else { "wall" },
            config.runs,
            config.limit
        ),
        &[
            "table",
            "cells",
            "refused (bound)",
            "cells without a packing",
            "failed runs",
            "speed-up min",
            "median",
            "max",
        ],
    );
    let mut matrices = String::new();
    let mut series = Vec::new();
    for method in &config.methods {
        let mut points = Vec::new();
        for &n in &config.counts {
            for (ai, a) in [3.0, 5.0].into_iter().enumerate() {
                let (text, stats) = run_table(method, n, ai, a, config, &mut csv, &mut points);
                matrices += &text;
                summary.row(stats);
            }
        }
        series.push(Series::points(method.to_uppercase(), points));
    }
    let diagonal_ends = csv
        .rows
        .iter()
        .filter_map(|r| r[5].parse::<f64>().ok())
        .fold((f64::INFINITY, 0.0f64), |(lo, hi), p| {
            (lo.min(p), hi.max(p))
        });
    let mut figure = Figure::new(
        "Sphere + cylinder RVEs: densepack against the paper",
        "paper mean time (s)",
        "densepack mean time (s)",
    )
    .log(true, true);
    figure.series = series;
    if diagonal_ends.0 < diagonal_ends.1 {
        figure = figure.with(Series::line(
            "equal time",
            vec![
                (diagonal_ends.0, diagonal_ends.0),
                (diagonal_ends.1, diagonal_ends.1),
            ],
        ));
    }
    StudyOutput {
        markdown: summary.markdown() + &matrices,
        csv,
        figure,
    }
}

/// One table of the paper (method, `n`, aspect `a`): its markdown matrix and summary row;
/// cells go to `csv` and `(paper, densepack)` times to `points`.
fn run_table(
    method: &str,
    n: usize,
    ai: usize,
    a: f64,
    config: &TablesConfig,
    csv: &mut Table,
    points: &mut Vec<(f64, f64)>,
) -> (String, Vec<String>) {
    let cols: &[f64] = if method == "rsa" {
        &[0.05, 0.1, 0.15, 0.2, 0.25, 0.3]
    } else {
        &[0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45]
    };
    let roman = ["II", "III", "IV", "V", "VI", "VII", "VIII", "IX", "X", "XI"];
    let table = roman[(n / 10 - 1) + if method == "md" { 5 } else { 0 }];
    let name = format!(
        "{} {n} spheres + {n} cylinders, a = {a}",
        method.to_uppercase()
    );
    let mut s = format!(
        "\n### {name} (paper Table {table})\n\n\
         Cell: paper s / densepack mean {clock} s (runs that failed: `k✗`); `bound`: \
         N_cyl < 4 f_c a²/π.\n\n| f_s \\ f_c |",
        clock = if config.cpu { "CPU" } else { "wall" }
    );
    for c in cols {
        s += &format!(" {c} |");
    }
    s += "\n|---|";
    for _ in cols {
        s += "---|";
    }
    s += "\n";
    let (mut cells, mut bound_cells, mut empty_cells, mut failed_runs) = (0, 0, 0, 0);
    let mut speedups = Vec::new();
    for (ri, &fs) in cols.iter().enumerate() {
        let mut row = format!("| {fs} |");
        let mut any = false;
        for (ci, &fc) in cols.iter().enumerate() {
            let paper = paper_time(method, n, ri, ci, ai);
            let in_paper = paper_time(method, n, ri, ci, 0).is_some();
            let selected = config.cells.as_ref().is_none_or(|c| {
                c.iter()
                    .any(|&(s, f)| (s - fs).abs() < 1e-9 && (f - fc).abs() < 1e-9)
            });
            if !in_paper || !selected {
                row.push_str(" |");
                continue;
            }
            any = true;
            cells += 1;
            let spec = unit_cube(n, n, a, fs, fc);
            let mut times = Vec::new();
            let mut failed = 0;
            let mut bound = false;
            for run in 0..config.runs {
                let seed = 1_000_003 * n as u64
                    + 10_007 * (ri * 16 + ci) as u64
                    + 101 * ai as u64
                    + run as u64;
                match generate(
                    method,
                    &spec,
                    GenerationOrder::CylindersFirst,
                    seed,
                    config.limit,
                    &RelaxSettings::default(),
                ) {
                    Ok(g) => times.push(if config.cpu { g.cpu_seconds } else { g.seconds }),
                    Err(GenerationFailure::Bound) => {
                        bound = true;
                        break;
                    }
                    Err(_) => failed += 1,
                }
            }
            failed_runs += failed;
            let mean = (!times.is_empty()).then(|| times.iter().sum::<f64>() / times.len() as f64);
            let ours = if bound {
                bound_cells += 1;
                "bound".to_string()
            } else if let Some(m) = mean {
                format!("{m:.2e}")
            } else {
                empty_cells += 1;
                "none".to_string()
            };
            let speedup = match (paper, mean) {
                (Some(p), Some(m)) if !bound => {
                    speedups.push(p / m);
                    points.push((p, m));
                    format!("{:.2}", p / m)
                }
                _ => String::new(),
            };
            csv.row(vec![
                method.into(),
                n.to_string(),
                format!("{a}"),
                format!("{fs}"),
                format!("{fc}"),
                paper.map_or(String::new(), |p| format!("{p}")),
                if bound {
                    "bound".into()
                } else {
                    mean.map_or(String::new(), |m| format!("{m:.4e}"))
                },
                config.runs.to_string(),
                failed.to_string(),
                speedup,
            ]);
            let fail = if failed > 0 {
                format!(" {failed}✗")
            } else {
                String::new()
            };
            row += &format!(
                " {} / {ours}{fail} |",
                paper.map_or("–".into(), |p| format!("{p}"))
            );
            eprint!(".");
        }
        if any {
            s += &row;
            s += "\n";
        }
    }
    eprintln!();
    let lo = speedups.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = speedups.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let x = |v: f64| {
        if v.is_finite() {
            format!("{v:.1}×")
        } else {
            "–".into()
        }
    };
    let stats = vec![
        format!("{name} (Table {table})"),
        cells.to_string(),
        bound_cells.to_string(),
        empty_cells.to_string(),
        failed_runs.to_string(),
        x(lo),
        x(median(speedups)),
        x(hi),
    ];
    (s, stats)
}

/// The paper's tables: quick = the 10 + 10 tables, one run per cell, 1 s per run; full = all
/// five sizes, 3 runs per cell, 5 s per run (about 15 minutes).
pub fn tables(ctx: &StudyContext) -> StudyOutput {
    let config = if ctx.quick {
        TablesConfig {
            methods: vec!["rsa".into(), "md".into()],
            counts: vec![10],
            runs: 1,
            limit: 1.0,
            cells: None,
            cpu: true,
        }
    } else {
        TablesConfig {
            methods: vec!["rsa".into(), "md".into()],
            counts: vec![10, 20, 30, 40, 50],
            runs: 3,
            limit: 5.0,
            cells: None,
            cpu: true,
        }
    };
    paper_tables(&config)
}

/// The relaxer's time step `Δt` and force rescaling (the doublings of the prefactor `κ` up to
/// `max_prefactor`) against wall time and residual overlap.
pub fn relaxer(ctx: &StudyContext) -> StudyOutput {
    let (n, a, fs, fc, seeds, limit) = if ctx.quick {
        (10, 3.0, 0.2, 0.25, 3, 2.0)
    } else {
        (30, 5.0, 0.15, 0.30, 8, 10.0)
    };
    let spec = unit_cube(n, n, a, fs, fc);
    let defaults = RelaxSettings::default();
    let mut table = Table::new(
        "relaxer: time step and force rescaling",
        &format!(
            "{n} spheres + {n} cylinders, a = {a}, f_s = {fs}, f_c = {fc}, periodic unit cube, \
             random start, seeds 1…{seeds}, {limit} s per run; one parameter varied, the \
             others at their defaults (Δt = {}, κ₀ = {}, max κ = {}; max κ = κ₀ means no \
             rescaling). Residual overlap: the deepest intersection (ℓ = smallest body \
             dimension) left by the failed runs, 0 when every run succeeded; every success is \
             accepted by the independent check, whose smallest gap is listed (≥ 0).",
            defaults.time_step, defaults.initial_prefactor, defaults.max_prefactor
        ),
        &[
            "parameter",
            "value",
            "runs",
            "failed",
            "median s (successes)",
            "spread",
            "deepest residual overlap ℓ",
            "smallest verified gap",
        ],
    );
    let mut settings: Vec<(&str, f64, RelaxSettings)> = Vec::new();
    for dt in [0.025, 0.05, 0.1, 0.2, 0.4] {
        settings.push((
            "time_step",
            dt,
            RelaxSettings {
                time_step: dt,
                ..defaults
            },
        ));
    }
    for max in [defaults.initial_prefactor, 1.0, 4.0, 16.0] {
        settings.push((
            "max_prefactor",
            max,
            RelaxSettings {
                max_prefactor: max,
                ..defaults
            },
        ));
    }
    let mut series: Vec<Series> = Vec::new();
    let mut all = Vec::new();
    let mut best: Option<(&str, f64, f64)> = None;
    for (parameter, value, s) in settings {
        let mut times = Vec::new();
        let mut failed = 0;
        let mut depth = 0.0f64;
        let mut gap = f64::INFINITY;
        let mut rejected = Vec::new();
        for seed in 1..=seeds {
            match generate(
                "md",
                &spec,
                GenerationOrder::CylindersFirst,
                seed,
                limit,
                &s,
            ) {
                Ok(g) => {
                    times.push(g.seconds);
                    gap = gap.min(g.min_gap.unwrap_or(f64::INFINITY));
                }
                Err(GenerationFailure::GaveUp { max_depth, .. }) => {
                    failed += 1;
                    depth = depth.max(max_depth.unwrap_or(f64::NAN));
                }
                Err(GenerationFailure::Rejected(e)) => {
                    failed += 1;
                    rejected.push(e);
                }
                Err(GenerationFailure::Bound) => unreachable!("the study's spec is valid"),
            }
        }
        eprintln!(
            "relaxer {parameter} = {value}: {} ok, {failed} failed",
            times.len()
        );
        let t = median(times.clone());
        table.row(vec![
            parameter.into(),
            format!("{value}"),
            seeds.to_string(),
            if rejected.is_empty() {
                failed.to_string()
            } else {
                format!("{failed} (rejected by the check: {})", rejected.join("; "))
            },
            format!("{t:.4}"),
            format!("{:.2}", super::spread(&times)),
            format!("{depth:.3e}"),
            if gap.is_finite() {
                format!("{gap:.3e}")
            } else {
                "–".into()
            },
        ]);
        // Error axis: failed fraction (a failed run leaves an overlap); time: median of
        // successes, or the limit when none succeeded.
        let point = (
            if t.is_finite() { t } else { limit },
            failed as f64 / seeds as f64,
        );
        all.push(point);
        let is_default = match parameter {
            "time_step" => value == defaults.time_step,
            _ => value == defaults.max_prefactor,
        };
        series.push(Series::points(
            format!(
                "{parameter} {value}{}",
                if is_default { " (default)" } else { "" }
            ),
            vec![point],
        ));
        if failed == 0 && best.is_none_or(|(_, _, bt)| t < bt) {
            best = Some((parameter, value, t));
        }
    }
    let mut figure = Figure::new(
        format!("Relaxer, {n}+{n} bodies, a = {a}: time against failures"),
        "median wall seconds (successes)",
        "fraction of failed runs",
    )
    .log(true, false);
    figure.series = series;
    figure = figure.with(Series::pareto_front("Pareto front", &all));
    let verdict = best.map_or("Every setting had a failed run.".to_owned(), |(p, v, t)| {
        format!(
            "Fastest setting without a failed run here: {p} = {v} ({t:.4} s median). The \
                 defaults are Δt = {}, max κ = {}; one case does not show \
                 that a faster setting stays reliable at other fractions.",
            defaults.time_step, defaults.max_prefactor
        )
    });
    StudyOutput {
        markdown: table.markdown() + &verdict + "\n\n",
        csv: table,
        figure,
    }
}

/// The paper's RVE: `ns` spheres and `nc` cylinders of aspect ratio `a` at fractions `fs`, `fc`
/// in the periodic unit cube; a kind with fraction 0 has no bodies.
fn unit_cube(ns: usize, nc: usize, a: f64, fs: f64, fc: f64) -> MixtureSpec {
    MixtureSpec {
        sphere_fraction: fs,
        cylinder_fraction: fc,
        spheres: if fs > 0.0 { ns } else { 0 },
        cylinders: if fc > 0.0 { nc } else { 0 },
        aspect_ratio: a,
        box_size: 1.0,
    }
}

/// `k·step` for `k = from/step … to/step`, rounded to 10⁻⁹ (fractions printed as typed).
fn steps(from: f64, to: f64, step: f64) -> Vec<f64> {
    let (lo, hi) = ((from / step).round() as i64, (to / step).round() as i64);
    (lo..=hi)
        .map(|k| (k as f64 * step * 1e9).round() / 1e9)
        .collect()
}

/// One curve of paper 000's timing figures: a method and placement order, and the RVE at each
/// abscissa.
struct Curve {
    label: String,
    method: &'static str,
    order: GenerationOrder,
    points: Vec<(f64, MixtureSpec)>,
    /// The abscissae are rising total fractions: stop after the first point where no run gave
    /// a packing (a harder point would only spend `runs × limit`).
    stop_at_failure: bool,
}

/// A timing figure of paper 000: its curves, the runs per point and the wall-second limit per
/// run of each method.
struct TimingFigure {
    title: &'static str,
    caption: String,
    x_name: &'static str,
    curves: Vec<Curve>,
    runs: u64,
    rsa_limit: f64,
    md_limit: f64,
}

/// Runs a timing figure: per point the runs that gave a packing the independent check
/// accepts and their mean CPU seconds (seeds shared by all curves at a point, so curves are
/// compared on the same draws), per curve the largest abscissa where every run, and where half
/// the runs, gave a packing; a log-y figure of the mean CPU seconds.
fn timing_figure(study: TimingFigure) -> StudyOutput {
    let mut table = Table::new(
        study.title,
        &study.caption,
        &[
            "curve",
            study.x_name,
            "f_s",
            "f_c",
            "runs",
            "packings",
            "mean CPU s",
            "median CPU s",
            "gap bound",
        ],
    );
    let mut summary = Table::new(
        &format!("{}: reach", study.title),
        "Largest abscissa at which every run, and at least half the runs, gave a packing; mean \
         CPU seconds at the first point of each curve.",
        &[
            "curve",
            "all runs packed up to",
            "half the runs up to",
            "mean CPU s at the first point",
        ],
    );
    let mut figure =
        Figure::new(study.title, study.x_name, "mean CPU s per packing").log(false, true);
    for curve in &study.curves {
        let limit = if curve.method == "rsa" {
            study.rsa_limit
        } else {
            study.md_limit
        };
        let (mut all_up_to, mut half_up_to, mut first) = (None, None, None);
        let mut points = Vec::new();
        for (index, (x, spec)) in curve.points.iter().enumerate() {
            let mut times = Vec::new();
            let mut gap = f64::INFINITY;
            let mut problems = Vec::new();
            for run in 0..study.runs {
                let seed = 7_000_000 + 10_000 * index as u64 + run;
                match generate(
                    curve.method,
                    spec,
                    curve.order,
                    seed,
                    limit,
                    &RelaxSettings::default(),
                ) {
                    Ok(g) => {
                        times.push(g.cpu_seconds);
                        gap = gap.min(g.min_gap.unwrap_or(f64::INFINITY));
                    }
                    Err(GenerationFailure::GaveUp { .. }) => {}
                    Err(GenerationFailure::Bound) => problems.push("bound".to_string()),
                    Err(GenerationFailure::Rejected(e)) => problems.push(format!("rejected: {e}")),
                }
            }
            eprintln!(
                "-- {}: {} = {x}: {}/{} packed",
                curve.label,
                study.x_name,
                times.len(),
                study.runs
            );
            let packed = times.len() as u64;
            let mean = (packed > 0).then(|| times.iter().sum::<f64>() / packed as f64);
            if packed == study.runs {
                all_up_to = Some(*x);
            }
            if 2 * packed >= study.runs {
                half_up_to = Some(*x);
            }
            if index == 0 {
                first = mean;
            }
            if let Some(m) = mean {
                points.push((*x, m));
            }
            table.row(vec![
                curve.label.clone(),
                format!("{x}"),
                format!("{}", spec.sphere_fraction),
                format!("{}", spec.cylinder_fraction),
                study.runs.to_string(),
                if problems.is_empty() {
                    packed.to_string()
                } else {
                    format!("{packed} ({})", problems.join("; "))
                },
                mean.map_or("–".into(), |m| format!("{m:.3e}")),
                if packed > 0 {
                    format!("{:.3e}", median(times))
                } else {
                    "–".into()
                },
                if gap.is_finite() {
                    format!("{gap:.2e}")
                } else {
                    "–".into()
                },
            ]);
            if packed == 0 && curve.stop_at_failure {
                break;
            }
        }
        let up_to = |v: Option<f64>| v.map_or("–".into(), |x| format!("{x}"));
        summary.row(vec![
            curve.label.clone(),
            up_to(all_up_to),
            up_to(half_up_to),
            first.map_or("–".into(), |m| format!("{m:.3e}")),
        ]);
        figure = figure.with(Series::points(curve.label.clone(), points));
    }
    StudyOutput {
        markdown: format!("{}\n{}", summary.markdown(), table.markdown()),
        csv: table,
        figure,
    }
}

/// Runs per point and wall-second limits (RSA, MD) of the timing figures: the paper's 20 runs.
fn figure_budget(ctx: &StudyContext) -> (u64, f64, f64) {
    if ctx.quick {
        (2, 0.5, 1.0)
    } else {
        (20, 1.0, 3.0)
    }
}

const FIGURE_PROTOCOL: &str = "Periodic unit cube, 30 spheres and 30 cylinders of aspect ratio \
    a = 5 (a kind with no volume has no bodies), as in the paper's Fig. 4 (its Figs. 7–11 do \
    not state the counts). A run that gives up (RSA: a body rejected 10⁶ times, restarts until \
    the limit; MD: the relaxer's limit) is not a packing; every packing counted passed the \
    independent check; gap bound: the check's lower bound of the smallest surface gap (from \
    its separating planes; a negative bound, within its tolerance of 10⁻⁹ of the radii, is a \
    pair it cannot tell from touching, which the paper allows). Mean CPU seconds of the \
    generating thread over the packings (an RSA run under 1 ms: the mean of repeats of its \
    seed); the same seeds for every curve at a point.";

/// Paper 000, Fig. 4: RSA time against the total fraction (split equally) for the three
/// placement orders. The paper: cylinders first is faster at low fractions, spheres first
/// reaches higher ones.
pub fn order(ctx: &StudyContext) -> StudyOutput {
    let (runs, rsa_limit, md_limit) = figure_budget(ctx);
    let totals = if ctx.quick {
        vec![0.1, 0.3]
    } else {
        steps(0.02, 0.6, 0.02)
    };
    let orders = [
        ("cylinders first", GenerationOrder::CylindersFirst),
        ("spheres first", GenerationOrder::SpheresFirst),
        ("interleaved", GenerationOrder::Interleaved),
    ];
    timing_figure(TimingFigure {
        title: "paper 000, Fig. 4: RSA time against the fraction, by placement order",
        caption: format!(
            "{FIGURE_PROTOCOL} f_s = f_c = φ/2; {runs} runs per point, {rsa_limit} s per run; a \
             curve stops after its first point without a packing."
        ),
        x_name: "total fraction φ",
        curves: orders
            .iter()
            .map(|&(label, order)| Curve {
                label: label.into(),
                method: "rsa",
                order,
                points: totals
                    .iter()
                    .map(|&t| (t, unit_cube(30, 30, 5.0, t / 2.0, t / 2.0)))
                    .collect(),
                stop_at_failure: true,
            })
            .collect(),
        runs,
        rsa_limit,
        md_limit,
    })
}

/// Paper 000, Figs. 7–8: time against the sphere share of a fixed total, RSA at 0.3 and the
/// relaxer (MD) at 0.5. The paper: cylinders are the harder kind for MD, and for RSA at a high
/// cylinder share.
pub fn split(ctx: &StudyContext) -> StudyOutput {
    let (runs, rsa_limit, md_limit) = figure_budget(ctx);
    let curve = |method: &'static str, total: f64, step: f64| {
        let shares = if ctx.quick {
            vec![0.0, total / 2.0]
        } else {
            steps(0.0, total, step)
        };
        Curve {
            label: format!("{} at φ = {total}", method.to_uppercase()),
            method,
            order: GenerationOrder::CylindersFirst,
            points: shares
                .iter()
                .map(|&fs| {
                    let fc = ((total - fs) * 1e9).round() / 1e9;
                    (fs, unit_cube(30, 30, 5.0, fs, fc))
                })
                .collect(),
            stop_at_failure: false,
        }
    };
    timing_figure(TimingFigure {
        title: "paper 000, Figs. 7–8: time against the sphere share of a fixed total",
        caption: format!(
            "{FIGURE_PROTOCOL} RSA (cylinders first) at f_s + f_c = 0.3, the relaxer at 0.5; \
             f_s in steps of 0.025 and 0.05 (the paper: 0.01); {runs} runs per point, {rsa_limit} \
             s (RSA) and {md_limit} s (MD) per run."
        ),
        x_name: "sphere fraction f_s",
        curves: vec![curve("rsa", 0.3, 0.025), curve("md", 0.5, 0.05)],
        runs,
        rsa_limit,
        md_limit,
    })
}

/// Paper 000, Figs. 9–11: time against the total fraction for cylinders only, both kinds
/// (equal shares) and spheres only, RSA and MD. The paper: RSA is faster at low fractions,
/// MD reaches the higher ones.
pub fn fraction(ctx: &StudyContext) -> StudyOutput {
    let (runs, rsa_limit, md_limit) = figure_budget(ctx);
    let totals = if ctx.quick {
        vec![0.1, 0.2]
    } else {
        steps(0.05, 0.6, 0.05)
    };
    // (composition, the spheres' share of the total)
    let kinds = [
        ("cylinders only (Fig. 9)", 0.0),
        ("both, equal shares (Fig. 10)", 0.5),
        ("spheres only (Fig. 11)", 1.0),
    ];
    let mut curves = Vec::new();
    for (kind, sphere_share) in kinds {
        for method in ["rsa", "md"] {
            curves.push(Curve {
                label: format!("{}, {kind}", method.to_uppercase()),
                method,
                order: GenerationOrder::CylindersFirst,
                points: totals
                    .iter()
                    .map(|&t| {
                        let fs = sphere_share * t;
                        (t, unit_cube(30, 30, 5.0, fs, t - fs))
                    })
                    .collect(),
                stop_at_failure: true,
            });
        }
    }
    timing_figure(TimingFigure {
        title: "paper 000, Figs. 9–11: time against the total fraction, RSA and MD",
        caption: format!(
            "{FIGURE_PROTOCOL} φ in steps of 0.05 (the paper: 0.01); {runs} runs per point, \
             {rsa_limit} s (RSA, cylinders first) and {md_limit} s (MD) per run; a curve stops \
             after its first point without a packing."
        ),
        x_name: "total fraction φ",
        curves,
        runs,
        rsa_limit,
        md_limit,
    })
}
