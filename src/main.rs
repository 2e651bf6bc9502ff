//! The `densepack` command line. Thin: parses, calls the library, prints.

use clap::{Parser, Subcommand};
use densepack::io::packing::Packing;
use densepack::io::scene::Scene;
use densepack::kernel::StageReport;
use densepack::run::{run_scene, RunError};
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
        /// Scene file (TOML).
        scene: PathBuf,
        /// Output packing file.
        #[arg(long)]
        out: PathBuf,
        /// Print nothing but errors.
        #[arg(long)]
        quiet: bool,
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
            run(&scene, None, false)
        }
        Some(Command::Run { scene, out, quiet }) => {
            let text = match std::fs::read_to_string(&scene) {
                Ok(t) => t,
                Err(e) => {
                    eprintln!("error: {}: {e}", scene.display());
                    return ExitCode::from(2);
                }
            };
            match Scene::from_toml(&text) {
                Ok(s) => {
                    if let Err(e) = check_output_path(&out) {
                        eprintln!("error: --out {}: {e}", out.display());
                        return ExitCode::from(2);
                    }
                    run(&s, Some(out), quiet)
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

fn run(scene: &Scene, out: Option<PathBuf>, quiet: bool) -> ExitCode {
    let mut on_stage = |k: usize, r: &StageReport| {
        if !quiet {
            print_stage(k, r);
        }
    };
    match run_scene(scene, &mut on_stage) {
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
            if let RunError::StageFailed { .. } = e {
                eprintln!("no packing written");
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
