//! Progress of a run on stderr: a live line when stderr is a terminal (indicatif), one JSON
//! object per line with `--log-json`, nothing with `--quiet`. Data goes to stdout only.
//!
//! `--run-log FILE` keeps the same JSON records, one per time barrier (not thinned to the
//! tick) and one per finished stage, and writes them to FILE atomically when the run ends
//! (also when it fails): the input of `densepack plot convergence`.

use densepack::kernel::{Progress, StageReport};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::time::{Duration, Instant};

/// Fewest seconds between two progress ticks.
const TICK: Duration = Duration::from_millis(250);

enum Sink {
    Quiet,
    Json,
    /// Stage summaries only (stderr is not a terminal).
    Plain,
    Bar(ProgressBar),
}

/// Reports a run's progress according to the command-line flags.
pub struct Reporter {
    sink: Sink,
    last_tick: Option<Instant>,
    run_log: Option<RunLog>,
}

/// The records of `--run-log`, kept in memory until the run ends (a few hundred bytes per
/// time barrier).
struct RunLog {
    path: PathBuf,
    lines: String,
}

impl RunLog {
    fn push(&mut self, record: &serde_json::Value) {
        self.lines += &record.to_string();
        self.lines.push('\n');
    }
}

/// Reduced pressure above which a run shows no ETA.
const ETA_PRESSURE_LIMIT: f64 = 100.0;

/// The JSON record of a progress tick (`--log-json`, `--run-log`): `{"type": "progress",
/// "stage", "wall_seconds", "stage_time", "packing_fraction", "reduced_pressure", "gap",
/// "events", "collisions", "events_per_second", "eta_seconds"}`; NaN and infinities are
/// written as null.
pub fn progress_record(stage: usize, p: &Progress) -> serde_json::Value {
    let rate = p.counts.events as f64 / p.wall_seconds.max(1e-9);
    // Simulated time advances roughly linearly in wall time within a stage, until the
    // particles approach jamming: then the collision rate diverges, and a packing fraction
    // or gap goal may lie beyond the jamming point, so no ETA is promised (an equilibrium
    // hard-sphere fluid stays below Z ≈ 40 up to its freezing point and beyond).
    let eta = p
        .goal_time
        .filter(|_| {
            p.stage_time > 0.0
                && (p.reduced_pressure.is_nan() || p.reduced_pressure <= ETA_PRESSURE_LIMIT)
        })
        .map(|goal| (goal - p.stage_time).max(0.0) * p.wall_seconds / p.stage_time);
    serde_json::json!({
        "type": "progress",
        "stage": stage,
        "wall_seconds": p.wall_seconds,
        "stage_time": p.stage_time,
        "packing_fraction": p.packing_fraction,
        "reduced_pressure": finite(p.reduced_pressure),
        "gap": p.gap,
        "events": p.counts.events,
        "collisions": p.counts.collisions,
        "events_per_second": rate,
        "eta_seconds": eta,
    })
}

/// The JSON record of a finished stage: `{"type": "stage", "stage", "report"}`.
pub fn stage_record(stage: usize, r: &StageReport) -> serde_json::Value {
    serde_json::json!({"type": "stage", "stage": stage, "report": r})
}

impl Reporter {
    /// A reporter for `--quiet` / `--log-json` / the default (a live line on a terminal),
    /// keeping every record for `--run-log` when `run_log` is given.
    pub fn new(quiet: bool, log_json: bool, run_log: Option<PathBuf>) -> Self {
        let sink = if log_json {
            Sink::Json
        } else if quiet {
            Sink::Quiet
        } else if std::io::stderr().is_terminal() {
            let bar = ProgressBar::new_spinner();
            bar.set_style(
                ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}")
                    .expect("a valid template"),
            );
            bar.enable_steady_tick(Duration::from_millis(200));
            Sink::Bar(bar)
        } else {
            Sink::Plain
        };
        Reporter {
            sink,
            last_tick: None,
            run_log: run_log.map(|path| RunLog {
                path,
                lines: String::new(),
            }),
        }
    }

    /// Called at every time barrier; reports at most every [`TICK`].
    pub fn progress(&mut self, stage: usize, p: &Progress) {
        if let Some(log) = &mut self.run_log {
            log.push(&progress_record(stage, p));
        }
        if matches!(self.sink, Sink::Quiet | Sink::Plain) {
            return;
        }
        let now = Instant::now();
        if self.last_tick.is_some_and(|t| now - t < TICK) {
            return;
        }
        self.last_tick = Some(now);
        match &self.sink {
            Sink::Json => errln!("{}", progress_record(stage, p)),
            Sink::Bar(bar) => {
                let record = progress_record(stage, p);
                let eta = record["eta_seconds"].as_f64();
                bar.set_message(format!(
                    "stage {stage}: φ {:.5}  Z {:.3e}{}  {:.2} M events/s{}",
                    p.packing_fraction,
                    p.reduced_pressure,
                    p.gap.map_or(String::new(), |g| format!("  Δd {g:.4e}")),
                    record["events_per_second"].as_f64().unwrap_or(0.0) / 1e6,
                    eta.map_or(String::new(), |s| format!("  ETA {s:.0} s"))
                ))
            }
            Sink::Quiet | Sink::Plain => {}
        }
    }

    /// Called when a stage ends.
    pub fn stage_done(&mut self, k: usize, r: &StageReport) {
        let line = format!("stage {k}: {}", r.summary());
        if let Some(log) = &mut self.run_log {
            log.push(&stage_record(k, r));
        }
        match &self.sink {
            Sink::Quiet => {}
            Sink::Json => errln!("{}", stage_record(k, r)),
            Sink::Plain => errln!("{line}"),
            Sink::Bar(bar) => bar.println(line),
        }
    }

    /// Removes the live line and writes the run log (atomically), if one was asked for.
    pub fn finish(&self) -> Result<(), String> {
        if let Sink::Bar(bar) = &self.sink {
            bar.finish_and_clear();
        }
        match &self.run_log {
            None => Ok(()),
            Some(log) => densepack::io::packing::write_atomically(&log.path, |w| {
                std::io::Write::write_all(w, log.lines.as_bytes())
            })
            .map_err(|e| format!("--run-log {}: {e}", log.path.display())),
        }
    }
}

/// JSON has no NaN or infinity: report those as null.
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}
