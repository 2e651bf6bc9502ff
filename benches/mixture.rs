//! Sphere + cylinder RVEs: the paper's Tables II–VI (RSA) and VII–XI (MD relaxer) beside
//! densepack's times, success rates and fractions reached (Salnikov, Choï &
//! Karamian-Surville 2014, Appendix 2–3).
//!
//! ```sh
//! cargo bench --bench mixture                      # every table (see BENCHMARKS.md)
//! cargo bench --bench mixture -- --quick           # 50 + 50 tables only, 3 runs per cell
//! cargo bench --bench mixture -- --only md --counts 50 --runs 5 --out table.md
//! cargo bench --bench mixture -- --only rsa --cpu     # CPU time of the thread, not wall
//! ```
//!
//! `--cpu` reports the CPU time of the generating thread (`CLOCK_THREAD_CPUTIME_ID`)
//! instead of wall-clock time: on a shared machine the wall clock also counts the time the
//! thread waited for a core, which the paper's dedicated i7-960 did not.

use densepack::protocol::mixture::relax::{random_rve, relax, RelaxSettings};
use densepack::protocol::mixture::rsa::{rsa_mixture, RsaLimits};
use densepack::protocol::mixture::{GenerationOrder, MixtureSpec};
use densepack::verify::verify;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::fmt::Write as _;
use std::time::{Duration, Instant};

fn main() {
    let mut args = std::env::args().skip(1);
    let (mut only, mut counts, mut runs, mut out, mut limit) = (
        None::<String>,
        vec![10usize, 20, 30, 40, 50],
        5usize,
        None::<String>,
        10.0f64,
    );
    let mut cells: Option<Vec<(f64, f64)>> = None;
    let mut cpu = false;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--quick" => {
                counts = vec![50];
                runs = 3;
            }
            "--only" => only = args.next(),
            "--counts" => {
                counts = args
                    .next()
                    .expect("--counts N,N")
                    .split(',')
                    .map(|x| x.parse().expect("count"))
                    .collect()
            }
            "--runs" => runs = args.next().expect("--runs N").parse().expect("runs"),
            "--limit" => limit = args.next().expect("--limit S").parse().expect("seconds"),
            "--out" => out = args.next(),
            "--cells" => {
                cells = Some(
                    args.next()
                        .expect("--cells FS:FC,FS:FC")
                        .split(',')
                        .map(|c| {
                            let (a, b) = c.split_once(':').expect("FS:FC");
                            (a.parse().expect("f_s"), b.parse().expect("f_c"))
                        })
                        .collect(),
                )
            }
            "--cpu" => cpu = true,
            "--bench" => {}
            other => panic!("unknown argument {other}"),
        }
    }
    let mut text = String::new();
    for table in ["rsa", "md"] {
        if only.as_deref().is_some_and(|o| o != table) {
            continue;
        }
        for &n in &counts {
            let t = run_table(table, n, runs, limit, cells.as_deref(), cpu);
            print!("{t}");
            text.push_str(&t);
        }
    }
    if let Some(path) = out {
        std::fs::write(&path, text).expect("write --out");
    }
}
/// The paper's tables II–XI: per table, rows `f_s:cell,cell,…` (cells for f_c = 0.05, 0.10, …;
/// each `t_a3|t_a5` in seconds, one value when the paper gives one).
const PAPER: [&str; 10] = [
    "0.05:0.0002|0.0003,0.0003|0.0005,0.0005|0.0012,0.0011|0.0044,0.005|0.021,0.015|1.02;0.1:0.0002|0.0003,0.0004|0.0006,0.0007|0.0026,0.0018|0.0059,0.01|0.057,;0.15:0.0003|0.0004,0.0009|0.0027,0.0034|0.023,0.008|0.21,,;0.2:0.0013|0.0019,0.017|0.088,0.22,,,;0.25:0.022|0.029,8.49,,,,;0.3:0.015|1.49,,,,,",
    "0.05:0.0004|0.0006,0.0007|0.0013,0.0012|0.0031,0.0027|0.012,0.012|0.068,0.062|2.4;0.1:0.0004|0.0007,0.001|0.0017,0.0021|0.0042,0.0052|0.017,0.023|0.14,;0.15:0.0008|0.0011,0.0024|0.005,0.0094|0.077,2.7|7.7,,;0.2:0.0017|0.003,0.12|0.82,5.8|16.55,,,;0.25:0.086|0.17,2.86,,,,",
    "0.05:0.0007|0.0014,0.0015|0.0023,0.0026|0.0056,0.0047|0.018,0.017|0.14,0.17|3.36;0.1:0.001|0.0014,0.0018|0.0034,0.0041|0.0096,0.01|0.037,0.037|0.68,;0.15:0.0014|0.0021,0.0044|0.0095,0.021|0.099,2.6|13,,;0.2:0.0027|0.0061,0.21|0.99,6.49,,,;0.25:0.14|1.49,,,,,",
    "0.05:0.0012|0.0016,0.002|0.0037,0.0034|0.0079,0.0077|0.029,0.034|0.24,0.26|6.74;0.1:0.0015|0.0021,0.0027|0.005,0.0058|0.014,0.016|0.057,0.079|0.58,;0.15:0.0024|0.0035,0.0064|0.013,0.035|0.2,1.78|17.2,,;0.2:0.0064|0.011,0.14|1.18,10.6,,,;0.25:0.5|1.6,,,,,",
    "0.05:0.0017|0.0023,0.0027|0.0045,0.0045|0.012,0.011|0.038,0.043|0.38,0.29|8.38;0.1:0.0021|0.0029,0.0043|0.0067,0.0082|0.019,0.025|0.08,0.11|0.69,1.44|32;0.15:0.0035|0.0042,0.0086|0.017,0.057|0.29,3.85,,;0.2:0.0092|0.015,0.21|4.94,21.8,,,;0.25:0.21|4.02,,,,,",
    "0.05:0.06|0.07,0.09|0.12,0.12|0.16,0.14|0.19,0.19|0.37,0.27|0.52,0.38|0.82,0.66|1.62,0.74|2.17;0.1:0.07|0.1,0.12|0.12,0.11|0.16,0.18|0.22,0.21|0.33,0.29|0.7,0.38|1.0,0.63|2.08,;0.15:0.08|0.1,0.12|0.13,0.13|0.22,0.16|0.3,0.27|0.44,0.31|0.72,0.56|2.0,,;0.2:0.09|0.1,0.12|0.16,0.16|0.21,0.23|0.39,0.28|0.54,0.49|0.9,,,;0.25:0.1|0.14,0.14|0.18,0.19|0.25,0.29|0.43,0.5|0.93,,,,;0.3:0.12|0.14,0.15|0.21,0.20|0.35,0.35|0.65,,,,,;0.35:0.13|0.14,0.2|0.25,0.26|0.48,,,,,,;0.4:0.15|0.16,0.21|0.3,,,,,,,;0.45:0.17|0.22,,,,,,,,",
    "0.05:0.2|0.25,0.29|0.35,0.38|0.51,0.49|0.69,0.66|1.12,0.84|1.7,0.14|4.1,2.13|8.07,4.3|7.07;0.1:0.22|0.27,0.32|0.4,0.41|0.53,0.53|0.84,0.7|1.37,1.07|1.96,1.67|5.6,2.6|10.5,;0.15:0.23|0.29,0.35|0.4,0.45|0.59,0.64|0.87,0.79|1.52,1.21|3,2.08|8.75,,;0.2:0.31|0.33,0.39|0.47,0.47|0.62,0.65|1.11,0.9|1.59,1.86|5.51,,,;0.25:0.31|0.39,0.4|0.49,0.53|0.73,0.79|1.22,1.18|4.29,,,,;0.3:0.39|0.44,0.5|0.54,0.68|0.89,1.07|2.56,,,,,;0.35:0.42|0.48,0.62|0.66,0.85|1.39,,,,,,;0.4:0.45|0.57,0.72|0.81,,,,,,,;0.45:0.55|0.66,,,,,,,,",
    "0.05:0.39|0.5,0.59|0.73,0.75|1.06,0.96|1.33,1.15|1.92,1.62|3.57,2.19|8.85,4.01|16.94,7.36;0.1:0.47|0.62,0.59|0.92,0.81|1.1,0.99|1.57,1.22|2.63,1.77|4.4,3.22|9.6,5.77|17.8,;0.15:0.51|0.61,0.68|0.84,0.88|1.17,1.13|1.63,1.53|3.26,2.3|5.62,4.17|15.2,,;0.2:0.59|0.67,0.75|0.96,0.97|1.3,1.29|2.21,1.94|4.7,3.02|11.2,,,;0.25:0.66|0.74,0.86|1.06,1.13|1.72,1.51|2.81,2.55|7.85,,,,;0.3:0.74|0.81,1.01|1.19,1.29|1.88,2.1|4.03,,,,,;0.35:0.86|0.96,1.13|1.37,1.7|2.56,,,,,,;0.4:0.94|1.01,1.38|1.9,,,,,,,;0.45:1.1|1.32,,,,,,,,",
    "0.05:0.76|0.81,0.94|1.17,1.23|1.69,1.61|2.55,2.1|3.14,2.52|6.23,4.23|14,6.47|25,12.2;0.1:0.81|0.82,1.09|1.15,1.37|1.57,1.83|2.21,2.24|3.48,3.4|8.18,5.08|20.7,8.94|24.9,;0.15:0.9|0.98,1.16|1.31,1.42|1.72,1.85|2.83,2.53|4.86,3.96|10.3,6.33|26.7,,;0.2:0.97|1.1,1.33|1.5,1.61|2.06,2.17|3.31,3.29|7.21,5.42|16.3,,,;0.25:1.1|1.14,1.39|1.62,1.89|2.44,2.54|4.38,4.27|6.39,,,,;0.3:1.21|1.27,1.62|1.87,2.21|2.96,3.47|6.39,,,,,;0.35:1.44|1.43,1.94|2.32,2.87|3.91,,,,,,;0.4:1.59|1.67,2.25|2.94,,,,,,,;0.45:2.01|2.15,,,,,,,,",
    "0.05:1.15|1.18,1.38|1.77,1.93|2.37,2.36|3.24,3.04|5.32,3.99|9.01,6.47|20.2,8.8|31.4,15.6;0.1:1.2|1.24,1.56|1.73,1.87|2.42,2.58|3.22,3.41|5.65,4.7|11.5,7.36|22.7,14.3|39.2,;0.15:1.34|1.38,1.67|1.97,2.18|2.5,2.91|4.37,3.81|7.09,5.54|16.2,10.2|44.4,,;0.2:1.5|1.48,1.92|2.11,2.39|3.06,3.31|4.38,4.6|8.27,8.34|25.2,,,;0.25:1.61|1.7,2.14|2.36,2.69|3.5,3.84|6.96,6.39|17.3,,,,;0.3:1.77|1.85,2.3|2.66,3.3|4.37,4.99|9.89,,,,,;0.35:2.08|2.14,2.8|3.28,4.28|5.79,,,,,,;0.4:2.27|2.64,3.47|4.02,,,,,,,;0.45:2.69|3.33,,,,,,,,",
];

/// Paper time for table `method`, `n` bodies of each kind, cell (row, col), aspect index.
fn paper_time(method: &str, n: usize, row: usize, col: usize, aspect: usize) -> Option<f64> {
    let table = PAPER[(n / 10 - 1) + if method == "md" { 5 } else { 0 }];
    let r = table.split(';').nth(row)?;
    let cell = r.split(':').nth(1)?.split(',').nth(col)?;
    cell.split('|').nth(aspect)?.parse().ok()
}

/// CPU seconds consumed by the calling thread.
fn thread_cpu_seconds() -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid, writable timespec; the clock id is a constant of the platform.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut t) };
    assert_eq!(rc, 0, "clock_gettime(CLOCK_THREAD_CPUTIME_ID) failed");
    t.tv_sec as f64 + 1e-9 * t.tv_nsec as f64
}

/// One generation; `Ok(seconds)` (wall, or CPU of this thread with `cpu`) if it produced a
/// packing the independent check accepts.
fn generate(
    method: &str,
    spec: &MixtureSpec,
    seed: u64,
    limit: f64,
    cpu: bool,
) -> Result<f64, String> {
    spec.validate().map_err(|_| "bound".to_string())?;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let boundary = spec.boundary();
    let sizes = spec.sizes(GenerationOrder::CylindersFirst);
    let start = Instant::now();
    let cpu_start = thread_cpu_seconds();
    let rve = if method == "rsa" {
        let limits = RsaLimits {
            time_limit: Some(Duration::from_secs_f64(limit)),
            ..RsaLimits::default()
        };
        rsa_mixture(&boundary, &sizes, &limits, &mut rng)
            .map_err(|e| e.to_string())?
            .rve
    } else {
        let mut rve = random_rve(&boundary, &sizes, &mut rng);
        let settings = RelaxSettings {
            time_limit: Some(Duration::from_secs_f64(limit)),
            ..RelaxSettings::default()
        };
        relax(&mut rve, &settings).map_err(|e| e.to_string())?;
        rve
    };
    let seconds = start.elapsed().as_secs_f64();
    let cpu_seconds = thread_cpu_seconds() - cpu_start;
    let packing =
        densepack::run::mixture_packing(&rve, seed, seconds, method, serde_json::Map::new());
    let v = verify(&packing);
    if !v.ok() {
        return Err(format!("verification: {:?}", v.violations));
    }
    Ok(if cpu { cpu_seconds } else { seconds })
}

fn run_table(
    method: &str,
    n: usize,
    runs: usize,
    limit: f64,
    cells: Option<&[(f64, f64)]>,
    cpu: bool,
) -> String {
    let cols: &[f64] = if method == "rsa" {
        &[0.05, 0.1, 0.15, 0.2, 0.25, 0.3]
    } else {
        &[0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4, 0.45]
    };
    let roman = ["II", "III", "IV", "V", "VI", "VII", "VIII", "IX", "X", "XI"];
    let table = roman[(n / 10 - 1) + if method == "md" { 5 } else { 0 }];
    let mut s = String::new();
    for (ai, a) in [3.0, 5.0].into_iter().enumerate() {
        writeln!(
            s,
            "\n### {} {n} spheres + {n} cylinders, a = {a} (paper Table {table})\n\n\
             Cell: paper s / densepack mean {} s (runs that failed: `k✗`); `bound`: \
             N_cyl < 4 f_c a²/π.\n",
            method.to_uppercase(),
            if cpu { "CPU" } else { "wall" }
        )
        .unwrap();
        write!(s, "| f_s \\ f_c |").unwrap();
        for c in cols {
            write!(s, " {c} |").unwrap();
        }
        write!(s, "\n|---|").unwrap();
        for _ in cols {
            write!(s, "---|").unwrap();
        }
        writeln!(s).unwrap();
        for (ri, &fs) in cols.iter().enumerate() {
            let mut row = format!("| {fs} |");
            let mut any = false;
            for (ci, &fc) in cols.iter().enumerate() {
                let paper = paper_time(method, n, ri, ci, ai);
                let in_paper = paper_time(method, n, ri, ci, 0).is_some();
                let selected = cells.is_none_or(|c| {
                    c.iter()
                        .any(|&(s, f)| (s - fs).abs() < 1e-9 && (f - fc).abs() < 1e-9)
                });
                if !in_paper || !selected {
                    row.push_str(" |");
                    continue;
                }
                any = true;
                let spec = MixtureSpec {
                    sphere_fraction: fs,
                    cylinder_fraction: fc,
                    spheres: n,
                    cylinders: n,
                    aspect_ratio: a,
                    box_size: 1.0,
                };
                let mut times = Vec::new();
                let mut failed = 0;
                let mut bound = false;
                for run in 0..runs {
                    let seed = 1_000_003 * n as u64
                        + 10_007 * (ri * 16 + ci) as u64
                        + 101 * ai as u64
                        + run as u64;
                    match generate(method, &spec, seed, limit, cpu) {
                        Ok(t) => times.push(t),
                        Err(e) if e == "bound" => {
                            bound = true;
                            break;
                        }
                        Err(_) => failed += 1,
                    }
                }
                let paper = paper.map_or("–".into(), |p| format!("{p}"));
                let ours = if bound {
                    "bound".to_string()
                } else if times.is_empty() {
                    "none".to_string()
                } else {
                    format!("{:.2e}", times.iter().sum::<f64>() / times.len() as f64)
                };
                let fail = if failed > 0 {
                    format!(" {failed}✗")
                } else {
                    String::new()
                };
                write!(row, " {paper} / {ours}{fail} |").unwrap();
                eprint!(".");
            }
            if any {
                writeln!(s, "{row}").unwrap();
            }
        }
    }
    eprintln!();
    s
}
