//! Running a scene: seeding, stages, independent verification, the packing.
//!
//! [`run_scene`] picks the container and queue types from the scene once and runs a kernel
//! monomorphised for them: a fully periodic box gets [`PeriodicBox`] (no wall code at all).
//! Ellipsoid scenes go through [`ellipsoid`] with the same stage loop.
//!
//! The kernel runs relative to the container's origin (`container_origin`) and in the
//! scene's reduced lengths ([`Units`]: every length divided by `ℓ = 10^E`, exactly under
//! decimal changes of unit); the packing is scaled and translated back when it is written. Sphere and ellipsoid runs can write checkpoints at
//! time barriers and be resumed from them ([`run_scene_checkpointed`], [`resume_run`]).

pub mod ellipsoid;

use crate::boundary::{Boundary, CylinderContainer, PeriodicBox, WalledBox};
use crate::io::checkpoint::{write_checkpoint, CheckpointError, CheckpointFile, CheckpointHeader};
use crate::io::packing::{
    ContainerRecord, Packing, PackingStats, ParticleRecord, Provenance, Timings,
};
use crate::io::scene::{ContainerSpec, Method, Scene};
use crate::io::units::Units;
use crate::kernel::{Edmd, KernelConfig, Progress, StageProgress, StageReport, StopReason};
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
        "stage {stage} stopped without reaching its goal ({goal}): {reason} after {events} \
         events (packing fraction {fraction:.6}, reduced pressure {pressure:.4e}){hint}"
    )]
    StageFailed {
        /// Index of the stage.
        stage: usize,
        /// The goal the scene asked of the stage.
        goal: String,
        /// Stop reason.
        reason: &'static str,
        /// What the stop reason means for the scene, for people (may be empty).
        hint: &'static str,
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
    /// The scene as written (validated): its origin, units and provenance. The stages run
    /// on its reduced copy ([`Units::reduced`]).
    scene: &'a Scene,
    /// The scene's TOML text, stored in checkpoints.
    scene_toml: &'a str,
    /// A fresh run seeds; a resumed one rebuilds the kernel from the checkpoint.
    resume: Option<&'a CheckpointFile>,
    checkpoints: Option<&'a CheckpointPlan>,
}

/// Runs the scene given as TOML text (parsed and validated by the caller into `scene`)
/// and writes checkpoints as `plan` says. The packing is the one [`run_scene_observed`]
/// gives. Sphere and ellipsoid scenes (EDMD); RSA scenes never reach a time barrier.
pub fn run_scene_checkpointed(
    scene_toml: &str,
    scene: &Scene,
    plan: &CheckpointPlan,
    on_stage: &mut dyn FnMut(usize, &StageReport),
    on_progress: &mut dyn FnMut(usize, &Progress),
) -> Result<RunOutcome, RunError> {
    let job = Job {
        scene,
        scene_toml,
        resume: None,
        checkpoints: Some(plan),
    };
    run_job(&job, on_stage, on_progress)
}

/// Continues the run that wrote `checkpoint` to the packing the uninterrupted run gives
/// (the same particles, bit for bit; timings differ), writing further checkpoints as `plan`
/// says. `on_stage` hears of the stages that finish from here on.
pub fn resume_run(
    checkpoint: &CheckpointFile,
    plan: Option<&CheckpointPlan>,
    on_stage: &mut dyn FnMut(usize, &StageReport),
    on_progress: &mut dyn FnMut(usize, &Progress),
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
        scene: &scene,
        scene_toml: &header.scene_toml,
        resume: Some(checkpoint),
        checkpoints: plan,
    };
    run_job(&job, on_stage, on_progress)
}

/// Writes a checkpoint at a barrier once `plan.every` has passed since the last one.
struct Checkpointer<'a> {
    plan: &'a CheckpointPlan,
    scene_toml: &'a str,
    last: std::time::Instant,
}

impl<'a> Checkpointer<'a> {
    /// The checkpointer of a job that writes checkpoints.
    fn of(job: &Job<'a>) -> Option<Self> {
        job.checkpoints.map(|plan| Checkpointer {
            plan,
            scene_toml: job.scene_toml,
            last: std::time::Instant::now(),
        })
    }

    fn at_barrier<S, B: Boundary, Q: EventQueue>(
        &mut self,
        stage: usize,
        progress: &StageProgress,
        reports: &[StageReport],
        kernel: &Edmd<S, B, Q>,
    ) where
        S: Collidable + serde::Serialize,
        S::Spin: serde::Serialize,
    {
        if self.last.elapsed() < self.plan.every {
            return;
        }
        let header = CheckpointHeader::new(self.scene_toml, stage, progress, reports);
        if let Err(e) = write_checkpoint(&self.plan.path, &header, &kernel.snapshot()) {
            // The run goes on: a failed checkpoint costs insurance, not the result (and a
            // closed stderr must not stop it either, which `eprintln!` would by panicking).
            use std::io::Write;
            let _ = writeln!(
                std::io::stderr(),
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
    run_scene_observed(scene, on_stage, &mut |_, _| {})
}

/// [`run_scene`], also telling `on_progress` the stage index and its [`Progress`] at every
/// time barrier (throttle in the observer: barriers can come thousands of times a second).
pub fn run_scene_observed(
    scene: &Scene,
    on_stage: &mut dyn FnMut(usize, &StageReport),
    on_progress: &mut dyn FnMut(usize, &Progress),
) -> Result<RunOutcome, RunError> {
    let job = Job {
        scene,
        scene_toml: "",
        resume: None,
        checkpoints: None,
    };
    run_job(&job, on_stage, on_progress)
}

/// The point the kernel's coordinates are relative to: the box's lower corner or the
/// cylinder's base centre. A coordinate far from zero is resolved only to its last place
/// (1.2e-10 at 10⁶), coarser than the gaps of a jammed packing (~10⁻¹² of a diameter), so
/// the kernel runs at the origin and [`finish`] translates the packing (its coordinates then
/// carry the resolution of the offset, which the overlap check's relative tolerance of 1e-9
/// covers for offsets up to ~10⁶ diameters).
fn container_origin(scene: &Scene) -> [f64; 3] {
    match &scene.container {
        ContainerSpec::Box { min, .. } => *min,
        ContainerSpec::Cylinder { base_center, .. } => *base_center,
    }
}

/// Runs `job.scene` in its reduced units ([`Units`]): from here on every `scene` is the
/// reduced copy, and [`finish`] writes the packing in the units of `job.scene`.
fn run_job(
    job: &Job,
    on_stage: &mut dyn FnMut(usize, &StageReport),
    on_progress: &mut dyn FnMut(usize, &Progress),
) -> Result<RunOutcome, RunError> {
    let reduced = Units::of(job.scene).reduced(job.scene);
    let scene = &reduced;
    if scene.particles.ellipsoid.is_some() {
        return ellipsoid::run_ellipsoid_scene(scene, job, on_stage, on_progress);
    }
    // The kernel works relative to the container's origin (see `container_origin`).
    match &scene.container {
        ContainerSpec::Box { size, periodic, .. } => {
            dispatch_box::<Spheres>(scene, job, size, periodic, on_stage, on_progress)
        }
        ContainerSpec::Cylinder { radius, height, .. } => {
            let cylinder = CylinderContainer {
                base_center: Vec3::zeros(),
                radius: *radius,
                height: *height,
            };
            dispatch_queue::<Spheres, _>(scene, job, cylinder, on_stage, on_progress)
        }
    }
}

/// What differs between particle kinds in a run: how a fresh kernel is seeded and how the
/// finished kernel becomes the written packing. [`run_with`] does the rest (sizes from the
/// seed, resume, the scene's stages, statistics, verification) for every kind, container and
/// queue, each combination monomorphised, so the event loop never dispatches dynamically.
trait ShapeRun {
    /// The kernel's shape.
    type Shape: Collidable<Spin: serde::Serialize + serde::de::DeserializeOwned>
        + serde::Serialize
        + serde::de::DeserializeOwned;

    /// A fresh kernel for the scene's `true_diameters` (drawn first from `rng`; seeding
    /// draws after them), or the finished packing of a scene that ends with its seeding.
    fn seed<B: Boundary + SceneContainer, Q: EventQueue>(
        scene: &Scene,
        job: &Job,
        true_diameters: &[f64],
        boundary: B,
        rng: &mut Xoshiro256PlusPlus,
        started: std::time::Instant,
    ) -> Result<Seeded<Self::Shape, B, Q>, RunError>;

    /// The packing of the finished `kernel` in the container `original`, and the kind's
    /// own statistics (in the order they are written).
    fn packing<B: Boundary, Q: EventQueue>(
        kernel: Edmd<Self::Shape, B, Q>,
        original: &B,
        true_diameters: &[f64],
        done: &StagesDone,
    ) -> (Placed, Vec<(String, serde_json::Value)>);
}

/// What [`ShapeRun::seed`] gives. (`allow`, not `expect`: whether the lint fires depends on
/// the sizes of the kernel and of the verification report, which change.)
#[allow(
    clippy::large_enum_variant,
    reason = "one value per run, moved once: its size costs nothing"
)]
enum Seeded<S: Collidable, B: Boundary, Q: EventQueue> {
    /// A kernel ready for the first stage, and the seconds its seeding took.
    Kernel(Edmd<S, B, Q>, f64),
    /// The packing is complete already (an RSA scene).
    Finished(RunOutcome),
}

/// Runs particle kind `R` in `boundary` with event queue `Q`: seeding or resume, the
/// scene's stages (with checkpoints), the packing, its verification and output.
fn run_with<R: ShapeRun, B: Boundary + SceneContainer, Q: EventQueue>(
    scene: &Scene,
    job: &Job,
    boundary: B,
    on_stage: &mut dyn FnMut(usize, &StageReport),
    on_progress: &mut dyn FnMut(usize, &Progress),
) -> Result<RunOutcome, RunError> {
    let started = std::time::Instant::now();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(scene.seed);
    // Drawn first from the seed, so a resumed run draws the same sizes again.
    let true_diameters = scene.true_diameters(&mut rng);
    // Ellipsoids are volume-equivalent to spheres of the true diameters.
    let full_size_fraction = sphere_fraction(&true_diameters, boundary.volume());
    let original = boundary.clone();
    // The random generator is consumed by seeding and the initial velocities only, so a
    // checkpoint (taken at a later barrier) needs none of its state.
    let (mut kernel, from, seeding_seconds) = match job.resume {
        None => match R::seed::<B, Q>(scene, job, &true_diameters, boundary, &mut rng, started)? {
            Seeded::Kernel(kernel, seconds) => (kernel, StagesFrom::start(), seconds),
            Seeded::Finished(outcome) => return Ok(outcome),
        },
        Some(file) => {
            let (kernel, from) = resumed_kernel(scene, file, boundary)?;
            (kernel, from, 0.0)
        }
    };
    let done = run_stages(
        scene,
        job,
        &mut kernel,
        full_size_fraction,
        from,
        on_stage,
        on_progress,
    )?;
    let (placed, extra) = R::packing(kernel, &original, &true_diameters, &done);
    let mut stats = stats_of_stages(&done.reports, placed.particles.len());
    stats.extra.extend(extra);
    finish(
        job.scene,
        original.record(),
        &original,
        placed,
        stats,
        done.reports,
        seeding_seconds,
    )
}

/// Spheres ([`Sphere`]): the kinds of scene without `[particles.ellipsoid]`.
struct Spheres;

/// Runs `R` in a box of edge lengths `size` at the origin: the periodic box when every
/// axis is periodic (no wall code on the hot path), else the walled box.
fn dispatch_box<R: ShapeRun>(
    scene: &Scene,
    job: &Job,
    size: &[f64; 3],
    periodic: &[bool; 3],
    on_stage: &mut dyn FnMut(usize, &StageReport),
    on_progress: &mut dyn FnMut(usize, &Progress),
) -> Result<RunOutcome, RunError> {
    let min = Vec3::zeros();
    let len = Vec3::from(*size);
    if periodic.iter().all(|&p| p) {
        dispatch_queue::<R, _>(scene, job, PeriodicBox { min, len }, on_stage, on_progress)
    } else {
        let walled = WalledBox {
            min,
            max: min + len,
            periodic: *periodic,
        };
        dispatch_queue::<R, _>(scene, job, walled, on_stage, on_progress)
    }
}

/// Runs `R` in `boundary` with the scene's event queue.
fn dispatch_queue<R: ShapeRun, B: Boundary + SceneContainer>(
    scene: &Scene,
    job: &Job,
    boundary: B,
    on_stage: &mut dyn FnMut(usize, &StageReport),
    on_progress: &mut dyn FnMut(usize, &Progress),
) -> Result<RunOutcome, RunError> {
    match scene.queue {
        QueueKind::Heap => run_with::<R, B, HeapQueue>(scene, job, boundary, on_stage, on_progress),
        QueueKind::Calendar => {
            run_with::<R, B, CalendarQueue>(scene, job, boundary, on_stage, on_progress)
        }
    }
}

/// What a run needs of a container besides [`Boundary`].
pub trait SceneContainer: Sized {
    /// The packing-file description.
    fn record(&self) -> ContainerRecord;
}

impl SceneContainer for PeriodicBox {
    fn record(&self) -> ContainerRecord {
        ContainerRecord::Box {
            min: self.min.into(),
            max: (self.min + self.len).into(),
            periodic: [true; 3],
        }
    }
}

impl SceneContainer for WalledBox {
    fn record(&self) -> ContainerRecord {
        ContainerRecord::Box {
            min: self.min.into(),
            max: self.max.into(),
            periodic: self.periodic,
        }
    }
}

impl SceneContainer for CylinderContainer {
    fn record(&self) -> ContainerRecord {
        ContainerRecord::Cylinder {
            base_center: self.base_center.into(),
            radius: self.radius,
            height: self.height,
        }
    }
}

impl ShapeRun for Spheres {
    type Shape = Sphere;

    fn seed<B: Boundary + SceneContainer, Q: EventQueue>(
        scene: &Scene,
        job: &Job,
        true_diameters: &[f64],
        boundary: B,
        rng: &mut Xoshiro256PlusPlus,
        started: std::time::Instant,
    ) -> Result<Seeded<Sphere, B, Q>, RunError> {
        let scale = scene.seed_scale(true_diameters);
        let radii: Vec<f64> = true_diameters.iter().map(|d| 0.5 * scale * d).collect();
        let (rsa_gap, rsa_wall_gap) = match scene.method {
            Method::Rsa => {
                let gap = scene.particles.gap.unwrap_or(0.0);
                (gap, scene.particles.wall_gap.unwrap_or(0.5 * gap))
            }
            Method::Edmd => (0.0, 0.0),
        };
        let centres = rsa_spheres(
            &boundary,
            &radii,
            rsa_gap,
            rsa_wall_gap,
            scene.particles.rsa_max_failures,
            rng,
        )?;
        let seeding_seconds = started.elapsed().as_secs_f64();
        if scene.method == Method::Rsa {
            let placed = Placed::spheres(
                &boundary,
                centres,
                &radii,
                rsa_gap,
                scene.particles.wall_gap,
            );
            let stats = PackingStats {
                wall_seconds: started.elapsed().as_secs_f64(),
                stop_reason: "rsa_complete".into(),
                ..PackingStats::default()
            };
            let container = boundary.record();
            return finish(
                job.scene,
                container,
                &boundary,
                placed,
                stats,
                Vec::new(),
                seeding_seconds,
            )
            .map(Seeded::Finished);
        }
        let shapes = radii.iter().map(|&r| Sphere::new(r)).collect();
        let kernel = Edmd::new(centres, shapes, boundary, kernel_config(scene), rng);
        Ok(Seeded::Kernel(kernel, seeding_seconds))
    }

    fn packing<B: Boundary, Q: EventQueue>(
        kernel: Edmd<Sphere, B, Q>,
        original: &B,
        true_diameters: &[f64],
        done: &StagesDone,
    ) -> (Placed, Vec<(String, serde_json::Value)>) {
        // The kernel's other arrays are freed before the output is built, so that the output
        // and the verification's own index do not add to the kernel's peak memory.
        let particles = kernel.into_particles();
        let centres: Vec<Vec3> = particles.iter().map(|p| p.pos).collect();
        let grown: Vec<f64> = particles
            .iter()
            .map(|p| p.shape.bounding_radius(0.0))
            .collect();
        drop(particles);
        let (radii, min_gap, wall_gap) = match done.gap_wall_fraction {
            // The gap stage starts at the true sizes (validation requires it) and every radius
            // gains the same at the absolute rate; the guaranteed gap is twice the smallest gain
            // (they differ only by rounding), and the walls saw the fraction 2λ of each gain
            // (`Stage::wall_growth`). The true radii come from the seed, so a resumed run writes
            // the same.
            Some(fraction) => {
                let true_radii: Vec<f64> = true_diameters.iter().map(|d| 0.5 * d).collect();
                let gain = grown
                    .iter()
                    .zip(&true_radii)
                    .map(|(g, t)| g - t)
                    .fold(f64::INFINITY, f64::min)
                    .max(0.0);
                let min_gap = 2.0 * gain;
                let wall_gap = (fraction != 0.5).then_some(fraction * min_gap);
                (true_radii, min_gap, wall_gap)
            }
            None => (grown, 0.0, None),
        };
        let placed = Placed::spheres(original, centres, &radii, min_gap, wall_gap);
        let extra = if done.gap_history.is_empty() {
            Vec::new()
        } else {
            vec![("gap_history".into(), serde_json::json!(done.gap_history))]
        };
        (placed, extra)
    }
}

/// The kernel `file` stores, rebuilt in the scene's container `boundary` (relative to its
/// origin), and where its stages resume.
fn resumed_kernel<S, B, Q>(
    scene: &Scene,
    file: &CheckpointFile,
    boundary: B,
) -> Result<(Edmd<S, B, Q>, StagesFrom), RunError>
where
    S: Collidable + serde::de::DeserializeOwned,
    S::Spin: serde::de::DeserializeOwned,
    B: Boundary + SceneContainer,
    Q: EventQueue,
{
    let stage = file.header.stage;
    let kernel = Edmd::from_snapshot(file.take_kernel()?, boundary, kernel_config(scene))
        .map_err(|e| file.error(e.to_string()))?;
    let from = StagesFrom {
        stage,
        progress: Some(file.header.progress.clone().into_owned()),
        reports: file.header.reports.to_vec(),
    };
    Ok((kernel, from))
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

/// Where [`run_stages`] begins: at the first stage, or inside the stage a checkpoint was
/// taken in.
struct StagesFrom {
    /// Index of the first stage to run.
    stage: usize,
    /// Where that stage stands, if it had started.
    progress: Option<StageProgress>,
    /// Reports of the stages before it.
    reports: Vec<StageReport>,
}

impl StagesFrom {
    /// A fresh run.
    fn start() -> Self {
        Self {
            stage: 0,
            progress: None,
            reports: Vec::new(),
        }
    }
}

/// The stages of a run, and the wall gap fraction λ of the gap stage if one ran.
struct StagesDone {
    reports: Vec<StageReport>,
    gap_wall_fraction: Option<f64>,
    /// The gap Δd over time in a gap stage (paper 001, Fig. 10), at most
    /// [`GAP_HISTORY_POINTS`] barriers, evenly thinned; from the resume on after a restart.
    gap_history: Vec<GapSample>,
}

/// One barrier of a gap stage.
#[derive(Clone, Copy, Debug, serde::Serialize)]
struct GapSample {
    /// Simulated time of the stage.
    stage_time: f64,
    /// Gap between the grains at their true sizes: twice the radius gained.
    gap: f64,
    /// Events of the stage so far.
    events: u64,
    /// Wall-clock seconds of the stage so far.
    wall_seconds: f64,
    /// Reduced pressure over the last barrier interval.
    reduced_pressure: f64,
}

/// Most samples kept in a gap history.
const GAP_HISTORY_POINTS: usize = 256;

/// Packing fraction of spheres of diameters `d` (or of particles volume-equivalent to them)
/// in a container of volume `volume`.
fn sphere_fraction(d: &[f64], volume: f64) -> f64 {
    d.iter()
        .map(|d| std::f64::consts::PI / 6.0 * d * d * d)
        .sum::<f64>()
        / volume
}

/// Runs the scene's stages in order from `from`; the first stage that misses its goal fails
/// the run. `full_size_fraction` is the packing fraction of the particles at their true
/// sizes. At every time barrier `on_progress` hears of the stage, and a job that asks for
/// checkpoints writes one when its interval has passed.
fn run_stages<S, B: Boundary + SceneContainer, Q: EventQueue>(
    scene: &Scene,
    job: &Job,
    kernel: &mut Edmd<S, B, Q>,
    full_size_fraction: f64,
    from: StagesFrom,
    on_stage: &mut dyn FnMut(usize, &StageReport),
    on_progress: &mut dyn FnMut(usize, &Progress),
) -> Result<StagesDone, RunError>
where
    S: Collidable + serde::Serialize,
    S::Spin: serde::Serialize,
{
    let mut checkpointer = Checkpointer::of(job);
    let StagesFrom {
        stage: first,
        progress: mut resumed,
        mut reports,
    } = from;
    let mut gap_wall_fraction = None;
    let mut gap_history: Vec<GapSample> = Vec::new();
    for (k, spec) in scene.stages.iter().enumerate().skip(first) {
        // A resumed stage continues where its checkpoint was taken.
        let progress = resumed.take();
        if spec.opens_gap() {
            gap_wall_fraction = Some(spec.wall_gap_fraction());
        }
        let stage = spec.to_stage(full_size_fraction);
        let progress = progress.unwrap_or_else(|| kernel.start_stage(&stage));
        // In a gap stage (absolute growth) every radius has gained `∫ rate dt`
        // (`Progress::grown`); the gap is reported in the units of the scene as written.
        let opens_gap = spec.opens_gap();
        let units = Units::of(job.scene);
        let mut stride = 1usize;
        let mut barrier = 0usize;
        let report = kernel.continue_stage(&stage, progress, &mut |kernel, p| {
            let mut observed = p.observed(kernel);
            observed.gap = opens_gap.then(|| units.to_scene(2.0 * observed.grown));
            on_progress(k, &observed);
            if let Some(gap) = observed.gap {
                if barrier.is_multiple_of(stride) {
                    gap_history.push(GapSample {
                        stage_time: observed.stage_time,
                        gap,
                        events: observed.counts.events,
                        wall_seconds: observed.wall_seconds,
                        reduced_pressure: observed.reduced_pressure,
                    });
                    if gap_history.len() >= GAP_HISTORY_POINTS {
                        // Keep every other sample and sample half as often from now on.
                        let mut keep = false;
                        gap_history.retain(|_| {
                            keep = !keep;
                            keep
                        });
                        stride *= 2;
                    }
                }
                barrier += 1;
            }
            if let Some(c) = checkpointer.as_mut() {
                c.at_barrier(k, p, &reports, kernel);
            }
        });
        on_stage(k, &report);
        // A gap stage succeeds only when its time is up (every radius gained Δd/2): jamming
        // first (`JammedBeforeGoal`, or a `reduced_pressure` goal the scene adds) means the
        // gap does not fit. Δd maximisation ends when the gap cannot grow: jammed, or time
        // stopped advancing.
        let reached = if spec.until.gap.is_some() {
            report.stop_reason == StopReason::TimeReached
        } else {
            report.stop_reason.is_success()
                || (spec.until.max_gap == Some(true) && report.stop_reason == StopReason::Stalled)
        };
        reports.push(report);
        if !reached {
            let last = reports.last().expect("just pushed");
            return Err(RunError::StageFailed {
                stage: k,
                goal: spec.until.describe(),
                reason: last.stop_reason.as_str(),
                hint: last.stop_reason.hint(),
                events: last.counts.events,
                fraction: last.packing_fraction,
                pressure: last.reduced_pressure,
                stages: reports,
            });
        }
    }
    Ok(StagesDone {
        reports,
        gap_wall_fraction,
        gap_history,
    })
}

/// Where a packing came from: this program, the resolved scene, the seed, the timings.
fn provenance(scene: &impl serde::Serialize, seed: u64, timings: Timings) -> Provenance {
    Provenance {
        densepack_version: env!("CARGO_PKG_VERSION").into(),
        // Set by build.rs when built in a git checkout.
        git_commit: option_env!("DENSEPACK_GIT_COMMIT").map(Into::into),
        seed,
        scene: serde_json::to_value(scene).expect("a scene serialises"),
        timings,
        finished_unix_seconds: std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs()),
    }
}

/// The particles of a finished run (seeding order) and the gaps they guarantee.
struct Placed {
    particles: Vec<ParticleRecord>,
    /// Total particle volume.
    volume: f64,
    min_gap: f64,
    /// Gap to the walls when it is not `min_gap / 2`.
    wall_gap: Option<f64>,
}

impl Placed {
    /// Spheres with these centres (wrapped into `boundary`) and radii.
    fn spheres<B: Boundary>(
        boundary: &B,
        centres: Vec<Vec3>,
        radii: &[f64],
        min_gap: f64,
        wall_gap: Option<f64>,
    ) -> Self {
        let particles = centres
            .into_iter()
            .zip(radii)
            .map(|(mut c, &r)| {
                boundary.wrap(&mut c);
                ParticleRecord::Sphere {
                    center: c.into(),
                    radius: r,
                }
            })
            .collect();
        let volume = radii
            .iter()
            .map(|r| 4.0 / 3.0 * std::f64::consts::PI * r * r * r)
            .sum();
        Self {
            particles,
            volume,
            min_gap,
            wall_gap,
        }
    }
}

/// The statistics of an EDMD run of `n` particles from its stage reports (the packing
/// fraction is filled in by [`finish`]).
fn stats_of_stages(reports: &[StageReport], n: usize) -> PackingStats {
    let last = reports.last().expect("a scene has at least one stage");
    let events: u64 = reports.iter().map(|r| r.counts.events).sum();
    let collisions: u64 = reports.iter().map(|r| r.counts.collisions).sum();
    let wall_seconds: f64 = reports.iter().map(|r| r.wall_seconds).sum();
    let mut extra = serde_json::Map::new();
    extra.insert(
        "collisions_per_particle".into(),
        serde_json::json!(collisions as f64 / n.max(1) as f64),
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
    PackingStats {
        packing_fraction: 0.0,
        reduced_pressure: Some(last.reduced_pressure),
        events,
        collisions,
        wall_seconds,
        stop_reason: last.stop_reason.as_str().into(),
        extra,
    }
}

/// Builds the packing in the units and frame of `scene`, the scene as written (the run's
/// reduced lengths times `ℓ`, see [`Units`], translated from the kernel's coordinates to the
/// scene's, see [`container_origin`]), checks it independently and returns it. The packing
/// fraction is computed in reduced units: decimal rewrites of a scene give the same bits.
fn finish<B: Boundary>(
    scene: &Scene,
    container: ContainerRecord,
    boundary: &B,
    placed: Placed,
    stats: PackingStats,
    stages: Vec<StageReport>,
    seeding_seconds: f64,
) -> Result<RunOutcome, RunError> {
    let origin = container_origin(scene);
    let units = Units::of(scene);
    let to_scene = |y| units.to_scene(y);
    let particles = placed
        .particles
        .into_iter()
        .map(|p| p.in_frame(origin, to_scene))
        .collect();
    let mut packing = Packing {
        min_gap: to_scene(placed.min_gap),
        wall_gap: placed.wall_gap.map(to_scene),
        seed: scene.seed,
        stats: PackingStats {
            packing_fraction: placed.volume / boundary.volume(),
            ..stats
        },
        ..Packing::new(container.in_frame(origin, to_scene), particles)
    };
    let verify_started = std::time::Instant::now();
    let verification = verify(&packing);
    if !verification.ok() {
        return Err(RunError::Verification(verification.violations.join("; ")));
    }
    packing.provenance = Some(provenance(
        scene,
        scene.seed,
        Timings {
            seeding_seconds,
            stages_seconds: stages.iter().map(|r| r.wall_seconds).sum(),
            verification_seconds: verify_started.elapsed().as_secs_f64(),
        },
    ));
    Ok(RunOutcome {
        packing,
        stages,
        verification,
    })
}

// ------------------------------------------------------------------ sphere + cylinder mixtures

/// A finished mixture run: the verified packing and what the generation did.
#[derive(Debug)]
pub struct MixtureOutcome {
    /// The packing (verified).
    pub packing: Packing,
    /// The independent verification.
    pub verification: Verification,
}

/// Why a mixture run produced no packing.
#[derive(Debug, thiserror::Error)]
pub enum MixtureRunError {
    /// Random sequential adsorption failed.
    #[error(transparent)]
    Rsa(#[from] crate::protocol::mixture::rsa::RsaError),
    /// The relaxer gave up.
    #[error(transparent)]
    Relax(#[from] crate::protocol::mixture::relax::RelaxFailure),
    /// The independent check rejected the result: a bug; nothing is written.
    #[error("the independent overlap check rejected the packing: {0}")]
    Verification(String),
}

/// The packing record of a mixture configuration (periodic box, wrapped centres).
/// `reduced_pressure` is 0 (no pressure is measured without event-driven dynamics),
/// `events` counts RSA candidates or relaxer steps.
pub fn mixture_packing(
    rve: &crate::protocol::mixture::Rve,
    seed: u64,
    wall_seconds: f64,
    method: &str,
    mut extra: serde_json::Map<String, serde_json::Value>,
) -> Packing {
    let (fs, fc) = rve.fractions();
    extra.insert("method".into(), serde_json::json!(method));
    extra.insert("sphere_fraction".into(), serde_json::json!(fs));
    extra.insert("cylinder_fraction".into(), serde_json::json!(fc));
    let events = extra
        .get("candidates")
        .or_else(|| extra.get("steps"))
        .and_then(|v| v.as_u64())
        .unwrap_or(0);
    Packing {
        seed,
        stats: PackingStats {
            packing_fraction: fs + fc,
            events,
            wall_seconds,
            stop_reason: "intersection_free".into(),
            extra,
            ..PackingStats::default()
        },
        ..Packing::new(rve.boundary.record(), rve.records())
    }
}

/// Runs a validated mixture scene: RSA or random start + relaxer, then the independent
/// check; deterministic for the scene's seed (Xoshiro256++) unless a time limit strikes.
pub fn run_mixture(
    scene: &crate::io::scene::MixtureScene,
) -> Result<MixtureOutcome, MixtureRunError> {
    use crate::io::scene::MixtureMethod;
    use crate::protocol::mixture::{relax, rsa};
    let spec = scene.spec();
    let boundary = spec.boundary();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(scene.seed);
    let start = std::time::Instant::now();
    let mut extra = serde_json::Map::new();
    let method = scene.mixture.method.as_str();
    let rve = match scene.mixture.method {
        MixtureMethod::Rsa => {
            let sizes = spec.sizes(scene.mixture.order);
            let out = rsa::rsa_mixture(&boundary, &sizes, &scene.rsa_limits(), &mut rng)?;
            extra.insert("candidates".into(), serde_json::json!(out.candidates));
            extra.insert("restarts".into(), serde_json::json!(out.restarts));
            out.rve
        }
        MixtureMethod::Md => {
            let sizes = spec.sizes(crate::protocol::mixture::GenerationOrder::CylindersFirst);
            let mut rve = relax::random_rve(&boundary, &sizes, &mut rng);
            let report = relax::relax(&mut rve, &scene.relax_settings())?;
            extra.insert("steps".into(), serde_json::json!(report.steps));
            extra.insert("relax".into(), serde_json::json!(report));
            rve
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    let mut packing = mixture_packing(&rve, scene.seed, seconds, method, extra);
    let verify_started = std::time::Instant::now();
    let verification = verify(&packing);
    if !verification.ok() {
        return Err(MixtureRunError::Verification(
            verification.violations.join("; "),
        ));
    }
    packing.provenance = Some(provenance(
        scene,
        scene.seed,
        Timings {
            seeding_seconds: 0.0,
            stages_seconds: seconds,
            verification_seconds: verify_started.elapsed().as_secs_f64(),
        },
    ));
    Ok(MixtureOutcome {
        packing,
        verification,
    })
}
