//! Macro benchmarks: the studies behind `densepack bench` and the `cargo bench` binaries
//! (`benches/edmd.rs`, `benches/mixture.rs`, `benches/ellipsoids.rs`), one copy of each.
//!
//! Part of the binary, not of the library (they need `plotters` and `cpu-time`, which a program
//! using the library should not build): `main.rs` declares them under `cli`, and each bench
//! target compiles this same source as a module of its own (`#[path]`). So the studies reach
//! the library through `densepack::`, like any user, and use nothing of `cli` besides.
//!
//! A study runs whole scenes (release build), and returns a [`StudyOutput`]: its markdown
//! section (tables with the exact parameters in their captions), one long-format CSV table and
//! one [`Figure`]. [`run_report`] runs the selected studies and writes, into one directory,
//! `BENCHMARKS.md` (machine information, the command line, one section per study),
//! `<study>.csv` and `<study>.svg`; the report is rewritten after each study, so a long run
//! that is interrupted keeps what it finished.
//!
//! The study families, one file each: [`edmd`] (spheres: equilibrium, jamming, log-N scaling,
//! tuning, growth rate against jammed φ, memory), [`concrete`] (paper 001 §6), [`mixture`]
//! (sphere + cylinder RVEs, paper 000 Tables II–XI, and the relaxer's step size and force
//! rescaling), [`ellipsoid`] (paper 004 Table 2, Figs. 6–9, predictor cost and accuracy). Timings are
//! wall seconds of this process; nothing here asserts a time.

pub mod concrete;
pub mod edmd;
pub mod ellipsoid;
mod journal;
pub mod mixture;
mod plot;
mod table;

pub use journal::Journal;
pub use plot::{Figure, Series};
pub use table::{mean_sd, median, si, slope, spread, Table};

use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// What a study produced.
pub struct StudyOutput {
    /// The markdown section (tables and notes; the report adds the heading).
    pub markdown: String,
    /// The study's data in long format (`<study>.csv`).
    pub csv: Table,
    /// The study's plot (`<study>.svg`).
    pub figure: Figure,
}

/// How a study is run.
#[derive(Clone, Debug)]
pub struct StudyContext {
    /// Reduced sizes (`--quick`): the smallest rows of each study.
    pub quick: bool,
    /// The program and leading arguments that re-run this binary as the memory child
    /// ([`edmd::child_memory`] with `N QUEUE` appended), e.g. `[densepack, bench-child-memory]`.
    pub memory_child: Vec<String>,
    /// Where the concrete studies record each finished run and find those of an interrupted
    /// attempt ([`Journal`]); `None` records nothing.
    pub journal: Option<std::sync::Arc<Journal>>,
}

/// One study of the suite.
pub struct Study {
    /// Name used by `--only` and for the output files.
    pub name: &'static str,
    /// One line for `--help` and the report.
    pub summary: &'static str,
    /// Run by default (without `--only`); the long concrete studies are opt-in.
    pub default: bool,
    /// The study.
    pub run: fn(&StudyContext) -> StudyOutput,
}

/// Every study, in the order they run.
pub const STUDIES: &[Study] = &[
    Study {
        name: "scaling",
        summary: "µs per event against N (paper 001, Fig. 4), monodisperse and Fuller, both queues",
        default: true,
        run: edmd::scaling,
    },
    Study {
        name: "equilibrium",
        summary: "hard-sphere fluid at φ = 0.50: collisions/s, both queues",
        default: true,
        run: edmd::equilibrium,
    },
    Study {
        name: "jamming",
        summary: "the default jamming scene: wall time and collisions/s against rate and queue",
        default: true,
        run: edmd::jamming,
    },
    Study {
        name: "growth-rate",
        summary: "LS growth rate against jammed φ and wall time (Pareto)",
        default: true,
        run: edmd::growth_rate,
    },
    Study {
        name: "tuning",
        summary: "neighbour_skin and events_per_particle_per_interval sweeps",
        default: true,
        run: edmd::tuning,
    },
    Study {
        name: "memory",
        summary: "peak resident memory per particle (child process)",
        default: true,
        run: edmd::memory,
    },
    Study {
        name: "ellipsoid-predictor",
        summary: "ellipsoid predictors: µs per prediction against the largest overlap (Pareto)",
        default: true,
        run: ellipsoid::predictor,
    },
    Study {
        name: "ellipsoid-table2",
        summary:
            "paper 004 Table 2 (prolate and oblate, R = 2 … 40) beside densepack, both predictors",
        default: true,
        run: ellipsoid::table2,
    },
    Study {
        name: "ellipsoid-isotropy",
        summary: "paper 004 Fig. 6: orientation isotropy ρ̄ against N beside independent axes",
        default: true,
        run: ellipsoid::isotropy,
    },
    Study {
        name: "ellipsoid-cost-n",
        summary: "paper 004 Fig. 7: CPU time of prolate ellipsoids against N, fitted exponents",
        default: true,
        run: ellipsoid::cost_against_n,
    },
    Study {
        name: "ellipsoid-cost-fraction",
        summary: "paper 004 Fig. 8: CPU time against the volume fraction (R = 2), fitted exponent",
        default: true,
        run: ellipsoid::cost_against_fraction,
    },
    Study {
        name: "ellipsoid-cost-aspect",
        summary: "paper 004 Fig. 9: CPU time against the aspect ratio (φ = 0.1), fitted exponents",
        default: true,
        run: ellipsoid::cost_against_aspect,
    },
    Study {
        name: "relaxer",
        summary: "TDMD relaxer: time step and force rescaling against time and residual overlap",
        default: true,
        run: mixture::relaxer,
    },
    Study {
        name: "mixture-tables",
        summary: "paper 000 Tables II–XI (RSA, MD) beside densepack",
        default: true,
        run: mixture::tables,
    },
    Study {
        name: "mixture-order",
        summary: "paper 000 Fig. 4: RSA time against the fraction for the three placement orders",
        default: true,
        run: mixture::order,
    },
    Study {
        name: "mixture-split",
        summary: "paper 000 Figs. 7–8: RSA and MD time against the sphere share of a fixed total",
        default: true,
        run: mixture::split,
    },
    Study {
        name: "mixture-fraction",
        summary:
            "paper 000 Figs. 9–11: RSA and MD time against the total fraction, per composition",
        default: true,
        run: mixture::fraction,
    },
    Study {
        name: "concrete-jam",
        summary: "concrete jamming speed, 80 mm walled cube (paper 001 §6)",
        default: true,
        run: concrete::jam,
    },
    Study {
        name: "gap",
        summary:
            "concrete case 2: A16 with Δd = 1 mm, RSA and EDMD ψ against φ_M (paper 001, Fig. 9)",
        default: true,
        run: concrete::gap,
    },
    Study {
        name: "gapmax",
        summary: "concrete case 3: Δd_max at d_min = 4, 2 mm (paper 001, Fig. 10–11); opt-in",
        default: false,
        run: concrete::gapmax,
    },
    Study {
        name: "gapmax-fine",
        summary: "concrete case 3 at d_min = 1 mm (paper 001, Fig. 10–11); opt-in, hours",
        default: false,
        run: concrete::gapmax_fine,
    },
    Study {
        name: "fuller",
        summary: "concrete case 1: RSA against EDMD, ψ and t_ψ against φ_eff (paper 001, Fig. 7)",
        default: true,
        run: concrete::fuller,
    },
    Study {
        name: "fuller-fine",
        summary:
            "concrete case 1 on the paper's grid: 0.5 % steps, 50 seeds (Fig. 7); opt-in, hours",
        default: false,
        run: concrete::fuller_fine,
    },
];

/// The study called `name`.
pub fn study(name: &str) -> Option<&'static Study> {
    STUDIES.iter().find(|s| s.name == name)
}

/// The studies `only` names, in suite order, or the default ones; an unknown name is an
/// error naming it and the allowed names.
pub fn select(only: Option<&[String]>) -> Result<Vec<&'static Study>, String> {
    match only {
        None => Ok(STUDIES.iter().filter(|s| s.default).collect()),
        Some(names) => {
            if let Some(bad) = names.iter().find(|n| study(n).is_none()) {
                return Err(format!(
                    "unknown study `{bad}`; the studies are: {}",
                    STUDIES
                        .iter()
                        .map(|s| s.name)
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
            Ok(STUDIES
                .iter()
                .filter(|s| names.iter().any(|n| n == s.name))
                .collect())
        }
    }
}

/// Options of [`run_report`].
#[derive(Clone, Debug)]
pub struct ReportOptions {
    /// The studies to run.
    pub studies: Vec<&'static str>,
    /// Output directory (created if missing).
    pub out: PathBuf,
    /// The command line, recorded in the report.
    pub command_line: String,
    /// How the studies run.
    pub context: StudyContext,
}

/// Runs the studies and writes `BENCHMARKS.md`, `<study>.csv` and `<study>.svg` into
/// `options.out`; returns the path of the report. Progress goes to stderr.
pub fn run_report(options: &ReportOptions) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(&options.out)?;
    let report_path = options.out.join("BENCHMARKS.md");
    let started = Instant::now();
    let mut report = format!(
        "# densepack benchmark report{}\n\n\
         Generated by `densepack bench`; every table comes from this one run. Timings are wall \
         seconds on the machine below (shared machines make them noisy: compare rows of one \
         table). Per study: `<study>.csv` (data) and `<study>.svg` (plot) beside this file.\n\n{}",
        if options.context.quick {
            " (--quick)"
        } else {
            ""
        },
        machine_info(&options.command_line)
    );
    write_file(&report_path, report.as_bytes())?;
    for name in &options.studies {
        let study = study(name).ok_or_else(|| {
            std::io::Error::new(
                std::io::ErrorKind::InvalidInput,
                format!("unknown study `{name}`"),
            )
        })?;
        eprintln!("== {} ({})", study.name, study.summary);
        let t = Instant::now();
        let output = (study.run)(&options.context);
        let seconds = t.elapsed().as_secs_f64();
        write_study(&options.out, study.name, &output)?;
        let _ = write!(
            report,
            "## {}\n\n{}.\n\n{}\n_{} took {seconds:.1} s; data `{}.csv`, plot `{}.svg`:_\n\n\
             ![{}]({}.svg)\n\n",
            study.name,
            study.summary,
            output.markdown.trim_end(),
            study.name,
            study.name,
            study.name,
            study.name,
            study.name
        );
        write_file(&report_path, report.as_bytes())?;
        eprintln!("== {} done in {seconds:.1} s", study.name);
    }
    let _ = writeln!(report, "_Total: {:.1} s._", started.elapsed().as_secs_f64());
    write_file(&report_path, report.as_bytes())?;
    Ok(report_path)
}

/// Writes `<name>.csv` and `<name>.svg` of one study.
pub fn write_study(dir: &Path, name: &str, output: &StudyOutput) -> std::io::Result<()> {
    write_file(
        &dir.join(format!("{name}.csv")),
        output.csv.csv().as_bytes(),
    )?;
    let svg = output
        .figure
        .svg()
        .map_err(|e| std::io::Error::other(format!("{name}.svg: {e}")))?;
    write_file(&dir.join(format!("{name}.svg")), svg.as_bytes())
}

/// Replaces `path` with `bytes` atomically (no half-written file).
fn write_file(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    use std::io::Write as _;
    densepack::io::packing::write_atomically(path, |w| w.write_all(bytes))
}

/// Machine information as a markdown list: CPU model and cores (`/proc/cpuinfo`), OS, load,
/// densepack version, git commit (when run inside a git checkout) and the command line.
pub fn machine_info(command_line: &str) -> String {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = cpuinfo
        .lines()
        .find_map(|l| l.strip_prefix("model name"))
        .and_then(|l| l.split_once(':'))
        .map_or("unknown", |(_, m)| m.trim());
    let logical = cpuinfo
        .lines()
        .filter(|l| l.starts_with("processor"))
        .count();
    let available = std::thread::available_parallelism().map_or(0, |n| n.get());
    let os = std::fs::read_to_string("/etc/os-release")
        .ok()
        .and_then(|t| {
            t.lines()
                .find_map(|l| l.strip_prefix("PRETTY_NAME="))
                .map(|v| v.trim_matches('"').to_owned())
        })
        .unwrap_or_else(|| std::env::consts::OS.to_owned());
    let kernel = std::fs::read_to_string("/proc/sys/kernel/osrelease").unwrap_or_default();
    let memory = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find_map(|l| l.strip_prefix("MemTotal:"))
                .and_then(|v| v.split_whitespace().next()?.parse::<f64>().ok())
        })
        .map_or("unknown".into(), |kib| {
            format!("{:.1} GiB", kib / (1024.0 * 1024.0))
        });
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    let commit = std::process::Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
        .map(|c| {
            let dirty = std::process::Command::new("git")
                .args(["status", "--porcelain", "--untracked-files=no"])
                .output()
                .is_ok_and(|o| !o.stdout.is_empty());
            if dirty {
                format!("{c} (with uncommitted changes)")
            } else {
                c
            }
        })
        .unwrap_or_else(|| "unknown (not run in a git checkout)".into());
    format!(
        "- CPU: {model}\n\
         - cores: {logical} logical ({available} available to this process)\n\
         - memory: {memory}\n\
         - OS: {os} ({} {})\n\
         - densepack: {} (commit {commit}), {} build\n\
         - load average at start: {}\n\
         - command: `{command_line}`\n\n",
        std::env::consts::ARCH,
        kernel.trim(),
        env!("CARGO_PKG_VERSION"),
        if cfg!(debug_assertions) {
            "debug"
        } else {
            "release"
        },
        load.split_whitespace()
            .take(3)
            .collect::<Vec<_>>()
            .join(" "),
    )
}
