//! The `densepack` command line. Thin: parses, calls the library, prints.

use clap::{Parser, Subcommand};
use densepack::io::checkpoint::CheckpointFile;
use densepack::io::packing::Packing;
use densepack::io::scene::Scene;
use densepack::kernel::StageReport;
use densepack::run::{
    resume_run, run_scene, run_scene_checkpointed, CheckpointPlan, RunError, RunOutcome,
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
        /// Write a checkpoint to FILE during the run (atomically, at a time barrier, every
        /// --checkpoint-every seconds); continue a killed run with --resume FILE.
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
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        None => {
            println!("densepack: running the embedded default scene (10 000 equal spheres, periodic, grown to jamming)");
            let scene = Scene::from_toml(DEFAULT_SCENE).expect("the embedded scene is valid");
            run(|on_stage| run_scene(&scene, on_stage), None, false)
        }
        Some(Command::Run {
            scene,
            out,
            quiet,
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
                return run(
                    |on_stage| resume_run(&file, Some(&plan), on_stage),
                    Some(out),
                    quiet,
                );
            }
            let scene = scene.expect("clap requires a scene without --resume");
            let text = match std::fs::read_to_string(&scene) {
                Ok(t) => t,
                Err(e) => {
                    eprintln!("error: {}: {e}", scene.display());
                    return ExitCode::from(2);
                }
            };
            match Scene::from_toml(&text) {
                Ok(s) => {
                    let plan = checkpoint.map(|path| CheckpointPlan { path, every });
                    let start = |on_stage: &mut dyn FnMut(usize, &StageReport)| match &plan {
                        Some(plan) => run_scene_checkpointed(&text, &s, plan, on_stage),
                        None => run_scene(&s, on_stage),
                    };
                    run(start, Some(out), quiet)
                }
                Err(e) => {
                    eprintln!("error: {}: {e}", scene.display());
                    ExitCode::from(2)
                }
            }
        }
        Some(Command::Verify { packing, json }) => verify(&packing, json),
    }
}

/// A number of seconds ≥ 0.
fn parse_seconds(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if s.is_finite() && s >= 0.0 => Ok(s),
        _ => Err(format!("`{text}` is not a number of seconds ≥ 0")),
    }
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

fn print_stage(k: usize, r: &StageReport) {
    eprintln!(
        "stage {k}: {} after {} events ({} collisions) in {:.2} s, φ = {:.6}, Z = {:.4e}",
        r.stop_reason.as_str(),
        r.counts.events,
        r.counts.collisions,
        r.wall_seconds,
        r.packing_fraction,
        r.reduced_pressure
    );
}

/// Runs `start` (a fresh or resumed run), prints its summary and writes the packing.
fn run(
    start: impl FnOnce(&mut dyn FnMut(usize, &StageReport)) -> Result<RunOutcome, RunError>,
    out: Option<PathBuf>,
    quiet: bool,
) -> ExitCode {
    let mut on_stage = |k: usize, r: &StageReport| {
        if !quiet {
            print_stage(k, r);
        }
    };
    match start(&mut on_stage) {
        Ok(outcome) => {
            let s = &outcome.packing.stats;
            if !quiet {
                println!(
                    "particles {}  packing_fraction {:.6}  reduced_pressure {:.4e}  events {}  collisions {}  \
                     wall {:.2} s  ({:.3} M events/s)  stop {}  overlap check: ok (min gap {:.3e} of contact)",
                    outcome.packing.particles.len(),
                    s.packing_fraction,
                    s.reduced_pressure,
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
    }
}

fn verify(path: &std::path::Path, json: bool) -> ExitCode {
    let packing = match Packing::read(path) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let v = densepack::verify::verify(&packing);
    if json {
        println!(
            "{}",
            serde_json::to_string_pretty(&v).expect("serialisable")
        );
    } else {
        println!(
            "particles {}  packing_fraction {:.6}  min pair gap {:.3e} (relative {:.3e})  min wall gap {}  violations {}",
            v.particles,
            v.packing_fraction,
            v.min_pair_gap.unwrap_or(f64::NAN),
            v.min_pair_gap_relative.unwrap_or(f64::NAN),
            v.min_wall_gap.map_or("none".into(), |g| format!("{g:.3e}")),
            v.violation_count
        );
        for msg in &v.violations {
            println!("  {msg}");
        }
    }
    if v.ok() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
