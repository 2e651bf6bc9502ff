//! Profiling driver for the mixture RSA (BENCHMARKS.md, issue 5): one cell of the paper's
//! tables (`N` spheres + `N` cylinders, aspect ratio `A`, fractions `FS`, `FC`) over the
//! seeds `SEED0 .. SEED0 + SEEDS` (`REPEAT` times), with the bench's limits; prints the
//! process CPU seconds per packing, candidates and restarts per packing, and a hash of
//! every centre (to check that a change leaves the packings bit-identical). Run it under
//! `valgrind --tool=callgrind` or `perf record` for a profile of one cell.
//!
//! ```sh
//! cargo run --release --example rsa_cell -- 10 3 0.2 0.05 0 200
//! ```
use densepack::protocol::mixture::rsa::{rsa_mixture, RsaLimits};
use densepack::protocol::mixture::{GenerationOrder, MixtureSpec};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::hash::{Hash, Hasher};
use std::time::Duration;
const USAGE: &str = "usage: rsa_cell N A FS FC SEED0 SEEDS [REPEAT]";

/// Argument `i` (named `name` in the error) parsed as a `T`.
fn arg<T: std::str::FromStr>(args: &[String], i: usize, name: &str) -> T {
    let text = args
        .get(i)
        .unwrap_or_else(|| panic!("missing {name}; {USAGE}"));
    text.parse()
        .unwrap_or_else(|_| panic!("{name} = {text:?} is not a valid number; {USAGE}"))
}

fn main() {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let n: usize = arg(&a, 0, "N (bodies of each kind)");
    let spec = MixtureSpec {
        sphere_fraction: arg(&a, 2, "FS"),
        cylinder_fraction: arg(&a, 3, "FC"),
        spheres: n,
        cylinders: n,
        aspect_ratio: arg(&a, 1, "A"),
        box_size: 1.0,
    };
    if let Err(e) = spec.validate() {
        panic!("{e}");
    }
    let seed0: u64 = arg(&a, 4, "SEED0");
    let seeds: u64 = arg(&a, 5, "SEEDS");
    let repeat: u32 = if a.len() > 6 { arg(&a, 6, "REPEAT") } else { 1 };
    let boundary = spec.boundary();
    let sizes = spec.sizes(GenerationOrder::CylindersFirst);
    let limits = RsaLimits {
        time_limit: Some(Duration::from_secs_f64(5.0)),
        max_attempts_per_body: 1_000_000,
        max_restarts: u32::MAX,
    };
    let t = cpu_time::ProcessTime::now();
    let (mut ok, mut cand, mut restarts) = (0u64, 0u64, 0u64);
    let mut h = std::collections::hash_map::DefaultHasher::new();
    for _ in 0..repeat {
        for seed in seed0..seed0 + seeds {
            let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
            if let Ok(o) = rsa_mixture(&boundary, &sizes, &limits, None, &mut rng) {
                ok += 1;
                cand += o.candidates;
                restarts += u64::from(o.restarts);
                for b in &o.rve.bodies {
                    for k in 0..3 {
                        b.center()[k].to_bits().hash(&mut h);
                    }
                }
            }
        }
    }
    let cpu = t.elapsed().as_secs_f64();
    let runs = (seeds * u64::from(repeat)) as f64;
    println!(
        "{n} {} {} {}: cpu/packing {:.4e} s ok {} cand/packing {:.1} restarts/packing {:.2} hash {:016x}",
        a[1], a[2], a[3], cpu / runs, ok, cand as f64 / ok as f64, restarts as f64 / ok as f64, h.finish()
    );
}
