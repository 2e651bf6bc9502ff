//! Kernel snapshots for checkpoint and resume.
//!
//! A snapshot is taken at a time barrier (see [`Edmd::continue_stage`]'s `at_barrier`), where
//! the kernel is synchronised at kernel time 0, every local event list is about to be
//! cleared and the queue about to be reset. What survives a barrier is stored here
//! exactly — particles (delayed states at time 0, shapes with their growth),
//! neighbour-list spheres, envelopes and lists (in their order), the cell grid (with the
//! member order of every cell, which decides the order of future neighbour lists), the
//! particle numbering, the skin, the barrier interval, the elapsed time and the event
//! counters — so that a kernel rebuilt by [`Edmd::from_snapshot`] processes the same events
//! in the same order and ends in the same state, bit for bit, as the one that was
//! snapshotted. The local lists, the queue and the interval's virial are not stored: the next
//! interval starts them afresh.
//!
//! The snapshot borrows the kernel's arrays when it is written ([`Edmd::snapshot`] copies
//! nothing) and owns them when it is read back. The encoding is the caller's choice (serde);
//! `crate::io::checkpoint` writes the file.

use super::{Edmd, EventCounts, KernelConfig, LocalLists, NeighbourLists, Particle};
use crate::boundary::Boundary;
use crate::queue::EventQueue;
use crate::shape::{Collidable, EnvelopeModel, PeriodicImages};
use crate::spatial::CellGrid;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;

/// The state of a kernel at a time barrier (see the module docs).
#[derive(Serialize, Deserialize)]
#[serde(bound(
    serialize = "S: Serialize, S::Spin: Serialize",
    deserialize = "S: DeserializeOwned, S::Spin: DeserializeOwned"
))]
pub struct KernelSnapshot<'a, S: Collidable> {
    particles: Cow<'a, [Particle<S>]>,
    list_spheres: Cow<'a, [super::ListSphere]>,
    envelopes: Cow<'a, [S::Envelope]>,
    neighbours: Cow<'a, [super::NeighbourList]>,
    grid: Cow<'a, CellGrid>,
    ids: Cow<'a, [u32]>,
    reference_volume: f64,
    elapsed: f64,
    interval: f64,
    counters: EventCounts,
    updates_at_sort: u64,
    skin: f64,
    mean_radius: f64,
    /// Whether the neighbour entries carry periodic image shifts.
    images: bool,
}

/// A snapshot that cannot be the state of a kernel.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("inconsistent kernel snapshot: {0}")]
pub struct SnapshotError(String);

impl<S, B: Boundary, Q: EventQueue> Edmd<S, B, Q>
where
    S: Collidable + Serialize,
    S::Spin: Serialize,
{
    /// The kernel's state, borrowed. Only valid at a time barrier (the kernel synchronised
    /// at kernel time 0), which is where `at_barrier` of [`Edmd::continue_stage`] runs.
    ///
    /// # Panics
    /// If the kernel is not synchronised at time 0.
    pub fn snapshot(&self) -> KernelSnapshot<'_, S> {
        assert!(
            self.time == 0.0,
            "a kernel snapshot is taken at a time barrier"
        );
        KernelSnapshot {
            particles: Cow::Borrowed(&self.particles),
            list_spheres: Cow::Borrowed(self.lists.spheres()),
            envelopes: Cow::Borrowed(self.lists.envelopes()),
            neighbours: Cow::Borrowed(self.lists.all()),
            grid: Cow::Borrowed(self.lists.grid()),
            ids: Cow::Borrowed(&self.ids),
            reference_volume: self.reference_volume,
            elapsed: self.elapsed,
            interval: self.interval,
            counters: self.counters,
            updates_at_sort: self.lists.updates_at_sort(),
            skin: self.lists.skin(),
            mean_radius: self.lists.mean_radius(),
            images: self.lists.tracks_images(),
        }
    }
}

impl<S, B: Boundary, Q: EventQueue> Edmd<S, B, Q>
where
    S: Collidable + DeserializeOwned,
    S::Spin: DeserializeOwned,
{
    /// Rebuilds the kernel a snapshot was taken of. `boundary` and `config` must be those
    /// the snapshotted kernel was built with (the run stores its scene for that); the
    /// array lengths and indices are checked.
    pub fn from_snapshot(
        snapshot: KernelSnapshot<'_, S>,
        boundary: B,
        config: KernelConfig,
    ) -> Result<Self, SnapshotError> {
        let n = snapshot.particles.len();
        let lengths = [
            ("list_spheres", snapshot.list_spheres.len()),
            ("neighbours", snapshot.neighbours.len()),
            ("ids", snapshot.ids.len()),
        ];
        if let Some((name, len)) = lengths.iter().find(|(_, len)| *len != n) {
            return Err(SnapshotError(format!(
                "{name} has {len} entries for {n} particles"
            )));
        }
        let envelopes = S::Envelope::kept(n);
        if snapshot.envelopes.len() != envelopes {
            return Err(SnapshotError(format!(
                "envelopes has {} entries, expected {envelopes}",
                snapshot.envelopes.len()
            )));
        }
        let mut seen = vec![false; n];
        for &id in snapshot.ids.iter() {
            match seen.get_mut(id as usize) {
                Some(s) if !*s => *s = true,
                _ => {
                    return Err(SnapshotError(
                        "particle numbering is not a permutation".into(),
                    ))
                }
            }
        }
        if snapshot.neighbours.iter().flatten().any(|&j| {
            let index = if snapshot.images {
                super::images::index(j)
            } else {
                j as usize
            };
            index >= n
        }) {
            return Err(SnapshotError("a neighbour index is out of range".into()));
        }
        let images = match (snapshot.images, S::Images::tracking()) {
            (false, _) => None,
            (true, Some(tracking)) => Some(tracking),
            (true, None) => {
                return Err(SnapshotError(
                    "periodic images tracked for a shape without images".into(),
                ))
            }
        };
        let lists = NeighbourLists::restore(
            snapshot.list_spheres.into_owned(),
            snapshot.envelopes.into_owned(),
            snapshot.neighbours.into_owned(),
            snapshot.grid.into_owned(),
            &boundary,
            snapshot.updates_at_sort,
            snapshot.skin,
            snapshot.mean_radius,
            images,
        );
        Ok(Self {
            particles: snapshot.particles.into_owned(),
            changed_in: vec![0; n],
            event_number: 0,
            local: LocalLists::new(n),
            lists,
            boundary,
            ids: snapshot.ids.into_owned(),
            queue: Q::with_capacity(n),
            config,
            reference_volume: snapshot.reference_volume,
            time: 0.0,
            elapsed: snapshot.elapsed,
            barrier_time: 0.0,
            interval: snapshot.interval,
            virial: 0.0,
            kinetic_start: 0.0,
            counters: snapshot.counters,
            // Right for any rates; the next interval knows better.
            grows: true,
            scratch: Vec::new(),
            pair_times: Vec::new(),
            screened: Vec::new(),
            // Set by the stage the kernel continues (`Edmd::continue_stage`).
            wall_growth: 1.0,
            stage_clock: 0.0,
            cancel: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use crate::boundary::{Boundary, CylinderContainer, PeriodicBox};
    use crate::kernel::{Edmd, KernelConfig, Limits, Stage, Until};
    use crate::protocol::rsa::rsa_spheres;
    use crate::queue::{CalendarQueue, EventQueue, HeapQueue};
    use crate::shape::{Growth, Sphere, Vec3};
    use rand::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;

    fn kernel<B: Boundary, Q: EventQueue>(boundary: B, n: usize, r: f64) -> Edmd<Sphere, B, Q> {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        let radii = vec![r; n];
        let centres = rsa_spheres(&boundary, &radii, 0.0, 0.0, 100_000, None, &mut rng).unwrap();
        let shapes = radii.iter().map(|&r| Sphere::new(r)).collect();
        Edmd::new(centres, shapes, boundary, KernelConfig::default(), &mut rng)
    }

    /// Runs `stage` twice from the same start: once through, once snapshotted at barrier
    /// `at`, round-tripped through bytes and continued in a rebuilt kernel. Everything must
    /// agree bit for bit: particles, counters, pressure and its error.
    fn assert_resumes_exactly<B: Boundary, Q: EventQueue>(
        mut original: Edmd<Sphere, B, Q>,
        stage: &Stage,
        at: usize,
    ) {
        let progress = original.start_stage(stage);
        let mut saved = None;
        let mut barriers = 0;
        let report = original.continue_stage(stage, progress, &mut |k, p| {
            barriers += 1;
            if barriers == at {
                saved = Some((
                    postcard::to_stdvec(&k.snapshot()).unwrap(),
                    postcard::to_stdvec(p).unwrap(),
                ));
            }
        });
        let (kernel_bytes, progress_bytes) = saved.expect("the stage reaches the barrier");
        let snapshot = postcard::from_bytes(&kernel_bytes).unwrap();
        let boundary = original.boundary().clone();
        let mut restored: Edmd<Sphere, B, Q> =
            Edmd::from_snapshot(snapshot, boundary, KernelConfig::default()).unwrap();
        let progress = postcard::from_bytes(&progress_bytes).unwrap();
        let resumed = restored.continue_stage(stage, progress, &mut |_, _| {});
        assert_eq!(report.counts, resumed.counts);
        assert_eq!(report.stop_reason, resumed.stop_reason);
        assert_eq!(
            report.reduced_pressure.to_bits(),
            resumed.reduced_pressure.to_bits()
        );
        assert_eq!(
            report.reduced_pressure_stderr.map(f64::to_bits),
            resumed.reduced_pressure_stderr.map(f64::to_bits)
        );
        assert_eq!(report.simulated_time, resumed.simulated_time);
        for (a, b) in original.particles().iter().zip(restored.particles()) {
            assert_eq!(a.pos, b.pos);
            assert_eq!(a.vel, b.vel);
            assert_eq!(a.shape, b.shape);
        }
        assert_eq!(original.original_indices(), restored.original_indices());
    }

    #[test]
    fn a_growth_stage_resumes_exactly_in_a_periodic_box() {
        let boundary = PeriodicBox {
            min: Vec3::zeros(),
            len: Vec3::repeat(6.0),
        };
        let stage = Stage {
            growth: Growth::Relative(0.05),
            schedule: crate::kernel::RateSchedule::Fixed,
            until: Until {
                reduced_pressure: Some(1e6),
                ..Until::default()
            },
            limits: Limits::default(),
            thermostat: true,
            wall_growth: 1.0,
        };
        let k: Edmd<Sphere, _, CalendarQueue> = kernel(boundary, 125, 0.4);
        assert_resumes_exactly(k, &stage, 20);
    }

    #[test]
    fn an_equilibrium_stage_resumes_exactly_in_a_cylinder_with_the_heap() {
        let boundary = CylinderContainer {
            base_center: Vec3::zeros(),
            radius: 3.0,
            height: 5.0,
        };
        let stage = Stage {
            growth: Growth::None,
            schedule: crate::kernel::RateSchedule::Fixed,
            until: Until {
                collisions_per_particle: Some(200.0),
                ..Until::default()
            },
            limits: Limits::default(),
            thermostat: false,
            wall_growth: 1.0,
        };
        let k: Edmd<Sphere, _, HeapQueue> = kernel(boundary, 150, 0.35);
        assert_resumes_exactly(k, &stage, 30);
    }
}
