//! The sphere and concrete studies of `densepack bench` (`src/cli/studies/`) as a cargo bench target; the same
//! code as `densepack bench` (see there and BENCHMARKS.md for what each study measures).
//!
//! ```text
//! cargo bench --bench edmd -- [--quick] [--out DIR] [--only STUDY[,STUDY...]]
//! ```
//!
//! Without `--only` it runs the sphere studies (scaling, equilibrium, jamming, growth-rate,
//! tuning, memory); the report goes to `DIR` (default `target/bench-report`). As with
//! criterion, the binary benchmarks only when cargo passes `--bench` (`cargo bench`); run by
//! `cargo test --benches` it runs one tiny scene on each queue as a smoke test.

// The studies belong to the `densepack` binary, not to the library (which builds without
// plotters and cpu-time); this target compiles the binary's one copy of their source. It
// uses only some of them (`dead_code`), and their unit tests run with the binary's, not in
// this target without a test harness (their `use super::*` is unused here).
#[path = "../src/cli/studies/mod.rs"]
#[allow(dead_code, unused_imports)]
mod studies;

use std::path::PathBuf;
use std::process::ExitCode;
use studies::edmd::{child_memory, equilibrium_run, Tuning, QUEUES};
use studies::{run_report, select, ReportOptions, StudyContext};

/// The studies run without `--only`.
const SPHERE_STUDIES: [&str; 6] = [
    "scaling",
    "equilibrium",
    "jamming",
    "growth-rate",
    "tuning",
    "memory",
];

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--child-memory") {
        return match child_memory(&args[1..]) {
            Ok(lines) => {
                print!("{lines}");
                ExitCode::SUCCESS
            }
            Err(e) => {
                eprintln!("edmd: {e}");
                ExitCode::FAILURE
            }
        };
    }
    if !args.iter().any(|a| a == "--bench") {
        smoke_test();
        return ExitCode::SUCCESS;
    }
    let (mut quick, mut out, mut only) = (false, PathBuf::from("target/bench-report"), None);
    let mut it = args.iter();
    while let Some(arg) = it.next() {
        match (arg.as_str(), it.clone().next()) {
            ("--bench", _) => {}
            ("--quick", _) => quick = true,
            ("--out", Some(dir)) => {
                out = PathBuf::from(dir);
                it.next();
            }
            ("--only", Some(names)) => {
                only = Some(names.split(',').map(str::to_owned).collect::<Vec<_>>());
                it.next();
            }
            (other, _) => {
                eprintln!("edmd: unknown or incomplete argument `{other}`");
                eprintln!(
                    "usage: cargo bench --bench edmd -- [--quick] [--out DIR] [--only STUDY,...]"
                );
                return ExitCode::from(2);
            }
        }
    }
    let only = only.unwrap_or_else(|| SPHERE_STUDIES.map(str::to_owned).to_vec());
    let studies = match select(Some(&only)) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("edmd: {e}");
            return ExitCode::from(2);
        }
    };
    let exe = std::env::current_exe().expect("the path of the benchmark binary is known");
    let options = ReportOptions {
        studies: studies.iter().map(|s| s.name).collect(),
        out,
        command_line: std::env::args().collect::<Vec<_>>().join(" "),
        context: StudyContext {
            quick,
            memory_child: vec![exe.to_string_lossy().into_owned(), "--child-memory".into()],
            journal: None,
        },
    };
    match run_report(&options) {
        Ok(path) => {
            println!("wrote {}", path.display());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("edmd: {e}");
            ExitCode::FAILURE
        }
    }
}

/// What `cargo test --benches` runs: one tiny equilibrium scene on each queue.
fn smoke_test() {
    for queue in QUEUES {
        let r = equilibrium_run(queue, 200, 2.0, Tuning::default())
            .unwrap_or_else(|e| panic!("smoke test on the {queue} queue: {e}"));
        assert!(
            r.stop_reason.is_success(),
            "smoke test on the {queue} queue"
        );
    }
    eprintln!("edmd: smoke test passed (benchmarks run with `cargo bench --bench edmd`)");
}
