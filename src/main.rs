//! The `densepack` command line. Thin: parses, calls the library, prints.

mod cli;

use clap::{Parser, Subcommand};
use densepack::io::checkpoint::CheckpointFile;
use densepack::io::scene::{AnyScene, MixtureScene, Scene};
use densepack::kernel::{Progress, StageReport};
use densepack::run::{
    resume_run, run_mixture as run_mixture_scene, run_scene_checkpointed, run_scene_observed,
    CheckpointPlan, RunError, RunOutcome,
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
        /// Print nothing but errors.
        #[arg(long)]
        quiet: bool,
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
    },
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
    /// Export a packing for meshing (Gmsh), visualisation (VTK), FFT (voxels) or tables (CSV).
    Export(cli::export::ExportArgs),
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
    let cli = Cli::parse();
    match cli.command {
        None => {
            println!("densepack: running the embedded default scene (10 000 equal spheres, periodic, grown to jamming)");
            let scene = Scene::from_toml(DEFAULT_SCENE).expect("the embedded scene is valid");
            let start = |on_stage: &mut OnStage, on_progress: &mut OnProgress| {
                run_scene_observed(&scene, on_stage, on_progress)
            };
            run(start, None, false, false, None)
        }
        Some(Command::Run {
            scene,
            out,
            quiet,
            log_json,
            run_log,
            checkpoint,
            checkpoint_every,
            resume,
        }) => {
            let every = std::time::Duration::from_secs_f64(checkpoint_every);
            if let Err(e) = check_output_path(&out) {
                eprintln!("error: --out {}: {e}", out.display());
                return ExitCode::from(2);
            }
            if let Some(Err(e)) = checkpoint.as_deref().map(check_output_path) {
                eprintln!("error: --checkpoint: {e}");
                return ExitCode::from(2);
            }
            if let Some(Err(e)) = run_log.as_deref().map(check_output_path) {
                eprintln!("error: --run-log: {e}");
                return ExitCode::from(2);
            }
            if let Some(path) = resume {
                let file = match CheckpointFile::read(&path) {
                    Ok(f) => f,
                    Err(e) => {
                        eprintln!("error: {e}");
                        return ExitCode::from(2);
                    }
                };
                let plan = CheckpointPlan {
                    path: checkpoint.unwrap_or(path),
                    every,
                };
                let start = |on_stage: &mut OnStage, on_progress: &mut OnProgress| {
                    resume_run(&file, Some(&plan), on_stage, on_progress)
                };
                return run(start, Some(out), quiet, log_json, run_log);
            }
            let scene = scene.expect("clap requires a scene without --resume");
            let text = match std::fs::read_to_string(&scene) {
                Ok(t) => t,
                Err(e) => {
                    eprintln!("error: {}: {e}", scene.display());
                    return ExitCode::from(2);
                }
            };
            match AnyScene::from_toml(&text) {
                Ok(AnyScene::Spheres(s)) => {
                    let plan = checkpoint.map(|path| CheckpointPlan { path, every });
                    let start = |on_stage: &mut OnStage, on_progress: &mut OnProgress| match &plan {
                        Some(plan) => {
                            run_scene_checkpointed(&text, &s, plan, on_stage, on_progress)
                        }
                        None => run_scene_observed(&s, on_stage, on_progress),
                    };
                    run(start, Some(out), quiet, log_json, run_log)
                }
                Ok(AnyScene::Mixture(_)) if run_log.is_some() => {
                    eprintln!(
                        "error: --run-log: mixture scenes (RSA or relaxation) have no time \
                         barriers to log"
                    );
                    ExitCode::from(2)
                }
                Ok(AnyScene::Mixture(_)) if checkpoint.is_some() => {
                    eprintln!(
                        "error: --checkpoint: mixture scenes (RSA or relaxation, no time \
                         barriers) cannot be checkpointed"
                    );
                    ExitCode::from(2)
                }
                Ok(AnyScene::Mixture(s)) => run_mixture(&s, &out, quiet),
                Err(e) => {
                    eprintln!("error: {}: {e}", scene.display());
                    ExitCode::from(2)
                }
            }
        }
        Some(Command::Verify {
            packing,
            json,
            grading,
            d_min,
            tolerance,
        }) => cli::verify::run(&packing, json, grading.as_deref(), d_min, tolerance),
        Some(Command::Export(args)) => cli::export::run(&args),
        Some(Command::Take(args)) => cli::take::run(&args),
        Some(Command::Init(args)) => cli::init::run(&args),
        Some(Command::Plot(args)) => cli::plot::run(&args),
        Some(Command::Bench(args)) => cli::bench::run(&args),
        Some(Command::BenchChildMemory { args }) => cli::bench::child_memory(&args),
    }
}

/// A number of seconds in `[0, MAX_SECONDS]` (a `Duration` must hold it).
fn parse_seconds(text: &str) -> Result<f64, String> {
    use densepack::io::scene::MAX_SECONDS;
    match text.parse::<f64>() {
        Ok(s) if s.is_finite() && (0.0..=MAX_SECONDS).contains(&s) => Ok(s),
        _ => Err(format!(
            "`{text}` is not a number of seconds in [0, {MAX_SECONDS:e}]"
        )),
    }
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

/// Refuses an output path that cannot be written before a run spends hours on it: its
/// directory must exist and the path must not be a directory.
fn check_output_path(out: &std::path::Path) -> Result<(), String> {
    let dir = out
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(std::path::Path::new("."));
    if !dir.is_dir() {
        return Err(format!("directory {} does not exist", dir.display()));
    }
    if out.is_dir() {
        return Err("is a directory".into());
    }
    Ok(())
}

/// Hears of every finished stage.
type OnStage<'a> = dyn FnMut(usize, &StageReport) + 'a;
/// Hears of a stage's progress at time barriers.
type OnProgress<'a> = dyn FnMut(usize, &Progress) + 'a;

/// Runs `start` (a fresh or resumed run) with the progress reporter, prints its summary and
/// writes the packing.
fn run(
    start: impl FnOnce(&mut OnStage, &mut OnProgress) -> Result<RunOutcome, RunError>,
    out: Option<PathBuf>,
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
        eprintln!("error: {e}");
    }
    let code = match result {
        Ok(outcome) => {
            let s = &outcome.packing.stats;
            if !quiet {
                println!(
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
            }
            if let Some(path) = out {
                if let Err(e) = outcome.packing.write(&path) {
                    eprintln!("error: {e}");
                    return ExitCode::from(1);
                }
                if !quiet {
                    println!("wrote {}", path.display());
                }
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            match e {
                RunError::StageFailed { .. } => eprintln!("no packing written"),
                RunError::Checkpoint(_) => return ExitCode::from(2),
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

/// Runs a sphere + cylinder mixture scene and writes the verified packing.
fn run_mixture(scene: &MixtureScene, out: &std::path::Path, quiet: bool) -> ExitCode {
    match run_mixture_scene(scene) {
        Ok(outcome) => {
            let s = &outcome.packing.stats;
            if !quiet {
                let fraction =
                    |k: &str| s.extra.get(k).and_then(|v| v.as_f64()).unwrap_or(f64::NAN);
                println!(
                    "bodies {}  f_s {:.6}  f_c {:.6}  total {:.6}  method {}  wall {:.3} s  \
                     overlap check: ok (min gap {:.3e})",
                    outcome.packing.particles.len(),
                    fraction("sphere_fraction"),
                    fraction("cylinder_fraction"),
                    s.packing_fraction,
                    scene.mixture.method.as_str(),
                    s.wall_seconds,
                    outcome.verification.min_pair_gap.unwrap_or(f64::NAN),
                );
            }
            if let Err(e) = outcome.packing.write(out) {
                eprintln!("error: {e}");
                return ExitCode::from(1);
            }
            if !quiet {
                println!("wrote {}", out.display());
            }
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {e}");
            eprintln!("no packing written");
            ExitCode::from(1)
        }
    }
}
