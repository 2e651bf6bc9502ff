//! Running a scene: seeding, stages, independent verification, the packing.
//!
//! [`run_scene`] picks the container and queue types from the scene once and runs a kernel
//! monomorphised for them: a fully periodic box gets [`PeriodicBox`] (no wall code at all).
//! The rooms of the runner, by what they run:
//!
//! - this module: the entry points, errors and outcome, the container and queue dispatch,
//!   and the run of any particle kind (`ShapeRun`);
//! - `spheres`: sphere scenes, their seeding (RSA scenes end there) and written spheres;
//! - [`ellipsoid`]: ellipsoid scenes, seeding with random orientations, the orientation
//!   tensor;
//! - `stages`: the scene's stage specs as kernel stages ([`kernel_stage`], the gap rule
//!   [`gap_opened`]), the stage loop (checkpoints, gap history), statistics, provenance and
//!   the verified packing;
//! - `mixture`: sphere + cylinder mixtures (no EDMD kernel), RSA or the relaxer, and their
//!   file records.
//!
//! The kernel runs relative to the container's origin (`container_origin`) and in the
//! scene's reduced lengths ([`Units`]: every length divided by `ℓ = 10^E`, exactly under
//! decimal changes of unit); the packing is scaled and translated back when it is written.
//! [`run`] runs any scene ([`AnyScene`]) with [`RunOptions`]: checkpoints at time barriers
//! (sphere and ellipsoid runs; [`resume_run`] continues from one), a cancel flag
//! ([`crate::cancel`]) and observers of stages and progress. [`run_scene`] is the plain
//! entry for a sphere or ellipsoid scene.

pub mod ellipsoid;
mod mixture;
mod spheres;
mod stages;

pub use mixture::mixture_packing;
pub use stages::{gap_opened, kernel_stage};

use crate::boundary::{Boundary, CylinderContainer, PeriodicBox, WalledBox};
use crate::cancel::CancelFlag;
use crate::io::checkpoint::{CheckpointError, CheckpointFile};
use crate::io::packing::ContainerRecord;
use crate::io::packing::Packing;
use crate::io::scene::{AnyScene, ContainerSpec, Scene, StartPacking};
use crate::io::units::Units;
use crate::kernel::{Edmd, Progress, StageReport};
use crate::protocol::mixture::{relax::RelaxFailure, rsa::RsaError};
use crate::protocol::rsa::{RsaFailure, SeedingError};
use crate::queue::{CalendarQueue, EventQueue, HeapQueue, QueueKind};
use crate::shape::{Collidable, Vec3};
use crate::verify::Verification;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use spheres::Spheres;
use stages::{
    finish, jam_placed, resumed_kernel, run_stages, sphere_fraction, stats_of_stages, Placed,
    StagesDone, StagesFrom,
};

/// A finished run of any scene: the packing (verified) and what happened.
#[derive(Debug)]
pub struct RunOutcome {
    /// The packing, synchronised at the end of the last stage.
    pub packing: Packing,
    /// Report of every stage that ran (empty for RSA and mixture scenes, which have none).
    pub stages: Vec<StageReport>,
    /// The independent verification of the packing.
    pub verification: Verification,
}

/// Why a run produced no packing.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Seeding by random sequential addition failed.
    #[error(transparent)]
    Seeding(RsaFailure),
    /// Random sequential adsorption of a mixture failed (never its `Cancelled`, which is
    /// [`RunError::Cancelled`]).
    #[error(transparent)]
    Adsorption(RsaError),
    /// The relaxer of a mixture gave up.
    #[error(transparent)]
    Relaxation(RelaxFailure),
    /// The cancel flag of [`RunOptions::cancel`] was set: no packing.
    #[error("the run was cancelled")]
    Cancelled,
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
    /// The packing a scene starts from (`particles.from`) cannot be read or used: its
    /// spheres overlap by the independent check, or the file changed since validation.
    #[error("{0}")]
    Start(String),
}

impl RunError {
    /// The failure of stage `stage`, whose goal was `goal` and whose report is the last of
    /// `reports` (the stages so far).
    pub(crate) fn stage_failed(stage: usize, goal: String, reports: Vec<StageReport>) -> Self {
        let last = reports.last().expect("a failed stage has a report");
        Self::StageFailed {
            stage,
            goal,
            reason: last.stop_reason.as_str(),
            hint: last.stop_reason.hint(),
            events: last.counts.events,
            fraction: last.packing_fraction,
            pressure: last.reduced_pressure,
            stages: reports,
        }
    }
}

impl From<SeedingError> for RunError {
    fn from(e: SeedingError) -> Self {
        match e {
            SeedingError::Failed(f) => RunError::Seeding(f),
            SeedingError::Cancelled => RunError::Cancelled,
        }
    }
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

/// Hears of each finished stage: its index (from 0) and report.
pub type StageObserver<'a> = dyn FnMut(usize, &StageReport) + 'a;

/// Hears of the running stage (its index from 0) at every time barrier.
pub type ProgressObserver<'a> = dyn FnMut(usize, &Progress) + 'a;

/// How a run is carried out besides its scene: checkpoints, cancellation, observers. Every
/// field is optional (`RunOptions::default()` runs plainly).
#[derive(Default)]
pub struct RunOptions<'a> {
    /// Write checkpoints as the plan says (sphere and ellipsoid scenes: a mixture scene with
    /// a plan fails with [`RunError::Unsupported`]; an RSA scene never reaches a barrier).
    pub checkpoints: Option<CheckpointPlan>,
    /// Stop the run, from any thread, by setting the flag: the run returns
    /// [`RunError::Cancelled`] within milliseconds (see [`crate::cancel`] for where it is
    /// checked).
    pub cancel: Option<CancelFlag>,
    /// Told of each finished stage: its index (from 0, as in errors and reports) and report.
    pub on_stage: Option<&'a mut StageObserver<'a>>,
    /// Told the stage index and its [`Progress`] at every time barrier (throttle in the
    /// observer: barriers can come thousands of times a second).
    pub on_progress: Option<&'a mut ProgressObserver<'a>>,
}

/// How a run starts and what it writes on the way.
struct Job<'a> {
    /// The scene as written (validated): its origin, units and provenance. The stages run
    /// on its reduced copy ([`Units::reduced`]).
    scene: &'a Scene,
    /// The scene's TOML text, stored in checkpoints (empty without checkpoints).
    scene_toml: &'a str,
    /// A fresh run seeds; a resumed one rebuilds the kernel from the checkpoint.
    resume: Option<&'a CheckpointFile>,
    checkpoints: Option<&'a CheckpointPlan>,
    /// Given to the seeding and the kernel.
    cancel: Option<CancelFlag>,
}

/// Runs any validated scene (spheres, ellipsoids or a mixture) as `options` say. Same scene
/// and seed give the same particles bit for bit, with or without checkpoints and observers.
pub fn run(scene: &AnyScene, options: RunOptions) -> Result<RunOutcome, RunError> {
    let scene = match scene {
        AnyScene::Spheres(scene) => scene,
        AnyScene::Mixture(mixture) => {
            if options.checkpoints.is_some() {
                return Err(RunError::Unsupported(
                    "checkpoints: mixture scenes (RSA or relaxation, no time barriers) cannot \
                     be checkpointed"
                        .into(),
                ));
            }
            return mixture::run_mixture(mixture, options.cancel.as_deref());
        }
    };
    let scene_toml = match &options.checkpoints {
        // A checkpoint stores the scene it resumes (the scene round-trips exactly).
        Some(_) => toml::to_string(scene.as_ref())
            .map_err(|e| RunError::Unsupported(format!("the scene cannot be stored: {e}")))?,
        None => String::new(),
    };
    let job = Job {
        scene,
        scene_toml: &scene_toml,
        resume: None,
        checkpoints: options.checkpoints.as_ref(),
        cancel: options.cancel.clone(),
    };
    run_observed(&job, options.on_stage, options.on_progress)
}

/// Continues the run that wrote `checkpoint` to the packing the uninterrupted run gives
/// (the same particles, bit for bit; timings differ), writing further checkpoints as
/// `options.checkpoints` says. `options.on_stage` hears of the stages that finish from
/// here on.
pub fn resume_run(
    checkpoint: &CheckpointFile,
    options: RunOptions,
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
        checkpoints: options.checkpoints.as_ref(),
        cancel: options.cancel.clone(),
    };
    run_observed(&job, options.on_stage, options.on_progress)
}

/// Runs a validated sphere or ellipsoid scene. `on_stage` is told about each finished
/// stage. ([`run`] takes any scene and more options.)
pub fn run_scene(
    scene: &Scene,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<RunOutcome, RunError> {
    let job = Job {
        scene,
        scene_toml: "",
        resume: None,
        checkpoints: None,
        cancel: None,
    };
    run_job(&job, on_stage, &mut |_, _| {})
}

/// [`run_job`] with the observers of [`RunOptions`] (none: nobody is told).
fn run_observed(
    job: &Job,
    on_stage: Option<&mut StageObserver>,
    on_progress: Option<&mut ProgressObserver>,
) -> Result<RunOutcome, RunError> {
    let mut no_stage = |_: usize, _: &StageReport| {};
    let mut no_progress = |_: usize, _: &Progress| {};
    run_job(
        job,
        on_stage.unwrap_or(&mut no_stage),
        on_progress.unwrap_or(&mut no_progress),
    )
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
    /// draws after them; freed before the kernel is built) or the spheres of `start`
    /// (`particles.from`, at their places; `true_diameters` is then empty), or the finished
    /// packing of a scene that ends with its seeding.
    fn seed<B: Boundary + SceneContainer, Q: EventQueue>(
        scene: &Scene,
        job: &Job,
        true_diameters: Vec<f64>,
        start: Option<&StartPacking>,
        boundary: B,
        rng: &mut Xoshiro256PlusPlus,
        started: std::time::Instant,
    ) -> Result<Seeded<Self::Shape, B, Q>, RunError>;

    /// The packing of the finished `kernel` in the container `original`, and the kind's
    /// own statistics (in the order they are written). `true_diameters` gives the sizes
    /// [`ShapeRun::seed`] had (in input order), for the kinds that need them.
    fn packing<B: Boundary, Q: EventQueue>(
        kernel: Edmd<Self::Shape, B, Q>,
        original: &B,
        true_diameters: &dyn Fn() -> Vec<f64>,
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
    // Drawn first from the seed, so a resumed run draws the same sizes again; a scene that
    // starts from a packing has the file's.
    let start = scene
        .start_packing()
        .map_err(|e| RunError::Start(e.to_string()))?;
    let true_diameters = match &start {
        Some(s) => s.radii.iter().map(|r| 2.0 * r).collect(),
        None => scene.true_diameters(&mut rng),
    };
    // Ellipsoids are volume-equivalent to spheres of the true diameters.
    let full_size_fraction = sphere_fraction(&true_diameters, boundary.volume());
    let original = boundary.clone();
    // Not held through the stages (8 B per particle of the peak): drawn sizes are drawn again
    // from the seed for the packing; a start packing's are kept (and its centres freed).
    let (true_diameters, given) = match &start {
        Some(_) => (Vec::new(), Some(true_diameters)),
        None => (true_diameters, None),
    };
    // The random generator is consumed by seeding and the initial velocities only, so a
    // checkpoint (taken at a later barrier) needs none of its state.
    let (mut kernel, from, seeding_seconds) = match job.resume {
        None => match R::seed::<B, Q>(
            scene,
            job,
            true_diameters,
            start.as_ref(),
            boundary,
            &mut rng,
            started,
        )? {
            Seeded::Kernel(kernel, seconds) => (kernel, StagesFrom::start(), seconds),
            Seeded::Finished(outcome) => return Ok(outcome),
        },
        Some(file) => {
            drop(true_diameters);
            let (kernel, from) = resumed_kernel(scene, file, boundary)?;
            (kernel, from, 0.0)
        }
    };
    drop(start);
    let true_sizes = || match &given {
        Some(sizes) => sizes.clone(),
        None => scene.true_diameters(&mut Xoshiro256PlusPlus::seed_from_u64(scene.seed)),
    };
    kernel.set_cancel(job.cancel.clone());
    let mut done = run_stages(
        scene,
        job,
        &mut kernel,
        full_size_fraction,
        from,
        on_stage,
        on_progress,
    )?;
    let (mut placed, extra) = R::packing(kernel, &original, &true_sizes, &done);
    if let Some(jam) = &scene.jam {
        let report = jam_placed(
            &mut placed,
            &original.record(),
            jam,
            done.reports.last(),
            job.cancel.clone(),
            &mut |progress| on_progress(done.reports.len(), progress),
        );
        on_stage(done.reports.len(), &report);
        let stop = report.stop_reason;
        if stop == crate::kernel::StopReason::Cancelled {
            return Err(RunError::Cancelled);
        }
        done.reports.push(report);
        if !stop.is_success() {
            let stage = done.reports.len() - 1;
            return Err(RunError::stage_failed(
                stage,
                "[jam]: collectively jammed".into(),
                done.reports,
            ));
        }
    }
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
