//! Progress of a run on stderr: a live line when stderr is a terminal (indicatif), one JSON
//! object per line with `--log-json`, nothing with `--quiet`. Data goes to stdout only.

use densepack::kernel::{Progress, StageReport};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
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
}

impl Reporter {
    /// A reporter for `--quiet` / `--log-json` / the default (a live line on a terminal).
    pub fn new(quiet: bool, log_json: bool) -> Self {
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
        }
    }

    /// Called at every time barrier; reports at most every [`TICK`].
    pub fn progress(&mut self, stage: usize, p: &Progress) {
        if matches!(self.sink, Sink::Quiet | Sink::Plain) {
            return;
        }
        let now = Instant::now();
        if self.last_tick.is_some_and(|t| now - t < TICK) {
            return;
        }
        self.last_tick = Some(now);
        let rate = p.counts.events as f64 / p.wall_seconds.max(1e-9);
        // Simulated time advances roughly linearly in wall time within a stage.
        let eta = p
            .goal_time
            .filter(|_| p.stage_time > 0.0)
            .map(|goal| (goal - p.stage_time).max(0.0) * p.wall_seconds / p.stage_time);
        match &self.sink {
            Sink::Json => eprintln!(
                "{}",
                serde_json::json!({
                    "type": "progress",
                    "stage": stage,
                    "wall_seconds": p.wall_seconds,
                    "stage_time": p.stage_time,
                    "packing_fraction": p.packing_fraction,
                    "reduced_pressure": finite(p.reduced_pressure),
                    "events": p.counts.events,
                    "collisions": p.counts.collisions,
                    "events_per_second": rate,
                    "eta_seconds": eta,
                })
            ),
            Sink::Bar(bar) => bar.set_message(format!(
                "stage {stage}: φ {:.5}  Z {:.3e}  {:.2} M events/s{}",
                p.packing_fraction,
                p.reduced_pressure,
                rate / 1e6,
                eta.map_or(String::new(), |s| format!("  ETA {s:.0} s"))
            )),
            Sink::Quiet | Sink::Plain => {}
        }
    }

    /// Called when a stage ends.
    pub fn stage_done(&mut self, k: usize, r: &StageReport) {
        let line = format!(
            "stage {k}: {} after {} events ({} collisions) in {:.2} s, φ = {:.6}, Z = {:.4e}",
            r.stop_reason.as_str(),
            r.counts.events,
            r.counts.collisions,
            r.wall_seconds,
            r.packing_fraction,
            r.reduced_pressure
        );
        match &self.sink {
            Sink::Quiet => {}
            Sink::Json => eprintln!(
                "{}",
                serde_json::json!({"type": "stage", "stage": k, "report": r})
            ),
            Sink::Plain => eprintln!("{line}"),
            Sink::Bar(bar) => bar.println(line),
        }
    }

    /// Removes the live line.
    pub fn finish(&self) {
        if let Sink::Bar(bar) = &self.sink {
            bar.finish_and_clear();
        }
    }
}

/// JSON has no NaN or infinity: report those as null.
fn finite(x: f64) -> Option<f64> {
    x.is_finite().then_some(x)
}
