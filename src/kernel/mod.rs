//! The EDMD kernel: event-driven molecular dynamics of growing hard particles
//! (Lubachevsky–Stillinger), generic over shape, container and event queue.
//!
//! Why this file is over 900 lines: it holds the methods of `Edmd` that share the
//! particles' delayed states within one event — construction and thermodynamics, the
//! barrier's re-prediction (`begin_interval`), the event loop with its prefetch pipeline
//! (`run_interval`, `collide`, `hit_wall`, `renew_neighbours`) and the prediction passes
//! (`predict_pairs_as`, `predict_own`) — plus the event budget and ~270 lines of unit
//! tests. The prediction pass borrows the particles, event numbers, lists and buffers of the
//! kernel at once and is called from every kind of event, so it stays beside the loop as a
//! method of the one struct; what has a state and invariants of its own lives apart: the
//! neighbour lists (`lists`), the local event lists (`local`), stages (`stage`), periodic
//! images (`images`) and checkpoints (`checkpoint`).
//!
//! # How an event flows
//! Every particle keeps a *delayed state* — its free flight since its own last event, stored
//! by the flight's point at kernel time 0 ([`Particle`]) — and a *local event list*: the
//! events predicted for it since its trajectory last changed, each pair event carrying the
//! number of the event (within the barrier interval) that predicted it. The kernel records
//! for each particle the number of the event that last changed its flight
//! (`changed_in`). The queue ([`crate::queue`]) holds one entry per particle,
//! the earliest of its local list. The loop peeks the queue:
//!
//! 1. an event later than the *time barrier* ends the interval (see below);
//! 2. a pair event whose partner's flight changed in a later event than the one that
//!    predicted it is stale: it is dropped from the local list and the particle is
//!    rescheduled with its next local event;
//! 3. a collision evaluates both particles at the event time, applies the impulse
//!    ([`Collidable::collision_impulse`]) by changing both flights, records the change for
//!    both and predicts fresh local lists for both against their neighbour lists;
//! 4. a wall contact does the same for one particle ([`Boundary`]);
//! 5. a neighbour-list update (the particle reaches the surface of its neighbour-list
//!    sphere) moves its sphere to where it is now, re-registers it in the cell grid (the
//!    *cell transfer* of the cell method) and predicts against the new neighbours: its
//!    trajectory did not change, so events of others that name it stay valid.
//!
//! Shapes that rotate carry their orientation and angular velocity in the delayed state too
//! ([`Collidable::Spin`]); the kernel keeps it like the centre and hands it to the shape's
//! predictions and impulses without knowing what it is (`()` for spheres).
//!
//! # Neighbour lists
//! Each particle `i` owns a neighbour-list sphere: centre `c_i` (its position when the list
//! was built) and radius `R_i = r_i + skin·min(r_i, r̄)` (`r̄` the mean radius), and stays
//! inside it
//! (`|p_i(t) − c_i| + r_i(t) ≤ R_i`) until its update event. Two particles whose spheres do
//! not overlap cannot touch, so predictions only look at the particles whose spheres overlap
//! `i`'s (Donev, Torquato, Stillinger 2005). Near jamming a list holds ~12 partners where
//! the 27 cells of the plain cell method hold ~36, and the cell grid is touched only at
//! updates. The grid indexes the sphere centres on several levels (cells halving in width
//! down to the smallest sphere), so wide size distributions stay cheap; the skin adapts at
//! barriers ([`Edmd::skin`]). The lists are their own type, `lists::NeighbourLists`
//! (spheres, envelopes and their exits, the lists, the grid, the skin, the image mode),
//! which states these invariants; the event loop and the prediction passes call it to
//! build, update, renumber and read them.
//!
//! Shapes that may grow longer than half the box ([`Collidable::Images`]) switch to
//! image-aware lists at the barrier where the list spheres reach half the shortest periodic
//! edge: entries then name a partner *and* its periodic image, including the particle's own
//! images (`images`).
//!
//! Invalidation never scans the queue: a particle's own events go with its local list, and
//! events of others that name it are recognised as stale by the event numbers.
//!
//! # Time barriers
//! Events later than the barrier are not stored. At the barrier all particles are brought to
//! the barrier time, the time origin is moved there ([`Collidable::rebase`]: long runs keep
//! full precision), velocities are rescaled to the set temperature when particles grow, the
//! cell grid is rebuilt if the particles have outgrown it, the reduced pressure of the
//! interval is measured, stop criteria are checked and all events are predicted afresh. The
//! barrier interval adapts so that an interval holds about
//! [`KernelConfig::events_per_particle_per_interval`] events per particle (the default and
//! the measurements behind it: `BENCHMARKS.md`, "Defaults").
//!
//! # Pressure
//! The reduced pressure `Z = PV/(NkT)` comes from the collision virial,
//! `Z = 1 + Σ J·ℓ / (Σ m v² · Δt)`, with `J` the impulse of a contact and `ℓ` the distance
//! from each centre to the contact point summed over the bodies that move (`σ` for a pair of
//! spheres, `r` for a sphere against a wall: then `Z` is the wall pressure).

mod checkpoint;
mod images;
mod lists;
mod local;
mod stage;
pub use checkpoint::{KernelSnapshot, SnapshotError};
use lists::{ListSphere, NeighbourList, NeighbourLists};
use local::{EventKind, LocalEvent, LocalList, LocalLists, LOCAL_CAPACITY};
pub use stage::{
    Limits, PressureAdaptive, Progress, RateSchedule, Stage, StageProgress, StageReport,
    StopReason, Until, JAMMING_PRESSURE,
};

use crate::boundary::{Boundary, PlanarWalls, WallId, Walls};
use crate::cancel::CancelFlag;
use crate::prefetch;
use crate::queue::EventQueue;
use crate::shape::{
    bounding_sphere_wall_impulse, exit_ball_time, lanes3, stays_in_ball, Collidable, EnvelopeModel,
    Lanes, MassRule, PairScreen, PeriodicImages, PlaneContact, Rotation, Vec3,
};
use crate::tuning::{DEFAULT_EVENTS_PER_INTERVAL, DEFAULT_NEIGHBOUR_SKIN, DEFAULT_TEMPERATURE};
use rand::Rng;
use rand_distr::StandardNormal;

/// A particle in delayed state: its free flight since its own last event, which only that
/// particle's events change (the kernel never advances a particle that takes no part in an
/// event). Serialisable (for checkpoints) when the shape and its rotational state are.
///
/// The flight is stored by its point at *kernel time 0* rather than at the time of the last
/// event: the centre at kernel time `t` is `pos + vel·t`, and an event at time `t` that
/// changes the velocity by `Δv` moves `pos` by `−Δv·t` (likewise the rotation). So a particle
/// needs no update time of its own, and a sphere's record (centre, velocity, radius, growth
/// rate) fills exactly one aligned 64-byte cache line instead of straddling two (72 bytes
/// with an update time): a pair prediction loads one line per partner. Kernel time restarts at 0 at every barrier, where the
/// stored point is the centre itself ([`Edmd::particles`] are read there), so `vel·t` spans
/// at most one barrier interval, as the per-event extrapolation it replaces did.
#[derive(Clone, Debug, serde::Serialize, serde::Deserialize)]
#[serde(bound(
    serialize = "S: serde::Serialize, S::Spin: serde::Serialize",
    deserialize = "S: serde::de::DeserializeOwned, S::Spin: serde::de::DeserializeOwned"
))]
#[repr(align(64))]
pub struct Particle<S: Collidable> {
    /// Centre at kernel time 0 on the current free flight (the centre itself at a barrier).
    pub pos: Vec3,
    /// Velocity (constant between events).
    pub vel: Vec3,
    /// Shape and growth.
    pub shape: S,
    /// Orientation at kernel time 0 on the current free rotation, and angular velocity
    /// (zero-sized for spheres).
    pub spin: S::Spin,
}

impl<S: Collidable> Particle<S> {
    /// Centre at kernel time `t`.
    #[inline]
    pub fn position_at(&self, t: f64) -> Vec3 {
        self.pos + self.vel * t
    }

    /// Rotational state at kernel time `t`.
    #[inline]
    pub fn spin_at(&self, t: f64) -> S::Spin {
        self.spin.after(t)
    }

    /// Changes the velocity by `dv` and sets the rotational state to `spin`, both at kernel
    /// time `t` (an event): the stored line moves so that the centre at `t` stays put.
    #[inline]
    fn kick(&mut self, dv: Vec3, spin: S::Spin, t: f64) {
        self.pos -= dv * t;
        self.vel += dv;
        self.spin = spin.after(-t);
    }
}

/// Settings of the kernel that do not change between stages.
#[derive(Clone, Debug)]
pub struct KernelConfig {
    /// Mass rule (Eq. 27 or Eq. 29).
    pub mass: MassRule,
    /// Temperature `kT` of the initial velocities and of the thermostat at barriers.
    pub temperature: f64,
    /// Target number of events per particle between two time barriers.
    pub events_per_particle_per_interval: f64,
    /// Initial neighbour-list skin relative to the particle's bounding radius:
    /// `R = (1 + skin)·r`. The kernel adapts it at barriers (see [`Edmd::skin`]).
    pub neighbour_skin: f64,
}

impl Default for KernelConfig {
    fn default() -> Self {
        Self {
            mass: MassRule::Equal,
            temperature: DEFAULT_TEMPERATURE,
            events_per_particle_per_interval: DEFAULT_EVENTS_PER_INTERVAL,
            neighbour_skin: DEFAULT_NEIGHBOUR_SKIN,
        }
    }
}

/// Counts of processed events, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct EventCounts {
    /// All processed events (collisions, wall contacts, neighbour-list updates).
    pub events: u64,
    /// Pair collisions.
    pub collisions: u64,
    /// Wall contacts.
    pub wall_collisions: u64,
    /// Neighbour-list updates (cell transfers).
    pub neighbour_list_updates: u64,
    /// Stale queue entries skipped (not counted in `events`).
    pub stale: u64,
    /// Particles predicted afresh because their truncated local list ran empty.
    pub repredictions: u64,
    /// Time barriers.
    pub barriers: u64,
    /// Cell grid rebuilds.
    pub grid_rebuilds: u64,
    /// Events whose predicted time was already past when they were processed (rounding in a
    /// prediction; the event is processed at the current time). A numerical-health counter.
    pub late_events: u64,
    /// Predictions that gave up and answered conservatively
    /// ([`Collidable::numerical_failures`]; always 0 for spheres). A numerical-health counter.
    pub prediction_failures: u64,
}

impl EventCounts {
    /// The counts accumulated since `before` was taken.
    pub fn since(&self, before: &Self) -> Self {
        Self {
            events: self.events - before.events,
            collisions: self.collisions - before.collisions,
            wall_collisions: self.wall_collisions - before.wall_collisions,
            neighbour_list_updates: self.neighbour_list_updates - before.neighbour_list_updates,
            stale: self.stale - before.stale,
            repredictions: self.repredictions - before.repredictions,
            barriers: self.barriers - before.barriers,
            grid_rebuilds: self.grid_rebuilds - before.grid_rebuilds,
            late_events: self.late_events - before.late_events,
            prediction_failures: self.prediction_failures - before.prediction_failures,
        }
    }
}

/// Largest neighbour-list skin the kernel adapts to (defined in the leaf module
/// [`crate::tuning`], where the scene schema validates against it too).
pub use crate::tuning::MAX_SKIN;

/// Neighbours screened per block of a prediction pass: one bit each in a `u64` marks those
/// that pass the screen ([`Edmd::predict_pairs`]).
const SCREEN_BLOCK: usize = 64;

/// Which partners a prediction pass considers.
#[derive(Clone, Copy)]
enum Partners {
    /// Everybody but the particle itself.
    All,
    /// Everybody but the particle itself and one other (already predicted with it).
    AllBut(usize),
    /// Only partners with a larger index (full re-prediction at a barrier).
    Above,
}

/// The event-driven molecular dynamics engine.
///
/// `S` is the particle shape, `B` the container, `Q` the event queue; all three are static
/// types, so the event loop is monomorphised for the scene.
pub struct Edmd<S: Collidable, B: Boundary, Q: EventQueue> {
    particles: Vec<Particle<S>>,
    /// For each particle, the number ([`Self::event_number`]) of the event of the current
    /// barrier interval that last changed its trajectory, 0 if none has. A collision predicted
    /// during event `k` is valid while its partner's entry is at most `k`: within an event
    /// every trajectory change comes before every prediction, so an entry above `k` means
    /// the partner moved off the flight the prediction used. The prediction pass reads
    /// nothing of the partner but its state (a per-particle counter, read there for each
    /// kept event, was a cache miss at 10⁶ particles); the check reads the entry once, for
    /// the event about to be processed, requested one event ahead.
    changed_in: Vec<u32>,
    /// Number of the event being processed in the current barrier interval, counted from 1
    /// (0 while the barrier predicts every particle). Stale entries popped from the queue
    /// take no number: predictions made when one is dropped carry the last event's. An
    /// interval ends before `u32::MAX` events ([`stage::MAX_INTERVAL_EVENTS`]).
    event_number: u32,
    local: LocalLists,
    /// The neighbour lists, their spheres, envelopes and cell grid, and the skin.
    lists: NeighbourLists<S>,
    boundary: B,
    /// Index each particle had when the kernel was built (the kernel keeps particles sorted
    /// by cell so that neighbours are close in memory).
    ids: Vec<u32>,
    queue: Q,
    config: KernelConfig,
    /// Volume of a particle of mass 1 under [`MassRule::Volume`].
    reference_volume: f64,
    /// Kernel time (since the last barrier).
    time: f64,
    /// Simulated time before the last barrier.
    elapsed: f64,
    /// Time of the next barrier (kernel time).
    barrier_time: f64,
    /// Length of the current barrier interval.
    interval: f64,
    /// Collision virial `Σ J·ℓ` since the last barrier.
    virial: f64,
    /// `Σ m v²` right after the last barrier.
    kinetic_start: f64,
    counters: EventCounts,
    /// Whether any particle grows in the current barrier interval (set by
    /// [`Self::begin_interval`]; growth rates change only between intervals): with `false`
    /// the prediction pass's screen leaves the growth terms out ([`PairScreen::may_collide`]).
    /// `true` is right for any rates.
    grows: bool,
    /// Reused buffer for the partners of a barrier's pass ([`Self::predict_pairs`]).
    scratch: Vec<u32>,
    /// Reused buffer of [`Self::predict_pairs`]: the contact times found in a pass, with
    /// the neighbour's position in the list.
    pair_times: Vec<(f64, u32)>,
    /// Reused buffer of [`Self::predict_pairs`]: what the screen hands on for each step of
    /// two neighbours ([`Collidable::Screened`]).
    screened: Vec<S::Screened>,
    /// [`Stage::wall_growth`] of the running stage: the fraction of each bounding growth
    /// rate that the walls see (1 outside stages that set it).
    wall_growth: f64,
    /// Simulated time of the running stage at kernel time 0 (the last barrier).
    stage_clock: f64,
    /// Set by another thread to stop the running stage ([`StopReason::Cancelled`]);
    /// not part of a snapshot.
    cancel: Option<CancelFlag>,
}

impl<S: Collidable, B: Boundary, Q: EventQueue> Edmd<S, B, Q> {
    /// A kernel for particles with the given centres and shapes at kernel time 0, with
    /// Maxwell–Boltzmann velocities of temperature `config.temperature` and zero total momentum.
    /// Rotating shapes start in their default orientation ([`Edmd::with_spins`] sets them).
    ///
    /// The caller guarantees that the particles do not overlap and lie inside the container.
    pub fn new<R: Rng>(
        centres: Vec<Vec3>,
        shapes: Vec<S>,
        boundary: B,
        config: KernelConfig,
        rng: &mut R,
    ) -> Self {
        let spins = vec![S::Spin::default(); centres.len()];
        Self::with_spins(centres, shapes, spins, boundary, config, rng)
    }

    /// Like [`Edmd::new`], with the initial rotational states (orientations) of the particles;
    /// angular velocities are drawn at the temperature after the linear ones.
    pub fn with_spins<R: Rng>(
        centres: Vec<Vec3>,
        shapes: Vec<S>,
        spins: Vec<S::Spin>,
        boundary: B,
        config: KernelConfig,
        rng: &mut R,
    ) -> Self {
        assert_eq!(centres.len(), shapes.len(), "one shape per centre");
        assert_eq!(centres.len(), spins.len(), "one spin per centre");
        let n = centres.len();
        let reference_volume = if n == 0 {
            1.0
        } else {
            shapes.iter().map(|s| s.volume(0.0)).sum::<f64>() / n as f64
        };
        let mut particles: Vec<Particle<S>> = centres
            .into_iter()
            .zip(shapes)
            .zip(spins)
            .map(|((mut pos, shape), spin)| {
                boundary.wrap(&mut pos);
                Particle {
                    pos,
                    vel: Vec3::zeros(),
                    shape,
                    spin,
                }
            })
            .collect();
        let masses: Vec<f64> = particles
            .iter()
            .map(|p| mass_of(config.mass, &p.shape, 0.0, reference_volume))
            .collect();
        for (p, m) in particles.iter_mut().zip(&masses) {
            let sd = (config.temperature / m).sqrt();
            p.vel = Vec3::new(
                rng.sample::<f64, _>(StandardNormal) * sd,
                rng.sample::<f64, _>(StandardNormal) * sd,
                rng.sample::<f64, _>(StandardNormal) * sd,
            );
        }
        if n > 1 {
            let total_mass: f64 = masses.iter().sum();
            let momentum: Vec3 = particles.iter().zip(&masses).map(|(p, m)| p.vel * *m).sum();
            let drift = momentum / total_mass;
            for p in &mut particles {
                p.vel -= drift;
            }
        }
        if <S::Spin as Rotation<S>>::FREEDOMS > 0 {
            for (p, m) in particles.iter_mut().zip(&masses) {
                p.spin = p.spin.thermal(&p.shape, *m, config.temperature, 0.0, rng);
            }
        }
        // Freed before the kernel's other arrays exist (8 B per particle of the peak).
        drop(masses);
        let lists = NeighbourLists::new(&particles, &boundary, config.neighbour_skin);
        let mut kernel = Self {
            changed_in: vec![0; n],
            event_number: 0,
            local: LocalLists::new(n),
            lists,
            ids: (0..n as u32).collect(),
            queue: Q::with_capacity(n),
            particles,
            boundary,
            config,
            reference_volume,
            time: 0.0,
            elapsed: 0.0,
            barrier_time: 0.0,
            interval: 0.0,
            virial: 0.0,
            kinetic_start: 0.0,
            counters: EventCounts::default(),
            grows: true,
            scratch: Vec::new(),
            pair_times: Vec::new(),
            screened: Vec::new(),
            wall_growth: 1.0,
            stage_clock: 0.0,
            cancel: None,
        };
        kernel.rescale_temperature();
        kernel.lists.update_mean_radius(&kernel.particles);
        kernel.lists.size_spheres(&kernel.particles);
        let width = kernel.needed_cell_width(0.0);
        kernel.rebuild_grid(width);
        kernel.lists.track_images_if_needed(&kernel.boundary, width);
        kernel.lists.build_all(&kernel.boundary);
        kernel
    }

    /// The particles in the kernel's memory order; their states are synchronised (all at
    /// kernel time 0) between stages. [`Edmd::original_indices`] maps them back.
    pub fn particles(&self) -> &[Particle<S>] {
        &self.particles
    }

    /// For each particle of [`Edmd::particles`], its index in the input of [`Edmd::new`].
    pub fn original_indices(&self) -> &[u32] {
        &self.ids
    }

    /// Consumes the kernel and returns its particles in input order (element `k` is the
    /// particle given as the `k`-th centre to [`Edmd::new`]). The kernel's other arrays (lists,
    /// grid, queue) are freed before the particles are reordered.
    pub fn into_particles(mut self) -> Vec<Particle<S>> {
        let mut particles = std::mem::take(&mut self.particles);
        let ids = std::mem::take(&mut self.ids);
        drop(self);
        let mut order = vec![0u32; ids.len()];
        for (k, &id) in ids.iter().enumerate() {
            order[id as usize] = k as u32;
        }
        drop(ids);
        permute_in_place(&mut particles, &order, &mut vec![false; order.len()]);
        particles
    }

    /// Sets every particle's velocity to `velocity(id)`, `id` its index in the input of
    /// [`Edmd::new`]. Between stages only (the kernel is synchronised there and the next
    /// stage predicts every event afresh): scripted starts such as particles at rest or equal
    /// speeds on a lattice.
    pub fn set_velocities(&mut self, velocity: impl Fn(usize) -> Vec3) {
        for (p, &id) in self.particles.iter_mut().zip(&self.ids) {
            p.vel = velocity(id as usize);
        }
    }

    /// The container.
    pub fn boundary(&self) -> &B {
        &self.boundary
    }

    /// Event counts since the kernel was built.
    pub fn counters(&self) -> EventCounts {
        self.counters
    }

    /// Stages run from now on stop with [`StopReason::Cancelled`] within 1000 events (where
    /// the wall-clock limit is checked) or at the next time barrier once `flag` is set;
    /// `None` removes the flag.
    pub fn set_cancel(&mut self, flag: Option<CancelFlag>) {
        self.cancel = flag;
    }

    /// Current neighbour-list skin, relative to the radius.
    ///
    /// A thick skin means long lists (more predictions per collision), a thin one frequent
    /// list updates, and an update costs about three collisions (it queries the cell grid
    /// and edits the lists of old and new neighbours). After every barrier interval the skin
    /// is multiplied by 1.2 when there were more than 0.15 updates per collision and divided
    /// by 1.2 below 0.05, within `[0.01, MAX_SKIN]`: a fluid settles at a thick skin, a packing
    /// near jamming (particles rattle in tiny cages) shrinks its lists to the touching
    /// neighbours (the band's measurements: BENCHMARKS.md, "Defaults").
    pub fn skin(&self) -> f64 {
        self.lists.skin()
    }

    /// Adapts the skin to the list updates and collisions of the last interval.
    fn adapt_skin(&mut self, collisions: u64, updates: u64) {
        let n = self.particles.len();
        self.lists.adapt_skin(collisions, updates, n);
    }

    /// Simulated time since the kernel was built.
    pub fn elapsed(&self) -> f64 {
        self.elapsed + self.time
    }

    /// Packing fraction at kernel time `t`.
    pub fn packing_fraction_at(&self, t: f64) -> f64 {
        self.particles
            .iter()
            .map(|p| p.shape.volume(t))
            .sum::<f64>()
            / self.boundary.volume()
    }

    /// Total momentum `Σ m v`.
    pub fn momentum(&self) -> Vec3 {
        self.particles
            .iter()
            .map(|p| p.vel * self.mass(p, self.time))
            .sum()
    }

    /// Twice the kinetic energy, `Σ m v²`.
    pub fn kinetic_twice(&self) -> f64 {
        self.kinetic_twice_at(self.time)
    }

    /// `Σ m v²` with masses evaluated at kernel time `t` (they change as particles grow).
    fn kinetic_twice_at(&self, t: f64) -> f64 {
        self.particles
            .iter()
            .map(|p| self.mass(p, t) * p.vel.norm_squared())
            .sum()
    }

    /// Twice the rotational kinetic energy, `Σ ωᵀIω` (zero for shapes that do not rotate).
    pub fn rotational_kinetic_twice(&self) -> f64 {
        let t = self.time;
        self.particles
            .iter()
            .map(|p| p.spin_at(t).kinetic_twice(&p.shape, self.mass(p, t), t))
            .sum()
    }

    #[inline]
    fn mass(&self, p: &Particle<S>, t: f64) -> f64 {
        mass_of(self.config.mass, &p.shape, t, self.reference_volume)
    }

    /// The particles' bounding diameters at kernel time `t` (length units).
    fn bounding_diameters(&self, t: f64) -> impl Iterator<Item = f64> + '_ {
        self.particles
            .iter()
            .map(move |p| 2.0 * p.shape.bounding_radius(t))
    }

    /// Largest bounding diameter at kernel time `t` (0 without particles).
    fn max_diameter(&self, t: f64) -> f64 {
        self.bounding_diameters(t).fold(0.0, f64::max)
    }

    /// Cell width that holds every neighour-list sphere existing now or built up to time `t`.
    fn needed_cell_width(&self, t: f64) -> f64 {
        let r = 0.5 * self.max_diameter(t);
        self.lists.needed_cell_width(r)
    }

    fn rescale_temperature(&mut self) {
        let dof = 3.0 * self.particles.len() as f64;
        let k2 = self.kinetic_twice();
        if k2 > 0.0 {
            let factor = (self.config.temperature * dof / k2).sqrt();
            for p in &mut self.particles {
                p.vel *= factor;
            }
        }
        let freedoms = <S::Spin as Rotation<S>>::FREEDOMS;
        if freedoms > 0 {
            // Rotation has its own degrees of freedom.
            let dof = f64::from(freedoms) * self.particles.len() as f64;
            let k2 = self.rotational_kinetic_twice();
            if k2 > 0.0 {
                let factor = (self.config.temperature * dof / k2).sqrt();
                for p in &mut self.particles {
                    p.spin.scale_angular_velocity(factor);
                }
            }
        }
    }

    /// Rebuilds the cell grid of neighbour-list centres for cells at least `width` wide, and
    /// renumbers the particles in cell order ([`NeighbourLists::rebuild_grid`]) so that
    /// neighbours sit close in memory (the event loop's data then stays in cache for large
    /// systems). Only where every local event list is predicted afresh before the next event
    /// (construction and [`Self::begin_interval`]): the lists are freed for the renumbering
    /// and come back empty, so the renumbering's scratch (at most 17 B per particle) lives in
    /// their 49 B and a rebuild never raises the peak memory.
    fn rebuild_grid(&mut self, width: f64) {
        let n = self.particles.len();
        self.local = LocalLists::new(0);
        let (ids, particles) = (&mut self.ids, &mut self.particles);
        let updates = self.counters.neighbour_list_updates;
        // `changed_in` is not renumbered: `begin_interval` clears it before any prediction.
        self.lists
            .rebuild_grid(&self.boundary, width, updates, |order, visited| {
                permute_in_place(ids, order, visited);
                permute_in_place(particles, order, visited);
            });
        // The scratch, freed on the heap, would stay resident under the lists. Not worth a
        // heap walk at every rebuild of a small system (under 2 MB of scratch).
        if n >= TRIM_FROM {
            crate::memory::release_freed();
        }
        self.local = LocalLists::new(n);
        self.counters.grid_rebuilds += 1;
    }

    /// Moves particle `i`'s neighbour-list sphere to its position at the current time and
    /// rebuilds its list (symmetrically).
    fn update_neighbour_list(&mut self, i: usize) {
        let t = self.time;
        // The list sphere is centred on the wrapped centre, and the flight line moves by the
        // same period.
        let centre = self.particles[i].position_at(t);
        let mut wrapped = centre;
        self.boundary.wrap(&mut wrapped);
        self.particles[i].pos += wrapped - centre;
        let p = &self.particles[i];
        self.lists.update(&self.boundary, i, p, wrapped, t);
    }

    /// Brings every particle to kernel time `t` and moves the time origin there.
    fn synchronise_and_rebase(&mut self, t: f64) {
        for p in &mut self.particles {
            p.pos = p.position_at(t);
            p.spin = p.spin_at(t);
            self.boundary.wrap(&mut p.pos);
            p.shape.rebase(t);
        }
        self.elapsed += t;
        self.time = 0.0;
    }

    /// Starts a barrier interval of length `interval` at kernel time 0: adapts the grid,
    /// clears all events and predicts them afresh.
    fn begin_interval(&mut self, interval: f64) {
        self.interval = interval;
        self.barrier_time = interval;
        self.lists.update_mean_radius(&self.particles);
        self.grows = self
            .particles
            .iter()
            .any(|p| p.shape.bounding_growth_rate() != 0.0);
        let needed = self.needed_cell_width(interval);
        let n = self.particles.len();
        if self.lists.grid().min_width() < needed {
            // Rebuild with a small margin so that slow growth does not rebuild every barrier.
            self.rebuild_grid(needed * 1.05);
        } else if self.counters.neighbour_list_updates - self.lists.updates_at_sort() >= n as u64 {
            // Particles have moved since they were last sorted into cell order: sort again
            // (cheap next to the ~N events of an interval; keeps neighbours in cache).
            self.rebuild_grid(self.lists.grid().min_width());
        }
        if self.lists.track_images_if_needed(&self.boundary, needed) {
            self.lists.build_all(&self.boundary);
        }
        self.queue.reset(0.0, interval, n);
        self.event_number = 0;
        self.changed_in.fill(0);
        for i in 0..n {
            self.refresh_list_exit(i);
        }
        for i in 0..n {
            self.prefetch_partners(i);
            self.predict(i, Partners::Above);
            self.reschedule(i);
        }
        self.virial = 0.0;
        self.kinetic_start = self.kinetic_twice();
    }

    /// Predicts all of `i`'s events into a fresh local list, which replaces `i`'s: its
    /// collisions with `partners` ([`Self::predict_pairs`]), then its wall contact and its
    /// list update ([`Self::predict_own`]). The list is built as a value and stored once.
    #[inline]
    fn predict(&mut self, i: usize, partners: Partners) {
        let mut list = self.predict_pairs(i, partners);
        self.predict_own(i, &mut list);
        self.local.set(i, list);
    }

    /// Predicts collisions of particle `i` with its neighbours into a fresh local list for
    /// [`Self::predict`].
    ///
    /// The hot loop of the kernel (tens of predictions per collision), in three passes:
    /// 1. a screen ([`PairScreen::may_collide`]) marks the neighbours that may meet `i`
    ///    within the horizon, without the square root and division of a contact time: in the
    ///    φ = 0.5 fluid most neighbours recede, miss or meet after the barrier. Two neighbours
    ///    per step, one per lane of packed arithmetic ([`Lanes`]); a bit per neighbour in a
    ///    word per block of [`SCREEN_BLOCK`], and what the screen hands on per step
    ///    ([`Collidable::Screened`]: for spheres the lanes' gap quadratics). Shapes without a
    ///    screen (`()`) pass every neighbour, and the step compiles to setting the bits;
    /// 2. contact times for the marked ones only, from what the screen handed on
    ///    ([`PairScreen::contact_time`]), or for shapes without a screen from the pair's
    ///    state ([`Collidable::collision_time`]), `+∞` for none, appended to a buffer whose
    ///    end moves past an entry only if it is kept: for spheres nothing in the passes
    ///    branches on a pair's outcome but the loop over the marked ones, where acting on
    ///    each prediction at once would mispredict about one branch per neighbour;
    /// 3. the few contacts found are sorted (earliest first, the first neighbour on ties) and
    ///    the earliest [`LOCAL_CAPACITY`] go into the list — the events that pushing every
    ///    prediction in neighbour order would keep, up to the order of times that round to
    ///    the same event time, each marked with the number of the event that predicted it
    ///    ([`Self::changed_in`]). A list longer than a block (a large grain among small
    ///    ones) keeps only the earliest after each block, and the later blocks screen
    ///    against the latest of them.
    ///
    /// The caller has asked for the partners' states first ([`Self::prefetch_partners`]).
    #[inline]
    fn predict_pairs(&mut self, i: usize, partners: Partners) -> LocalList {
        // One pass for intervals with growth and one without, each compiled with its own
        // screen (a flag asked in each step would cost more than the second copy of the
        // code).
        if self.grows {
            self.predict_pairs_as::<true>(i, partners)
        } else {
            self.predict_pairs_as::<false>(i, partners)
        }
    }

    /// [`Self::predict_pairs`] in an interval where particles grow (`GROWS`) or do not.
    #[inline]
    fn predict_pairs_as<const GROWS: bool>(&mut self, i: usize, partners: Partners) -> LocalList {
        let t = self.time;
        let max_tau = self.barrier_time - t;
        let pi = &self.particles[i];
        let (pos_i, vel_i, spin_i, shape_i) =
            (pi.position_at(t), pi.vel, pi.spin_at(t), pi.shape.clone());
        // Skip `j` when `j == except` or `j < first`.
        let (except, first) = match partners {
            Partners::All => (i, 0),
            Partners::AllBut(k) => (k, 0),
            Partners::Above => (i, i + 1),
        };
        // Whether the pass leaves out partner `j`; a particle's own images are partners
        // like any other.
        let own_images = self.tracks_images();
        let skip = move |j: usize| ((j == except) | (j < first)) & !(own_images && j == i);
        // A barrier's pass (`Above`) leaves out half the neighbours: they are dropped before
        // the screen rather than screened for nothing. The one partner a collision's second
        // pass leaves out (`AllBut`) is dropped with the contact times instead: copying the
        // list to drop one entry costs more than checking each time against it.
        let mut above = std::mem::take(&mut self.scratch);
        let mut found = std::mem::take(&mut self.pair_times);
        let mut screened = std::mem::take(&mut self.screened);
        let neighbours = if matches!(partners, Partners::Above) {
            above.clear();
            let listed = self.lists.list(i).iter();
            above.extend(listed.filter(|&&e| !skip(self.partner_index(e))));
            above.as_slice()
        } else {
            self.lists.list(i).as_slice()
        };
        // One slot more than neighbours: an odd last step writes one past them.
        if found.len() <= neighbours.len() {
            found.resize(neighbours.len() + 1, (f64::INFINITY, 0));
        }
        if screened.len() < SCREEN_BLOCK / 2 {
            screened.resize(SCREEN_BLOCK / 2, S::Screened::default());
        }
        // The horizon of the pair of `i` and `j` (`i`'s exit was recorded by the caller,
        // [`Self::refresh_list_exit`]).
        let horizon_with =
            |j: usize| S::Envelope::pair_horizon(self.lists.exits(), i, j, t, max_tau);
        // The relative position, velocity and rotation of partner `entry`, and the horizon
        // of the pair.
        let pair = |entry: u32| {
            let j = self.partner_index(entry);
            let pj = &self.particles[j];
            let dr = self.separation(i, &pos_i, j, &pj.position_at(t), entry);
            (pj, dr, vel_i - pj.vel, pj.spin_at(t), horizon_with(j))
        };
        let mut count = 0;
        // Only the earliest `LOCAL_CAPACITY` contacts are kept. Once a block that is not the
        // last has found more, the later of them are dropped and the rest of the pass looks
        // no further than the latest kept (`cap`, a horizon for every pair): a grain with
        // hundreds of small neighbours (concrete, size ratio 32) then computes a few contact
        // times instead of hundreds and sorts a few. The kept events are those the whole
        // pass would keep: every contact among them is at or before `cap`, whose value only
        // falls, and ties go to the earlier neighbour as before (a later block holds later
        // neighbours). The list is truncated exactly when the whole pass would find more
        // than the capacity. Shapes without a screen compute every time with the pair's own
        // horizon (a shorter one could move an iterative root in its last bits).
        let mut cap = f64::INFINITY;
        let mut dropped = false;
        let earliest_first =
            |x: &(f64, u32), y: &(f64, u32)| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1));
        // Most passes are over lists inside the box, which need no minimum image (the more
        // so the larger the box).
        let wraps = !self.lists.pairs_free_of_images(i);
        // Screen: the neighbours that may meet `i` within the horizon, two per step in the
        // two lanes of packed arithmetic, a block of up to 64 at a time: a bit per neighbour
        // marks those that pass, and what the screen hands on is kept per step. Then the
        // times of those that pass, keeping the ones that meet and are not left out. Nothing
        // in either part branches on a pair's outcome but the loop over the marked ones.
        // Without a screen every neighbour passes and the pair's state is computed once, for
        // its contact time; the relative state the screen would take is then never used
        // and compiles out.
        for (block, in_block) in neighbours.chunks(SCREEN_BLOCK).enumerate() {
            let mut passed = 0u64;
            for (step, two) in in_block.chunks(2).enumerate() {
                // An odd last neighbour fills both lanes; its second lane is cut below.
                let entries = [two[0], two[two.len() - 1]];
                let j = entries.map(|e| self.partner_index(e));
                let pj = j.map(|j| &self.particles[j]);
                // The pairs' relative states, for a screen that looks at them.
                let relative = || {
                    let dr = if self.tracks_images() {
                        let dr = entries.map(|e| pair(e).1);
                        lanes3(&dr[0], &dr[1])
                    } else {
                        // The minimum image in lanes, without the scalar one's jumps.
                        let dr = pj.map(|p| pos_i - p.position_at(t));
                        let mut dr = lanes3(&dr[0], &dr[1]);
                        if wraps {
                            self.boundary.minimum_image_lanes(&mut dr);
                        }
                        dr
                    };
                    let dv = lanes3(&(vel_i - pj[0].vel), &(vel_i - pj[1].vel));
                    (dr, dv, pj.map(|p| p.spin_at(t)))
                };
                let horizon = Lanes::new(j.map(|j| horizon_with(j).min(cap)));
                let (pass, handed_on) = S::Screened::may_collide(
                    &shape_i,
                    [&pj[0].shape, &pj[1].shape],
                    &spin_i,
                    t,
                    horizon,
                    GROWS,
                    relative,
                );
                screened[step] = handed_on;
                passed |= (u64::from(pass[0]) | u64::from(pass[1]) << 1) << (2 * step);
            }
            passed &= u64::MAX >> (SCREEN_BLOCK - in_block.len());
            while passed != 0 {
                let k = passed.trailing_zeros() as usize;
                passed &= passed - 1;
                let entry = in_block[k];
                let j = self.partner_index(entry);
                // A partner left out is not predicted without a screen (a contact time is
                // dear then); with one, it is dropped with its time, not by a branch.
                let unscreened = || {
                    if skip(j) {
                        return f64::INFINITY;
                    }
                    let (pj, dr, dv, spin_j, horizon) = pair(entry);
                    S::collision_time(&shape_i, &pj.shape, &spin_i, &spin_j, &dr, &dv, t, horizon)
                };
                let tau = screened[k / 2].contact_time(k % 2, horizon_with(j).min(cap), unscreened);
                // Kept by moving the end past it, not by a branch.
                found[count] = (tau, (block * SCREEN_BLOCK + k) as u32);
                count += usize::from((tau < f64::INFINITY) & !skip(j));
            }
            // Not after the last block, where the sort below does it (lists of equal
            // spheres fill one block).
            let more = neighbours.len() > (block + 1) * SCREEN_BLOCK;
            if more && count > LOCAL_CAPACITY {
                found[..count].select_nth_unstable_by(LOCAL_CAPACITY - 1, earliest_first);
                count = LOCAL_CAPACITY;
                cap = found[LOCAL_CAPACITY - 1].0;
                dropped = true;
            }
        }
        let truncated = dropped || count > LOCAL_CAPACITY;
        let found_now = &mut found[..count];
        if truncated {
            // Earliest first, the first neighbour on ties (as pushes in order would keep).
            found_now.sort_unstable_by(earliest_first);
        }
        let mut list = LocalList::default();
        for &(tau, k) in found_now.iter().take(LOCAL_CAPACITY) {
            list.push(LocalEvent::new(
                t + tau,
                EventKind::Collision {
                    partner: neighbours[k as usize],
                    predicted_in: self.event_number,
                },
            ));
        }
        if truncated {
            list.mark_truncated();
        }
        self.pair_times = found;
        self.screened = screened;
        self.scratch = above;
        list
    }

    /// Asks the memory system for the state of every partner of `i` before a prediction
    /// pass needs it. The partners are scattered through the particle array; without the
    /// hints their loads wait one after the other behind the loop's mispredicted branches
    /// (at 10⁵ particles a large share of the fluid's run time).
    /// `i`'s own list sphere comes along: [`Self::predict_own`] reads it after the pass.
    /// Once per pass: a collision asks for both particles' partners before the first pass
    /// (the second particle's load while the first is predicted), the other callers through
    /// [`Self::predict_afresh`].
    #[inline]
    fn prefetch_partners(&self, i: usize) {
        prefetch(self.lists.sphere(i));
        for &entry in self.lists.list(i).iter() {
            prefetch(&self.particles[self.partner_index(entry)]);
        }
    }

    /// Predicts the wall contact and the neighbour-list update of particle `i` into its new
    /// local `list`.
    #[inline]
    fn predict_own(&self, i: usize, list: &mut LocalList) {
        let t = self.time;
        let max_tau = self.barrier_time - t;
        let p = &self.particles[i];
        let pos = p.position_at(t);
        if let Some(walls) = self.boundary.walls() {
            let contact = if let Some((own, planes)) = self.shaped_walls() {
                let spin = p.spin_at(t);
                planes.predict_shaped_wall(&pos, &p.vel, &p.shape, own, &spin, t, max_tau)
            } else {
                let (r, g) = self.wall_sphere(&p.shape, t);
                walls.predict_wall(&pos, &p.vel, r, g, max_tau)
            };
            if let Some((tau, wall)) = contact {
                list.push(LocalEvent::new(t + tau, EventKind::Wall(wall)));
            }
        }
        // A recorded envelope exit (refreshed before every prediction pass of `i`,
        // [`Self::refresh_list_exit`]), or when the list sphere is the envelope the time the
        // bounding sphere leaves it.
        let exit = S::Envelope::list_update(self.lists.exits(), i, t, || {
            let mut q = pos - self.lists.sphere(i).centre;
            self.boundary.minimum_image(&mut q);
            let s = self.lists.sphere(i).radius - p.shape.bounding_radius(t);
            let g = p.shape.bounding_growth_rate();
            // Most particles stay inside their list sphere until the barrier.
            if stays_in_ball(&q, &p.vel, s, g, max_tau) {
                None
            } else {
                exit_ball_time(q.norm_squared(), q.dot(&p.vel), p.vel.norm_squared(), s, g)
            }
        });
        if let Some(tau) = exit.filter(|&tau| tau <= max_tau) {
            list.push(LocalEvent::new(t + tau, EventKind::NeighbourList));
        }
    }

    /// Records `i`'s list exit ([`EnvelopeModel::record_exit`]) before a prediction pass of
    /// `i`: once per pass, not again for a partner whose exit was refreshed earlier in the
    /// event. Nothing when the list sphere is the envelope (its exit is predicted after the
    /// pass and bounds no pair).
    #[inline]
    fn refresh_list_exit(&mut self, i: usize) {
        let t = self.time;
        self.lists
            .refresh_exit(&self.boundary, &self.particles, i, t);
    }

    /// The shape's own plane contacts and the container's planes, when wall contacts go
    /// through them: the shape has them, every wall is a plane, and the walls see the whole
    /// growth. `None` at compile time for a shape or a container without them (their types
    /// have no value).
    #[inline]
    fn shaped_walls(&self) -> Option<(S::PlaneContact, &B::Planes)> {
        let own = S::PlaneContact::own()?;
        let planes = self.boundary.planes()?;
        (self.wall_growth == 1.0).then_some((own, planes))
    }

    /// The sphere the walls see of `shape` at kernel time `t`: its radius and growth rate.
    /// The walls see the bounding sphere grow at [`Stage::wall_growth`] `f` times its rate
    /// `g` since the stage began: radius `r(t) − (1 − f)·g·τ` at stage time `τ`, rate `f·g`.
    /// With `f = 1` (every stage but gap stages) both are the bounding sphere's.
    #[inline]
    fn wall_sphere(&self, shape: &S, t: f64) -> (f64, f64) {
        let (r, g) = (shape.bounding_radius(t), shape.bounding_growth_rate());
        if self.wall_growth == 1.0 {
            return (r, g);
        }
        let lag = (1.0 - self.wall_growth) * g;
        (r - lag * (self.stage_clock + t), g - lag)
    }

    /// Puts particle `i`'s earliest local event into the queue (or removes it). A list that
    /// ran empty after dropping predictions is predicted afresh first. Inlined always: it
    /// runs after every event, and the compiler's own choice flips with unrelated changes
    /// elsewhere in the event loop.
    #[inline(always)]
    fn reschedule(&mut self, i: usize) {
        if self.local.exhausted(i) {
            self.predict_afresh(i);
            self.counters.repredictions += 1;
        }
        match self.local.earliest(i) {
            Some((_, e)) => self.queue.schedule(i, e.time),
            None => self.queue.cancel(i),
        }
    }

    /// Processes events up to the barrier. Returns `false` if `budget` ran out first (then
    /// the kernel time is that of the last processed event, and `budget.stopped` says why,
    /// or is `None` when only the interval's own event allowance ran out).
    fn run_interval(&mut self, budget: &mut EventBudget) -> bool {
        // The particle whose partners' states were requested one event ago.
        let mut requested = None;
        loop {
            let Some((i, t)) = self.queue.peek() else {
                return true;
            };
            if t > self.barrier_time {
                return true;
            }
            // Data of the next events loads while this one is processed (at 10⁵ particles
            // these loads would wait on main memory), in a pipeline two events deep. The likeliest next particle, whose
            // local and neighbour lists were requested one event ago: the states of its
            // partners, and its next partner's last change (the validity check), state,
            // neighbour list, local list (rewritten, then read back by the collision) and
            // queue entry. The candidates for the event after it: their local lists, states
            // and neighbour lists.
            let upcoming = self.queue.upcoming();
            let partners_requested = requested == Some(i);
            requested = upcoming[0];
            if let Some(k) = upcoming[0] {
                self.prefetch_partners(k);
                if let Some((_, e)) = self.local.earliest(k) {
                    if let EventKind::Collision { partner, .. } = e.kind() {
                        let j = self.partner_index(partner);
                        prefetch(&self.changed_in[j]);
                        prefetch(&self.particles[j]);
                        prefetch(self.lists.list(j));
                        self.local.prefetch(j);
                        self.queue.prefetch(j);
                    }
                }
            }
            for &k in upcoming.iter().flatten() {
                self.local.prefetch(k);
                prefetch(&self.particles[k]);
                prefetch(self.lists.list(k));
            }
            let (idx, event) = self
                .local
                .earliest(i)
                .expect("a queued particle has events");
            let late = t < self.time;
            self.time = self.time.max(t);
            let kind = event.kind();
            if let EventKind::Collision {
                partner,
                predicted_in,
            } = kind
            {
                if self.changed_in[self.partner_index(partner)] > predicted_in {
                    self.local.remove(i, idx);
                    self.reschedule(i);
                    self.counters.stale += 1;
                    continue;
                }
            }
            self.event_number += 1;
            match kind {
                EventKind::Collision { partner, .. } => {
                    self.collide(i, partner, partners_requested)
                }
                EventKind::Wall(wall) => self.hit_wall(i, wall),
                EventKind::NeighbourList => self.renew_neighbours(i),
            }
            self.counters.events += 1;
            self.counters.late_events += u64::from(late);
            if !budget.spend(self.elapsed + self.time) {
                return false;
            }
        }
    }

    /// Resolves the collision of `i` with the neighbour-list entry `partner` (an index, or an
    /// index and an image shift when the kernel tracks images). `partners_requested`: `i`'s
    /// partners' states have been requested already ([`Self::prefetch_partners`]; asking
    /// again would walk the neighbour list for nothing).
    fn collide(&mut self, i: usize, partner: u32, partners_requested: bool) {
        let j = self.partner_index(partner);
        let t = self.time;
        if let Some(tracking) = self.lists.images() {
            if j == i {
                self.collide_with_own_image(tracking, i, partner);
                return;
            }
        }
        let (pi, pj) = (&self.particles[i], &self.particles[j]);
        let dr = self.separation(i, &pi.position_at(t), j, &pj.position_at(t), partner);
        let dv = pi.vel - pj.vel;
        let (mi, mj) = (self.mass(pi, t), self.mass(pj, t));
        let (mut spin_i, mut spin_j) = (pi.spin_at(t), pj.spin_at(t));
        let impulse = S::collision_impulse(
            &pi.shape,
            &pj.shape,
            &mut spin_i,
            &mut spin_j,
            &dr,
            &dv,
            t,
            mi,
            mj,
        );
        self.virial += impulse.dot(&dr);
        self.particles[i].kick(impulse / mi, spin_i, t);
        self.particles[j].kick(-impulse / mj, spin_j, t);
        self.changed_in[i] = self.event_number;
        self.changed_in[j] = self.event_number;
        // Both before the predictions: `i`'s look no further than `j`'s new list exit.
        self.refresh_list_exit(i);
        self.refresh_list_exit(j);
        // `j`'s partners load while `i`'s are predicted.
        self.prefetch_partners(j);
        if !partners_requested {
            self.prefetch_partners(i);
        }
        self.predict(i, Partners::All);
        self.predict(j, Partners::AllBut(i));
        self.reschedule(i);
        self.reschedule(j);
        self.counters.collisions += 1;
    }

    fn hit_wall(&mut self, i: usize, wall: WallId) {
        let t = self.time;
        let p = &self.particles[i];
        let Some(walls) = self.boundary.walls() else {
            unreachable!("wall events are predicted only through `Boundary::walls`")
        };
        let n = walls.wall_normal(wall, &p.position_at(t));
        let m = self.mass(p, t);
        let mut spin = p.spin_at(t);
        let (dv, virial) = if let Some((own, _)) = self.shaped_walls() {
            own.impulse(&p.shape, &mut spin, &n, &p.vel, t, m)
        } else {
            let (r, g) = self.wall_sphere(&p.shape, t);
            bounding_sphere_wall_impulse(r, g, &n, &p.vel, m)
        };
        self.virial += virial;
        self.particles[i].kick(dv, spin, t);
        self.predict_changed(i);
        self.counters.wall_collisions += 1;
    }

    /// After an event that changed only `i`'s trajectory: records the change
    /// ([`Self::changed_in`]) and predicts `i` afresh.
    #[inline]
    fn predict_changed(&mut self, i: usize) {
        self.changed_in[i] = self.event_number;
        self.predict_afresh(i);
        self.reschedule(i);
    }

    /// Predicts all of `i`'s events into a fresh local list: its list exit, its partners'
    /// states requested ahead of the pass, the pairs, then the wall and the list update.
    #[inline]
    fn predict_afresh(&mut self, i: usize) {
        self.refresh_list_exit(i);
        self.prefetch_partners(i);
        self.predict(i, Partners::All);
    }

    /// Resolves the contact of `i` with its own image `entry`
    /// ([`PeriodicImages::self_image_impulse`], with the licence `tracking` the kernel holds
    /// while it tracks images): only its rotation changes.
    fn collide_with_own_image(&mut self, tracking: S::Images, i: usize, entry: u32) {
        let t = self.time;
        let dr = -images::translation(images::shift(entry), &lists::period(&self.boundary));
        let p = &self.particles[i];
        let m = self.mass(p, t);
        let mut spin = p.spin_at(t);
        let impulse = tracking.self_image_impulse(&p.shape, &mut spin, &dr, t, m);
        self.virial += impulse.dot(&dr);
        self.particles[i].kick(Vec3::zeros(), spin, t);
        self.predict_changed(i);
        self.counters.collisions += 1;
    }

    /// Whether neighbour entries carry image shifts ([`NeighbourLists::tracks_images`]).
    #[inline(always)]
    fn tracks_images(&self) -> bool {
        self.lists.tracks_images()
    }

    /// Particle index of a neighbour entry.
    #[inline(always)]
    fn partner_index(&self, entry: u32) -> usize {
        self.lists.partner_index(entry)
    }

    /// Separation `c_i − c_j` of `i` at `pos_i` and the image of `j` at `pos_j` that the
    /// neighbour entry names ([`NeighbourLists::separation`]).
    #[inline(always)]
    fn separation(&self, i: usize, pos_i: &Vec3, j: usize, pos_j: &Vec3, entry: u32) -> Vec3 {
        self.lists
            .separation(&self.boundary, i, pos_i, j, pos_j, entry)
    }

    fn renew_neighbours(&mut self, i: usize) {
        self.update_neighbour_list(i);
        // The trajectory is unchanged, but the new neighbours need predictions; the wall
        // event is recomputed with them.
        self.predict_afresh(i);
        self.reschedule(i);
        self.counters.neighbour_list_updates += 1;
    }
}

/// Particle count from which a grid rebuild hands its freed scratch back to the system
/// ([`crate::memory::release_freed`]).
const TRIM_FROM: usize = 100_000;

/// Reorders `v` so that `v_new[i] = v_old[order[i]]`, in place by following the cycles of
/// the permutation (no second copy of `v`: the kernel's arrays are its bulk of memory).
/// `visited` is scratch space of `v.len()` entries.
fn permute_in_place<T>(v: &mut [T], order: &[u32], visited: &mut [bool]) {
    visited.fill(false);
    for start in 0..v.len() {
        if visited[start] {
            continue;
        }
        let mut j = start;
        loop {
            visited[j] = true;
            let k = order[j] as usize;
            if k == start {
                break;
            }
            v.swap(j, k);
            j = k;
        }
    }
}

#[inline]
fn mass_of<S: Collidable>(rule: MassRule, shape: &S, t: f64, reference_volume: f64) -> f64 {
    match rule {
        MassRule::Equal => 1.0,
        MassRule::Volume => shape.volume(t) / reference_volume,
    }
}

/// Limits checked while events are processed: event count, wall clock, stalling.
struct EventBudget {
    events_left: u64,
    deadline: Option<std::time::Instant>,
    /// Checked with the deadline, every [`CHECK_EVERY`] events.
    cancel: Option<CancelFlag>,
    stall_epsilon: f64,
    since_check: u32,
    time_at_check: f64,
    /// Consecutive checks at which the time had not advanced at all.
    frozen_checks: u32,
    /// Consecutive frozen checks that make a stall (see [`frozen_check_limit`]).
    frozen_limit: u32,
    /// Events the current barrier interval may still process before it ends early.
    interval_events_left: u64,
    stopped: Option<StopReason>,
}

/// Events between two checks of the clock and of the stall criterion (paper 001: Δt < ε
/// over 1000 events).
const CHECK_EVERY: u32 = 1000;

/// Events per particle without any advance of the time that make a stall. Simultaneous
/// collisions legitimately take many events at one instant: spheres touching in rows
/// exchange their velocities in a cascade of zero-time collisions (up to ℓ²/2 per row of
/// ℓ spheres, about 30 per particle for rows of 8 along three axes); a rigid cluster (a row
/// filling the space between two walls) does so forever.
const FROZEN_EVENTS_PER_PARTICLE: u64 = 100;

/// Consecutive frozen checks of [`CHECK_EVERY`] events before a stall, for `n` particles.
fn frozen_check_limit(n: usize) -> u32 {
    (FROZEN_EVENTS_PER_PARTICLE * n as u64)
        .div_ceil(CHECK_EVERY as u64)
        .clamp(1, u32::MAX as u64) as u32
}

impl EventBudget {
    #[inline]
    fn spend(&mut self, now: f64) -> bool {
        self.events_left = self.events_left.saturating_sub(1);
        if self.events_left == 0 {
            self.stopped = Some(StopReason::EventLimit);
            return false;
        }
        self.interval_events_left = self.interval_events_left.saturating_sub(1);
        if self.interval_events_left == 0 {
            return false; // an early barrier, not a stop
        }
        self.since_check += 1;
        self.since_check < CHECK_EVERY || self.check(now)
    }

    /// The checks of every [`CHECK_EVERY`] events: stall, wall clock, cancel flag. Out of
    /// line (once per 1000 events), so that the event loop stays small enough for the
    /// compiler to inline its per-event calls.
    #[cold]
    #[inline(never)]
    fn check(&mut self, now: f64) -> bool {
        self.since_check = 0;
        if self.stall_epsilon > 0.0 && now - self.time_at_check < self.stall_epsilon {
            self.stopped = Some(StopReason::Stalled);
            return false;
        }
        // Time that does not advance at all is a stall whatever ε is, once it has stood
        // still for longer than simultaneous collisions can take.
        if now == self.time_at_check {
            self.frozen_checks += 1;
            if self.frozen_checks >= self.frozen_limit {
                self.stopped = Some(StopReason::Stalled);
                return false;
            }
        } else {
            self.frozen_checks = 0;
        }
        self.time_at_check = now;
        if self
            .deadline
            .is_some_and(|d| std::time::Instant::now() >= d)
        {
            self.stopped = Some(StopReason::WallClockLimit);
            return false;
        }
        if crate::cancel::is_set(self.cancel.as_deref()) {
            self.stopped = Some(StopReason::Cancelled);
            return false;
        }
        true
    }
}

#[cfg(test)]
mod tests {
    use super::permute_in_place;

    /// Spheres in a periodic box with the calendar queue ([`growing_spheres`]).
    type GrowingSpheres = super::Edmd<
        crate::shape::Sphere,
        crate::boundary::PeriodicBox,
        crate::queue::CalendarQueue,
    >;

    /// `n` spheres of radius 0.5 seeded by RSA in a periodic cube of edge 9, all growing at
    /// `g`, at the start of a barrier interval of length 2.
    fn growing_spheres(n: usize, g: f64, seed: u64) -> GrowingSpheres {
        use super::KernelConfig;
        use crate::boundary::PeriodicBox;
        use crate::protocol::rsa::rsa_spheres;
        use crate::shape::{Sphere, Vec3};
        use rand::SeedableRng;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
        let boundary = PeriodicBox {
            min: Vec3::zeros(),
            len: Vec3::new(9.0, 9.0, 9.0),
        };
        let radii = vec![0.5; n];
        let centres = rsa_spheres(&boundary, &radii, 0.0, 0.0, 100_000, None, &mut rng).unwrap();
        let shapes = radii.iter().map(|&r| Sphere { r0: r, g }).collect();
        let mut k =
            GrowingSpheres::new(centres, shapes, boundary, KernelConfig::default(), &mut rng);
        k.begin_interval(2.0);
        k
    }

    /// At a barrier each pair's collision is predicted from its lower index only
    /// (`Partners::Above`): no pair sits in both particles' lists.
    #[test]
    fn a_barrier_lists_each_pair_once() {
        use super::EventKind;
        let k = growing_spheres(300, 0.05, 5);
        let partners = |k: &GrowingSpheres, i: usize| {
            k.local
                .events(i)
                .iter()
                .filter_map(|e| match e.kind() {
                    EventKind::Collision { partner, .. } if e.time.is_finite() => {
                        Some(k.partner_index(partner))
                    }
                    _ => None,
                })
                .collect::<Vec<_>>()
        };
        let mut listed = 0;
        for i in 0..300 {
            let p = partners(&k, i);
            assert!(p.iter().all(|&j| j > i), "{i} lists {p:?} after a barrier");
            listed += p.len();
        }
        assert!(listed > 20, "only {listed} collisions predicted");
    }

    /// A pair event is kept while its partner's flight is the one it was predicted from:
    /// after every few hundred events of a growing φ ≈ 0.3 packing, every pair event that
    /// the event numbers call valid is a contact of the two particles' current flights (its
    /// time solved again here from their states, Eq. 22 in closed form, without the
    /// kernel's solver), and the numbers call some stale (so both sides of the check are
    /// exercised).
    #[test]
    fn a_pair_event_stays_valid_exactly_while_its_partner_keeps_its_flight() {
        use super::{EventBudget, EventKind};
        use crate::boundary::Boundary;
        let mut k = growing_spheres(400, 0.02, 11);
        let (mut valid, mut stale) = (0, 0);
        for _ in 0..6 {
            let mut budget = EventBudget {
                events_left: 400,
                deadline: None,
                cancel: None,
                stall_epsilon: 0.0,
                since_check: 0,
                time_at_check: 0.0,
                frozen_checks: 0,
                frozen_limit: u32::MAX,
                interval_events_left: u64::MAX,
                stopped: None,
            };
            assert!(
                !k.run_interval(&mut budget),
                "the interval outlasts 400 events"
            );
            let t = k.time;
            for i in 0..k.particles.len() {
                for e in k.local.events(i).iter().filter(|e| e.time.is_finite()) {
                    let EventKind::Collision {
                        partner,
                        predicted_in,
                    } = e.kind()
                    else {
                        continue;
                    };
                    let j = k.partner_index(partner);
                    if k.changed_in[j] > predicted_in {
                        stale += 1;
                        continue;
                    }
                    valid += 1;
                    let (pi, pj) = (&k.particles[i], &k.particles[j]);
                    let mut dr = pi.position_at(t) - pj.position_at(t);
                    k.boundary.minimum_image(&mut dr);
                    let sigma = pi.shape.radius(t) + pj.shape.radius(t);
                    let growth = pi.shape.g + pj.shape.g;
                    let dv = pi.vel - pj.vel;
                    // |dr + dv τ| = σ + G τ: a τ² + 2 b τ + c = 0; the pair is apart
                    // (c > 0), and its first root is (−b − √(b² − ac)) / a for either sign
                    // of a whenever it is a contact ahead.
                    let a = dv.norm_squared() - growth * growth;
                    let b = dr.dot(&dv) - sigma * growth;
                    let c = dr.norm_squared() - sigma * sigma;
                    let disc = b * b - a * c;
                    let tau = (-b - disc.max(0.0).sqrt()) / a;
                    let meets = c > 0.0 && disc >= 0.0 && tau >= 0.0 && (b < 0.0 || a < 0.0);
                    let again = meets.then_some(t + tau);
                    assert!(
                        again.is_some_and(|again| (again - e.time).abs() < 1e-6),
                        "({i}, {j}) kept at {} but its flights meet at {again:?}",
                        e.time
                    );
                }
            }
        }
        assert!(valid > 100 && stale > 10, "{valid} valid, {stale} stale");
    }

    /// A large sphere among small ones lists more neighbours than a block of the prediction
    /// pass, so the pass keeps the earliest contacts after each block and screens the later
    /// blocks against them. Its local list must still hold the earliest `LOCAL_CAPACITY`
    /// contacts of all its neighbours (the first neighbour on ties), truncated exactly when
    /// there are more: checked against contact times solved here in closed form,
    /// `|dr + dv·τ| = σ + ġ·τ` (spheres growing at constant rates), over the barrier
    /// interval.
    #[test]
    fn a_large_sphere_keeps_its_earliest_contacts_of_every_block() {
        // Seeds enough that the earliest contacts lie in the first block for some and in later
        // blocks for others.
        for seed in 0..12 {
            a_large_sphere_among_small_ones(seed);
        }
    }

    fn a_large_sphere_among_small_ones(seed: u64) {
        use super::{Edmd, EventKind, KernelConfig, Partners, LOCAL_CAPACITY, SCREEN_BLOCK};
        use crate::boundary::PeriodicBox;
        use crate::protocol::rsa::rsa_spheres;
        use crate::queue::CalendarQueue;
        use crate::shape::{Sphere, Vec3};
        use rand::SeedableRng;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
        let edge = 14.0;
        let boundary = PeriodicBox {
            min: Vec3::zeros(),
            len: Vec3::new(edge, edge, edge),
        };
        let mut radii = vec![0.25; 6001];
        radii[0] = 4.0;
        let centres = rsa_spheres(&boundary, &radii, 0.0, 0.0, 1_000_000, None, &mut rng).unwrap();
        let shapes = radii
            .iter()
            .map(|&r| Sphere { r0: r, g: 0.02 * r })
            .collect();
        let config = KernelConfig {
            neighbour_skin: 0.5,
            ..KernelConfig::default()
        };
        let mut k: Edmd<Sphere, PeriodicBox, CalendarQueue> =
            Edmd::new(centres, shapes, boundary, config, &mut rng);
        let interval = 2.0;
        k.begin_interval(interval);
        let big = k.ids.iter().position(|&id| id == 0).unwrap();
        let listed: Vec<u32> = k.lists.list(big).iter().copied().collect();
        assert!(
            listed.len() > 2 * SCREEN_BLOCK,
            "seed {seed}: {} neighbours",
            listed.len()
        );
        k.refresh_list_exit(big);
        let list = k.predict_pairs(big, Partners::All);
        k.local.set(big, list);
        // Contact times in closed form: the smaller root of
        // (dv² − ġ²)τ² + 2(dr·dv − σġ)τ + (dr² − σ²) = 0 in [0, interval].
        let pb = &k.particles[big];
        let mut expected: Vec<(f64, usize, usize)> = Vec::new();
        for (position, &entry) in listed.iter().enumerate() {
            let j = k.partner_index(entry);
            let pj = &k.particles[j];
            let mut dr = pb.pos - pj.pos;
            for a in 0..3 {
                dr[a] -= edge * (dr[a] / edge).round();
            }
            let dv = pb.vel - pj.vel;
            let (sigma, growth) = (pb.shape.r0 + pj.shape.r0, pb.shape.g + pj.shape.g);
            let a = dv.norm_squared() - growth * growth;
            let b = dr.dot(&dv) - sigma * growth;
            let c = dr.norm_squared() - sigma * sigma;
            assert!(c > 0.0, "pair ({big}, {j}) overlaps");
            let disc = b * b - a * c;
            if disc < 0.0 {
                continue;
            }
            // The root where the gap closes: (−b − √disc)/a for a > 0, the other form for
            // a ≤ 0 (growth outruns the relative speed: the gap always closes).
            let tau = c / (-b + disc.sqrt());
            if tau > 0.0 && tau <= interval && (b < 0.0 || a < 0.0) {
                expected.push((tau, position, j));
            }
        }
        assert!(
            expected.len() > LOCAL_CAPACITY,
            "{} contacts",
            expected.len()
        );
        expected.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        let mut kept: Vec<(f64, usize)> = k
            .local
            .events(big)
            .iter()
            .filter_map(|e| match e.kind() {
                EventKind::Collision { partner, .. } if e.time.is_finite() => {
                    Some((e.time, k.partner_index(partner)))
                }
                _ => None,
            })
            .collect();
        kept.sort_by(|x, y| x.0.total_cmp(&y.0));
        assert_eq!(kept.len(), LOCAL_CAPACITY);
        for (&(time, j), &(tau, _, j_expected)) in kept.iter().zip(&expected) {
            assert_eq!(
                j, j_expected,
                "seed {seed}: kept {kept:?}, expected {expected:?}"
            );
            assert!(
                (time - tau).abs() <= 1e-9 * tau,
                "time {time}, expected {tau}"
            );
        }
        assert!(
            k.local.truncated(big),
            "more contacts than kept: the list is truncated"
        );
    }

    /// A sphere's record is one aligned cache line: a partner costs one line to load.
    #[test]
    fn a_sphere_particle_fills_one_cache_line() {
        type P = super::Particle<crate::shape::Sphere>;
        assert_eq!(std::mem::size_of::<P>(), 64);
        assert_eq!(std::mem::align_of::<P>(), 64);
    }

    /// The state is kept at kernel time 0: an event's velocity change moves the stored line
    /// so that the centre at the event time stays put, and the new velocity holds after it.
    /// (Dyadic values: every operation is exact, so the check is exact too.)
    #[test]
    fn a_kick_keeps_the_centre_at_the_event_time() {
        use crate::shape::{Sphere, Vec3};
        let mut p = super::Particle {
            pos: Vec3::new(1.0, 2.0, 3.0),
            vel: Vec3::new(0.5, -0.25, 2.0),
            shape: Sphere::new(0.5),
            spin: (),
        };
        let t = 0.75;
        let before = p.position_at(t);
        p.kick(Vec3::new(-1.0, 0.5, 0.125), (), t);
        assert_eq!(p.position_at(t), before);
        assert_eq!(p.vel, Vec3::new(-0.5, 0.25, 2.125));
        assert_eq!(p.position_at(t + 2.0), before + p.vel * 2.0);
    }

    #[test]
    fn in_place_permutation_gathers() {
        let order = [3u32, 0, 4, 1, 2, 5];
        let mut v = vec!['a', 'b', 'c', 'd', 'e', 'f'];
        let expected: Vec<char> = order.iter().map(|&o| v[o as usize]).collect();
        permute_in_place(&mut v, &order, &mut [false; 6]);
        assert_eq!(v, expected);
    }
}
