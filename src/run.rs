//! Running a scene: seeding, stages, independent verification, the packing.
//!
//! [`run_scene`] picks the container and queue types from the scene once and runs a kernel
//! monomorphised for them: a fully periodic box gets [`PeriodicBox`] (no wall code at all).
//! Ellipsoid scenes go through [`ellipsoid`] with the same stage loop.

pub mod ellipsoid;

use crate::boundary::{Boundary, CylinderContainer, PeriodicBox, WalledBox};
use crate::io::packing::{ContainerRecord, Packing, PackingStats, ParticleRecord, FORMAT};
use crate::io::scene::{ContainerSpec, Scene};
use crate::kernel::{Edmd, KernelConfig, StageReport};
use crate::protocol::rsa::{rsa_spheres, RsaFailure};
use crate::queue::{CalendarQueue, EventQueue, HeapQueue, QueueKind};
use crate::shape::{Collidable, Sphere, Vec3};
use crate::verify::{verify, Verification};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// A finished run: the packing (verified) and what happened.
#[derive(Debug)]
pub struct RunOutcome {
    /// The packing, synchronised at the end of the last stage.
    pub packing: Packing,
    /// Report of every stage that ran.
    pub stages: Vec<StageReport>,
    /// The independent verification of the packing.
    pub verification: Verification,
}

/// Why a run produced no packing.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Seeding by random sequential addition failed.
    #[error(transparent)]
    Seeding(#[from] RsaFailure),
    /// A stage stopped before reaching its goal.
    #[error(
        "stage {stage} stopped without reaching its goal: {reason} after {events} events \
         (packing fraction {fraction:.6}, reduced pressure {pressure:.4e})"
    )]
    StageFailed {
        /// Index of the stage.
        stage: usize,
        /// Stop reason.
        reason: &'static str,
        /// Events in the stage.
        events: u64,
        /// Packing fraction at the stop.
        fraction: f64,
        /// Reduced pressure at the stop.
        pressure: f64,
        /// Reports of the stages so far.
        stages: Vec<StageReport>,
    },
    /// The scene asks for something this build cannot run (e.g. ellipsoids in a cylinder).
    #[error("{0}")]
    Unsupported(String),
    /// The independent check found overlaps: a kernel bug; nothing is written.
    #[error("the independent overlap check rejected the packing: {0}")]
    Verification(String),
}

/// Runs a validated scene. `on_stage` is told about each finished stage.
pub fn run_scene(
    scene: &Scene,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<RunOutcome, RunError> {
    if scene.particles.ellipsoid.is_some() {
        return ellipsoid::run_ellipsoid_scene(scene, on_stage);
    }
    match &scene.container {
        ContainerSpec::Box {
            min,
            size,
            periodic,
        } => {
            let min = Vec3::from(*min);
            let len = Vec3::from(*size);
            if periodic.iter().all(|&p| p) {
                dispatch_queue(scene, PeriodicBox { min, len }, on_stage)
            } else {
                let walled = WalledBox {
                    min,
                    max: min + len,
                    periodic: *periodic,
                };
                dispatch_queue(scene, walled, on_stage)
            }
        }
        ContainerSpec::Cylinder {
            base_center,
            radius,
            height,
        } => {
            let cylinder = CylinderContainer {
                base_center: Vec3::from(*base_center),
                radius: *radius,
                height: *height,
            };
            dispatch_queue(scene, cylinder, on_stage)
        }
    }
}

fn dispatch_queue<B: Boundary + ContainerRecordOf>(
    scene: &Scene,
    boundary: B,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<RunOutcome, RunError> {
    match scene.queue {
        QueueKind::Heap => run_with::<B, HeapQueue>(scene, boundary, on_stage),
        QueueKind::Calendar => run_with::<B, CalendarQueue>(scene, boundary, on_stage),
    }
}

/// The packing-file description of a container.
pub trait ContainerRecordOf {
    /// The record.
    fn record(&self) -> ContainerRecord;
}

impl ContainerRecordOf for PeriodicBox {
    fn record(&self) -> ContainerRecord {
        ContainerRecord::Box {
            min: self.min.into(),
            max: (self.min + self.len).into(),
            periodic: [true; 3],
        }
    }
}

impl ContainerRecordOf for WalledBox {
    fn record(&self) -> ContainerRecord {
        ContainerRecord::Box {
            min: self.min.into(),
            max: self.max.into(),
            periodic: self.periodic,
        }
    }
}

impl ContainerRecordOf for CylinderContainer {
    fn record(&self) -> ContainerRecord {
        ContainerRecord::Cylinder {
            base_center: self.base_center.into(),
            radius: self.radius,
            height: self.height,
        }
    }
}

fn run_with<B: Boundary + ContainerRecordOf, Q: EventQueue>(
    scene: &Scene,
    boundary: B,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<RunOutcome, RunError> {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(scene.seed);
    let radii: Vec<f64> = scene.seeding_diameters().iter().map(|d| 0.5 * d).collect();
    let centres = rsa_spheres(
        &boundary,
        &radii,
        0.0,
        scene.particles.rsa_max_failures,
        &mut rng,
    )?;
    let shapes = radii.iter().map(|&r| Sphere::new(r)).collect();
    let config = kernel_config(scene);
    let mut kernel: Edmd<Sphere, B, Q> = Edmd::new(centres, shapes, boundary, config, &mut rng);
    let reports = run_stages(scene, &mut kernel, on_stage)?;
    let packing = packing_of(scene, &kernel, &reports, |p| ParticleRecord::Sphere {
        center: p.pos.into(),
        radius: p.shape.radius(0.0),
    });
    drop(kernel); // the verification's own index should not add to the kernel's peak memory
    verified(packing, reports)
}

/// The kernel settings of a scene.
fn kernel_config(scene: &Scene) -> KernelConfig {
    KernelConfig {
        mass: scene.mass,
        temperature: scene.temperature,
        events_per_particle_per_interval: scene.events_per_particle_per_interval,
        neighbour_skin: scene.neighbour_skin,
    }
}

/// Runs the scene's stages in order; the first stage that misses its goal fails the run.
fn run_stages<S: Collidable, B: Boundary, Q: EventQueue>(
    scene: &Scene,
    kernel: &mut Edmd<S, B, Q>,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<Vec<StageReport>, RunError> {
    let mut reports: Vec<StageReport> = Vec::new();
    for (k, spec) in scene.stages.iter().enumerate() {
        let report = kernel.run_stage(&spec.to_stage());
        on_stage(k, &report);
        let failed = !report.stop_reason.is_success();
        reports.push(report);
        if failed {
            let last = reports.last().expect("just pushed");
            return Err(RunError::StageFailed {
                stage: k,
                reason: last.stop_reason.as_str(),
                events: last.counts.events,
                fraction: last.packing_fraction,
                pressure: last.reduced_pressure,
                stages: reports,
            });
        }
    }
    Ok(reports)
}

/// Checks a packing independently; only a packing without violations is returned.
fn verified(packing: Packing, reports: Vec<StageReport>) -> Result<RunOutcome, RunError> {
    let verification = verify(&packing);
    if !verification.ok() {
        return Err(RunError::Verification(verification.violations.join("; ")));
    }
    Ok(RunOutcome {
        packing,
        stages: reports,
        verification,
    })
}

fn packing_of<S: Collidable, B: Boundary + ContainerRecordOf, Q: EventQueue>(
    scene: &Scene,
    kernel: &Edmd<S, B, Q>,
    reports: &[StageReport],
    record: impl Fn(&crate::kernel::Particle<S>) -> ParticleRecord,
) -> Packing {
    // Back to the order of the seeding, which the kernel permutes for cache locality.
    let mut order: Vec<u32> = vec![0; kernel.particles().len()];
    for (k, &id) in kernel.original_indices().iter().enumerate() {
        order[id as usize] = k as u32;
    }
    let particles = order
        .into_iter()
        .map(|k| record(&kernel.particles()[k as usize]))
        .collect();
    let last = reports.last().expect("a scene has at least one stage");
    let events: u64 = reports.iter().map(|r| r.counts.events).sum();
    let collisions: u64 = reports.iter().map(|r| r.counts.collisions).sum();
    let wall_seconds: f64 = reports.iter().map(|r| r.wall_seconds).sum();
    let n = kernel.particles().len().max(1) as f64;
    let mut extra = serde_json::Map::new();
    extra.insert(
        "collisions_per_particle".into(),
        serde_json::json!(collisions as f64 / n),
    );
    extra.insert(
        "events_per_second".into(),
        serde_json::json!(events as f64 / wall_seconds.max(1e-12)),
    );
    extra.insert(
        "reduced_pressure_stderr".into(),
        serde_json::json!(last.reduced_pressure_stderr),
    );
    extra.insert("stages".into(), serde_json::json!(reports));
    Packing {
        format: FORMAT.into(),
        version: 1,
        container: kernel.boundary().record(),
        particles,
        min_gap: 0.0,
        seed: scene.seed,
        stats: PackingStats {
            packing_fraction: kernel.packing_fraction_at(0.0),
            reduced_pressure: last.reduced_pressure,
            events,
            collisions,
            wall_seconds,
            stop_reason: last.stop_reason.as_str().into(),
            extra,
        },
    }
}
