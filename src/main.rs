//! The `densepack` command line. Thin: parses, calls the library, prints.

#[macro_use]
mod cli;

use clap::{Parser, Subcommand};
use densepack::io::checkpoint::CheckpointFile;
use densepack::io::scene::{AnyScene, MixtureScene, Scene};
use densepack::kernel::{Progress, StageReport};
use densepack::run::{
    resume_run, CheckpointPlan, ProgressObserver as OnProgress, RunError, RunOptions, RunOutcome,
    StageObserver as OnStage,
};
use std::path::PathBuf;
use std::process::ExitCode;

/// The scene `densepack` runs without arguments.
const DEFAULT_SCENE: &str = include_str!("../examples/scenes/mono_periodic_jam.toml");

#[derive(Parser)]
#[command(
    name = "densepack",
    version,
    about = "Dense random packings of hard particles"
)]
struct Cli {
    #[command(subcommand)]
    command: Option<Command>,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene and write the packing (JSON).
    Run {
        /// Scene file (TOML); not with --resume.
        #[arg(required_unless_present = "resume", conflicts_with = "resume")]
        scene: Option<PathBuf>,
        /// Output packing file.
        #[arg(long)]
        out: PathBuf,
        /// Run the scene with this seed instead of its own (not with --resume).
        #[arg(long, conflicts_with = "resume")]
        seed: Option<u64>,
        /// Set a scene value, KEY=VALUE with a dotted key (particles.d_min=2.0,
        /// stage.0.rate=0.01; stages count from 0), checked like the file; repeatable
        /// (docs/scenes.md, "Overrides and seeds"). Not with --resume.
        #[arg(long = "set", value_name = "KEY=VALUE", conflicts_with = "resume")]
        set: Vec<String>,
        /// Print nothing but errors.
        #[arg(long)]
        quiet: bool,
        /// Write the packing JSON on one line, without pretty printing (113 instead of 181
        /// bytes per sphere, 255 instead of 408 per ellipsoid; the same fields, read the
        /// same way).
        #[arg(long)]
        compact: bool,
        /// Progress as one JSON object per line on stderr (about 4 a second, plus one per
        /// finished stage) instead of the live line.
        #[arg(long)]
        log_json: bool,
        /// Also write every progress record (one JSON line per time barrier, the records of
        /// --log-json with Δd in gap stages, and one per finished stage) to FILE when the run
        /// ends, also when it fails; `densepack plot convergence FILE` draws it. Sphere and
        /// ellipsoid scenes.
        #[arg(long, value_name = "FILE")]
        run_log: Option<PathBuf>,
        /// Write a checkpoint to FILE during the run (atomically, at a time barrier, every
        /// --checkpoint-every seconds); continue a killed run with --resume FILE. EDMD
        /// scenes (spheres and ellipsoids); not mixtures.
        #[arg(long, value_name = "FILE")]
        checkpoint: Option<PathBuf>,
        /// Wall-clock seconds between checkpoints.
        #[arg(long, value_name = "SECONDS", default_value_t = 600.0, value_parser = parse_seconds)]
        checkpoint_every: f64,
        /// Continue the run that wrote CHECKPOINT to the packing the uninterrupted run gives
        /// (same particles, bit for bit). Checkpoints go on into the same file unless
        /// --checkpoint names another.
        #[arg(long, value_name = "CHECKPOINT")]
        resume: Option<PathBuf>,
        /// Run even if the scene's memory estimate exceeds the memory available (the run
        /// may then abort in an allocation or be killed). The same as setting
        /// DENSEPACK_IGNORE_MEMORY_CHECK=1.
        #[arg(long)]
        ignore_memory_check: bool,
    },
    /// Run one scene for many seeds (threads), writing seed-<k>.json and summary.csv into
    /// a directory; a rerun skips the seeds done (docs/scenes.md, "Ensembles").
    Ensemble(cli::ensemble::EnsembleArgs),
    /// Check a packing for overlaps, gaps and containment, independently of the simulation.
    Verify {
        /// Packing file (JSON).
        packing: PathBuf,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
        /// Also compare the sieve curve of the spheres with this grading curve (a DIN name,
        /// fuller:Q:D_MAX or a TOML file with a `grading` table).
        #[arg(long)]
        grading: Option<String>,
        /// Cut-off diameter of the grading comparison (default: the smallest sphere).
        #[arg(long, requires = "grading")]
        d_min: Option<f64>,
        /// Relative tolerance of the overlap and gap tests, in [0, 0.01]: a pair overlaps when
        /// its centres are closer than (1 − TOL)·(r_i + r_j). Never taken from the file.
        #[arg(long, value_name = "TOL", default_value_t = densepack::verify::TOLERANCE,
              allow_hyphen_values = true, value_parser = parse_tolerance)]
        tolerance: f64,
    },
    /// Is a sphere packing jammed? Contacts against the gap cut-off, rattlers, the
    /// backbone's contact number, Q6 and a linear-programming certificate; then g(r), size
    /// classes and packing-fraction profiles along the walls.
    Analyse(cli::analyse::AnalyseArgs),
    /// Export a packing for meshing (Gmsh, Abaqus), visualisation (VTK), FFT (voxels, VTK
    /// image data), other codes (LAMMPS, PackingGeneration) or tables (CSV).
    Export(cli::export::ExportArgs),
    /// Import a packing from another tool (CSV, PackingGeneration .xyzd, LAMMPS data or dump,
    /// packing JSON) into a packing JSON that verify, export, plot and analyse read.
    Import(cli::import::ImportArgs),
    /// Dry run of the take phase: grading curve → expected particle count, φ_eff, memory;
    /// optionally the drawn diameters.
    Take(cli::take::TakeArgs),
    /// Write a commented sample scene.
    Init(cli::init::InitArgs),
    /// Draw an SVG figure: sieve curve, size histogram, section, or convergence of a run.
    Plot(cli::plot::PlotArgs),
    /// Run the macro benchmarks; write a report (BENCHMARKS.md), a CSV and an SVG plot per
    /// study into --out.
    Bench(cli::bench::BenchArgs),
    /// Internal: one memory measurement of `bench` in a fresh process (N QUEUE).
    #[command(name = "bench-child-memory", hide = true)]
    BenchChildMemory {
        /// N and the queue.
        args: Vec<String>,
    },
}

fn main() -> ExitCode {
    densepack::memory::map_large_blocks();
    let cli = Cli::parse();
    cli::out::finish(command(cli))
}

/// Runs the command line's command; the exit code.
fn command(cli: Cli) -> ExitCode {
    match cli.command {
        None => {
            outln!("densepack: running the embedded default scene (10 000 equal spheres, periodic, grown to reduced pressure 1e12)");
            let scene = AnyScene::Spheres(Box::new(
                Scene::from_toml(DEFAULT_SCENE).expect("the embedded scene is valid"),
            ));
            let start = |on_stage: &mut OnStage, on_progress: &mut OnProgress| {
                densepack::run::run(&scene, observed(None, on_stage, on_progress))
            };
            run(start, None, false, false, None)
        }
        Some(Command::Run {
            scene,
            out,
            seed,
            set,
            quiet,
            compact,
            log_json,
            run_log,
            checkpoint,
            checkpoint_every,
            resume,
            ignore_memory_check,
        }) => {
            // `parse_seconds` bounds it to what a Duration holds.
            let every = std::time::Duration::from_secs_f64(checkpoint_every);
            // Every output is checked before any work; a resumed run's checkpoints go on
            // into the file it resumes from unless --checkpoint names another.
            let mut outputs: Vec<cli::paths::Named> = vec![("--out", &out)];
            outputs.extend(checkpoint.as_deref().map(|c| ("--checkpoint", c)));
            outputs.extend(run_log.as_deref().map(|r| ("--run-log", r)));
            let mut inputs: Vec<cli::paths::Named> = Vec::new();
            inputs.extend(scene.as_deref().map(|s| ("scene", s)));
            if let Some(r) = resume.as_deref() {
                if checkpoint.is_none() {
                    outputs.push(("--resume", r));
                } else {
                    inputs.push(("--resume", r));
                }
            }
            if let Err(e) = cli::paths::check_outputs(&outputs, &inputs) {
                errln!("error: {e}");
                return ExitCode::from(2);
            }
            let memory_checked = !(ignore_memory_check || densepack::memory::overridden());
            if let Some(path) = resume {
                let file = match CheckpointFile::read(&path) {
                    Ok(f) => f,
                    Err(e) => {
                        errln!("error: {e}");
                        return ExitCode::from(2);
                    }
                };
                if memory_checked {
                    if let Ok(scene) = Scene::from_toml(&file.header.scene_toml) {
                        if let Err(code) = check_memory(scene.memory_estimate()) {
                            return code;
                        }
                    }
                }
                let plan = CheckpointPlan {
                    path: checkpoint.unwrap_or(path),
                    every,
                };
                let start = |on_stage: &mut OnStage, on_progress: &mut OnProgress| {
                    resume_run(&file, observed(Some(plan), on_stage, on_progress))
                };
                return run(start, Some((out, compact)), quiet, log_json, run_log);
            }
            let path = scene.expect("clap requires a scene without --resume");
            let scene = match cli::ensemble::load_scene(&path, seed, &set) {
                Ok(scene) => scene,
                Err(e) => {
                    errln!("error: {e}");
                    return ExitCode::from(2);
                }
            };
            if memory_checked {
                if let Err(code) = check_memory(scene.memory_estimate()) {
                    return code;
                }
            }
            match &scene {
                AnyScene::Spheres(_) => {
                    let plan = checkpoint.map(|path| CheckpointPlan { path, every });
                    let start = |on_stage: &mut OnStage, on_progress: &mut OnProgress| {
                        densepack::run::run(&scene, observed(plan, on_stage, on_progress))
                    };
                    run(start, Some((out, compact)), quiet, log_json, run_log)
                }
                AnyScene::Mixture(_) if run_log.is_some() => {
                    errln!(
                        "error: --run-log: mixture scenes (RSA or relaxation) have no time \
                         barriers to log"
                    );
                    ExitCode::from(2)
                }
                AnyScene::Mixture(_) if checkpoint.is_some() => {
                    errln!(
                        "error: --checkpoint: mixture scenes (RSA or relaxation, no time \
                         barriers) cannot be checkpointed"
                    );
                    ExitCode::from(2)
                }
                AnyScene::Mixture(m) => run_mixture(&scene, m, &out, compact, quiet),
            }
        }
        Some(Command::Ensemble(args)) => cli::ensemble::run(&args),
        Some(Command::Verify {
            packing,
            json,
            grading,
            d_min,
            tolerance,
        }) => cli::verify::run(&packing, json, grading.as_deref(), d_min, tolerance),
        Some(Command::Analyse(args)) => cli::analyse::run(&args),
        Some(Command::Export(args)) => cli::export::run(&args),
        Some(Command::Import(args)) => cli::import::run(&args),
        Some(Command::Take(args)) => cli::take::run(&args),
        Some(Command::Init(args)) => cli::init::run(&args),
        Some(Command::Plot(args)) => cli::plot::run(&args),
        Some(Command::Bench(args)) => cli::bench::run(&args),
        Some(Command::BenchChildMemory { args }) => cli::bench::child_memory(&args),
    }
}

/// A number of seconds in `[0, MAX_WALL_SECONDS]` (0: at every time barrier), the range
/// scene durations have: a `Duration` of more panics or overflows the clock.
fn parse_seconds(text: &str) -> Result<f64, String> {
    use densepack::io::scene::MAX_WALL_SECONDS;
    match text.parse::<f64>() {
        Ok(s) if s.is_finite() && (0.0..=MAX_WALL_SECONDS).contains(&s) => Ok(s),
        _ => Err(format!(
            "`{text}` is not a number of seconds in the allowed range [0, {MAX_WALL_SECONDS:e}]"
        )),
    }
}

/// Refuses (exit 2) a run whose memory estimate `(bytes, how)` exceeds the available
/// memory, before anything is allocated.
pub(crate) fn check_memory((needed, what): (u64, String)) -> Result<(), ExitCode> {
    let hint = format!(
        "--ignore-memory-check (or {}=1)",
        densepack::memory::OVERRIDE_ENV
    );
    densepack::memory::check(needed, what, &hint).map_err(|e| {
        errln!("error: the scene {e}");
        errln!("nothing written");
        ExitCode::from(2)
    })
}

/// A verification tolerance (see [`densepack::verify::VerifyOptions::check`]).
fn parse_tolerance(text: &str) -> Result<f64, String> {
    let tolerance = text
        .parse::<f64>()
        .map_err(|_| format!("`{text}` is not a number"))?;
    densepack::verify::VerifyOptions { tolerance }
        .check()
        .map(|()| tolerance)
}

/// Run options with these observers and checkpoints.
fn observed<'a>(
    checkpoints: Option<CheckpointPlan>,
    on_stage: &'a mut OnStage,
    on_progress: &'a mut OnProgress,
) -> RunOptions<'a> {
    RunOptions {
        checkpoints,
        on_stage: Some(on_stage),
        on_progress: Some(on_progress),
        ..RunOptions::default()
    }
}

/// Runs `start` (a fresh or resumed run) with the progress reporter, prints its summary and
/// writes the packing to `out` (path, compact).
fn run(
    start: impl FnOnce(&mut OnStage, &mut OnProgress) -> Result<RunOutcome, RunError>,
    out: Option<(PathBuf, bool)>,
    quiet: bool,
    log_json: bool,
    run_log: Option<PathBuf>,
) -> ExitCode {
    let reporter = std::cell::RefCell::new(cli::progress::Reporter::new(quiet, log_json, run_log));
    let result = start(
        &mut |k: usize, r: &StageReport| reporter.borrow_mut().stage_done(k, r),
        &mut |k: usize, p: &Progress| reporter.borrow_mut().progress(k, p),
    );
    let reporter = reporter.into_inner();
    // The log of a failed run is written too: it shows where the run got stuck.
    let logged = reporter.finish();
    if let Err(e) = &logged {
        errln!("error: {e}");
    }
    let code = match result {
        Ok(outcome) => {
            let s = &outcome.packing.stats;
            if !quiet {
                outln!(
                    "particles {}  packing_fraction {:.6}  reduced_pressure {:.4e}  events {}  collisions {}  \
                     wall {:.2} s  ({:.3} M events/s)  stop {}  overlap check: ok (min gap {:.3e} of contact)",
                    outcome.packing.particles.len(),
                    s.packing_fraction,
                    s.reduced_pressure.unwrap_or(f64::NAN),
                    s.events,
                    s.collisions,
                    s.wall_seconds,
                    s.events as f64 / s.wall_seconds.max(1e-12) / 1e6,
                    s.stop_reason,
                    outcome.verification.min_pair_gap_relative.unwrap_or(f64::NAN),
                );
                use densepack::kernel::StopReason;
                let judged = [StopReason::PressureReached, StopReason::CollectivelyJammed];
                if judged.iter().any(|r| s.stop_reason == r.as_str()) {
                    if let Some(line) = cli::analyse::run_summary(&outcome.packing) {
                        outln!("{line}");
                    }
                }
            }
            if let Some((path, compact)) = out {
                let written = if compact {
                    outcome.packing.write_compact(&path)
                } else {
                    outcome.packing.write(&path)
                };
                if let Err(e) = written {
                    errln!("error: {e}");
                    return ExitCode::from(1);
                }
                if !quiet {
                    outln!("wrote {}", path.display());
                }
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            errln!("error: {e}");
            match e {
                RunError::StageFailed { .. } => errln!("no packing written"),
                RunError::Checkpoint(_) | RunError::Start(_) => return ExitCode::from(2),
                _ => {}
            }
            ExitCode::from(1)
        }
    };
    if logged.is_err() && code == ExitCode::SUCCESS {
        return ExitCode::from(1);
    }
    code
}

/// Runs a sphere + cylinder mixture scene (`mixture` is `scene`'s) and writes the verified
/// packing.
fn run_mixture(
    scene: &AnyScene,
    mixture: &MixtureScene,
    out: &std::path::Path,
    compact: bool,
    quiet: bool,
) -> ExitCode {
    match densepack::run::run(scene, RunOptions::default()) {
        Ok(outcome) => {
            let s = &outcome.packing.stats;
            if !quiet {
                let fraction =
                    |k: &str| s.extra.get(k).and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
                outln!(
                    "bodies {}  f_s {:.6}  f_c {:.6}  total {:.6}  method {}  wall {:.3} s  \
                     overlap check: ok (min gap {:.3e})",
                    outcome.packing.particles.len(),
                    fraction("sphere_fraction"),
                    fraction("cylinder_fraction"),
                    s.packing_fraction,
                    mixture.mixture.method.as_str(),
                    s.wall_seconds,
                    outcome.verification.min_pair_gap.unwrap_or(f64::NAN),
                );
            }
            let written = if compact {
                outcome.packing.write_compact(out)
            } else {
                outcome.packing.write(out)
            };
            if let Err(e) = written {
                errln!("error: {e}");
                return ExitCode::from(1);
            }
            if !quiet {
                outln!("wrote {}", out.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            errln!("error: {e}");
            errln!("no packing written");
            ExitCode::from(1)
        }
    }
}
