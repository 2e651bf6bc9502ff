//! Stages: one growth protocol run until a stop criterion.

use super::{frozen_check_limit, Edmd, EventBudget, EventCounts};
use crate::boundary::Boundary;
use crate::queue::EventQueue;
use crate::shape::{Collidable, Growth};

/// When a stage has reached its goal (first criterion met wins). All are optional; a stage
/// with none runs until a [`Limits`] entry stops it, which counts as failure.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Until {
    /// Stop when the packing fraction reaches this value (exactly: the barrier is placed at
    /// the time the growing sizes give this fraction).
    pub packing_fraction: Option<f64>,
    /// Stop when the reduced pressure `Z` of a barrier interval reaches this value
    /// (jamming; 1e12 is the usual threshold).
    pub reduced_pressure: Option<f64>,
    /// Stop after this much simulated time.
    pub time: Option<f64>,
    /// Stop after this many pair collisions per particle.
    pub collisions_per_particle: Option<f64>,
}

/// Limits whose firing means the stage failed.
#[derive(Clone, Debug, PartialEq)]
pub struct Limits {
    /// Most events the stage may process.
    pub events: u64,
    /// Most wall-clock seconds the stage may take.
    pub wall_seconds: Option<f64>,
    /// Stall criterion of paper 001: fail when the simulated time advances less than this
    /// over 1000 events. Zero still fails a run whose time does not advance at all.
    pub stall_epsilon: f64,
    /// A growing stage fails when the reduced pressure of a barrier interval reaches this
    /// value before its goal: the particles are jammed, so no packing fraction, time or gap
    /// beyond that point can be reached by growth ([`StopReason::JammedBeforeGoal`]). A goal
    /// of [`Until::reduced_pressure`] is checked first, so a jamming stage succeeds.
    /// `None` lets a stage grow on at any pressure (it then needs another limit to end).
    pub jamming_pressure: Option<f64>,
}

/// Reduced pressure `Z = PV/(NkT)` taken as jammed: at `Z = 10¹²` the gaps that carry the
/// pressure are about `10⁻¹²` diameters wide, the resolution of double precision.
pub const JAMMING_PRESSURE: f64 = 1e12;

impl Default for Limits {
    fn default() -> Self {
        Self {
            events: u64::MAX,
            wall_seconds: None,
            stall_epsilon: 0.0,
            jamming_pressure: Some(JAMMING_PRESSURE),
        }
    }
}

/// How a growing stage sets its rate at each time barrier.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum RateSchedule {
    /// The rate of [`Stage::growth`] throughout.
    #[default]
    Fixed,
    /// The rate falls as the reduced pressure rises ([`PressureAdaptive::rate`]).
    PressureAdaptive(PressureAdaptive),
}

/// A growth rate that falls as the reduced pressure `Z` rises, so that the particles relax
/// between increments near jamming (the protocols of Donev, Torquato & Stillinger and of
/// Skoge et al., PRE 74, 041127, 2006: fast compression to moderate pressure, then slower
/// growth). Near jamming a pair's gap is about `d/Z`, and growth at a relative rate `γ`
/// closes it in a time `1/(γZ)`, while the collective rearrangements that make the contact
/// network rigid need a time that does not shrink with `Z`: a fixed rate freezes a floppy
/// network (`densepack analyse` measures it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PressureAdaptive {
    /// Reduced pressure below which the stage grows at its full rate.
    pub onset: f64,
    /// Exponent `α` of the fall: `rate = rate₀·(onset/Z)^α` above the onset.
    pub exponent: f64,
    /// Smallest rate (same unit as the stage's rate).
    pub min_rate: f64,
}

impl PressureAdaptive {
    /// The rate for base rate `base` at reduced pressure `z`:
    /// `clamp(base·(onset/z)^α, min_rate, base)`; `base` before the first measurement.
    pub fn rate(&self, base: f64, z: f64) -> f64 {
        if z.is_nan() || z <= self.onset {
            return base;
        }
        (base * (self.onset / z).powf(self.exponent)).clamp(self.min_rate.min(base), base)
    }
}

/// One stage of a run.
#[derive(Clone, Debug, PartialEq)]
pub struct Stage {
    /// Growth protocol (with the stage's full rate).
    pub growth: Growth,
    /// How the rate follows the pressure.
    pub schedule: RateSchedule,
    /// Goal.
    pub until: Until,
    /// Failure limits.
    pub limits: Limits,
    /// Rescale velocities to the set temperature at every barrier. Growth heats the system,
    /// so growth stages want it; equilibrium stages conserve energy without it.
    pub thermostat: bool,
    /// Fraction `f ∈ [0, 1]` of each particle's bounding growth rate `g` that the walls see:
    /// a wall meets the particle's bounding sphere less `(1 − f)·g·τ` at stage time `τ`, so
    /// the particle at its size of the stage start keeps `f·g·τ` from the walls while its
    /// bounding sphere reaches `(1 − f)·g·τ` into them. 1 (walls see the particle as it is)
    /// for every stage but gap stages (paper 001, Eq. 31), where the grains' true sizes are
    /// those of the stage start and `f = 2·wall gap/Δd`. Shapes with their own plane contacts
    /// ([`Collidable::PlaneContact`]) meet walls through their bounding sphere when
    /// `f < 1`.
    pub wall_growth: f64,
}

/// Why a stage stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The requested packing fraction was reached.
    PackingFractionReached,
    /// The reduced pressure passed the stage's goal (`until.reduced_pressure`). Whether the
    /// packing is jammed is judged from its contact network (`crate::analysis`), not by
    /// this stop.
    #[serde(alias = "jammed")]
    PressureReached,
    /// The requested simulated time passed.
    TimeReached,
    /// A gap stage opened its gap Δd (set by the runner, whose gap rule turns Δd into the
    /// stage's time; the kernel itself stops with [`StopReason::TimeReached`]).
    GapReached,
    /// The requested number of collisions per particle was processed.
    CollisionsReached,
    /// Simulated time stopped advancing (Δt < ε over 1000 events, or no advance at all over
    /// 100 events per particle), or nothing moves and nothing grows.
    Stalled,
    /// The event limit was hit.
    EventLimit,
    /// The wall-clock limit was hit.
    WallClockLimit,
    /// The goal cannot be reached by this stage (e.g. a packing fraction without growth).
    Unreachable,
    /// The particles jammed ([`Limits::jamming_pressure`]) before the goal was reached.
    JammedBeforeGoal,
    /// Another thread set the kernel's cancel flag ([`Edmd::set_cancel`]).
    Cancelled,
    /// `[jam]` found no first-order motion that grows the particles: collectively jammed
    /// (set by the runner, [`crate::protocol::slp`]).
    CollectivelyJammed,
    /// `[jam]`'s linear program could not be solved.
    SolverFailed,
}

impl StopReason {
    /// Whether the stage reached its goal.
    pub fn is_success(self) -> bool {
        matches!(
            self,
            Self::PackingFractionReached
                | Self::PressureReached
                | Self::TimeReached
                | Self::GapReached
                | Self::CollisionsReached
                | Self::CollectivelyJammed
        )
    }

    /// What a failure means for the scene, for people: `": …"`, or empty when the name
    /// says it all.
    pub fn hint(self) -> &'static str {
        match self {
            Self::JammedBeforeGoal => {
                ": the particles jammed first, so the goal cannot be reached by growth (lower \
                 the packing fraction or gap, or grow more slowly to pack denser)"
            }
            Self::Stalled => {
                ": simulated time stopped advancing (see `stall_epsilon` in docs/scenes.md)"
            }
            Self::SolverFailed => {
                ": the solver of `[jam]` failed on a step's linear program (report it with the \
                 scene)"
            }
            _ => "",
        }
    }

    /// The snake-case name used in outputs.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::PackingFractionReached => "packing_fraction_reached",
            Self::PressureReached => "pressure_reached",
            Self::TimeReached => "time_reached",
            Self::GapReached => "gap_reached",
            Self::CollisionsReached => "collisions_reached",
            Self::Stalled => "stalled",
            Self::EventLimit => "event_limit",
            Self::WallClockLimit => "wall_clock_limit",
            Self::Unreachable => "unreachable",
            Self::JammedBeforeGoal => "jammed_before_goal",
            Self::Cancelled => "cancelled",
            Self::CollectivelyJammed => "collectively_jammed",
            Self::SolverFailed => "solver_failed",
        }
    }
}

/// What a stage did.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct StageReport {
    /// Why it stopped.
    pub stop_reason: StopReason,
    /// Events of this stage, by kind.
    pub counts: EventCounts,
    /// Simulated time of the stage.
    pub simulated_time: f64,
    /// Wall-clock seconds.
    pub wall_seconds: f64,
    /// Packing fraction at the end.
    pub packing_fraction: f64,
    /// Reduced pressure `Z`: time average over the stage without growth, value over the last
    /// barrier interval with growth.
    pub reduced_pressure: f64,
    /// Standard error of the time-averaged `Z` from block averages (stages without growth).
    pub reduced_pressure_stderr: Option<f64>,
}

impl StageReport {
    /// One line for people: why it stopped, events, collisions, wall seconds, φ and `Z`.
    pub fn summary(&self) -> String {
        format!(
            "{} after {} events ({} collisions) in {:.2} s, φ = {:.6}, Z = {:.4e}",
            self.stop_reason.as_str(),
            self.counts.events,
            self.counts.collisions,
            self.wall_seconds,
            self.packing_fraction,
            self.reduced_pressure
        )
    }
}

/// Multiple of its planned events after which a barrier interval ends early.
const EARLY_BARRIER_EVENTS: f64 = 16.0;

/// Most events a barrier interval processes: the kernel numbers an interval's events in 32
/// bits (`Edmd::changed_in`), so an interval that would take more ends early (only with
/// some 6.7·10⁷ particles or more, at the default of 4 events per particle and interval and
/// the early barrier at 16 times that).
pub(super) const MAX_INTERVAL_EVENTS: u64 = u32::MAX as u64 - 1;

/// Per-interval pressure record: virial and `Σ m v² · Δt`.
#[derive(Clone, Copy, Debug, serde::Serialize, serde::Deserialize)]
struct PressureBlock {
    virial: f64,
    kinetic_time: f64,
}

/// State of a running stage, as the observer of [`Edmd::run_stage_observed`] sees it at a
/// time barrier ([`StageProgress::observed`]).
#[derive(Clone, Debug)]
pub struct Progress {
    /// Simulated time of the stage so far.
    pub stage_time: f64,
    /// Simulated time at which the goal is met, when known in advance (time or packing
    /// fraction goals).
    pub goal_time: Option<f64>,
    /// Packing fraction now.
    pub packing_fraction: f64,
    /// Reduced pressure over the last barrier interval.
    pub reduced_pressure: f64,
    /// Events of the stage so far.
    pub counts: EventCounts,
    /// Wall-clock seconds of the stage so far.
    pub wall_seconds: f64,
    /// The growth rate now (it changes at barriers under [`RateSchedule::PressureAdaptive`]).
    pub rate: f64,
    /// `∫ rate dt` over the stage so far: under absolute growth, the radius every particle
    /// has gained.
    pub grown: f64,
    /// The gap Δd between the grains at their true sizes that a gap stage has opened so far
    /// (`crate::run::gap_opened` of [`Progress::grown`], paper 001 Eq. 31); `None` outside
    /// gap stages. The kernel does not know which stages open gaps: `crate::run` fills it in.
    pub gap: Option<f64>,
}

/// Where a stage stands between two barrier intervals: everything the stage loop carries
/// from one interval to the next besides the kernel itself. [`Edmd::continue_stage`] resumes
/// from it exactly, so a checkpoint stores it (`crate::kernel::checkpoint`).
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
pub struct StageProgress {
    /// Kernel counters when the stage started.
    counts_before: EventCounts,
    /// Simulated stage time at which the goal is met exactly, if the goal is a time or a
    /// packing fraction.
    end_time: Option<f64>,
    /// The goal was found unreachable when the stage started.
    unreachable: bool,
    /// Collision count at which the stage's collision goal is met.
    collisions_goal: Option<u64>,
    /// Simulated time of the stage so far.
    stage_time: f64,
    /// Reduced pressure of the last interval (NaN before the first).
    last_z: f64,
    /// Pressure record of every interval so far.
    blocks: Vec<PressureBlock>,
    /// Events the stage may still process.
    events_left: u64,
    /// Events since the last stall and clock check.
    since_check: u32,
    /// Simulated time at the last stall check.
    time_at_check: f64,
    /// Consecutive stall checks without any advance of the time.
    frozen_checks: u32,
    /// Wall-clock seconds spent on the stage before the current continuation.
    wall_seconds: f64,
    /// The growth rate of the current interval.
    rate: f64,
    /// `∫ rate dt / rate`: the time the stage would have taken to grow as far at the current
    /// rate (equal to `stage_time` under a fixed rate). The walls of a gap stage lag the
    /// grains by a fraction of `rate·growth_clock` (`Stage::wall_growth`).
    growth_clock: f64,
}

impl StageProgress {
    /// What an observer sees of this stage in `kernel` (synchronised at a barrier).
    pub fn observed<S: Collidable, B: Boundary, Q: EventQueue>(
        &self,
        kernel: &Edmd<S, B, Q>,
    ) -> Progress {
        Progress {
            stage_time: self.stage_time,
            goal_time: self.end_time,
            packing_fraction: kernel.packing_fraction_at(0.0),
            reduced_pressure: self.last_z,
            counts: kernel.counters.since(&self.counts_before),
            wall_seconds: self.wall_seconds,
            rate: self.rate,
            grown: self.rate * self.growth_clock,
            gap: None,
        }
    }
}

impl<S: Collidable, B: Boundary, Q: EventQueue> Edmd<S, B, Q> {
    /// Runs one stage from a synchronised state and leaves the kernel synchronised.
    pub fn run_stage(&mut self, stage: &Stage) -> StageReport {
        self.run_stage_observed(stage, &mut |_| {})
    }

    /// [`Edmd::run_stage`], telling `observe` the [`Progress`] at the start of the stage
    /// and at every time barrier after which it goes on (its end is the [`StageReport`]).
    pub fn run_stage_observed(
        &mut self,
        stage: &Stage,
        observe: &mut dyn FnMut(&Progress),
    ) -> StageReport {
        let progress = self.start_stage(stage);
        self.continue_stage(stage, progress, &mut |kernel, p| {
            observe(&p.observed(kernel))
        })
    }

    /// Starts a stage: sets the growth, rescales the velocities if the stage has a
    /// thermostat, and places its goals. [`Edmd::continue_stage`] then runs it.
    pub fn start_stage(&mut self, stage: &Stage) -> StageProgress {
        let counts_before = self.counters;
        let n = self.particles.len().max(1) as f64;
        for p in &mut self.particles {
            p.shape.set_growth(0.0, stage.growth);
        }
        let growing = stage.growth != Growth::None;
        if stage.thermostat {
            self.rescale_temperature();
        }
        // Simulated time at which the goal is met exactly, if the goal is a time.
        let mut end_time = stage.until.time;
        let mut unreachable = false;
        if let Some(target) = stage.until.packing_fraction {
            match self.time_to_packing_fraction(target, growing) {
                Some(t) => end_time = Some(end_time.map_or(t, |e: f64| e.min(t))),
                None => unreachable = true,
            }
        }
        if self.interval <= 0.0 {
            self.interval = self.initial_interval();
        }
        StageProgress {
            counts_before,
            end_time,
            unreachable,
            collisions_goal: stage
                .until
                .collisions_per_particle
                .map(|c| counts_before.collisions + (c * n).ceil() as u64),
            stage_time: 0.0,
            last_z: f64::NAN,
            blocks: Vec::new(),
            events_left: stage.limits.events,
            since_check: 0,
            time_at_check: self.elapsed,
            frozen_checks: 0,
            wall_seconds: 0.0,
            rate: stage.growth.rate(),
            growth_clock: 0.0,
        }
    }

    /// Runs a started stage from `progress` to its end and leaves the kernel synchronised.
    /// `at_barrier` is shown the kernel and the progress at every barrier, before the next
    /// interval begins: the kernel is then synchronised at kernel time 0, and this state is
    /// all a continuation needs (checkpoints are written there).
    pub fn continue_stage(
        &mut self,
        stage: &Stage,
        mut progress: StageProgress,
        at_barrier: &mut dyn FnMut(&Self, &StageProgress),
    ) -> StageReport {
        let started = std::time::Instant::now();
        let n = self.particles.len().max(1) as f64;
        let growing = stage.growth != Growth::None;
        let mut report_reason = progress.unreachable.then_some(StopReason::Unreachable);
        let mut budget = EventBudget {
            events_left: progress.events_left,
            deadline: stage.limits.wall_seconds.map(|s| {
                started + std::time::Duration::from_secs_f64((s - progress.wall_seconds).max(0.0))
            }),
            stall_epsilon: stage.limits.stall_epsilon,
            cancel: self.cancel.clone(),
            since_check: progress.since_check,
            time_at_check: progress.time_at_check,
            frozen_checks: progress.frozen_checks,
            frozen_limit: frozen_check_limit(self.particles.len()),
            interval_events_left: 0,
            stopped: None,
        };
        let wall_before = progress.wall_seconds;
        self.wall_growth = stage.wall_growth;
        let target_events = self.config.events_per_particle_per_interval * n;
        let mut interval = self.interval;
        while report_reason.is_none() {
            progress.events_left = budget.events_left;
            progress.since_check = budget.since_check;
            progress.time_at_check = budget.time_at_check;
            progress.frozen_checks = budget.frozen_checks;
            progress.wall_seconds = wall_before + started.elapsed().as_secs_f64();
            at_barrier(self, &progress);
            // Before the interval's prediction pass, which alone is O(N) work.
            if crate::cancel::is_set(self.cancel.as_deref()) {
                report_reason = Some(StopReason::Cancelled);
                break;
            }
            let mut this = interval;
            if let Some(end) = progress.end_time {
                this = this.min((end - progress.stage_time).max(0.0));
            }
            let events_before = self.counters.events;
            let (collisions_before, updates_before) = (
                self.counters.collisions,
                self.counters.neighbour_list_updates,
            );
            let failures_before = S::numerical_failures();
            self.stage_clock = progress.growth_clock;
            self.begin_interval(this);
            // An interval that takes far more events than planned ends early: the approach
            // to jamming inside one interval (the collision rate diverges there) would
            // otherwise never reach the barrier where the pressure is measured.
            budget.interval_events_left =
                ((EARLY_BARRIER_EVENTS * target_events).ceil() as u64).min(MAX_INTERVAL_EVENTS);
            let completed = self.run_interval(&mut budget);
            let t_end = if completed {
                self.barrier_time
            } else {
                self.time
            };
            let events = self.counters.events - events_before;
            self.adapt_skin(
                self.counters.collisions - collisions_before,
                self.counters.neighbour_list_updates - updates_before,
            );
            // Pressure over the interval, from the virial and the mean of Σmv² at its ends.
            let virial = self.virial;
            let kinetic_end = self.kinetic_twice_at(t_end);
            let kinetic_time = 0.5 * (self.kinetic_start + kinetic_end) * t_end;
            if t_end > 0.0 && kinetic_time > 0.0 {
                progress.last_z = 1.0 + virial / kinetic_time;
                progress.blocks.push(PressureBlock {
                    virial,
                    kinetic_time,
                });
            }
            self.synchronise_and_rebase(t_end);
            self.counters.prediction_failures += S::numerical_failures() - failures_before;
            self.counters.barriers += 1;
            progress.stage_time += t_end;
            progress.growth_clock += t_end;
            if stage.thermostat && growing {
                self.rescale_temperature();
            }
            if budget.stopped.is_some() {
                report_reason = budget.stopped;
                break;
            }
            if let Some(end) = progress.end_time {
                if progress.stage_time >= end {
                    report_reason = Some(if stage.until.time == Some(end) {
                        StopReason::TimeReached
                    } else {
                        StopReason::PackingFractionReached
                    });
                    break;
                }
            }
            if let Some(z) = stage.until.reduced_pressure {
                if progress.last_z >= z {
                    report_reason = Some(StopReason::PressureReached);
                    break;
                }
            }
            if growing
                && stage
                    .limits
                    .jamming_pressure
                    .is_some_and(|z| progress.last_z >= z)
            {
                report_reason = Some(StopReason::JammedBeforeGoal);
                break;
            }
            if progress
                .collisions_goal
                .is_some_and(|goal| self.counters.collisions >= goal)
            {
                report_reason = Some(StopReason::CollisionsReached);
                break;
            }
            if events == 0 && !growing && kinetic_end == 0.0 {
                // Nothing moves and nothing grows: no event will ever happen.
                report_reason = Some(StopReason::Stalled);
                break;
            }
            if let RateSchedule::PressureAdaptive(law) = stage.schedule {
                let rate = law.rate(stage.growth.rate(), progress.last_z);
                if rate != progress.rate {
                    // The kernel is synchronised at time 0: the new rate starts here, as a
                    // new stage would. The clock is rescaled so that `rate·growth_clock`
                    // stays the growth so far.
                    progress.growth_clock *= progress.rate / rate;
                    progress.rate = rate;
                    for p in &mut self.particles {
                        p.shape.set_growth(0.0, stage.growth.with_rate(rate));
                    }
                }
            }
            // Adapt the interval to hold about `target_events` events.
            let factor = if events == 0 {
                4.0
            } else {
                (target_events / events as f64).clamp(0.25, 4.0)
            };
            if this >= interval * 0.999 {
                interval *= factor;
            }
            self.interval = interval;
        }
        let (reduced_pressure, reduced_pressure_stderr) = if growing {
            (progress.last_z, None)
        } else {
            block_average(&progress.blocks)
        };
        let counts = self.counters.since(&progress.counts_before);
        StageReport {
            stop_reason: report_reason.expect("a stage ends with a reason"),
            counts,
            simulated_time: progress.stage_time,
            wall_seconds: wall_before + started.elapsed().as_secs_f64(),
            packing_fraction: self.packing_fraction_at(0.0),
            reduced_pressure,
            reduced_pressure_stderr,
        }
    }

    /// A first barrier interval: a twentieth of the time the smallest particle needs to cross
    /// its own diameter at the root-mean-square speed (the interval adapts from there, by at
    /// most ×4 per barrier).
    ///
    /// The smallest particle and the plain (not mass-weighted) speed set the scale because the
    /// small, light particles of a wide size distribution collide most often: a scale from the
    /// largest diameter would make the first interval of a concrete scene (size ratio 32,
    /// masses ∝ d³) hundreds of times too long, so that it ran the 16× event cap of
    /// `EARLY_BARRIER_EVENTS` before the first barrier adapted the skin or reported progress.
    /// For equal particles with equal masses both scales coincide. Particles at rest that grow
    /// close their gaps at twice their growth rate, so that rate sets the scale when it
    /// exceeds the thermal speed (without it a start at rest would put the whole run into one
    /// interval).
    fn initial_interval(&self) -> f64 {
        let n = self.particles.len().max(1) as f64;
        let v_rms = (self
            .particles
            .iter()
            .map(|p| p.vel.norm_squared())
            .sum::<f64>()
            / n)
            .sqrt();
        let closing = self
            .particles
            .iter()
            .map(|p| 2.0 * p.shape.bounding_growth_rate())
            .fold(v_rms, f64::max)
            .max(1e-300);
        let d = self
            .bounding_diameters(0.0)
            .fold(f64::INFINITY, f64::min)
            .clamp(1e-300, f64::MAX);
        0.05 * d / closing
    }

    /// Kernel time at which the packing fraction reaches `target` under the current growth,
    /// or `None` if it never does.
    fn time_to_packing_fraction(&self, target: f64, growing: bool) -> Option<f64> {
        let phi0 = self.packing_fraction_at(0.0);
        if phi0 >= target {
            return Some(0.0);
        }
        if !growing {
            return None;
        }
        let mut hi = 1e-12_f64.max(self.initial_interval());
        while self.packing_fraction_at(hi) < target {
            hi *= 2.0;
            if !hi.is_finite() {
                return None;
            }
        }
        let mut lo = 0.0;
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid <= lo || mid >= hi {
                break;
            }
            if self.packing_fraction_at(mid) < target {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        Some(hi)
    }
}

/// Time-averaged `Z` and its standard error from up to 20 consecutive blocks of intervals.
fn block_average(blocks: &[PressureBlock]) -> (f64, Option<f64>) {
    let virial: f64 = blocks.iter().map(|b| b.virial).sum();
    let kt: f64 = blocks.iter().map(|b| b.kinetic_time).sum();
    if kt <= 0.0 {
        return (f64::NAN, None);
    }
    let mean = 1.0 + virial / kt;
    let nb = blocks.len().min(20);
    if nb < 4 {
        return (mean, None);
    }
    let per = blocks.len() / nb;
    let zs: Vec<f64> = blocks
        .chunks(per)
        .take(nb)
        .map(|c| {
            let v: f64 = c.iter().map(|b| b.virial).sum();
            let k: f64 = c.iter().map(|b| b.kinetic_time).sum();
            1.0 + v / k
        })
        .collect();
    let m = zs.iter().sum::<f64>() / zs.len() as f64;
    let var = zs.iter().map(|z| (z - m).powi(2)).sum::<f64>() / (zs.len() - 1) as f64;
    (mean, Some((var / zs.len() as f64).sqrt()))
}
