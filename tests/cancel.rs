//! Cancellation: a run given a cancel flag stops soon after another thread sets it, with
//! `RunError::Cancelled` and no packing, in every part of a run (EDMD stages, RSA seeding,
//! mixture adsorption and relaxation).

mod common;

use densepack::io::scene::AnyScene;
use densepack::run::{run, RunError, RunOptions};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// 10 000 spheres grown to Z = 10¹² at a slow rate: minutes of work (the flag stops it).
const LONG_RUN: &str = r#"
seed = 1
[container]
type = "box"
size = [22.0, 22.0, 22.0]
periodic = [true, true, true]
[particles]
count = 10000
diameter = 1.0
packing_fraction = 0.3
[[stage]]
growth = "relative"
rate = 0.001
until = { reduced_pressure = 1e12 }
"#;

/// Runs `scene` with a flag that a second thread sets after `delay`; the run's result, the
/// time from start to return and the latency from the flag to the return.
fn cancelled_after(
    scene: &AnyScene,
    delay: Duration,
) -> (Result<(), RunError>, Duration, Duration) {
    let flag = Arc::new(AtomicBool::new(false));
    let started = Instant::now();
    std::thread::scope(|s| {
        let setter = {
            let flag = flag.clone();
            s.spawn(move || {
                std::thread::sleep(delay);
                flag.store(true, Ordering::Relaxed);
                Instant::now()
            })
        };
        let options = RunOptions {
            cancel: Some(flag.clone()),
            ..RunOptions::default()
        };
        let result = run(scene, options).map(|_| ());
        let returned = Instant::now();
        let set_at = setter.join().expect("the setter runs");
        (
            result,
            returned - started,
            returned.saturating_duration_since(set_at),
        )
    })
}

#[test]
fn a_long_sphere_run_stops_within_a_second_of_the_flag() {
    let scene = AnyScene::from_toml(LONG_RUN).unwrap();
    let (result, total, latency) = cancelled_after(&scene, Duration::from_millis(1500));
    eprintln!("cancelled after {total:?}, {latency:?} after the flag was set");
    assert!(
        matches!(result, Err(RunError::Cancelled)),
        "the run ends cancelled: {result:?}"
    );
    assert_eq!(
        result.unwrap_err().to_string(),
        "the run was cancelled",
        "the message says so"
    );
    // The run was still going when the flag was set (it needs minutes), so this measures
    // the stop, not the run's end.
    assert!(total >= Duration::from_millis(1500), "{total:?}");
    // A correctness bound on responsiveness (the flag is checked every 1000 events and at
    // every barrier: milliseconds of work), not a speed threshold: a caller such as a
    // notebook interrupt or a Dask cancellation must get control back promptly.
    assert!(latency < Duration::from_secs(1), "{latency:?}");
}

/// A flag set before the start stops each kind of run at its first check, before any
/// result: the checks are in the seeding and in both mixture methods too.
#[test]
fn a_flag_set_before_the_start_stops_every_kind_of_run() {
    let rsa_forever = LONG_RUN.replace(
        "packing_fraction = 0.3",
        "packing_fraction = 0.6\nrsa_max_failures = 1000000000000",
    );
    let mixture = |method: &str| {
        format!(
            "seed = 1\n[mixture]\nmethod = \"{method}\"\nsphere_fraction = 0.15\n\
             cylinder_fraction = 0.35\nspheres = 50\ncylinders = 50\naspect_ratio = 5.0\n"
        )
    };
    for (name, text) in [
        ("spheres", LONG_RUN.to_string()),
        ("RSA seeding", rsa_forever),
        ("mixture rsa", mixture("rsa")),
        ("mixture md", mixture("md")),
    ] {
        let scene = AnyScene::from_toml(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
        let options = RunOptions {
            cancel: Some(Arc::new(AtomicBool::new(true))),
            ..RunOptions::default()
        };
        let started = Instant::now();
        let result = run(&scene, options);
        assert!(
            matches!(result, Err(RunError::Cancelled)),
            "{name}: {:?}",
            result.map(|o| o.packing.stats)
        );
        eprintln!("{name}: cancelled in {:?}", started.elapsed());
    }
}

/// Seeding that can never finish (φ = 0.6 by RSA, 10¹² rejections allowed) and the relaxer
/// on a start it cannot relax in time stop within a second of the flag as well.
#[test]
fn seeding_and_relaxation_stop_within_a_second_of_the_flag() {
    let rsa_forever = LONG_RUN.replace(
        "packing_fraction = 0.3",
        "packing_fraction = 0.6\nrsa_max_failures = 1000000000000",
    );
    let relax_long = "seed = 1\n[mixture]\nmethod = \"md\"\nsphere_fraction = 0.2\n\
                      cylinder_fraction = 0.4\nspheres = 400\ncylinders = 400\n\
                      aspect_ratio = 5.0\n[mixture.relax]\nmax_steps = 100000000\n";
    for (name, text) in [
        ("RSA seeding", rsa_forever.as_str()),
        ("relaxer", relax_long),
    ] {
        let scene = AnyScene::from_toml(text).unwrap_or_else(|e| panic!("{name}: {e}"));
        let (result, total, latency) = cancelled_after(&scene, Duration::from_millis(500));
        eprintln!("{name}: cancelled after {total:?}, {latency:?} after the flag");
        assert!(
            matches!(result, Err(RunError::Cancelled)),
            "{name}: {result:?}"
        );
        assert!(total >= Duration::from_millis(500), "{name}: {total:?}");
        assert!(latency < Duration::from_secs(1), "{name}: {latency:?}");
    }
}

/// A cancelled realisation of an ensemble is `lost`: no packing, and the resume rule runs
/// it again.
#[test]
fn a_cancelled_realisation_is_lost_and_runs_again() {
    use densepack::ensemble::{packing_path, run_realisation, seeds_to_run, Status, SummaryWriter};
    let dir = common::temp_dir("lost");
    let mut summary = SummaryWriter::open(&dir).unwrap();
    let scene = AnyScene::from_toml(LONG_RUN).unwrap();
    let row = run_realisation(&scene, 3, &dir, Some(Arc::new(AtomicBool::new(true))));
    assert_eq!(row.seed, 3);
    assert_eq!(row.status, Status::Lost);
    assert_eq!(row.message, "the run was cancelled");
    assert_eq!(row.packing_fraction, None);
    assert!(!packing_path(&dir, 3).exists());
    summary.append(&row).unwrap();
    assert_eq!(seeds_to_run(&dir, &[3]).unwrap(), [3]);
}
