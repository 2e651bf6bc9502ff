//! Random sequential addition (RSA) of spheres (paper 001, §4).
//!
//! Spheres are placed one after the other, largest first, at uniformly random admissible
//! centres (walls respected, periodic axes wrapped); a candidate that overlaps an already
//! placed sphere is rejected and drawn again. After `max_failures` consecutive rejections of
//! one sphere the addition stops and reports how far it got. A minimum gap `Δd` is honoured
//! by testing against diameters `d + Δd`; walls keep a clearance `wall_gap` (usually `Δd/2`).
//!
//! Overlap candidates come from a multi-level [`CellGrid`]. The paper (§4) rebuilds a single
//! cell grid whenever the diameter being placed has halved, so that small spheres are not
//! tested against cells sized for the largest; here each halving of the diameter owns a grid
//! level (cell width `d + Δd` halving down to the smallest sphere), a sphere is registered at
//! the finest level that holds it, and a candidate queries every level with the reach that
//! level's largest member needs. Same effect without rebuilding, and a cell never holds
//! spheres much smaller than itself (size ratio 32 for concrete: 0.5–16 mm).
//!
//! # Threads, and the same spheres on any number of them
//!
//! Each sphere draws its candidates from its own random stream (a [`Xoshiro256PlusPlus`]
//! seeded by one number drawn from the caller's generator plus the sphere's index), so the
//! placement is a function of the seed alone: sphere `k` lands on the first candidate of
//! its stream that keeps clear of spheres `0 … k−1` (placement order). The spheres are
//! processed in batches of consecutive spheres. First, on all threads (rayon), each sphere
//! of a batch finds the first candidate of its stream that keeps clear of the spheres placed
//! *before the batch*; every earlier candidate conflicts with one of those, so it is
//! rejected in the serial order too. Then, in order, each sphere's candidate is tested
//! against the spheres of its batch placed before it (it is clear of all others): accepted
//! if free, otherwise the sphere goes on along its stream from there against everything
//! placed, as it would one after the other. The result is the one-thread result, bit for
//! bit, on any number of threads and for any batch length; only a candidate that meets a
//! sphere of its own batch costs serial work, and batches are kept short against the
//! spheres already placed (an eighth of them, at most 256) so that this stays rare.

use crate::boundary::Boundary;
use crate::shape::Vec3;
use crate::spatial::{CellGrid, MAX_LEVELS};
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use rayon::prelude::*;
use std::sync::atomic::AtomicBool;

/// Longest batch of spheres placed in parallel (see the module docs).
const MAX_BATCH: usize = 256;

/// RSA could not place every sphere.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error(
    "random sequential addition placed {placed} of {total} spheres (packing fraction {fraction:.4}) \
     before {failures} consecutive rejections of sphere {placed}; lower the packing fraction or \
     raise the rejection limit"
)]
pub struct RsaFailure {
    /// Spheres placed.
    pub placed: usize,
    /// Spheres requested.
    pub total: usize,
    /// Packing fraction of the placed spheres.
    pub fraction: f64,
    /// The rejection limit that was hit.
    pub failures: u64,
}

/// Why random sequential addition of spheres stopped without placing them all.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SeedingError {
    /// The rejection limit struck.
    #[error(transparent)]
    Failed(#[from] RsaFailure),
    /// The cancel flag was set ([`crate::cancel`]).
    #[error("random sequential addition was cancelled")]
    Cancelled,
}

/// Places spheres of the given radii (any order; placed largest first) in `boundary`.
/// Returns the centres in the order of `radii`. `cancel` is checked at every candidate.
/// Draws one number from `rng` (the seed of the spheres' candidate streams); the result does
/// not depend on the number of threads (module docs).
pub fn rsa_spheres<B: Boundary, R: Rng>(
    boundary: &B,
    radii: &[f64],
    gap: f64,
    wall_gap: f64,
    max_failures: u64,
    cancel: Option<&AtomicBool>,
    rng: &mut R,
) -> Result<Vec<Vec3>, SeedingError> {
    let n = radii.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| radii[b].total_cmp(&radii[a]).then(a.cmp(&b)));
    let d_max = radii.iter().fold(0.0_f64, |m, &r| m.max(2.0 * r));
    let d_min = radii.iter().fold(f64::INFINITY, |m, &r| m.min(2.0 * r));
    let mut widths = vec![d_max + gap];
    while widths.len() < MAX_LEVELS && 0.5 * widths[widths.len() - 1] >= d_min + gap {
        widths.push(0.5 * widths[widths.len() - 1]);
    }
    let mut grid = CellGrid::with_levels(
        boundary.min(),
        boundary.max(),
        boundary.periodic(),
        &widths,
        n,
    );
    let streams: u64 = rng.gen();
    let mut centres = vec![Vec3::zeros(); n];
    let mut volume = 0.0;
    let mut placed = 0;
    let mut batch_placed: Vec<usize> = Vec::with_capacity(MAX_BATCH);
    while placed < n {
        let batch = &order[placed..(placed + (placed / 8).clamp(1, MAX_BATCH)).min(n)];
        let placed_before: &[Vec3] = &centres;
        let grid_before = &grid;
        // Each sphere's first candidate clear of the spheres placed before the batch.
        let firsts: Vec<Search> = batch
            .par_iter()
            .map(|&i| {
                let mut search = Search {
                    stream: Xoshiro256PlusPlus::seed_from_u64(streams.wrapping_add(i as u64)),
                    failures: 0,
                    outcome: Outcome::Exhausted,
                };
                search.run(max_failures, cancel, |stream| {
                    let r = radii[i];
                    boundary.sample_center(r + wall_gap, stream).filter(|&c| {
                        is_free(grid_before, boundary, placed_before, radii, c, r, gap)
                    })
                });
                search
            })
            .collect();
        // In order: a candidate clear of the spheres before the batch needs testing only
        // against the batch's spheres placed so far (a short list, with `is_free`'s pair
        // test); one that meets them goes on along its stream against everything.
        batch_placed.clear();
        for (&i, mut search) in batch.iter().zip(firsts) {
            let r = radii[i];
            let clear_of_batch = |c: &Vec3| {
                batch_placed
                    .iter()
                    .all(|&j| keeps_gap(boundary, c, r, &centres[j], radii[j], gap))
            };
            if let Outcome::Found(c) = search.outcome {
                if !clear_of_batch(&c) {
                    search.failures += 1;
                    search.run(max_failures, cancel, |stream| {
                        boundary
                            .sample_center(r + wall_gap, stream)
                            .filter(|&c| is_free(&grid, boundary, &centres, radii, c, r, gap))
                    });
                }
            }
            match search.outcome {
                Outcome::Cancelled => return Err(SeedingError::Cancelled),
                Outcome::Exhausted => {
                    return Err(RsaFailure {
                        placed,
                        total: n,
                        fraction: volume / boundary.volume(),
                        failures: max_failures,
                    }
                    .into())
                }
                Outcome::Found(c) => {
                    centres[i] = c;
                    let level = grid.level_for(2.0 * r + gap);
                    grid.insert(i, grid.cell_at(level, &c));
                    volume += 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
                    batch_placed.push(i);
                    placed += 1;
                }
            }
        }
    }
    Ok(centres)
}

/// One sphere's walk along its candidate stream.
struct Search {
    stream: Xoshiro256PlusPlus,
    /// Candidates rejected so far.
    failures: u64,
    outcome: Outcome,
}

/// Where a [`Search`] stopped.
enum Outcome {
    /// At this free candidate (the stream is past it).
    Found(Vec3),
    /// After `max_failures` rejections.
    Exhausted,
    /// The cancel flag was set.
    Cancelled,
}

impl Search {
    /// Draws candidates with `free` (a free centre, or `None` for a rejected candidate)
    /// until one is free or `max_failures` have been rejected in all.
    fn run(
        &mut self,
        max_failures: u64,
        cancel: Option<&AtomicBool>,
        mut free: impl FnMut(&mut Xoshiro256PlusPlus) -> Option<Vec3>,
    ) {
        while self.failures < max_failures {
            if crate::cancel::is_set(cancel) {
                self.outcome = Outcome::Cancelled;
                return;
            }
            if let Some(c) = free(&mut self.stream) {
                self.outcome = Outcome::Found(c);
                return;
            }
            self.failures += 1;
        }
        self.outcome = Outcome::Exhausted;
    }
}

/// Whether spheres of radii `r` at `c` and `r_j` at `c_j` are at least `gap` apart (nearest
/// periodic image): the one pair test of the addition, in the grid search and in a batch.
#[inline]
fn keeps_gap<B: Boundary>(boundary: &B, c: &Vec3, r: f64, c_j: &Vec3, r_j: f64, gap: f64) -> bool {
    let mut dr = c - c_j;
    boundary.minimum_image(&mut dr);
    let contact = r + r_j + gap;
    dr.norm_squared() >= contact * contact
}

/// Whether a sphere of radius `r` at `c` keeps at least `gap` from every placed sphere.
/// Spheres registered at a level have `2 r_j + gap` at most its cell width `w`, so a conflict
/// lies within `r + gap/2 + w/2` of `c` along each axis.
#[inline]
fn is_free<B: Boundary>(
    grid: &CellGrid,
    boundary: &B,
    centres: &[Vec3],
    radii: &[f64],
    c: Vec3,
    r: f64,
    gap: f64,
) -> bool {
    let mut free = true;
    for level in 0..grid.levels() {
        let reach = r + 0.5 * gap + 0.5 * grid.level_width(level);
        grid.for_each_within(level, &c, reach, |j| {
            if free {
                free = keeps_gap(boundary, &c, r, &centres[j], radii[j], gap);
            }
        });
        if !free {
            return false;
        }
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::boundary::{CylinderContainer, PeriodicBox, WalledBox};

    /// The placement rule of the module docs, one sphere after the other, with a linear scan
    /// of the placed spheres instead of the grid: what the batched search must reproduce.
    fn serial_reference<B: Boundary>(
        boundary: &B,
        radii: &[f64],
        gap: f64,
        wall_gap: f64,
        max_failures: u64,
        streams: u64,
    ) -> Result<Vec<Vec3>, usize> {
        let mut order: Vec<usize> = (0..radii.len()).collect();
        order.sort_by(|&a, &b| radii[b].total_cmp(&radii[a]).then(a.cmp(&b)));
        let mut centres = vec![Vec3::zeros(); radii.len()];
        let mut done: Vec<usize> = Vec::new();
        for (placed, &i) in order.iter().enumerate() {
            let mut stream = Xoshiro256PlusPlus::seed_from_u64(streams.wrapping_add(i as u64));
            let mut failures = 0;
            loop {
                let free = boundary
                    .sample_center(radii[i] + wall_gap, &mut stream)
                    .filter(|c| {
                        done.iter().all(|&j| {
                            let mut d = c - centres[j];
                            boundary.minimum_image(&mut d);
                            d.norm() >= radii[i] + radii[j] + gap
                        })
                    });
                if let Some(c) = free {
                    centres[i] = c;
                    done.push(i);
                    break;
                }
                failures += 1;
                if failures >= max_failures {
                    return Err(placed);
                }
            }
        }
        Ok(centres)
    }

    /// Runs [`rsa_spheres`] on `threads` threads and the reference with the same streams.
    /// Returns whether the addition failed.
    fn compare<B: Boundary>(
        boundary: &B,
        radii: &[f64],
        gap: f64,
        wall_gap: f64,
        max: u64,
    ) -> bool {
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
                    rsa_spheres(boundary, radii, gap, wall_gap, max, None, &mut rng)
                })
        };
        let streams = Xoshiro256PlusPlus::seed_from_u64(7).gen::<u64>();
        let reference = serial_reference(boundary, radii, gap, wall_gap, max, streams);
        for threads in [1, 2, 3, 8] {
            match (run(threads), &reference) {
                (Ok(got), Ok(want)) => assert!(got == *want, "{threads} threads"),
                (Err(SeedingError::Failed(f)), Err(placed)) => {
                    assert_eq!(f.placed, *placed, "{threads} threads")
                }
                (got, want) => panic!("{threads} threads: {got:?} against {want:?}"),
            }
        }
        reference.is_err()
    }

    /// Radii `r_max·u^{1/3}`-like spread: many small spheres after a few large ones.
    fn radii(n: usize, r_max: f64, seed: u64) -> Vec<f64> {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        (0..n)
            .map(|_| r_max * (0.25 + 0.75 * rng.gen::<f64>().powi(3)))
            .collect()
    }

    #[test]
    fn batches_on_any_thread_count_place_the_serial_spheres() {
        // Dense enough (φ ≈ 0.3–0.35) that candidates are rejected often and batch members
        // meet each other, so that the serial continuation is exercised.
        let periodic = PeriodicBox {
            min: Vec3::zeros(),
            len: Vec3::new(10.0, 12.0, 11.0),
        };
        assert!(!compare(
            &periodic,
            &radii(3000, 0.7, 1),
            0.02,
            0.0,
            100_000
        ));
        let walled = WalledBox {
            min: Vec3::new(-1.0, 0.0, 0.0),
            max: Vec3::new(9.0, 10.0, 10.0),
            periodic: [true, false, false],
        };
        assert!(!compare(
            &walled,
            &radii(1200, 0.7, 2),
            0.05,
            0.025,
            100_000
        ));
        let cylinder = CylinderContainer {
            base_center: Vec3::new(1.0, 2.0, 0.0),
            radius: 5.0,
            height: 12.0,
        };
        assert!(!compare(&cylinder, &radii(1500, 0.7, 3), 0.0, 0.0, 100_000));
    }

    #[test]
    fn a_failing_addition_fails_at_the_serial_sphere() {
        // Equal spheres far beyond the RSA saturation fraction (0.38): some sphere exhausts
        // its 50 candidates; every thread count must stop at the same one.
        let periodic = PeriodicBox {
            min: Vec3::zeros(),
            len: Vec3::new(8.0, 8.0, 8.0),
        };
        let r = (0.5 * 512.0 * 3.0 / (4.0 * std::f64::consts::PI) / 2000.0).cbrt();
        assert!(compare(&periodic, &vec![r; 2000], 0.0, 0.0, 50));
    }
}
