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

use crate::boundary::Boundary;
use crate::shape::Vec3;
use crate::spatial::{CellGrid, MAX_LEVELS};
use rand::Rng;
use std::sync::atomic::AtomicBool;

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
    let mut centres = vec![Vec3::zeros(); n];
    let mut volume = 0.0;
    for (placed, &i) in order.iter().enumerate() {
        let r = radii[i];
        let mut failures = 0u64;
        loop {
            if crate::cancel::is_set(cancel) {
                return Err(SeedingError::Cancelled);
            }
            let candidate = boundary.sample_center(r + wall_gap, rng);
            let free =
                candidate.is_some_and(|c| is_free(&grid, boundary, &centres, radii, c, r, gap));
            if free {
                let c = candidate.expect("checked");
                centres[i] = c;
                let level = grid.level_for(2.0 * r + gap);
                grid.insert(i, grid.cell_at(level, &c));
                volume += 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
                break;
            }
            failures += 1;
            if failures >= max_failures {
                return Err(RsaFailure {
                    placed,
                    total: n,
                    fraction: volume / boundary.volume(),
                    failures: max_failures,
                }
                .into());
            }
        }
    }
    Ok(centres)
}

/// Whether a sphere of radius `r` at `c` keeps at least `gap` from every placed sphere.
/// Spheres registered at a level have `2 r_j + gap` at most its cell width `w`, so a conflict
/// lies within `r + gap/2 + w/2` of `c` along each axis.
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
                let mut dr = c - centres[j];
                boundary.minimum_image(&mut dr);
                let contact = r + radii[j] + gap;
                free = dr.norm_squared() >= contact * contact;
            }
        });
        if !free {
            return false;
        }
    }
    true
}
