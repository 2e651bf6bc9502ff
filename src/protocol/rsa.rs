//! Random sequential addition (RSA) of spheres (paper 001, §4).
//!
//! Spheres are placed one after the other, largest first, at uniformly random admissible
//! centres (walls respected, periodic axes wrapped); a candidate that overlaps an already
//! placed sphere is rejected and drawn again. After `max_failures` consecutive rejections of
//! one sphere the addition stops and reports how far it got. A minimum gap `Δd` is honoured
//! by testing against diameters `d + Δd` (walls keep a clearance of `Δd/2`).
//!
//! Overlap candidates come from a [`CellGrid`] with cells as wide as the largest diameter
//! plus the gap.

use crate::boundary::Boundary;
use crate::shape::Vec3;
use crate::spatial::CellGrid;
use rand::Rng;

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

/// Places spheres of the given radii (any order; placed largest first) in `boundary`.
/// Returns the centres in the order of `radii`.
pub fn rsa_spheres<B: Boundary, R: Rng>(
    boundary: &B,
    radii: &[f64],
    gap: f64,
    max_failures: u64,
    rng: &mut R,
) -> Result<Vec<Vec3>, RsaFailure> {
    let n = radii.len();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| radii[b].total_cmp(&radii[a]).then(a.cmp(&b)));
    let d_max = radii.iter().fold(0.0_f64, |m, &r| m.max(2.0 * r));
    let mut grid = CellGrid::new(
        boundary.min(),
        boundary.max(),
        boundary.periodic(),
        d_max + gap,
        n,
    );
    let mut centres = vec![Vec3::zeros(); n];
    let mut volume = 0.0;
    for (placed, &i) in order.iter().enumerate() {
        let r = radii[i];
        let mut failures = 0u64;
        loop {
            let candidate = boundary.sample_center(r + 0.5 * gap, rng);
            let ok = candidate.is_some_and(|c| {
                let cells = grid.neighbourhood(grid.cell_at(0, &c));
                !cells.as_slice().iter().any(|&cell| {
                    grid.members(cell).any(|j| {
                        let mut dr = c - centres[j];
                        boundary.minimum_image(&mut dr);
                        let reach = r + radii[j] + gap;
                        dr.norm_squared() < reach * reach
                    })
                })
            });
            if ok {
                let c = candidate.expect("checked");
                centres[i] = c;
                grid.insert(i, grid.cell_at(0, &c));
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
                });
            }
        }
    }
    Ok(centres)
}
