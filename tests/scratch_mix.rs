use densepack::protocol::mixture::relax::{random_rve, relax, RelaxSettings};
use densepack::protocol::mixture::rsa::{rsa_mixture, RsaLimits};
use densepack::protocol::mixture::{GenerationOrder, MixtureSpec};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::time::Duration;

fn env(name: &str, d: f64) -> f64 { std::env::var(name).ok().and_then(|v| v.parse().ok()).unwrap_or(d) }

#[test]
fn scratch() {
    let spec = MixtureSpec { sphere_fraction: env("FS", 0.05), cylinder_fraction: env("FC", 0.3), spheres: env("N", 50.0) as usize, cylinders: env("N", 50.0) as usize, aspect_ratio: env("A", 5.0), box_size: 1.0 };
    for seed in 0..env("RUNS", 3.0) as u64 {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        let t = std::time::Instant::now();
        if env("MD", 0.0) == 0.0 {
            let limits = RsaLimits { time_limit: Some(Duration::from_secs(20)), max_attempts_per_body: env("ATT", 100000.0) as u64, ..Default::default() };
            match rsa_mixture(&spec.boundary(), &spec.sizes(GenerationOrder::CylindersFirst), &limits, &mut rng) {
                Ok(o) => println!("ok {:.3}s candidates {} restarts {}", t.elapsed().as_secs_f64(), o.candidates, o.restarts),
                Err(e) => println!("fail {:.3}s {e}", t.elapsed().as_secs_f64()),
            }
        } else {
            let mut rve = random_rve(&spec.boundary(), &spec.sizes(GenerationOrder::CylindersFirst), &mut rng);
            let d = RelaxSettings::default();
            let s = RelaxSettings { time_limit: Some(Duration::from_secs(30)), damping: env("BETA", d.damping), time_step: env("DT", d.time_step), max_prefactor: env("KMAX", d.max_prefactor), initial_prefactor: env("K0", d.initial_prefactor), berendsen_rate: env("ABER", d.berendsen_rate), nose_hoover_temperature: env("TNH", d.nose_hoover_temperature), nose_hoover_rate: env("ANH", d.nose_hoover_rate), stagnation_steps: env("STAG", d.stagnation_steps as f64) as u64, ..d };
            match relax(&mut rve, &s) {
                Ok(r) => println!("ok {:.3}s {:?}", t.elapsed().as_secs_f64(), r),
                Err(e) => println!("fail {:.3}s {e}", t.elapsed().as_secs_f64()),
            }
        }
    }
}
