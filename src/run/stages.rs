//! The stages of an EDMD run and what they leave: the scene's stage specs as kernel stages
//! ([`kernel_stage`], with the gap rule [`gap_opened`]), the stage loop over them (with
//! checkpoints at barriers and the gap history of a gap stage), the kernel settings of a
//! scene, a resumed kernel, the run's statistics and provenance, and the packing in the
//! scene's units and frame, checked independently ([`finish`]).

use super::{container_origin, CheckpointPlan, Job, RunError, RunOutcome, SceneContainer};
use crate::boundary::Boundary;
use crate::cancel::CancelFlag;
use crate::io::checkpoint::{write_checkpoint, CheckpointFile, CheckpointHeader};
use crate::io::packing::{
    ContainerRecord, Packing, PackingStats, ParticleRecord, Provenance, Timings,
};
use crate::io::record::SphereRecord;
use crate::io::scene::{GrowthKind, JamSpec, Scene, StageSpec};
use crate::io::units::Units;
use crate::kernel::{
    Edmd, EventCounts, KernelConfig, Limits, PressureAdaptive, Progress, RateSchedule, Stage,
    StageProgress, StageReport, StopReason, Until, JAMMING_PRESSURE,
};
use crate::protocol::slp::{BoxedSpheres, SlpSettings, SlpStop};
use crate::queue::EventQueue;
use crate::shape::{Collidable, Growth, Vec3};
use crate::verify::verify;

/// Writes a checkpoint at a barrier once `plan.every` has passed since the last one.
pub(super) struct Checkpointer<'a> {
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

/// The kernel `file` stores, rebuilt in the scene's container `boundary` (relative to its
/// origin), and where its stages resume.
pub(super) fn resumed_kernel<S, B, Q>(
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
pub(super) fn kernel_config(scene: &Scene) -> KernelConfig {
    KernelConfig {
        mass: scene.mass,
        temperature: scene.temperature,
        events_per_particle_per_interval: scene.events_per_particle_per_interval,
        neighbour_skin: scene.neighbour_skin,
    }
}

/// The gap rule of a gap stage (paper 001, Eq. 31): from their true sizes every grain grows
/// by the same radius `grown` (`∫ rate dt` at the absolute rate, `rate·t` for a fixed rate),
/// so the gap opened between any two grains is `Δd = 2·grown`. The one place the rule is
/// written: a gap stage's end time and wall growth ([`kernel_stage`]), the gap reported at
/// every barrier and the `min_gap` of the written packing all use it.
pub fn gap_opened(grown: f64) -> f64 {
    2.0 * grown
}

/// Relative extra time of a gap stage (see [`kernel_stage`]): the gap overshoots the
/// requested Δd by at most this fraction, far more than the rounding of the accumulated
/// growth (about 10⁻¹⁵ of a radius per barrier) and far below any length a user resolves.
const GAP_TIME_MARGIN: f64 = 1e-9;

/// The kernel stage a scene's stage `spec` describes. `full_size_fraction` is the packing
/// fraction of the particles at their true sizes (the `full_size` goal). The schema
/// (`io::scene`) validates and describes the spec; the conversion is the runner's.
pub fn kernel_stage(spec: &StageSpec, full_size_fraction: f64) -> Stage {
    let growth = match (spec.growth, spec.rate) {
        (GrowthKind::Relative, Some(r)) => Growth::Relative(r),
        (GrowthKind::Absolute, Some(r)) => Growth::Absolute(r),
        _ => Growth::None,
    };
    let u = &spec.until;
    let mut until = Until {
        packing_fraction: u.packing_fraction,
        reduced_pressure: u.reduced_pressure,
        time: u.time,
        collisions_per_particle: u.collisions_per_particle,
    };
    if u.full_size == Some(true) {
        until.packing_fraction = Some(full_size_fraction);
    }
    if let (Some(gap), Some(rate)) = (u.gap, spec.rate) {
        // At the fixed absolute rate the gap opens at `gap_opened(rate)` per unit time (the
        // rule is linear), so it reaches Δd at `Δd / gap_opened(rate)` (Eq. 31). The stage
        // runs `GAP_TIME_MARGIN` longer, so that rounding in the growth accumulated over
        // thousands of barriers cannot leave a grain short of Δd/2: the packing then keeps
        // the requested Δd, which is what it claims (`StagesDone::requested_gap`).
        let t = gap / gap_opened(rate) * (1.0 + GAP_TIME_MARGIN);
        until.time = Some(until.time.map_or(t, |x| x.min(t)));
    }
    // Δd maximisation ends when the grains jam; any other growing stage that jams fails
    // there (`Limits::jamming_pressure`) instead of grinding on.
    if u.max_gap == Some(true) && until.reduced_pressure.is_none() {
        until.reduced_pressure = Some(JAMMING_PRESSURE);
    }
    Stage {
        growth,
        schedule: match spec.adaptive {
            Some(a) => RateSchedule::PressureAdaptive(PressureAdaptive {
                onset: a.onset_pressure,
                exponent: a.exponent,
                min_rate: a.min_rate,
            }),
            None => RateSchedule::Fixed,
        },
        until,
        limits: Limits {
            events: spec.max_events.unwrap_or(u64::MAX),
            wall_seconds: spec.max_wall_seconds,
            stall_epsilon: spec.stall_epsilon.unwrap_or(0.0),
            jamming_pressure: Some(JAMMING_PRESSURE),
        },
        thermostat: spec.thermostat.unwrap_or(growth != Growth::None),
        // The walls see the fraction f of each grain's growth, so they keep f·grown from it;
        // the wall gap is to be λ·Δd = λ·gap_opened(grown) = gap_opened(λ)·grown (the rule is
        // linear), so f = gap_opened(λ).
        wall_growth: if spec.opens_gap() {
            gap_opened(spec.wall_gap_fraction())
        } else {
            1.0
        },
    }
}

/// Where [`run_stages`] begins: at the first stage, or inside the stage a checkpoint was
/// taken in.
pub(super) struct StagesFrom {
    /// Index of the first stage to run.
    pub(super) stage: usize,
    /// Where that stage stands, if it had started.
    pub(super) progress: Option<StageProgress>,
    /// Reports of the stages before it.
    pub(super) reports: Vec<StageReport>,
}

impl StagesFrom {
    /// A fresh run.
    pub(super) fn start() -> Self {
        Self {
            stage: 0,
            progress: None,
            reports: Vec::new(),
        }
    }
}

/// The stages of a run, and the wall gap fraction λ of the gap stage if one ran.
pub(super) struct StagesDone {
    pub(super) reports: Vec<StageReport>,
    /// `StageSpec::wall_gap_fraction` of the gap stage, if one ran.
    pub(super) wall_gap_fraction: Option<f64>,
    /// The gap Δd a `gap` stage asked for (not set by Δd maximisation).
    pub(super) requested_gap: Option<f64>,
    /// The gap Δd over time in a gap stage (paper 001, Fig. 10), at most
    /// [`GAP_HISTORY_POINTS`] barriers, evenly thinned; from the resume on after a restart.
    pub(super) gap_history: Vec<GapSample>,
}

/// One barrier of a gap stage.
#[derive(Clone, Copy, Debug, serde::Serialize)]
pub(super) struct GapSample {
    /// Simulated time of the stage.
    stage_time: f64,
    /// Gap between the grains at their true sizes ([`gap_opened`] of the radius gained).
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
pub(super) fn sphere_fraction(d: &[f64], volume: f64) -> f64 {
    d.iter()
        .map(|d| std::f64::consts::PI / 6.0 * d * d * d)
        .sum::<f64>()
        / volume
}

/// Runs the scene's stages in order from `from`; the first stage that misses its goal fails
/// the run. `full_size_fraction` is the packing fraction of the particles at their true
/// sizes. At every time barrier `on_progress` hears of the stage, and a job that asks for
/// checkpoints writes one when its interval has passed.
pub(super) fn run_stages<S, B: Boundary + SceneContainer, Q: EventQueue>(
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
    let mut wall_gap_fraction = None;
    let mut requested_gap = None;
    let mut gap_history: Vec<GapSample> = Vec::new();
    for (k, spec) in scene.stages.iter().enumerate().skip(first) {
        // A resumed stage continues where its checkpoint was taken.
        let progress = resumed.take();
        if spec.opens_gap() {
            wall_gap_fraction = Some(spec.wall_gap_fraction());
            requested_gap = spec.until.gap;
        }
        let stage = kernel_stage(spec, full_size_fraction);
        let progress = progress.unwrap_or_else(|| kernel.start_stage(&stage));
        // In a gap stage (absolute growth) every radius has gained `∫ rate dt`
        // (`Progress::grown`); the gap is reported in the units of the scene as written.
        let opens_gap = spec.opens_gap();
        let units = Units::of(job.scene);
        let mut stride = 1usize;
        let mut barrier = 0usize;
        let mut report = kernel.continue_stage(&stage, progress, &mut |kernel, p| {
            let mut observed = p.observed(kernel);
            observed.gap = opens_gap.then(|| units.to_scene(gap_opened(observed.grown)));
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
        // A gap stage's end time is the time its gap takes (unless the scene set a shorter
        // `until.time`): say so, rather than that a time ran out.
        let gap_time_governs = spec.until.time.is_none_or(|t| stage.until.time < Some(t));
        if spec.until.gap.is_some()
            && gap_time_governs
            && report.stop_reason == StopReason::TimeReached
        {
            report.stop_reason = StopReason::GapReached;
        }
        on_stage(k, &report);
        if report.stop_reason == StopReason::Cancelled {
            return Err(RunError::Cancelled);
        }
        // A gap stage succeeds only when its time is up (every radius gained Δd/2): jamming
        // first (`JammedBeforeGoal`, or a `reduced_pressure` goal the scene adds) means the
        // gap does not fit. Δd maximisation ends when the gap cannot grow: jammed, or time
        // stopped advancing.
        let reached = if spec.until.gap.is_some() {
            matches!(
                report.stop_reason,
                StopReason::GapReached | StopReason::TimeReached
            )
        } else {
            report.stop_reason.is_success()
                || (spec.until.max_gap == Some(true) && report.stop_reason == StopReason::Stalled)
        };
        reports.push(report);
        if !reached {
            return Err(RunError::stage_failed(k, spec.until.describe(), reports));
        }
    }
    Ok(StagesDone {
        reports,
        wall_gap_fraction,
        requested_gap,
        gap_history,
    })
}

/// Where a packing came from: this program, the resolved scene, the seed, the timings.
pub(super) fn provenance(scene: &impl serde::Serialize, seed: u64, timings: Timings) -> Provenance {
    Provenance::new(
        serde_json::to_value(scene).expect("a scene serialises"),
        seed,
        timings,
    )
}

/// The particles of a finished run (seeding order) and the gaps they guarantee.
pub(super) struct Placed {
    pub(super) particles: Vec<ParticleRecord>,
    /// Total particle volume.
    pub(super) volume: f64,
    pub(super) min_gap: f64,
    /// Gap to the walls when it is not `min_gap / 2`.
    pub(super) wall_gap: Option<f64>,
}

impl Placed {
    /// Spheres with these centres (wrapped into `boundary`) and radii.
    pub(super) fn spheres<B: Boundary>(
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
                ParticleRecord::Sphere(SphereRecord {
                    center: c.into(),
                    radius: r,
                })
            })
            .collect();
        Self {
            particles,
            volume: balls_volume(radii),
            min_gap,
            wall_gap,
        }
    }
}

/// Total volume of spheres of radii `radii`.
fn balls_volume(radii: &[f64]) -> f64 {
    radii
        .iter()
        .map(|r| 4.0 / 3.0 * std::f64::consts::PI * r * r * r)
        .sum()
}

/// The `[jam]` step on the spheres of a finished run in `container` (a box, in the
/// boundary's frame): sequential linear programming until collectively jammed
/// ([`crate::protocol::slp`]), its report as a stage's: its events are the programs
/// solved, its pressure the last stage's (the programs measure none). `on_progress` sees
/// the same record after every program.
pub(super) fn jam_placed(
    placed: &mut Placed,
    container: &ContainerRecord,
    jam: &JamSpec,
    last: Option<&StageReport>,
    cancel: Option<CancelFlag>,
    on_progress: &mut dyn FnMut(&Progress),
) -> StageReport {
    let ContainerRecord::Box { min, max, periodic } = container else {
        unreachable!("validation admits [jam] in a box only");
    };
    let (centers, radii) = placed
        .particles
        .iter()
        .map(|p| match p {
            ParticleRecord::Sphere(s) => (s.center, s.radius),
            _ => unreachable!("validation admits [jam] with spheres only"),
        })
        .unzip();
    let mut spheres = BoxedSpheres {
        lo: *min,
        len: std::array::from_fn(|k| max[k] - min[k]),
        periodic: *periodic,
        centers,
        radii,
    };
    let settings = SlpSettings {
        max_steps: jam.max_steps.unwrap_or(SlpSettings::default().max_steps),
        max_seconds: jam.max_wall_seconds.unwrap_or(f64::INFINITY),
        cancel,
        ..SlpSettings::default()
    };
    let volume: f64 = spheres.len.iter().product();
    let pressure = last.map_or(0.0, |r| r.reduced_pressure);
    let mut fraction = balls_volume(&spheres.radii) / volume;
    let outcome = spheres.jam(&settings, &mut |step| {
        fraction *= step.scale.powi(3);
        on_progress(&Progress {
            stage_time: 0.0,
            goal_time: None,
            packing_fraction: fraction,
            reduced_pressure: pressure,
            counts: EventCounts {
                events: step.step as u64,
                ..EventCounts::default()
            },
            wall_seconds: step.seconds,
            rate: 0.0,
            grown: 0.0,
            gap: None,
        });
    });
    for (p, (c, r)) in placed
        .particles
        .iter_mut()
        .zip(spheres.centers.iter().zip(&spheres.radii))
    {
        *p = ParticleRecord::Sphere(SphereRecord {
            center: *c,
            radius: *r,
        });
    }
    placed.volume = balls_volume(&spheres.radii);
    StageReport {
        stop_reason: match outcome.stop {
            SlpStop::Jammed => StopReason::CollectivelyJammed,
            SlpStop::StepLimit => StopReason::EventLimit,
            SlpStop::TimeLimit => StopReason::WallClockLimit,
            SlpStop::SolverFailed(_) => StopReason::SolverFailed,
            SlpStop::Cancelled => StopReason::Cancelled,
        },
        counts: EventCounts {
            events: outcome.steps as u64,
            ..EventCounts::default()
        },
        simulated_time: 0.0,
        wall_seconds: outcome.seconds,
        packing_fraction: placed.volume / volume,
        reduced_pressure: pressure,
        reduced_pressure_stderr: None,
    }
}

/// The statistics of an EDMD run of `n` particles from its stage reports (the packing
/// fraction is filled in by [`finish`]).
pub(super) fn stats_of_stages(reports: &[StageReport], n: usize) -> PackingStats {
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
pub(super) fn finish<B: Boundary>(
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

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(toml_text: &str) -> StageSpec {
        toml::from_str(toml_text).expect("a stage table")
    }

    #[test]
    fn a_gap_stage_ends_when_every_radius_has_gained_half_the_gap() {
        // Δd = 1 at the absolute rate 0.01: each radius gains 0.5, which takes 50 time units
        // (and the margin 10⁻⁹ of them more); a wall gap of 0.25 is λ = 1/4 of Δd, so the
        // walls see half of each grain's growth.
        let s = spec("growth = \"absolute\"\nrate = 0.01\nuntil = { gap = 1.0 }\nwall_gap = 0.25");
        let stage = kernel_stage(&s, 0.3);
        assert_eq!(stage.growth, Growth::Absolute(0.01));
        assert_eq!(stage.until.time, Some(50.0 * (1.0 + GAP_TIME_MARGIN)));
        assert_eq!(stage.wall_growth, 0.5);
        assert_eq!(gap_opened(0.5), 1.0);
        // A time goal shorter than the gap's wins.
        let s = spec("growth = \"absolute\"\nrate = 0.01\nuntil = { gap = 1.0, time = 20.0 }");
        assert_eq!(kernel_stage(&s, 0.3).until.time, Some(20.0));
        // Without a wall gap each grain keeps half the gap to the walls: they see it whole.
        let s = spec("growth = \"absolute\"\nrate = 0.01\nuntil = { max_gap = true }");
        let stage = kernel_stage(&s, 0.3);
        assert_eq!(stage.wall_growth, 1.0);
        assert_eq!(stage.until.time, None);
        assert_eq!(stage.until.reduced_pressure, Some(JAMMING_PRESSURE));
    }

    #[test]
    fn other_stages_see_the_walls_at_the_particles_size_and_full_size_is_a_fraction() {
        let s = spec("growth = \"relative\"\nrate = 0.05\nuntil = { full_size = true }");
        let stage = kernel_stage(&s, 0.42);
        assert_eq!(stage.growth, Growth::Relative(0.05));
        assert_eq!(stage.until.packing_fraction, Some(0.42));
        assert_eq!(stage.wall_growth, 1.0);
        assert!(stage.thermostat);
        assert_eq!(stage.limits.jamming_pressure, Some(JAMMING_PRESSURE));
        let s = spec("growth = \"none\"\nuntil = { time = 3.0 }\nmax_events = 7");
        let stage = kernel_stage(&s, 0.42);
        assert_eq!(stage.growth, Growth::None);
        assert!(!stage.thermostat);
        assert_eq!(stage.limits.events, 7);
    }
}
