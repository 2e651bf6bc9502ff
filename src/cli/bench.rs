//! `densepack bench [--quick] [--only STUDY,...] [--out DIR] [--resume]`: the macro benchmark
//! suite of [`super::studies`], written as a report directory (`BENCHMARKS.md`, `<study>.csv`,
//! `<study>.svg`, and the run journal `runs.jsonl` that `--resume` reads).

use super::studies::{run_report, select, Journal, ReportOptions, StudyContext, STUDIES};
use clap::Args;
use std::path::PathBuf;
use std::process::ExitCode;

/// The name of the hidden subcommand that runs one memory measurement in a child process.
pub const CHILD_MEMORY: &str = "bench-child-memory";

/// Arguments of `bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Reduced sizes: the smallest rows of each study (a few minutes in all).
    #[arg(long)]
    quick: bool,
    /// Run only these studies (comma-separated); `--list` names them.
    #[arg(long, value_delimiter = ',', value_name = "STUDY,...")]
    only: Option<Vec<String>>,
    /// Output directory for BENCHMARKS.md, <study>.csv and <study>.svg (created if missing).
    #[arg(long, default_value = "bench-report")]
    out: PathBuf,
    /// Re-use the runs that an interrupted `bench` of this same build recorded in
    /// DIR/runs.jsonl (the concrete studies'); without it none is re-used (the file is kept).
    #[arg(long)]
    resume: bool,
    /// List the studies and exit.
    #[arg(long)]
    list: bool,
}

/// Runs `densepack bench`.
pub fn run(args: &BenchArgs) -> ExitCode {
    if args.list {
        for s in STUDIES {
            outln!(
                "{:<20} {}{}",
                s.name,
                s.summary,
                if s.default {
                    ""
                } else {
                    " [not run by default]"
                }
            );
        }
        return ExitCode::SUCCESS;
    }
    let studies = match select(args.only.as_deref()) {
        Ok(s) => s,
        Err(e) => {
            errln!("error: --only: {e}");
            return ExitCode::from(2);
        }
    };
    if cfg!(debug_assertions) {
        errln!("warning: a debug build; benchmark numbers need `cargo build --release`");
    }
    let exe = match std::env::current_exe() {
        Ok(p) => p.to_string_lossy().into_owned(),
        Err(e) => {
            errln!("error: cannot find this program's path for the memory child: {e}");
            return ExitCode::from(1);
        }
    };
    let journal = match std::fs::create_dir_all(&args.out)
        .and_then(|()| Journal::open(&args.out.join(Journal::FILE), args.resume))
    {
        Ok(j) => j,
        Err(e) => {
            errln!("error: --out {}: {e}", args.out.display());
            return ExitCode::from(1);
        }
    };
    let options = ReportOptions {
        studies: studies.iter().map(|s| s.name).collect(),
        out: args.out.clone(),
        command_line: std::env::args().collect::<Vec<_>>().join(" "),
        context: StudyContext {
            quick: args.quick,
            memory_child: vec![exe, CHILD_MEMORY.into()],
            journal: Some(std::sync::Arc::new(journal)),
        },
    };
    match run_report(&options) {
        Ok(path) => {
            outln!("wrote {}", path.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            errln!("error: --out {}: {e}", args.out.display());
            ExitCode::from(1)
        }
    }
}

/// The hidden child of the memory study: `densepack bench-child-memory N QUEUE`.
pub fn child_memory(args: &[String]) -> ExitCode {
    match super::studies::edmd::child_memory(args) {
        Ok(lines) => {
            out!("{lines}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            errln!("error: {e}");
            ExitCode::FAILURE
        }
    }
}
