//! The EDMD kernel: event-driven molecular dynamics of growing hard particles
//! (Lubachevsky–Stillinger), generic over shape, container and event queue.
//!
//! # How an event flows
//! Every particle keeps a *delayed state* — centre and velocity at its own last update time —
//! and a *local event list*: the events predicted for it since its trajectory last changed,
//! each event carrying the collision counter of its partner. The queue ([`crate::queue`])
//! holds one entry per particle, the earliest of its local list. The loop peeks the queue:
//!
//! 1. an event later than the *time barrier* ends the interval (see below);
//! 2. a pair event whose partner's counter has moved on is stale: it is dropped from the
//!    local list and the particle is rescheduled with its next local event;
//! 3. a collision brings both particles up to date, applies the impulse
//!    ([`Collidable::collision_impulse`]), bumps both counters, clears both local lists and
//!    predicts new events for both against the 27 surrounding cells;
//! 4. a wall contact does the same for one particle ([`Boundary`]);
//! 5. a cell crossing moves the particle to the next cell and predicts only against the
//!    newly adjacent layer of 9 cells: its trajectory did not change, so its other events
//!    stay valid.
//!
//! Invalidation never scans the queue: a particle's own events go with its local list, and
//! events of others that name it are recognised as stale by the counter.
//!
//! # Time barriers
//! Events later than the barrier are not stored. At the barrier all particles are brought to
//! the barrier time, the time origin is moved there ([`Collidable::rebase`]: long runs keep
//! full precision), velocities are rescaled to the set temperature when particles grow, the
//! cell grid is rebuilt if the particles have outgrown it, the reduced pressure of the
//! interval is measured, stop criteria are checked and all events are predicted afresh. The
//! barrier interval adapts so that an interval holds about
//! [`KernelConfig::events_per_particle_per_interval`] events per particle (measured: see
//! `BENCHMARKS.md`).
//!
//! # Pressure
//! The reduced pressure `Z = PV/(NkT)` comes from the collision virial,
//! `Z = 1 + Σ J·ℓ / (Σ m v² · Δt)`, with `J` the impulse of a contact and `ℓ` the distance
//! from each centre to the contact point summed over the bodies that move (`σ` for a pair of
//! spheres, `r` for a sphere against a wall: then `Z` is the wall pressure).

mod stage;

pub use stage::{Limits, Stage, StageReport, StopReason, Until};

use crate::boundary::{Boundary, WallId};
use crate::queue::EventQueue;
use crate::shape::{Collidable, MassRule, Vec3};
use crate::spatial::{CellGrid, Crossing};
use rand::Rng;
use rand_distr::StandardNormal;

/// A particle in delayed state: centre and velocity valid at `time`.
#[derive(Clone, Debug)]
pub struct Particle<S> {
    /// Centre at `time`.
    pub pos: Vec3,
    /// Velocity (constant between events).
    pub vel: Vec3,
    /// Kernel time of the last update of `pos`.
    pub time: f64,
    /// Shape and growth.
    pub shape: S,
}

impl<S> Particle<S> {
    /// Centre at kernel time `t`.
    #[inline]
    pub fn position_at(&self, t: f64) -> Vec3 {
        self.pos + self.vel * (t - self.time)
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
}

impl Default for KernelConfig {
    fn default() -> Self {
        Self {
            mass: MassRule::Equal,
            temperature: 1.0,
            events_per_particle_per_interval: 4.0,
        }
    }
}

/// Counts of processed events, by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct EventCounts {
    /// All processed events (collisions, wall contacts, cell crossings).
    pub events: u64,
    /// Pair collisions.
    pub collisions: u64,
    /// Wall contacts.
    pub wall_collisions: u64,
    /// Cell crossings.
    pub cell_crossings: u64,
    /// Stale queue entries skipped (not counted in `events`).
    pub stale: u64,
    /// Time barriers.
    pub barriers: u64,
    /// Cell grid rebuilds.
    pub grid_rebuilds: u64,
}

#[derive(Clone, Copy, Debug)]
enum EventKind {
    Collision,
    Wall(WallId),
    Crossing(Crossing),
}

#[derive(Clone, Copy, Debug)]
struct LocalEvent {
    time: f64,
    partner: u32,
    partner_count: u32,
    kind: EventKind,
}

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
    counts: Vec<u32>,
    local: Vec<Vec<LocalEvent>>,
    boundary: B,
    grid: CellGrid,
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
}

impl<S: Collidable, B: Boundary, Q: EventQueue> Edmd<S, B, Q> {
    /// A kernel for particles with the given centres and shapes at kernel time 0, with
    /// Maxwell–Boltzmann velocities of temperature `config.temperature` and zero total momentum.
    ///
    /// The caller guarantees that the particles do not overlap and lie inside the container.
    pub fn new<R: Rng>(
        centres: Vec<Vec3>,
        shapes: Vec<S>,
        boundary: B,
        config: KernelConfig,
        rng: &mut R,
    ) -> Self {
        assert_eq!(centres.len(), shapes.len(), "one shape per centre");
        let n = centres.len();
        let reference_volume = if n == 0 {
            1.0
        } else {
            shapes.iter().map(|s| s.volume(0.0)).sum::<f64>() / n as f64
        };
        let mut particles: Vec<Particle<S>> = centres
            .into_iter()
            .zip(shapes)
            .map(|(mut pos, shape)| {
                boundary.wrap(&mut pos);
                Particle {
                    pos,
                    vel: Vec3::zeros(),
                    time: 0.0,
                    shape,
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
            let momentum: Vec3 = particles
                .iter()
                .zip(&masses)
                .map(|(p, m)| p.vel * *m)
                .sum();
            let drift = momentum / total_mass;
            for p in &mut particles {
                p.vel -= drift;
            }
        }
        let grid = CellGrid::new(boundary.min(), boundary.max(), boundary.periodic(), 1.0, 0);
        let mut kernel = Self {
            counts: vec![0; n],
            local: vec![Vec::new(); n],
            queue: Q::with_capacity(n),
            particles,
            boundary,
            grid,
            config,
            reference_volume,
            time: 0.0,
            elapsed: 0.0,
            barrier_time: 0.0,
            interval: 0.0,
            virial: 0.0,
            kinetic_start: 0.0,
            counters: EventCounts::default(),
        };
        if n > 1 {
            kernel.rescale_temperature();
        }
        kernel.rebuild_grid(kernel.max_diameter(0.0));
        kernel
    }

    /// The particles; their states are synchronised (all at `time() == 0`) between stages.
    pub fn particles(&self) -> &[Particle<S>] {
        &self.particles
    }

    /// The container.
    pub fn boundary(&self) -> &B {
        &self.boundary
    }

    /// Event counts since the kernel was built.
    pub fn counters(&self) -> EventCounts {
        self.counters
    }

    /// Simulated time since the kernel was built.
    pub fn elapsed(&self) -> f64 {
        self.elapsed + self.time
    }

    /// Packing fraction at kernel time `t`.
    pub fn packing_fraction_at(&self, t: f64) -> f64 {
        self.particles.iter().map(|p| p.shape.volume(t)).sum::<f64>() / self.boundary.volume()
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
        self.particles
            .iter()
            .map(|p| self.mass(p, self.time) * p.vel.norm_squared())
            .sum()
    }

    #[inline]
    fn mass(&self, p: &Particle<S>, t: f64) -> f64 {
        mass_of(self.config.mass, &p.shape, t, self.reference_volume)
    }

    fn max_diameter(&self, t: f64) -> f64 {
        self.particles
            .iter()
            .map(|p| 2.0 * p.shape.bounding_radius(t))
            .fold(0.0, f64::max)
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
    }

    /// Rebuilds the cell grid for cells at least `width` wide (particles must be synchronised).
    fn rebuild_grid(&mut self, width: f64) {
        let b = &self.boundary;
        self.grid = CellGrid::new(b.min(), b.max(), b.periodic(), width, self.particles.len());
        for (i, p) in self.particles.iter().enumerate() {
            let c = self.grid.cell_at(&p.pos);
            self.grid.insert(i, c);
        }
        self.counters.grid_rebuilds += 1;
    }

    /// Brings every particle to kernel time `t` and moves the time origin there.
    fn synchronise_and_rebase(&mut self, t: f64) {
        for p in &mut self.particles {
            p.pos += p.vel * (t - p.time);
            self.boundary.wrap(&mut p.pos);
            p.time = 0.0;
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
        let needed = self.max_diameter(interval);
        if self.grid.min_width() < needed {
            // Rebuild with a small margin so that slow growth does not rebuild every barrier.
            self.rebuild_grid(needed * 1.05);
        }
        // Cells stay valid only while no particle outgrows them.
        let n = self.particles.len();
        self.queue.reset(0.0, interval, n);
        for list in &mut self.local {
            list.clear();
        }
        for i in 0..n {
            let cells = self.grid.neighbourhood(self.grid.cell_of(i));
            self.predict_pairs(i, cells.as_slice(), Partners::Above);
            self.predict_own(i);
            self.reschedule(i);
        }
        self.virial = 0.0;
        self.kinetic_start = self.kinetic_twice();
    }

    /// Predicts collisions of particle `i` with the members of `cells`.
    #[inline]
    fn predict_pairs(&mut self, i: usize, cells: &[u32], partners: Partners) {
        let t = self.time;
        let max_tau = self.barrier_time - t;
        let pi = &self.particles[i];
        let pos_i = pi.position_at(t);
        let list = &mut self.local[i];
        for &c in cells {
            for j in self.grid.members(c) {
                let skip = match partners {
                    Partners::All => j == i,
                    Partners::AllBut(k) => j == i || j == k,
                    Partners::Above => j <= i,
                };
                if skip {
                    continue;
                }
                let pj = &self.particles[j];
                let mut dr = pos_i - pj.position_at(t);
                self.boundary.minimum_image(&mut dr);
                let dv = pi.vel - pj.vel;
                if let Some(tau) = S::predict_collision(&pi.shape, &pj.shape, &dr, &dv, t, max_tau)
                {
                    list.push(LocalEvent {
                        time: t + tau,
                        partner: j as u32,
                        partner_count: self.counts[j],
                        kind: EventKind::Collision,
                    });
                }
            }
        }
    }

    /// Predicts the wall contact and the cell crossing of particle `i`.
    #[inline]
    fn predict_own(&mut self, i: usize) {
        let t = self.time;
        let max_tau = self.barrier_time - t;
        let p = &self.particles[i];
        let pos = p.position_at(t);
        if B::HAS_WALLS {
            let r = p.shape.bounding_radius(t);
            let g = p.shape.bounding_growth_rate();
            if let Some((tau, wall)) = self.boundary.predict_wall(&pos, &p.vel, r, g, max_tau) {
                self.local[i].push(LocalEvent {
                    time: t + tau,
                    partner: i as u32,
                    partner_count: 0,
                    kind: EventKind::Wall(wall),
                });
            }
        }
        if let Some((tau, crossing)) = self.grid.predict_crossing(self.grid.cell_of(i), &pos, &p.vel) {
            if tau <= max_tau {
                self.local[i].push(LocalEvent {
                    time: t + tau,
                    partner: i as u32,
                    partner_count: 0,
                    kind: EventKind::Crossing(crossing),
                });
            }
        }
    }

    /// Puts particle `i`'s earliest local event into the queue (or removes it).
    #[inline]
    fn reschedule(&mut self, i: usize) {
        match earliest(&self.local[i]) {
            Some((_, e)) => self.queue.schedule(i, e.time),
            None => self.queue.cancel(i),
        }
    }

    #[inline]
    fn advance(&mut self, i: usize, t: f64) {
        let p = &mut self.particles[i];
        p.pos += p.vel * (t - p.time);
        p.time = t;
    }

    /// Processes events up to the barrier. Returns `false` if `budget` ran out first (then
    /// the kernel time is that of the last processed event).
    fn run_interval(&mut self, budget: &mut EventBudget) -> bool {
        loop {
            let Some((i, t)) = self.queue.peek() else {
                return true;
            };
            if t > self.barrier_time {
                return true;
            }
            let (idx, event) = earliest(&self.local[i]).expect("a queued particle has events");
            self.time = self.time.max(t);
            match event.kind {
                EventKind::Collision => {
                    let j = event.partner as usize;
                    if self.counts[j] != event.partner_count {
                        self.local[i].swap_remove(idx);
                        self.reschedule(i);
                        self.counters.stale += 1;
                        continue;
                    }
                    self.collide(i, j);
                }
                EventKind::Wall(wall) => self.hit_wall(i, wall),
                EventKind::Crossing(crossing) => {
                    self.local[i].swap_remove(idx);
                    self.cross(i, crossing);
                }
            }
            self.counters.events += 1;
            if !budget.spend(self.elapsed + self.time) {
                return false;
            }
        }
    }

    fn collide(&mut self, i: usize, j: usize) {
        let t = self.time;
        self.advance(i, t);
        self.advance(j, t);
        let (pi, pj) = (&self.particles[i], &self.particles[j]);
        let mut dr = pi.pos - pj.pos;
        self.boundary.minimum_image(&mut dr);
        let dv = pi.vel - pj.vel;
        let (mi, mj) = (self.mass(pi, t), self.mass(pj, t));
        let impulse = S::collision_impulse(&pi.shape, &pj.shape, &dr, &dv, t, mi, mj);
        self.virial += impulse.dot(&dr);
        self.particles[i].vel += impulse / mi;
        self.particles[j].vel -= impulse / mj;
        self.counts[i] = self.counts[i].wrapping_add(1);
        self.counts[j] = self.counts[j].wrapping_add(1);
        self.local[i].clear();
        self.local[j].clear();
        let cells_i = self.grid.neighbourhood(self.grid.cell_of(i));
        self.predict_pairs(i, cells_i.as_slice(), Partners::All);
        self.predict_own(i);
        let cells_j = self.grid.neighbourhood(self.grid.cell_of(j));
        self.predict_pairs(j, cells_j.as_slice(), Partners::AllBut(i));
        self.predict_own(j);
        self.reschedule(i);
        self.reschedule(j);
        self.counters.collisions += 1;
    }

    fn hit_wall(&mut self, i: usize, wall: WallId) {
        let t = self.time;
        self.advance(i, t);
        let p = &self.particles[i];
        let n = self.boundary.wall_normal(wall, &p.pos);
        let g = p.shape.bounding_growth_rate();
        let u = p.vel.dot(&n);
        // Reflect the gap velocity u − g (Eq. 24 for g = 0); never leave it closing.
        let u_after = (2.0 * g - u).max(g);
        let m = self.mass(p, t);
        self.virial += m * (u_after - u) * p.shape.bounding_radius(t);
        self.particles[i].vel += n * (u_after - u);
        self.counts[i] = self.counts[i].wrapping_add(1);
        self.local[i].clear();
        let cells = self.grid.neighbourhood(self.grid.cell_of(i));
        self.predict_pairs(i, cells.as_slice(), Partners::All);
        self.predict_own(i);
        self.reschedule(i);
        self.counters.wall_collisions += 1;
    }

    fn cross(&mut self, i: usize, crossing: Crossing) {
        let t = self.time;
        self.advance(i, t);
        let (cell, shift) = self.grid.neighbour_across(self.grid.cell_of(i), crossing);
        if shift != 0 {
            let k = crossing.axis as usize;
            let len = self.boundary.max()[k] - self.boundary.min()[k];
            self.particles[i].pos[k] += shift as f64 * len;
        }
        self.grid.remove(i);
        self.grid.insert(i, cell);
        let layer = self.grid.new_layer(cell, crossing);
        self.predict_pairs(i, layer.as_slice(), Partners::All);
        // The wall event (if any) is still in the list; only the next crossing is new.
        if let Some((tau, next)) =
            self.grid
                .predict_crossing(cell, &self.particles[i].pos, &self.particles[i].vel)
        {
            if tau <= self.barrier_time - t {
                self.local[i].push(LocalEvent {
                    time: t + tau,
                    partner: i as u32,
                    partner_count: 0,
                    kind: EventKind::Crossing(next),
                });
            }
        }
        self.reschedule(i);
        self.counters.cell_crossings += 1;
    }
}

#[inline]
fn mass_of<S: Collidable>(rule: MassRule, shape: &S, t: f64, reference_volume: f64) -> f64 {
    match rule {
        MassRule::Equal => 1.0,
        MassRule::Volume => shape.volume(t) / reference_volume,
    }
}

/// Index and copy of the earliest event of a local list (first one on ties).
#[inline]
fn earliest(list: &[LocalEvent]) -> Option<(usize, LocalEvent)> {
    let mut best: Option<(usize, LocalEvent)> = None;
    for (k, e) in list.iter().enumerate() {
        if best.is_none_or(|(_, b)| e.time < b.time) {
            best = Some((k, *e));
        }
    }
    best
}

/// Limits checked while events are processed: event count, wall clock, stalling.
struct EventBudget {
    events_left: u64,
    deadline: Option<std::time::Instant>,
    stall_epsilon: f64,
    since_check: u32,
    time_at_check: f64,
    stopped: Option<StopReason>,
}

/// Events between two checks of the clock and of the stall criterion (paper 001: Δt < ε
/// over 1000 events).
const CHECK_EVERY: u32 = 1000;

impl EventBudget {
    #[inline]
    fn spend(&mut self, now: f64) -> bool {
        self.events_left = self.events_left.saturating_sub(1);
        if self.events_left == 0 {
            self.stopped = Some(StopReason::EventLimit);
            return false;
        }
        self.since_check += 1;
        if self.since_check >= CHECK_EVERY {
            self.since_check = 0;
            // Time that does not advance at all is a stall whatever ε is.
            if now - self.time_at_check < self.stall_epsilon || now == self.time_at_check {
                self.stopped = Some(StopReason::Stalled);
                return false;
            }
            self.time_at_check = now;
            if self.deadline.is_some_and(|d| std::time::Instant::now() >= d) {
                self.stopped = Some(StopReason::WallClockLimit);
                return false;
            }
        }
        true
    }
}
