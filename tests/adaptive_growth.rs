//! The pressure-adaptive growth rate: the law, the rate the kernel applies at each barrier,
//! and the growth it reports against the radii the particles actually gained.

mod common;

use common::assert_no_overlap;
use densepack::boundary::PeriodicBox;
use densepack::kernel::{
    Edmd, KernelConfig, Limits, PressureAdaptive, Progress, RateSchedule, Stage, StopReason, Until,
};
use densepack::protocol::rsa::rsa_spheres;
use densepack::queue::CalendarQueue;
use densepack::shape::{Collidable, Growth, Sphere, Vec3};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

const LAW: PressureAdaptive = PressureAdaptive {
    onset: 100.0,
    exponent: 0.5,
    min_rate: 0.004,
};

#[test]
fn the_rate_law_is_full_below_the_onset_then_falls_as_a_power_to_its_floor() {
    let base = 0.1;
    assert_eq!(LAW.rate(base, f64::NAN), base);
    assert_eq!(LAW.rate(base, 50.0), base);
    assert_eq!(LAW.rate(base, 100.0), base);
    // (100/400)^0.5 = 1/2, (100/10⁴)^0.5 = 1/10.
    assert!((LAW.rate(base, 400.0) - 0.05).abs() < 1e-15);
    assert!((LAW.rate(base, 1e4) - 0.01).abs() < 1e-15);
    assert_eq!(LAW.rate(base, 1e12), 0.004);
}

/// 600 spheres in a periodic box, seeded at φ = 0.3.
fn kernel() -> Edmd<Sphere, PeriodicBox, CalendarQueue> {
    let n = 600;
    let edge = 9.0;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
    let boundary = PeriodicBox {
        min: Vec3::zeros(),
        len: Vec3::new(edge, edge, edge),
    };
    let r = 0.5 * (0.3 * edge.powi(3) / (n as f64 * std::f64::consts::PI / 6.0)).cbrt();
    let radii = vec![r; n];
    let centres = rsa_spheres(&boundary, &radii, 0.0, 0.0, 1_000_000, None, &mut rng).unwrap();
    let shapes = radii.iter().map(|&r| Sphere::new(r)).collect();
    Edmd::new(centres, shapes, boundary, KernelConfig::default(), &mut rng)
}

#[test]
fn an_adaptive_stage_applies_the_law_at_every_barrier_and_reports_the_radius_gained() {
    let mut kernel = kernel();
    let r0 = kernel.particles()[0].shape.bounding_radius(0.0);
    let base = 0.1;
    let stage = Stage {
        growth: Growth::Absolute(base),
        schedule: RateSchedule::PressureAdaptive(LAW),
        until: Until {
            reduced_pressure: Some(1e8),
            ..Until::default()
        },
        limits: Limits::default(),
        thermostat: true,
        wall_growth: 1.0,
    };
    let mut seen: Vec<Progress> = Vec::new();
    let report = kernel.run_stage_observed(&stage, &mut |p| seen.push(p.clone()));
    assert_eq!(report.stop_reason, StopReason::PressureReached);
    assert!(seen.len() > 10);
    // The rate of each interval is the law at the pressure of the interval before it.
    for w in seen.windows(2) {
        assert_eq!(
            w[1].rate,
            LAW.rate(base, w[1].reduced_pressure),
            "{:?}",
            w[1]
        );
        // The growth so far, recomputed from the observed times and rates.
        let expected = w[0].grown + w[0].rate * (w[1].stage_time - w[0].stage_time);
        assert!(
            (w[1].grown - expected).abs() <= 1e-9 * expected,
            "grown {} vs {expected}",
            w[1].grown
        );
    }
    let last = seen.last().unwrap();
    assert_eq!(
        last.rate, LAW.min_rate,
        "Z = 1e8 is far above the floor's onset"
    );
    // Under absolute growth every radius gained the same: the integral of the rate up to
    // the last barrier plus the last interval at the last rate.
    let gained = kernel.particles()[0].shape.bounding_radius(0.0) - r0;
    let integral = last.grown + last.rate * (report.simulated_time - last.stage_time);
    assert!(
        (gained - integral).abs() <= 1e-9 * gained,
        "radius gained {gained} vs ∫ rate dt = {integral}"
    );
}

#[test]
fn a_scene_with_an_adaptive_rate_jams_and_rejects_goals_that_need_a_fixed_rate() {
    let scene = |goal: &str| {
        format!(
            "seed = 3\n[container]\ntype = \"box\"\nsize = [9.0, 9.0, 9.0]\n\
             periodic = [true, true, true]\n[particles]\ncount = 600\ndiameter = 1.0\n\
             packing_fraction = 0.3\n[[stage]]\ngrowth = \"relative\"\nrate = 0.1\n\
             adaptive = {{ onset_pressure = 100.0, exponent = 0.5, min_rate = 0.004 }}\n\
             until = {{ {goal} }}\n"
        )
    };
    let outcome = common::run_toml(&scene("reduced_pressure = 1e9"));
    assert_eq!(outcome.packing.stats.stop_reason, "pressure_reached");
    assert_no_overlap(&outcome.packing);
    let refused = densepack::io::scene::Scene::from_toml(&scene("packing_fraction = 0.6"));
    let message = refused.unwrap_err().to_string();
    assert!(message.contains("stage[0].adaptive"), "{message}");
    let bad_floor = scene("reduced_pressure = 1e9").replace("min_rate = 0.004", "min_rate = 0.5");
    let message = densepack::io::scene::Scene::from_toml(&bad_floor)
        .unwrap_err()
        .to_string();
    assert!(message.contains("stage[0].adaptive.min_rate"), "{message}");
}
