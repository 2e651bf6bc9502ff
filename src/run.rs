//! Running a scene: seeding, stages, independent verification, the packing.
//!
//! [`run_scene`] picks the container and queue types from the scene once and runs a kernel
//! monomorphised for them: a fully periodic box gets [`PeriodicBox`] (no wall code at all).

use crate::boundary::{Boundary, CylinderContainer, PeriodicBox, WalledBox};
use crate::io::checkpoint::{write_checkpoint, CheckpointError, CheckpointFile, CheckpointHeader};
use crate::io::packing::{ContainerRecord, Packing, PackingStats, ParticleRecord, FORMAT};
use crate::io::scene::{ContainerSpec, Scene};
use crate::kernel::{Edmd, KernelConfig, StageProgress, StageReport};
use crate::protocol::rsa::{rsa_spheres, RsaFailure};
use crate::queue::{CalendarQueue, EventQueue, HeapQueue, QueueKind};
use crate::shape::{Sphere, Vec3};
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
    /// The independent check found overlaps: a kernel bug; nothing is written.
    #[error("the independent overlap check rejected the packing: {0}")]
    Verification(String),
    /// The checkpoint to resume from cannot be used.
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
}

/// Where and how often a run writes checkpoints ([`crate::io::checkpoint`]).
#[derive(Clone, Debug)]
pub struct CheckpointPlan {
    /// The checkpoint file, replaced atomically at every write.
    pub path: std::path::PathBuf,
    /// Least wall-clock time between two checkpoints; they are written at the first time
    /// barrier after it has passed.
    pub every: std::time::Duration,
}

/// How a run starts and what it writes on the way.
struct Job<'a> {
    /// The scene's TOML text, stored in checkpoints.
    scene_toml: &'a str,
    /// A fresh run seeds; a resumed one rebuilds the kernel from the checkpoint.
    resume: Option<&'a CheckpointFile>,
    checkpoints: Option<&'a CheckpointPlan>,
}

/// Runs the scene given as TOML text (parsed and validated by the caller into `scene`)
/// and writes checkpoints as `plan` says. The packing is the one [`run_scene`] gives.
pub fn run_scene_checkpointed(
    scene_toml: &str,
    scene: &Scene,
    plan: &CheckpointPlan,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<RunOutcome, RunError> {
    let job = Job {
        scene_toml,
        resume: None,
        checkpoints: Some(plan),
    };
    dispatch_container(scene, &job, on_stage)
}

/// Continues the run that wrote `checkpoint` to the packing the uninterrupted run gives
/// (the same particles, bit for bit; timings differ), writing further checkpoints as `plan`
/// says. `on_stage` hears of the stages that finish from here on.
pub fn resume_run(
    checkpoint: &CheckpointFile,
    plan: Option<&CheckpointPlan>,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<RunOutcome, RunError> {
    let header = &checkpoint.header;
    let scene = Scene::from_toml(&header.scene_toml)
        .map_err(|e| checkpoint.error(format!("its scene is invalid: {e}")))?;
    if header.stage >= scene.stages.len() {
        return Err(checkpoint
            .error(format!(
                "stage {} of a scene with {} stages",
                header.stage,
                scene.stages.len()
            ))
            .into());
    }
    let job = Job {
        scene_toml: &header.scene_toml,
        resume: Some(checkpoint),
        checkpoints: plan,
    };
    dispatch_container(&scene, &job, on_stage)
}

/// Writes a checkpoint at a barrier once `plan.every` has passed since the last one.
struct Checkpointer<'a> {
    plan: &'a CheckpointPlan,
    scene_toml: &'a str,
    last: std::time::Instant,
}

impl Checkpointer<'_> {
    fn at_barrier<B: Boundary, Q: EventQueue>(
        &mut self,
        stage: usize,
        progress: &StageProgress,
        reports: &[StageReport],
        kernel: &Edmd<Sphere, B, Q>,
    ) {
        if self.last.elapsed() < self.plan.every {
            return;
        }
        let header = CheckpointHeader::new(self.scene_toml, stage, progress, reports);
        if let Err(e) = write_checkpoint(&self.plan.path, &header, &kernel.snapshot()) {
            // The run goes on: a failed checkpoint costs insurance, not the result.
            eprintln!(
                "warning: checkpoint {} not written: {e}",
                self.plan.path.display()
            );
        }
        self.last = std::time::Instant::now();
    }
}

/// Runs a validated scene. `on_stage` is told about each finished stage.
pub fn run_scene(
    scene: &Scene,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<RunOutcome, RunError> {
    let job = Job {
        scene_toml: "",
        resume: None,
        checkpoints: None,
    };
    dispatch_container(scene, &job, on_stage)
}

/// The point the kernel's coordinates are relative to: the box's lower corner or the
/// cylinder's base centre. A coordinate far from zero is resolved only to its last place
/// (1.2e-10 at 10⁶), coarser than the gaps of a jammed packing (~10⁻¹² of a diameter), so
/// the kernel runs at the origin and the packing is translated when it is written (its
/// coordinates then carry the resolution of the offset, which the overlap check's relative
/// tolerance of 1e-9 covers for offsets up to ~10⁶ diameters).
fn container_origin(scene: &Scene) -> Vec3 {
    match &scene.container {
        ContainerSpec::Box { min, .. } => Vec3::from(*min),
        ContainerSpec::Cylinder { base_center, .. } => Vec3::from(*base_center),
    }
}

fn dispatch_container(
    scene: &Scene,
    job: &Job,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<RunOutcome, RunError> {
    // The kernel works relative to the container's origin (see `container_origin`).
    match &scene.container {
        ContainerSpec::Box { size, periodic, .. } => {
            let min = Vec3::zeros();
            let len = Vec3::from(*size);
            if periodic.iter().all(|&p| p) {
                dispatch_queue(scene, job, PeriodicBox { min, len }, on_stage)
            } else {
                let walled = WalledBox {
                    min,
                    max: min + len,
                    periodic: *periodic,
                };
                dispatch_queue(scene, job, walled, on_stage)
            }
        }
        ContainerSpec::Cylinder { radius, height, .. } => {
            let cylinder = CylinderContainer {
                base_center: Vec3::zeros(),
                radius: *radius,
                height: *height,
            };
            dispatch_queue(scene, job, cylinder, on_stage)
        }
    }
}

fn dispatch_queue<B: Boundary + ContainerRecordOf>(
    scene: &Scene,
    job: &Job,
    boundary: B,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<RunOutcome, RunError> {
    match scene.queue {
        QueueKind::Heap => run_with::<B, HeapQueue>(scene, job, boundary, on_stage),
        QueueKind::Calendar => run_with::<B, CalendarQueue>(scene, job, boundary, on_stage),
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
    job: &Job,
    boundary: B,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<RunOutcome, RunError> {
    let config = KernelConfig {
        mass: scene.mass,
        temperature: scene.temperature,
        events_per_particle_per_interval: scene.events_per_particle_per_interval,
        neighbour_skin: scene.neighbour_skin,
    };
    // The random generator is consumed by seeding and the initial velocities only, so a
    // checkpoint (taken at a later barrier) needs none of its state.
    let (mut kernel, first_stage, mut resumed, mut reports): (Edmd<Sphere, B, Q>, _, _, _) =
        match job.resume {
            None => {
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
                let kernel = Edmd::new(centres, shapes, boundary, config, &mut rng);
                (kernel, 0, None, Vec::new())
            }
            Some(file) => {
                let kernel = Edmd::from_snapshot(file.kernel()?, boundary, config)
                    .map_err(|e| file.error(e.to_string()))?;
                let progress: StageProgress = file.header.progress.clone().into_owned();
                (
                    kernel,
                    file.header.stage,
                    Some(progress),
                    file.header.reports.to_vec(),
                )
            }
        };
    let mut checkpointer = job.checkpoints.map(|plan| Checkpointer {
        plan,
        scene_toml: job.scene_toml,
        last: std::time::Instant::now(),
    });
    for (k, spec) in scene.stages.iter().enumerate().skip(first_stage) {
        let stage = spec.to_stage();
        let progress = match resumed.take() {
            Some(progress) => progress,
            None => kernel.start_stage(&stage),
        };
        let report = kernel.continue_stage(&stage, progress, &mut |kernel, progress| {
            if let Some(c) = checkpointer.as_mut() {
                c.at_barrier(k, progress, &reports, kernel);
            }
        });
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
    let packing = packing_of(scene, &kernel, &reports);
    drop(kernel); // the verification's own index should not add to the kernel's peak memory
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

fn packing_of<B: Boundary + ContainerRecordOf, Q: EventQueue>(
    scene: &Scene,
    kernel: &Edmd<Sphere, B, Q>,
    reports: &[StageReport],
) -> Packing {
    let origin = container_origin(scene);
    // Back to the order of the seeding, which the kernel permutes for cache locality.
    let mut order: Vec<u32> = vec![0; kernel.particles().len()];
    for (k, &id) in kernel.original_indices().iter().enumerate() {
        order[id as usize] = k as u32;
    }
    let particles = order
        .into_iter()
        .map(|k| {
            let p = &kernel.particles()[k as usize];
            ParticleRecord::Sphere {
                center: (p.pos + origin).into(),
                radius: p.shape.radius(0.0),
            }
        })
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
        container: kernel.boundary().record().translated(origin.into()),
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
