//! Numerical stress of the EDMD kernel — spheres: runs to jamming and long runs near it, wide
//! size ratios, degenerate starts, scale covariance and far-off coordinates; ellipsoids of
//! aspect ratio 50 (prolate and oblate, periodic and walled) grown towards jamming — and of
//! the sphere + cylinder relaxer on starts with parallel, crossing and coincident axes.
//!
//! Every case is watched at every time barrier: the kernel is synchronised there, and its
//! particles are handed to the independent check (`densepack::verify`, which shares no code
//! with the kernel) — so "no overlap" holds for the whole run, not only for the final
//! packing. Each case prints a row: stop reason, packing fraction, the smallest pair gap
//! and wall gap ever seen (relative; negative = overlap within the check's 1e-9 tolerance;
//! for ellipsoids the Perram–Wertheim contact scale less one), and the kernel's counters,
//! among them `late` (events whose predicted time had already passed: rounding in a
//! prediction), `repred` (local lists predicted afresh) and `pfail` (ellipsoid predictions
//! that gave up and answered conservatively: the numerical-failure counter).
//!
//! Sizes: reduced by default (the whole target takes about a minute in release mode, run by
//! CI); `DENSEPACK_STRESS=full cargo test --release --test stress -- --nocapture` runs the
//! full sizes (10⁴ spheres, 10⁷ events near jamming, size ratio 100; tens of minutes).
//!
//! Ellipsoids run as `Edmd<Ellipsoid, …>` kernels through the same [`watch_stage`]; the
//! mixture relaxer (time-driven, no barriers) is checked on its result, by the exact typed
//! tests and by the independent GJK certificates.

mod common;

use densepack::boundary::{Boundary, PeriodicBox, WalledBox};
use densepack::io::packing::{Packing, ParticleRecord};
use densepack::io::record::{EllipsoidRecord, SphereRecord};
use densepack::kernel::{
    Edmd, EventCounts, KernelConfig, Limits, Particle, RateSchedule, Stage, StopReason, Until,
};
use densepack::protocol::mixture::relax::{relax, RelaxSettings};
use densepack::protocol::mixture::{
    first_intersection, BodySize, GenerationOrder, MixtureSpec, Rve,
};
use densepack::protocol::rsa::rsa_spheres;
use densepack::queue::CalendarQueue;
use densepack::run::mixture_packing;
use densepack::run::SceneContainer;
use densepack::shape::ellipsoid::Spin;
use densepack::shape::{Collidable, Ellipsoid, Growth, Sphere, Vec3};
use densepack::verify::verify;
use nalgebra::{Quaternion, UnitQuaternion};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

type Kernel<S, B> = Edmd<S, B, CalendarQueue>;

/// What the watch needs of a particle shape: its packing record and its smallest size.
trait Recorded: Collidable {
    fn record(p: &Particle<Self>) -> ParticleRecord;
    /// Smallest half-width: a sphere's radius, an ellipsoid's smallest semi-axis.
    fn min_half_width(&self) -> f64;
}

impl Recorded for Sphere {
    fn record(p: &Particle<Self>) -> ParticleRecord {
        ParticleRecord::Sphere(SphereRecord {
            center: p.pos.into(),
            radius: p.shape.radius(0.0),
        })
    }
    fn min_half_width(&self) -> f64 {
        self.radius(0.0)
    }
}

impl Recorded for Ellipsoid {
    fn record(p: &Particle<Self>) -> ParticleRecord {
        let q = p.spin.orientation;
        ParticleRecord::Ellipsoid(EllipsoidRecord {
            center: p.pos.into(),
            semi_axes: p.shape.semi_axes(0.0).into(),
            orientation: [q.w, q.i, q.j, q.k],
        })
    }
    fn min_half_width(&self) -> f64 {
        self.min_semi_axis(0.0)
    }
}

fn full() -> bool {
    std::env::var("DENSEPACK_STRESS").is_ok_and(|v| v == "full")
}

/// Reduced or full size.
fn size(reduced: usize, full_size: usize) -> usize {
    if full() {
        full_size
    } else {
        reduced
    }
}

/// What a watched run saw.
#[derive(Debug, Default)]
struct Watch {
    /// Barriers checked.
    checks: usize,
    /// Smallest `|c_i − c_j| / (r_i + r_j) − 1` ever seen (ellipsoids: the Perram–Wertheim
    /// contact scale less one).
    min_pair_gap: f64,
    /// Smallest particle–wall gap ever seen, divided by the smallest half-width.
    min_wall_gap: f64,
    /// Violations the independent check reported, over all barriers.
    violations: usize,
    /// First violation message.
    first_violation: Option<String>,
    /// Packing fraction at every barrier.
    trajectory: Vec<f64>,
}

impl Watch {
    fn new() -> Self {
        Self {
            min_pair_gap: f64::INFINITY,
            min_wall_gap: f64::INFINITY,
            ..Self::default()
        }
    }

    /// Checks the synchronised kernel with the independent verification.
    fn check<S: Recorded, B: Boundary + SceneContainer>(&mut self, kernel: &Kernel<S, B>) {
        let packing = packing_of(kernel);
        let report = verify(&packing);
        self.checks += 1;
        if let Some(g) = report.min_pair_gap_relative {
            self.min_pair_gap = self.min_pair_gap.min(g);
        }
        if let Some(g) = report.min_wall_gap {
            let r_min = kernel
                .particles()
                .iter()
                .map(|p| p.shape.min_half_width())
                .fold(f64::INFINITY, f64::min);
            self.min_wall_gap = self.min_wall_gap.min(g / r_min);
        }
        self.violations += report.violation_count;
        if self.first_violation.is_none() {
            self.first_violation = report.violations.first().cloned();
        }
        self.trajectory.push(report.packing_fraction);
    }
}

fn packing_of<S: Recorded, B: Boundary + SceneContainer>(kernel: &Kernel<S, B>) -> Packing {
    let particles = kernel.particles().iter().map(S::record).collect();
    Packing::new(kernel.boundary().record(), particles)
}

/// Runs a stage, checking the kernel at every barrier and at the end.
fn watch_stage<S: Recorded, B: Boundary + SceneContainer>(
    kernel: &mut Kernel<S, B>,
    stage: &Stage,
    watch: &mut Watch,
) -> StopReason {
    let progress = kernel.start_stage(stage);
    let report = kernel.continue_stage(stage, progress, &mut |k, _| watch.check(k));
    watch.check(kernel);
    report.stop_reason
}

/// One row of the table.
struct Row {
    name: String,
    n: usize,
    stops: Vec<StopReason>,
    phi: f64,
    seconds: f64,
    watch: Watch,
    counts: EventCounts,
}

fn header() {
    eprintln!(
        "{:<34} {:>6} {:>9} {:>10} {:>10} {:>6} {:>11} {:>11} {:>9} {:>7} {:>7} {:>6} {:>6} {:>5} {:>7} {:>6}  stops",
        "case", "N", "phi", "min gap", "min wall", "checks", "events", "collisions", "walls",
        "nl upd", "stale", "repred", "late", "pfail", "barrier", "s"
    );
}

impl Row {
    fn print(&self) {
        let c = &self.counts;
        let stops: Vec<&str> = self.stops.iter().map(|s| s.as_str()).collect();
        eprintln!(
            "{:<34} {:>6} {:>9.6} {:>10.2e} {:>10.2e} {:>6} {:>11} {:>11} {:>9} {:>7} {:>7} {:>6} {:>6} {:>5} {:>7} {:>6.1}  {}",
            self.name,
            self.n,
            self.phi,
            self.watch.min_pair_gap,
            self.watch.min_wall_gap,
            self.watch.checks,
            c.events,
            c.collisions,
            c.wall_collisions,
            c.neighbour_list_updates,
            c.stale,
            c.repredictions,
            c.late_events,
            c.prediction_failures,
            c.barriers,
            self.seconds,
            stops.join(",")
        );
    }

    /// The independent check never found an overlap or a sphere outside the container.
    fn assert_clean(&self) {
        assert_eq!(
            self.watch.violations, 0,
            "{}: {} violations, first: {:?}",
            self.name, self.watch.violations, self.watch.first_violation
        );
        assert!(self.watch.checks > 0);
    }
}

/// Runs `stages` on a kernel and returns the row.
fn run_case<S: Recorded, B: Boundary + SceneContainer>(
    name: &str,
    mut kernel: Kernel<S, B>,
    stages: &[Stage],
) -> (Row, Kernel<S, B>) {
    let started = std::time::Instant::now();
    let mut watch = Watch::new();
    watch.check(&kernel);
    let stops = stages
        .iter()
        .map(|s| watch_stage(&mut kernel, s, &mut watch))
        .collect();
    let row = Row {
        name: name.into(),
        n: kernel.particles().len(),
        stops,
        phi: kernel.packing_fraction_at(0.0),
        seconds: started.elapsed().as_secs_f64(),
        watch,
        counts: kernel.counters(),
    };
    row.print();
    row.assert_clean();
    (row, kernel)
}

/// Spheres of the given diameters seeded by RSA, Maxwell–Boltzmann velocities at `kT`.
fn seeded<B: Boundary>(boundary: B, diameters: &[f64], seed: u64, kt: f64) -> Kernel<Sphere, B> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let radii: Vec<f64> = diameters.iter().map(|d| 0.5 * d).collect();
    let centres =
        rsa_spheres(&boundary, &radii, 0.0, 0.0, 1_000_000, None, &mut rng).expect("RSA seeds");
    let shapes = radii.iter().map(|&r| Sphere::new(r)).collect();
    let config = KernelConfig {
        temperature: kt,
        ..KernelConfig::default()
    };
    Edmd::new(centres, shapes, boundary, config, &mut rng)
}

/// Placed spheres (no RSA), Maxwell–Boltzmann velocities at kT = 1.
fn placed<B: Boundary>(
    boundary: B,
    centres: Vec<Vec3>,
    diameter: f64,
    seed: u64,
) -> Kernel<Sphere, B> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let shapes = vec![Sphere::new(0.5 * diameter); centres.len()];
    Edmd::new(centres, shapes, boundary, KernelConfig::default(), &mut rng)
}

/// Equal diameters giving packing fraction `phi` for `n` spheres in volume `volume`.
fn diameter_for(n: usize, phi: f64, volume: f64) -> f64 {
    (6.0 * phi * volume / (std::f64::consts::PI * n as f64)).cbrt()
}

fn cube(edge: f64) -> PeriodicBox {
    PeriodicBox {
        min: Vec3::zeros(),
        len: Vec3::repeat(edge),
    }
}

fn walled_cube(min: f64, edge: f64) -> WalledBox {
    WalledBox {
        min: Vec3::repeat(min),
        max: Vec3::repeat(min + edge),
        periodic: [false; 3],
    }
}

fn grow_to_jamming(rate: f64) -> Stage {
    Stage {
        growth: Growth::Relative(rate),
        schedule: RateSchedule::Fixed,
        until: Until {
            reduced_pressure: Some(1e12),
            ..Until::default()
        },
        limits: Limits {
            events: 2_000_000_000,
            ..Limits::default()
        },
        thermostat: true,
        wall_growth: 1.0,
    }
}

fn equilibrate(collisions_per_particle: f64) -> Stage {
    Stage {
        growth: Growth::None,
        schedule: RateSchedule::Fixed,
        until: Until {
            collisions_per_particle: Some(collisions_per_particle),
            ..Until::default()
        },
        limits: Limits::default(),
        thermostat: false,
        wall_growth: 1.0,
    }
}

fn jam_row<B: Boundary + SceneContainer>(
    name: &str,
    kernel: Kernel<Sphere, B>,
    rattle: f64,
    jam_from: f64,
) -> Row {
    // A short fluid run first: the kernel's prediction pass leaves the growth terms out
    // while nothing grows, and must take them up again when the growth begins.
    let stages = [equilibrate(2.0), grow_to_jamming(0.05), equilibrate(rattle)];
    let (row, _) = run_case(name, kernel, &stages);
    assert_eq!(row.stops[0], StopReason::CollisionsReached, "{name}");
    assert_eq!(row.stops[1], StopReason::PressureReached, "{name}");
    assert_eq!(row.stops[2], StopReason::CollisionsReached, "{name}");
    assert!(
        row.phi > jam_from && row.phi < 0.74049,
        "{name}: jammed at φ = {}",
        row.phi
    );
    row
}

/// Equal spheres, periodic and walled: a short fluid run, grown to Z = 10¹², then run
/// without growth at that pressure (rattling in cages of relative width ~10⁻¹²) for many
/// collisions per particle.
#[test]
fn jamming_and_long_runs_near_jamming_equal_spheres() {
    header();
    let n = size(1000, 10_000);
    let rattle = if full() { 1000.0 } else { 150.0 };
    let edge = 12.0 * (n as f64 / 1000.0).cbrt();
    let d = diameter_for(n, 0.3, edge.powi(3));
    let periodic = seeded(cube(edge), &vec![d; n], 1, 1.0);
    jam_row("jam + rattle, periodic, equal", periodic, rattle, 0.62);
    let walled = seeded(walled_cube(0.0, edge), &vec![d; n], 2, 1.0);
    // Walls order the spheres next to them: a walled packing jams lower.
    jam_row("jam + rattle, walled, equal", walled, rattle, 0.55);
}

/// Two sizes, ratio 10 (reduced) and 100 (full): a jammed skeleton of large spheres with
/// small ones rattling in its voids, seven grid levels at ratio 100; and a ratio-4 mixture
/// of comparable volume fractions in walls.
#[test]
fn jamming_wide_size_ratios() {
    header();
    let ratio = if full() { 100.0 } else { 10.0 };
    let n = size(400, 5000);
    let edge = 10.0 * (n as f64 / 600.0).cbrt();
    let mut diameters = vec![1.0; n];
    diameters.extend(vec![1.0 / ratio; n]);
    let scale = (0.3 * edge.powi(3) / (n as f64 * std::f64::consts::PI / 6.0)).cbrt();
    for d in &mut diameters {
        *d *= scale;
    }
    let kernel = seeded(cube(edge), &diameters, 3, 1.0);
    let name = format!("jam, periodic, ratio {ratio}");
    let (row, _) = run_case(&name, kernel, &[grow_to_jamming(0.05), equilibrate(50.0)]);
    assert_eq!(row.stops[0], StopReason::PressureReached);

    // Ratio 4 with equal volumes of both sizes, walled.
    let n_small = size(960, 12_800);
    let n_large = n_small / 64;
    let mut diameters = vec![4.0; n_large];
    diameters.extend(vec![1.0; n_small]);
    let volume: f64 = diameters
        .iter()
        .map(|d| std::f64::consts::PI / 6.0 * d * d * d)
        .sum();
    let edge = (volume / 0.3).cbrt();
    let kernel = seeded(walled_cube(0.0, edge), &diameters, 4, 1.0);
    let (row, _) = run_case(
        "jam, walled, ratio 4 (equal volumes)",
        kernel,
        &[grow_to_jamming(0.05)],
    );
    assert_eq!(row.stops[0], StopReason::PressureReached);
}

/// Lattice positions `spacing·(i + offset)` for `k³` spheres.
fn lattice(k: usize, spacing: f64, offset: f64) -> Vec<Vec3> {
    (0..k * k * k)
        .map(|m| {
            let (i, j, l) = (m % k, (m / k) % k, m / (k * k));
            Vec3::new(i as f64, j as f64, l as f64).add_scalar(offset) * spacing
        })
        .collect()
}

/// Degenerate starts: many simultaneous collisions, spheres touching each other, walls and
/// corners from the start, spheres at rest.
#[test]
fn degenerate_starts() {
    header();
    let k = 8;
    // Simple cubic lattice, every sphere at the same speed, neighbours along each axis
    // approaching head-on: all pairs collide at the same instant, again and again.
    let mut kernel = placed(cube(k as f64 * 1.5), lattice(k, 1.5, 0.0), 1.0, 5);
    let sign = |i: usize| if i.is_multiple_of(2) { 1.0 } else { -1.0 };
    kernel.set_velocities(|m| Vec3::new(sign(m % k), sign((m / k) % k), sign(m / (k * k))));
    let (row, _) = run_case(
        "sc lattice, equal speeds, grow",
        kernel,
        &[equilibrate(20.0), grow_to_jamming(0.05)],
    );
    assert_eq!(row.stops[1], StopReason::PressureReached);

    // Touching neighbours and walls everywhere: the lattice fills the walled box exactly, so
    // every row of spheres is rigid between two walls and its momentum bounces through it
    // in zero time (Newton's cradle without end). The kernel must say so — stalled —
    // rather than loop or overlap.
    let rigid = placed(walled_cube(0.0, k as f64), lattice(k, 1.0, 0.5), 1.0, 6);
    let mut for_a_while = equilibrate(50.0);
    for_a_while.until = Until {
        time: Some(1.0),
        ..Until::default()
    };
    let (row, _) = run_case("sc lattice filling walled box", rigid, &[for_a_while]);
    assert_eq!(row.stops[0], StopReason::Stalled);
    // The same lattice touching the three lower walls, with room to move: the touching
    // contacts resolve (cradles of finite length) and the spheres grow to jamming.
    let touching = placed(
        walled_cube(0.0, k as f64 + 0.5),
        lattice(k, 1.0, 0.5),
        1.0,
        6,
    );
    let (row, _) = run_case(
        "sc lattice touching, 3 walls, grow",
        touching,
        &[equilibrate(50.0), grow_to_jamming(0.05)],
    );
    assert_eq!(row.stops[1], StopReason::PressureReached);

    // Spheres in all 8 corners touching three walls, plus touching pairs in between.
    let edge = 6.0;
    let mut centres = Vec::new();
    for m in 0..8 {
        let pick = |bit: usize| if m >> bit & 1 == 0 { 0.5 } else { edge - 0.5 };
        centres.push(Vec3::new(pick(0), pick(1), pick(2)));
    }
    for z in [2.0, 3.0, 4.0] {
        centres.push(Vec3::new(2.5, 3.0, z));
        centres.push(Vec3::new(3.5, 3.0, z));
    }
    let corners = placed(walled_cube(0.0, edge), centres, 1.0, 7);
    let (row, _) = run_case(
        "corners and touching pairs, grow",
        corners,
        &[equilibrate(100.0), grow_to_jamming(0.05)],
    );
    assert_eq!(row.stops[1], StopReason::PressureReached);

    // At rest: only growth brings spheres into contact; the thermostat then has energy to
    // scale.
    let n = size(500, 5000);
    let edge = 9.0 * (n as f64 / 500.0).cbrt();
    let d = diameter_for(n, 0.3, edge.powi(3));
    let mut at_rest = seeded(cube(edge), &vec![d; n], 8, 1.0);
    at_rest.set_velocities(|_| Vec3::zeros());
    let (row, _) = run_case("at rest, grow", at_rest, &[grow_to_jamming(0.05)]);
    assert_eq!(row.stops[0], StopReason::PressureReached);

    // At rest without growth: nothing ever happens, and the stage says so instead of
    // waiting forever.
    let mut frozen = seeded(cube(edge), &vec![d; n], 9, 1.0);
    frozen.set_velocities(|_| Vec3::zeros());
    let mut stage = equilibrate(10.0);
    stage.until.reduced_pressure = Some(10.0);
    let (row, _) = run_case("at rest, no growth", frozen, &[stage]);
    assert!(!row.stops[0].is_success(), "{:?}", row.stops);
    assert_eq!(row.counts.events, 0);
}

/// A jamming run with every length scaled by `s` (and kT by s², so that velocities scale by
/// s and times do not change): the packing fraction at every barrier, the final packing
/// fraction, the counters and the kernel.
fn scaled_run(s: f64, n: usize) -> (Row, Kernel<Sphere, PeriodicBox>) {
    let edge = 9.0 * s;
    let d = diameter_for(n, 0.3, 9.0f64.powi(3)) * s;
    let kernel = seeded(cube(edge), &vec![d; n], 10, s * s);
    run_case(&format!("scale {s:e}"), kernel, &[grow_to_jamming(0.05)])
}

/// Scale covariance, at two levels.
///
/// **Kernel.** EDMD with lengths ×s, kT ×s² (velocities ×s, times unchanged) and the relative
/// growth rate unchanged computes every time and every ratio from quantities that all scale
/// by the same power of s. Multiplying by a power of two is exact in floating point, so with
/// s = 2^±10 ≈ 10^∓3 the kernel run is *identical*: the same events in the same order, the
/// same packing-fraction trajectory bit for bit, centres exactly s times the reference. Given
/// inputs multiplied by s = 10^±3 in floating point, the kernel sees inputs that round
/// differently at the last bit, and hard-sphere dynamics amplifies such differences (positive
/// Lyapunov exponent): the trajectories agree to 1e-9 only until the event sequences part;
/// after that only the statistics agree. (Dividing such inputs by a reference length does
/// not help: fl(9e-3 / fl(d·1e-3)) ≠ fl(9 / d) in general.)
///
/// **Scenes.** Decimal changes of unit are therefore made exact one level up, where the
/// lengths are still decimal literals: `run` reduces every length of a scene by
/// ℓ = 10^E, shifting each literal's decimal exponent (`densepack::io::units`), and keeps
/// `temperature` (time is in units of ℓ·√(m/kT)). A jamming scene written with every length
/// literal ×10⁻³ and ×10³ (the same `temperature`) gives the same events, the same packing
/// fraction at every barrier bit for bit, and centres ×10^±3 to one rounding
/// (`tests/units.rs` checks more scenes through the binary).
#[test]
fn scale_covariance() {
    header();
    let n = size(500, 4000);
    let (reference, ref_kernel) = scaled_run(1.0, n);
    for s in [2f64.powi(-10), 2f64.powi(10)] {
        let (row, kernel) = scaled_run(s, n);
        assert_eq!(row.counts, reference.counts, "scale {s}: other events");
        assert_eq!(row.watch.trajectory.len(), reference.watch.trajectory.len());
        for (a, b) in row.watch.trajectory.iter().zip(&reference.watch.trajectory) {
            assert!((a - b).abs() <= 1e-9 * b, "scale {s}: φ {a} vs {b}");
            assert_eq!(a.to_bits(), b.to_bits(), "scale {s}: not bit-identical");
        }
        for (p, q) in kernel.particles().iter().zip(ref_kernel.particles()) {
            assert_eq!(p.pos, q.pos * s);
            assert_eq!(p.shape.radius(0.0), q.shape.radius(0.0) * s);
        }
    }
    for s in [1e-3, 1e3] {
        let (row, _) = scaled_run(s, n);
        let common = row
            .watch
            .trajectory
            .iter()
            .zip(&reference.watch.trajectory)
            .take_while(|(a, b)| ((*a - *b) / *b).abs() <= 1e-9)
            .count();
        eprintln!(
            "  scale {s:e}: packing fraction within 1e-9 of the reference for the first {common} of {} barriers; jammed at φ = {:.6} vs {:.6}",
            reference.watch.trajectory.len(),
            row.phi,
            reference.phi
        );
        assert!(common >= 2, "scale {s}: the trajectories part at once");
        assert_eq!(row.stops[0], StopReason::PressureReached);
        assert!(
            (row.phi - reference.phi).abs() < 0.01,
            "scale {s}: jammed at {} vs {}",
            row.phi,
            reference.phi
        );
    }
    // The same jam as a scene, every length literal written ×10^k: identical runs.
    let edge = 9.0 * (n as f64 / 500.0).cbrt();
    let scene_at = |exponent: i32| {
        let text = format!(
            "seed = 10\n[container]\ntype = \"box\"\nsize = [{edge:.2}e{exponent}, \
             {edge:.2}e{exponent}, {edge:.2}e{exponent}]\nperiodic = [true, true, true]\n\
             [particles]\ncount = {n}\ndiameter = 1.05e{exponent}\npacking_fraction = 0.3\n\
             [[stage]]\ngrowth = \"relative\"\nrate = 0.05\n\
             until = {{ reduced_pressure = 1e12 }}\n"
        );
        let scene = densepack::io::scene::Scene::from_toml(&text).unwrap();
        let mut trajectory = Vec::new();
        let started = std::time::Instant::now();
        let mut on_progress =
            |_: usize, p: &densepack::kernel::Progress| trajectory.push(p.packing_fraction);
        let options = densepack::run::RunOptions {
            on_progress: Some(&mut on_progress),
            ..densepack::run::RunOptions::default()
        };
        let scene = densepack::io::scene::AnyScene::Spheres(Box::new(scene));
        let outcome = densepack::run::run(&scene, options).unwrap();
        eprintln!(
            "  scene ×1e{exponent}: {} events, φ = {:.6}, {:.1} s",
            outcome.packing.stats.events,
            outcome.packing.stats.packing_fraction,
            started.elapsed().as_secs_f64()
        );
        (outcome.packing, trajectory)
    };
    let (reference, ref_trajectory) = scene_at(0);
    for exponent in [-3, 3] {
        let (packing, trajectory) = scene_at(exponent);
        assert_eq!(packing.stats.events, reference.stats.events);
        assert_eq!(
            packing.stats.packing_fraction.to_bits(),
            reference.stats.packing_fraction.to_bits()
        );
        assert_eq!(trajectory.len(), ref_trajectory.len());
        for (a, b) in trajectory.iter().zip(&ref_trajectory) {
            assert_eq!(
                a.to_bits(),
                b.to_bits(),
                "scene ×1e{exponent}: φ {a} vs {b}"
            );
        }
        let s = 10f64.powi(exponent);
        for (p, q) in packing.particles.iter().zip(&reference.particles) {
            let (
                ParticleRecord::Sphere(SphereRecord { center: a, .. }),
                ParticleRecord::Sphere(SphereRecord { center: b, .. }),
            ) = (p, q)
            else {
                panic!("spheres expected");
            };
            for k in 0..3 {
                assert!(
                    (a[k] - b[k] * s).abs() <= 1e-12 * edge * s,
                    "{a:?} vs {b:?}·{s}"
                );
            }
        }
    }
}

/// Coordinates far from the origin: a container whose corner sits at 10⁶ (unit-size
/// spheres). A coordinate near 10⁶ is resolved to 1.2e-10 (one unit in the last place):
/// relative gaps below ~10⁻¹⁰ cannot be represented there, and jammed packings have gaps of
/// ~10⁻¹². What holds:
/// - the kernel itself, given a container at 10⁶, grows to a dense fluid (φ = 0.6) and
///   equilibrates there with no overlap beyond 1e-9 at any barrier (periodic and walled);
///   run on to jamming there it overlaps by ~1e-8 and stalls (measured), so
/// - a scene run (`densepack run`) puts the kernel at the container's origin and translates
///   the packing when it writes it: the run is the same as at the origin (particles equal to
///   the origin run's plus the offset, bit for bit), and the written packing, resolved to
///   1.2e-10, passes the independent check.
#[test]
fn coordinates_offset_by_a_million() {
    header();
    let n = size(500, 4000);
    let edge = 9.0 * (n as f64 / 500.0).cbrt();
    let d = diameter_for(n, 0.3, edge.powi(3));
    let to_dense = Stage {
        growth: Growth::Relative(0.05),
        schedule: RateSchedule::Fixed,
        until: Until {
            packing_fraction: Some(0.6),
            ..Until::default()
        },
        limits: Limits::default(),
        thermostat: true,
        wall_growth: 1.0,
    };
    let offset = 1e6;
    let periodic = PeriodicBox {
        min: Vec3::repeat(offset),
        len: Vec3::repeat(edge),
    };
    let kernel = seeded(periodic, &vec![d; n], 11, 1.0);
    let (row, _) = run_case(
        "kernel at 1e6, periodic, to φ 0.6",
        kernel,
        &[to_dense.clone(), equilibrate(50.0)],
    );
    assert_eq!(row.stops[0], StopReason::PackingFractionReached);
    let kernel = seeded(walled_cube(offset, edge), &vec![d; n], 12, 1.0);
    let (row, _) = run_case(
        "kernel at 1e6, walled, to φ 0.55",
        kernel,
        &[
            Stage {
                until: Until {
                    packing_fraction: Some(0.55),
                    ..Until::default()
                },
                ..to_dense
            },
            equilibrate(50.0),
        ],
    );
    assert_eq!(row.stops[0], StopReason::PackingFractionReached);

    // Scenes to jamming, walls on z, at the origin and at 10⁶.
    let scene = |min: f64| {
        format!(
            "seed = 14\n[container]\ntype = \"box\"\nmin = [{min:?}, {min:?}, {min:?}]\n\
             size = [{edge:?}, {edge:?}, {edge:?}]\nperiodic = [true, true, false]\n\
             [particles]\ncount = {n}\ndiameter = 1.0\npacking_fraction = 0.3\n\
             [[stage]]\ngrowth = \"relative\"\nrate = 0.05\nuntil = {{ reduced_pressure = 1e12 }}\n"
        )
    };
    let at_origin = common::run_toml(&scene(0.0));
    let far = common::run_toml(&scene(offset));
    assert!(far.verification.ok());
    eprintln!(
        "scene at 1e6, jammed at φ = {:.6}: written packing's smallest relative gap {:.2e}, wall gap {:.2e} (at the origin: {:.2e})",
        far.packing.stats.packing_fraction,
        far.verification.min_pair_gap_relative.unwrap(),
        far.verification.min_wall_gap.unwrap(),
        at_origin.verification.min_pair_gap_relative.unwrap(),
    );
    assert_eq!(far.packing.stats.events, at_origin.packing.stats.events);
    for (p, q) in far
        .packing
        .particles
        .iter()
        .zip(&at_origin.packing.particles)
    {
        let (
            ParticleRecord::Sphere(SphereRecord {
                center: a,
                radius: ra,
            }),
            ParticleRecord::Sphere(SphereRecord {
                center: b,
                radius: rb,
            }),
        ) = (p, q)
        else {
            panic!("sphere scenes write spheres: {p:?}, {q:?}");
        };
        assert_eq!(ra, rb);
        for k in 0..3 {
            assert_eq!(a[k], b[k] + offset);
        }
    }
}

// ------------------------------------------------------------------------ ellipsoids

/// A uniformly random rotation: a uniform point of the unit 4-ball, normalised.
fn random_rotation<R: Rng>(rng: &mut R) -> UnitQuaternion<f64> {
    loop {
        let mut c = || rng.gen_range(-1.0..1.0);
        let q = Quaternion::new(c(), c(), c(), c());
        if (1e-3..=1.0).contains(&q.norm()) {
            return UnitQuaternion::from_quaternion(q);
        }
    }
}

/// `n` equal ellipsoids of relative semi-axes `shape` (largest 1), seeded by RSA of their
/// bounding spheres filling 15 % of the container, with random orientations, kT = 1.
fn seeded_ellipsoids<B: Boundary>(
    boundary: B,
    shape: Vec3,
    n: usize,
    seed: u64,
) -> Kernel<Ellipsoid, B> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let bounding =
        (0.15 * boundary.volume() / (n as f64 * 4.0 / 3.0 * std::f64::consts::PI)).cbrt();
    let centres = rsa_spheres(
        &boundary,
        &vec![bounding; n],
        0.0,
        0.0,
        1_000_000,
        None,
        &mut rng,
    )
    .expect("RSA seeds");
    let spins = (0..n)
        .map(|_| Spin {
            orientation: random_rotation(&mut rng),
            omega: Vec3::zeros(),
        })
        .collect();
    let shapes = vec![Ellipsoid::new(shape * bounding); n];
    Edmd::with_spins(
        centres,
        shapes,
        spins,
        boundary,
        KernelConfig::default(),
        &mut rng,
    )
}

/// Growth at relative rate 0.05 until the reduced pressure `z` (or the packing fraction
/// `cap`, where the minimum image of a periodic box ends), at most `events` events.
fn grow_towards_jamming(z: f64, cap: Option<f64>, events: u64) -> Stage {
    Stage {
        growth: Growth::Relative(0.05),
        schedule: RateSchedule::Fixed,
        until: Until {
            reduced_pressure: Some(z),
            packing_fraction: cap,
            ..Until::default()
        },
        limits: Limits {
            events,
            ..Limits::default()
        },
        thermostat: true,
        wall_growth: 1.0,
    }
}

/// Ellipsoids of aspect ratio 50 — needles (prolate, semi-axes 1 : 1/50 : 1/50) and platelets
/// (oblate, 1 : 1 : 1/50) — grown from a dilute random start towards jamming, in walled and
/// in periodic cubes, checked by the independent Perram–Wertheim test at every barrier.
/// Walled boxes have no minimum-image limit: the needles grow longer than half the box and
/// jam against each other and the walls. In a periodic box this test keeps the bounding sphere
/// shorter than a quarter of the edge (minimum image holds; needles nearly as long as the box,
/// where the kernel tracks periodic images, are the Table 2 scenes of paper 004), which caps the
/// packing fraction at `n·V(a = L/4)/L³`: for needles that cap is far below their jamming
/// density (φ_J ≈ 5.4/α ≈ 0.1 for rods, Philipse 1996; it would take ~5000 needles), so
/// periodic needles test dilute, fast-rotating collisions only; for platelets the cap is
/// 0.07 (reduced) to 0.46 (full).
///
/// Needles are slow: about half their predictions give up after `MAX_STEPS` certified steps
/// (the curvature bound grows like the aspect ratio), which the `pfail` column shows; those
/// are answered conservatively (an early event with zero impulse), never with an overlap.
#[test]
fn ellipsoids_of_aspect_ratio_50() {
    header();
    let prolate = Vec3::new(1.0, 0.02, 0.02);
    let oblate = Vec3::new(1.0, 1.0, 0.02);
    // Reduced: a reduced pressure of 100 (the needles are then jammed at φ ≈ 0.014 in their
    // box); full: 10⁹.
    let z = if full() { 1e9 } else { 1e2 };
    let events = if full() { 200_000_000 } else { 400_000 };
    let walled = |shape: Vec3, edge: f64, n: usize, seed: u64, name: &str| {
        let kernel = seeded_ellipsoids(walled_cube(0.0, edge), shape, n, seed);
        run_case(name, kernel, &[grow_towards_jamming(z, None, events)]).0
    };
    let periodic = |shape: Vec3, n: usize, seed: u64, name: &str| {
        let edge: f64 = 10.0;
        let a_max = 0.24 * edge;
        let cap = n as f64 * 4.0 / 3.0 * std::f64::consts::PI * a_max.powi(3) * shape.product()
            / edge.powi(3);
        let kernel = seeded_ellipsoids(cube(edge), shape, n, seed);
        let stage = grow_towards_jamming(z, Some(cap), events);
        (run_case(name, kernel, &[stage]).0, cap)
    };
    let rows = [
        walled(prolate, 10.0, size(10, 800), 21, "needles α 50, walled"),
        walled(oblate, 10.0, size(30, 400), 22, "platelets α 50, walled"),
    ];
    for row in &rows {
        assert!(row.stops[0].is_success(), "{}: {:?}", row.name, row.stops);
    }
    for (shape, n, seed, name) in [
        (prolate, size(40, 1000), 23, "needles α 50, periodic"),
        (oblate, size(60, 400), 24, "platelets α 50, periodic"),
    ] {
        let (row, cap) = periodic(shape, n, seed, name);
        assert!(row.stops[0].is_success(), "{name}: {:?}", row.stops);
        eprintln!("  {name}: minimum-image cap φ = {cap:.4}");
    }
}

// ------------------------------------------------------------------------ mixtures

/// Relaxes a start with the time-driven relaxer and checks the result: no intersection by
/// the exact typed tests, and a separating-plane certificate for every pair from the
/// independent check. Prints what the relaxer did and the smallest gap left.
fn relax_case(name: &str, mut rve: Rve) {
    let started = std::time::Instant::now();
    assert!(
        first_intersection(&rve).is_some(),
        "{name}: the start must intersect"
    );
    let report = relax(&mut rve, &RelaxSettings::default(), None)
        .unwrap_or_else(|e| panic!("{name}: the relaxer failed: {e}"));
    assert!(
        first_intersection(&rve).is_none(),
        "{name}: the exact tests find an intersection"
    );
    let packing = mixture_packing(&rve, 0, 0.0, "stress", serde_json::Map::new());
    let v = verify(&packing);
    let (fs, fc) = rve.fractions();
    eprintln!(
        "{name:<34} {:>5} bodies, f_s {fs:.3} f_c {fc:.3}: {} contacts at the start (Σ depth² {:.3e} ℓ²), \
         {} steps, prefactor {:.3e}, {} Nosé–Hoover activations; smallest gap {:.3e}, {} violations, {:.1} s",
        rve.bodies.len(),
        report.initial_contacts,
        report.initial_energy,
        report.steps,
        report.final_prefactor,
        report.nose_hoover_activations,
        v.min_pair_gap.unwrap_or(f64::INFINITY),
        v.violation_count,
        started.elapsed().as_secs_f64(),
    );
    assert!(v.ok(), "{name}: independent check: {:?}", v.violations);
}

/// Sphere and cylinder sizes of a mixture (fractions `fs`, `fc`, cylinders of aspect ratio
/// 5) in the unit box.
fn mixture_sizes(n: usize, fs: f64, fc: f64) -> (PeriodicBox, BodySize, BodySize) {
    let spec = MixtureSpec {
        sphere_fraction: fs,
        cylinder_fraction: fc,
        spheres: n,
        cylinders: n,
        aspect_ratio: 5.0,
        box_size: 1.0,
    };
    spec.validate().expect("a valid mixture");
    let sizes = spec.sizes(GenerationOrder::CylindersFirst);
    (spec.boundary(), sizes[0], sizes[n])
}

/// Starts the relaxer must separate: every cylinder axis parallel (side by side, sliding
/// along each other); pairs of cylinders whose axes cross at their midpoints with a sphere
/// at the crossing; and coincident bodies — cylinder pairs on the same axis (identical, and
/// shifted along it by half their length) and sphere pairs at the same centre — where the
/// contact direction is degenerate.
#[test]
fn mixture_relaxer_separates_parallel_crossing_and_coincident_axes() {
    let n = size(24, 120);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(31);
    let random_centre = |boundary: &PeriodicBox, rng: &mut Xoshiro256PlusPlus| {
        boundary.min + boundary.len.map(|l| l * rng.gen::<f64>())
    };
    let wrapped = |boundary: &PeriodicBox, mut c: Vec3| {
        boundary.wrap(&mut c);
        c
    };

    // Parallel axes, at 40 % (15 % spheres, 25 % cylinders).
    let (boundary, cylinder, sphere) = mixture_sizes(n, 0.15, 0.25);
    let mut bodies = Vec::new();
    for _ in 0..n {
        bodies.push(cylinder.at(random_centre(&boundary, &mut rng), Vec3::z()));
    }
    for _ in 0..n {
        bodies.push(sphere.at(random_centre(&boundary, &mut rng), Vec3::z()));
    }
    relax_case("relax: parallel axes", Rve { boundary, bodies });

    // Crossing axes: each pair crosses at its midpoints (one along x, one along y, in a
    // random frame), with a sphere at the crossing.
    let (boundary, cylinder, sphere) = mixture_sizes(n, 0.10, 0.25);
    let mut bodies = Vec::new();
    for _ in 0..n / 2 {
        let c = random_centre(&boundary, &mut rng);
        let frame = random_rotation(&mut rng);
        bodies.push(cylinder.at(c, frame * Vec3::x()));
        bodies.push(cylinder.at(c, frame * Vec3::y()));
        bodies.push(sphere.at(c, Vec3::z()));
    }
    for _ in n / 2..n {
        bodies.push(sphere.at(random_centre(&boundary, &mut rng), Vec3::z()));
    }
    relax_case("relax: crossing axes", Rve { boundary, bodies });

    // Coincident axes and centres.
    let (boundary, cylinder, sphere) = mixture_sizes(n, 0.10, 0.20);
    let BodySize::Cylinder { half_length, .. } = cylinder else {
        unreachable!("sizes[0] is a cylinder")
    };
    let mut bodies = Vec::new();
    for k in 0..n / 2 {
        let c = random_centre(&boundary, &mut rng);
        let axis = frame_axis(&mut rng);
        bodies.push(cylinder.at(c, axis));
        let twin = if k % 2 == 0 {
            c
        } else {
            wrapped(&boundary, c + axis * half_length)
        };
        bodies.push(cylinder.at(twin, axis));
    }
    for _ in 0..n / 2 {
        let c = random_centre(&boundary, &mut rng);
        bodies.push(sphere.at(c, Vec3::z()));
        bodies.push(sphere.at(c, Vec3::z()));
    }
    relax_case(
        "relax: coincident axes and centres",
        Rve { boundary, bodies },
    );
}

/// A uniformly random unit vector.
fn frame_axis<R: Rng>(rng: &mut R) -> Vec3 {
    random_rotation(rng) * Vec3::z()
}
