//! Sphere + cylinder RVEs: the paper's Tables II–VI (RSA) and VII–XI (MD relaxer) beside
//! densepack's times (Salnikov, Choï & Karamian-Surville 2014, Appendix 2–3); the study code
//! is [`studies::mixture`] (`src/cli/studies/mixture.rs`), shared with `densepack bench --only mixture-tables`.
//!
//! ```sh
//! cargo bench --bench mixture                      # every table (see BENCHMARKS.md)
//! cargo bench --bench mixture -- --quick           # 50 + 50 tables only, 3 runs per cell
//! cargo bench --bench mixture -- --only md --counts 50 --runs 5 --out table.md
//! cargo bench --bench mixture -- --only rsa --wall    # wall time instead of the thread's CPU time
//! ```

// The studies belong to the `densepack` binary, not to the library (which builds without
// plotters and cpu-time); this target compiles the binary's one copy of their source. It
// uses only some of them (`dead_code`), and their unit tests run with the binary's, not in
// this target without a test harness (their `use super::*` is unused here).
#[path = "../src/cli/studies/mod.rs"]
#[allow(dead_code, unused_imports)]
mod studies;

use studies::mixture::{paper_tables, TablesConfig};

fn main() {
    let mut args = std::env::args().skip(1);
    let mut config = TablesConfig {
        methods: vec!["rsa".into(), "md".into()],
        counts: vec![10, 20, 30, 40, 50],
        runs: 5,
        limit: 10.0,
        cells: None,
        cpu: true,
    };
    let mut out = None::<String>;
    while let Some(a) = args.next() {
        match a.as_str() {
            "--quick" => {
                config.counts = vec![50];
                config.runs = 3;
            }
            "--only" => config.methods = vec![args.next().expect("--only rsa|md")],
            "--counts" => {
                config.counts = args
                    .next()
                    .expect("--counts N,N")
                    .split(',')
                    .map(|x| x.parse().expect("count"))
                    .collect()
            }
            "--runs" => config.runs = args.next().expect("--runs N").parse().expect("runs"),
            "--limit" => config.limit = args.next().expect("--limit S").parse().expect("seconds"),
            "--out" => out = args.next(),
            "--cells" => {
                config.cells = Some(
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
            "--cpu" => config.cpu = true,
            "--wall" => config.cpu = false,
            "--bench" => {}
            other => panic!("unknown argument {other}"),
        }
    }
    let text = paper_tables(&config).markdown;
    print!("{text}");
    if let Some(path) = out {
        std::fs::write(&path, text).expect("write --out");
    }
}
