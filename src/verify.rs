//! Independent verification of a packing: overlap, gap and containment.
//!
//! This module shares no code with the kernel's prediction, cell grid or boundaries: it works
//! on the packing as written ([`Packing`]), finds candidate pairs through its own hash grid
//! and measures distances with its own minimum-image rule (`dx − L·round(dx/L)`). A pair is
//! accepted when `|c_i − c_j| ≥ (1 − tol)·(r_i + r_j) + min_gap`, a sphere when its distance
//! to every wall is at least `(1 − tol)·r + min_gap/2`, with `tol` = [`TOLERANCE`].

use crate::io::packing::{ContainerRecord, Packing, ParticleRecord};
use std::collections::HashMap;

/// Relative tolerance of the overlap test (rounding of the written coordinates and of the
/// kernel's time stepping stay far below it).
pub const TOLERANCE: f64 = 1e-9;

/// The outcome of a verification.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Verification {
    /// Number of particles.
    pub particles: usize,
    /// Packing fraction recomputed from the particles and the container.
    pub packing_fraction: f64,
    /// Smallest surface-to-surface distance between two particles relative to the sum of
    /// their radii (`|c_i − c_j| / (r_i + r_j) − 1`); `None` with fewer than two particles
    /// close enough to be candidates.
    pub min_pair_gap_relative: Option<f64>,
    /// Smallest absolute surface-to-surface distance between two particles.
    pub min_pair_gap: Option<f64>,
    /// Smallest distance between a particle surface and a wall (`None` without walls).
    pub min_wall_gap: Option<f64>,
    /// Human-readable violations (at most 20 listed).
    pub violations: Vec<String>,
    /// Total number of violations.
    pub violation_count: usize,
    /// Per particle, the smallest relative gap `|c_i − c_j| / (r_i + r_j) − 1` to any
    /// neighbour found by the candidate search (`+∞` when none is near); for the gap
    /// histogram of [`crate::analysis`].
    #[serde(skip)]
    pub nearest_gap_relative: Vec<f64>,
}

impl Verification {
    /// Whether the packing satisfies all constraints.
    pub fn ok(&self) -> bool {
        self.violation_count == 0
    }
}

struct Ball {
    c: [f64; 3],
    r: f64,
}

/// Checks a packing; never trusts anything the simulation computed.
pub fn verify(packing: &Packing) -> Verification {
    let balls: Vec<Ball> = packing
        .particles
        .iter()
        .map(|p| match p {
            ParticleRecord::Sphere { center, radius } => Ball {
                c: *center,
                r: *radius,
            },
        })
        .collect();
    let gap = packing.min_gap;
    let mut out = Verification {
        particles: balls.len(),
        packing_fraction: 0.0,
        min_pair_gap_relative: None,
        min_pair_gap: None,
        min_wall_gap: None,
        violations: Vec::new(),
        violation_count: 0,
        nearest_gap_relative: vec![f64::INFINITY; balls.len()],
    };
    let violate = |out: &mut Verification, msg: String| {
        out.violation_count += 1;
        if out.violations.len() < 20 {
            out.violations.push(msg);
        }
    };
    for (i, b) in balls.iter().enumerate() {
        if !(b.r.is_finite() && b.r > 0.0 && b.c.iter().all(|x| x.is_finite())) {
            violate(
                &mut out,
                format!("particle {i}: non-finite centre or radius ≤ 0"),
            );
        }
    }
    let (lo, hi, periodic, volume) = match &packing.container {
        ContainerRecord::Box { min, max, periodic } => (
            *min,
            *max,
            *periodic,
            (max[0] - min[0]) * (max[1] - min[1]) * (max[2] - min[2]),
        ),
        ContainerRecord::Cylinder {
            base_center,
            radius,
            height,
        } => (
            [
                base_center[0] - radius,
                base_center[1] - radius,
                base_center[2],
            ],
            [
                base_center[0] + radius,
                base_center[1] + radius,
                base_center[2] + height,
            ],
            [false; 3],
            std::f64::consts::PI * radius * radius * height,
        ),
    };
    let sphere_volume: f64 = balls
        .iter()
        .map(|b| 4.0 / 3.0 * std::f64::consts::PI * b.r.powi(3))
        .sum();
    out.packing_fraction = sphere_volume / volume;

    // Containment.
    for (i, b) in balls.iter().enumerate() {
        let wall_distance = match &packing.container {
            ContainerRecord::Box { .. } => (0..3)
                .filter(|&k| !periodic[k])
                .map(|k| (b.c[k] - lo[k]).min(hi[k] - b.c[k]))
                .fold(f64::INFINITY, f64::min),
            ContainerRecord::Cylinder {
                base_center,
                radius,
                height,
            } => {
                let rho = (b.c[0] - base_center[0]).hypot(b.c[1] - base_center[1]);
                let z = b.c[2] - base_center[2];
                (radius - rho).min(z).min(height - z)
            }
        };
        for k in 0..3 {
            if periodic[k] && !(b.c[k] >= lo[k] && b.c[k] <= hi[k]) {
                violate(
                    &mut out,
                    format!(
                        "particle {i}: centre {:?} is not wrapped into the periodic box",
                        b.c
                    ),
                );
            }
        }
        if wall_distance.is_finite() {
            let g = wall_distance - b.r;
            out.min_wall_gap = Some(out.min_wall_gap.map_or(g, |m: f64| m.min(g)));
            if wall_distance < (1.0 - TOLERANCE) * b.r + 0.5 * gap {
                violate(
                    &mut out,
                    format!(
                        "particle {i} (radius {}) is {wall_distance} from a wall: needs ≥ {}",
                        b.r,
                        b.r + 0.5 * gap
                    ),
                );
            }
        }
    }

    // Pairs through a hash grid of cells at least as wide as the largest contact distance.
    let r_max = balls.iter().map(|b| b.r).fold(0.0, f64::max);
    let h = (2.0 * r_max + gap).max(f64::MIN_POSITIVE);
    let len = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let ncell: [i64; 3] = std::array::from_fn(|k| ((len[k] / h).floor() as i64).max(1));
    let key = |c: &[f64; 3]| -> [i64; 3] {
        std::array::from_fn(|k| {
            let x = ((c[k] - lo[k]) / (len[k] / ncell[k] as f64)).floor() as i64;
            x.clamp(0, ncell[k] - 1)
        })
    };
    let mut cells: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    for (i, b) in balls.iter().enumerate() {
        cells.entry(key(&b.c)).or_default().push(i);
    }
    // Offsets along each axis: all cells if a periodic axis has fewer than 3.
    let offsets: [Vec<i64>; 3] = std::array::from_fn(|k| {
        if periodic[k] && ncell[k] < 3 {
            (0..ncell[k]).collect()
        } else {
            vec![-1, 0, 1]
        }
    });
    for (i, bi) in balls.iter().enumerate() {
        let ki = key(&bi.c);
        let mut seen: Vec<[i64; 3]> = Vec::with_capacity(27);
        for ox in &offsets[0] {
            for oy in &offsets[1] {
                for oz in &offsets[2] {
                    let o = [*ox, *oy, *oz];
                    let mut kj = [0i64; 3];
                    let mut valid = true;
                    for k in 0..3 {
                        let x = if periodic[k] && ncell[k] < 3 {
                            o[k]
                        } else {
                            ki[k] + o[k]
                        };
                        kj[k] = if periodic[k] {
                            x.rem_euclid(ncell[k])
                        } else if (0..ncell[k]).contains(&x) {
                            x
                        } else {
                            valid = false;
                            0
                        };
                    }
                    if !valid || seen.contains(&kj) {
                        continue;
                    }
                    seen.push(kj);
                    let Some(members) = cells.get(&kj) else {
                        continue;
                    };
                    for &j in members {
                        if j <= i {
                            continue;
                        }
                        let bj = &balls[j];
                        let mut d2 = 0.0;
                        for k in 0..3 {
                            let mut d = bi.c[k] - bj.c[k];
                            if periodic[k] {
                                d -= len[k] * (d / len[k]).round();
                            }
                            d2 += d * d;
                        }
                        let dist = d2.sqrt();
                        let sum = bi.r + bj.r;
                        let rel = dist / sum - 1.0;
                        out.nearest_gap_relative[i] = out.nearest_gap_relative[i].min(rel);
                        out.nearest_gap_relative[j] = out.nearest_gap_relative[j].min(rel);
                        if out.min_pair_gap_relative.is_none_or(|m| rel < m) {
                            out.min_pair_gap_relative = Some(rel);
                        }
                        let abs = dist - sum;
                        if out.min_pair_gap.is_none_or(|m| abs < m) {
                            out.min_pair_gap = Some(abs);
                        }
                        if dist < (1.0 - TOLERANCE) * sum + gap {
                            violate(
                                &mut out,
                                format!(
                                    "particles {i} and {j} are {dist} apart: needs ≥ {} \
                                     (radii {} + {}, gap {gap})",
                                    sum + gap,
                                    bi.r,
                                    bj.r
                                ),
                            );
                        }
                    }
                }
            }
        }
    }
    out
}
