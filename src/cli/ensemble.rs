//! `densepack ensemble`: one scene, many seeds, worker threads; the directory layout, the
//! summary and the resume rule are the library's (`densepack::ensemble`). Also the scene
//! loading with `--seed` and `--set` that `run` shares.

use densepack::ensemble::{
    parse_seeds, read_summary, run_realisation, seeds_to_run, Status, SummaryRow, SummaryWriter,
};
use densepack::io::scene::{parse_assignment, AnyScene};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

/// Arguments of `densepack ensemble`.
#[derive(clap::Args)]
pub struct EnsembleArgs {
    /// Scene file (TOML); its own seed is replaced by each of --seeds.
    scene: PathBuf,
    /// Seeds: 1..100 (inclusive: 100 seeds), 1,5,9 or 1..10,20.
    #[arg(long)]
    seeds: String,
    /// Worker threads, at least 1 (default: the available parallelism). Each runs one
    /// realisation at a time.
    #[arg(long)]
    jobs: Option<usize>,
    /// Ensemble directory (created if need be): seed-<k>.json and summary.csv. A rerun into
    /// the same directory runs only the seeds without a result (ok with its file, or failed).
    #[arg(long)]
    out: PathBuf,
    /// Set a scene value, KEY=VALUE with a dotted key, as for `densepack run`; repeatable.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    set: Vec<String>,
    /// Print nothing but errors.
    #[arg(long)]
    quiet: bool,
    /// Run even if --jobs times the scene's memory estimate exceeds the memory available.
    /// The same as setting DENSEPACK_IGNORE_MEMORY_CHECK=1.
    #[arg(long)]
    ignore_memory_check: bool,
}

/// The scene of file `path` with the `--set` overrides applied in order and then `seed`
/// (if given); the message names the file or the override.
pub fn load_scene(path: &Path, seed: Option<u64>, set: &[String]) -> Result<AnyScene, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    // A relative `particles.from` is relative to the scene file.
    let scene = AnyScene::from_toml_at(&text, path.parent())
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let values = set
        .iter()
        .map(|a| parse_assignment(a).map_err(|e| format!("--set {e}")))
        .collect::<Result<Vec<_>, _>>()?;
    let scene = if values.is_empty() {
        scene
    } else {
        scene
            .with_values(&values)
            .map_err(|e| format!("--set {}: {e}", set.join(" --set ")))?
    };
    Ok(match seed {
        Some(seed) => scene.with_seed(seed),
        None => scene,
    })
}

/// One line for people about a finished realisation.
fn describe(row: &SummaryRow) -> String {
    match row.status {
        Status::Ok => format!(
            "seed {}: ok  packing_fraction {:.6}  min_gap {:.3e}  reduced_pressure {:.4e}  \
             events {}  wall {:.2} s",
            row.seed,
            row.packing_fraction.unwrap_or(f64::NAN),
            row.min_gap.unwrap_or(f64::NAN),
            row.reduced_pressure.unwrap_or(f64::NAN),
            row.events.unwrap_or(0),
            row.wall_seconds,
        ),
        status => format!("seed {}: {}: {}", row.seed, status.as_str(), row.message),
    }
}

/// Runs the ensemble; exit 0 when every seed of --seeds is ok, 1 when any failed or was
/// lost (after all ran), 2 on bad input (before any run).
pub fn run(args: &EnsembleArgs) -> ExitCode {
    let seeds = match parse_seeds(&args.seeds) {
        Ok(s) => s,
        Err(e) => {
            errln!("error: --seeds: {e}");
            return ExitCode::from(2);
        }
    };
    let jobs = match args.jobs {
        Some(0) => {
            errln!("error: --jobs 0: at least 1 worker thread is needed");
            return ExitCode::from(2);
        }
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, |n| n.get()),
    };
    let scene = match load_scene(&args.scene, None, &args.set) {
        Ok(s) => s,
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let todo = match seeds_to_run(&args.out, &seeds) {
        Ok(t) => t,
        Err(e) => {
            errln!("error: --out: {e}");
            return ExitCode::from(2);
        }
    };
    let jobs = jobs.min(todo.len()).max(1);
    if !(args.ignore_memory_check || densepack::memory::overridden()) {
        // Every worker holds one run at a time.
        let (bytes, what) = scene.memory_estimate();
        let needed = bytes.saturating_mul(jobs as u64);
        if let Err(code) = crate::check_memory((needed, format!("{jobs} jobs × ({what})"))) {
            return code;
        }
    }
    let mut writer = match SummaryWriter::open(&args.out) {
        Ok(w) => w,
        Err(e) => {
            errln!("error: --out: {e}");
            return ExitCode::from(2);
        }
    };
    if !args.quiet {
        outln!(
            "densepack ensemble: {} of {} seeds to run ({} done or failed before) on {jobs} \
             threads into {}",
            todo.len(),
            seeds.len(),
            seeds.len() - todo.len(),
            args.out.display()
        );
    }
    // Set when the summary cannot be written: the running realisations stop (lost) and no
    // further seed starts.
    let cancel = Arc::new(AtomicBool::new(false));
    let next = AtomicUsize::new(0);
    let mut summary_failed = false;
    std::thread::scope(|s| {
        let (tx, rx) = std::sync::mpsc::channel::<SummaryRow>();
        for _ in 0..jobs {
            let (tx, next, todo, scene, dir, cancel) =
                (tx.clone(), &next, &todo, &scene, &args.out, &cancel);
            s.spawn(move || loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                if k >= todo.len() || cancel.load(Ordering::Relaxed) {
                    break;
                }
                let row = run_realisation(scene, todo[k], dir, Some(cancel.clone()));
                if tx.send(row).is_err() {
                    break;
                }
            });
        }
        drop(tx);
        for (done, row) in rx.iter().enumerate() {
            if let Err(e) = writer.append(&row) {
                errln!("error: {e}");
                summary_failed = true;
                cancel.store(true, Ordering::Relaxed);
            }
            if !args.quiet {
                outln!("[{}/{}] {}", done + 1, todo.len(), describe(&row));
            }
        }
    });
    // The verdict covers every requested seed, also those a previous run settled.
    let last = match read_summary(&args.out) {
        Ok(rows) => rows,
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    let requested: std::collections::HashSet<u64> = seeds.iter().copied().collect();
    let count = |status| {
        last.iter()
            .filter(|r| r.status == status && requested.contains(&r.seed))
            .count()
    };
    let (ok, failed, lost) = (
        count(Status::Ok),
        count(Status::Failed),
        count(Status::Lost),
    );
    if !args.quiet {
        outln!(
            "{ok} ok, {failed} failed, {lost} lost of {} seeds; summary {}",
            seeds.len(),
            args.out.join(densepack::ensemble::SUMMARY_FILE).display()
        );
    }
    if ok == seeds.len() && !summary_failed {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
