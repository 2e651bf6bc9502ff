//! Descriptions of a packing for `densepack verify` and `densepack plot`: the gap histogram,
//! the sieve curve against a grading curve, the size histogram and plane sections. Pure
//! functions of the written packing. [`jamming`] says whether a sphere packing is jammed;
//! [`structure`] describes its structure (g(r), size classes, wall profiles).

pub mod jamming;
pub mod structure;

use crate::io::export::{container_bounds, periodic_axes};
use crate::io::packing::{ContainerRecord, Packing, ParticleRecord};
pub use crate::io::record::SectionCut;
use crate::protocol::take_phase::GradingCurve;

/// One bin of the gap histogram: particles whose nearest relative gap lies in `[lo, hi)`.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct GapBin {
    /// Lower edge (relative gap `|c_i − c_j| / (r_i + r_j) − 1`).
    pub lo: f64,
    /// Upper edge.
    pub hi: f64,
    /// Number of particles.
    pub count: usize,
}

/// Histogram of each particle's nearest relative gap in decades `[10^(k−1), 10^k)` from
/// `10⁻¹⁶` to `10⁰`, with a first bin `(−∞, 10⁻¹⁶)` (touching within rounding, or overlapping)
/// and a last bin `[1, ∞)` (no neighbour within a diameter, or none found).
pub fn gap_histogram(nearest_gap_relative: &[f64]) -> Vec<GapBin> {
    let mut edges = vec![f64::NEG_INFINITY];
    edges.extend((-16..=0).map(|k| 10f64.powi(k)));
    edges.push(f64::INFINITY);
    let mut bins: Vec<GapBin> = edges
        .windows(2)
        .map(|w| GapBin {
            lo: w[0],
            hi: w[1],
            count: 0,
        })
        .collect();
    for &g in nearest_gap_relative {
        let k = edges.partition_point(|&e| e <= g).clamp(1, bins.len()) - 1;
        bins[k].count += 1;
    }
    bins
}

/// One sieve of the sieve curve.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SievePoint {
    /// Sieve size (diameter, in the packing's unit).
    pub size: f64,
    /// Volume fraction of the particles with diameter ≤ `size`.
    pub passing: f64,
    /// The grading curve renormalised to the generated range:
    /// `(F(size) − F(d_min)) / (1 − F(d_min))`.
    pub target: f64,
}

/// The sieve curve of the packing against `curve` cut off at `d_min`, at half-octave sieves
/// `d_min · 2^(k/2)` up to the curve's `d_max`, plus the curve's own sieves in that range.
/// Returns the points and the largest `|passing − target|`.
pub fn sieve_curve(packing: &Packing, curve: &GradingCurve, d_min: f64) -> (Vec<SievePoint>, f64) {
    let d_max = curve.d_max();
    let mut sizes: Vec<f64> = (0..)
        .map(|k| d_min * 2f64.powf(0.5 * f64::from(k)))
        .take_while(|&d| d < d_max)
        .collect();
    sizes.extend(
        curve
            .sieve_sizes()
            .iter()
            .filter(|&&d| d > d_min && d < d_max),
    );
    sizes.push(d_max);
    sizes.sort_unstable_by(f64::total_cmp);
    sizes.dedup();
    let mut grains: Vec<(f64, f64)> = packing
        .particles
        .iter()
        .map(|p| (p.sieve_diameter(), p.volume()))
        .collect();
    grains.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let total: f64 = grains.iter().map(|g| g.1).sum();
    let f_min = curve.passing(d_min);
    let mut worst: f64 = 0.0;
    let points = sizes
        .into_iter()
        .map(|size| {
            let n = grains.partition_point(|g| g.0 <= size);
            // `0.0 +` turns the empty sum's −0 into +0.
            let passing = (0.0 + grains[..n].iter().map(|g| g.1).sum::<f64>()) / total;
            let target = (curve.passing(size) - f_min) / (1.0 - f_min);
            worst = worst.max((passing - target).abs());
            SievePoint {
                size,
                passing,
                target,
            }
        })
        .collect();
    (points, worst)
}

/// One bin of the size histogram: particles whose sieve diameter ([`ParticleRecord::sieve_diameter`]) lies
/// in `[lo, hi)` (the last bin includes `hi`).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SizeBin {
    /// Lower edge (diameter, in the packing's unit).
    pub lo: f64,
    /// Upper edge.
    pub hi: f64,
    /// Number of particles.
    pub count: usize,
}

/// Histogram of the particles' sieve diameters in `bins ≥ 1` bins of equal width in `ln d`
/// from the smallest to the largest diameter (grading curves are logarithmic in `d`). Equal
/// diameters give one bin from 0.95 d to 1.05 d; an empty packing, no bins.
pub fn size_histogram(packing: &Packing, bins: usize) -> Vec<SizeBin> {
    size_classes(packing, bins).0
}

/// [`size_histogram`] and the bin of each particle (index into the bins, in the packing's
/// order).
pub fn size_classes(packing: &Packing, bins: usize) -> (Vec<SizeBin>, Vec<usize>) {
    let sizes: Vec<f64> = packing
        .particles
        .iter()
        .map(ParticleRecord::sieve_diameter)
        .collect();
    let (lo, hi) = sizes
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &d| {
            (lo.min(d), hi.max(d))
        });
    if sizes.is_empty() {
        return (Vec::new(), Vec::new());
    }
    if hi <= lo * (1.0 + 1e-9) {
        let one = SizeBin {
            lo: 0.95 * lo,
            hi: 1.05 * hi,
            count: sizes.len(),
        };
        return (vec![one], vec![0; sizes.len()]);
    }
    let bins = bins.max(1);
    let step = (hi / lo).ln() / bins as f64;
    let edge = |k: usize| {
        if k == bins {
            hi
        } else {
            lo * (step * k as f64).exp()
        }
    };
    let mut out: Vec<SizeBin> = (0..bins)
        .map(|k| SizeBin {
            lo: edge(k),
            hi: edge(k + 1),
            count: 0,
        })
        .collect();
    let mut class = Vec::with_capacity(sizes.len());
    for d in sizes {
        let k = (((d / lo).ln() / step) as usize).min(bins - 1);
        out[k].count += 1;
        class.push(k);
    }
    (out, class)
}

/// `cj − ci` in a box of edges `len`, wrapped to the nearest image along `periodic` axes.
pub(crate) fn separation(
    len: &[f64; 3],
    periodic: &[bool; 3],
    ci: &[f64; 3],
    cj: &[f64; 3],
) -> [f64; 3] {
    std::array::from_fn(|a| {
        let d = cj[a] - ci[a];
        // Near pairs rarely straddle a face: the rounding (a libm call) only then.
        if periodic[a] && d.abs() > 0.5 * len[a] {
            d - len[a] * (d / len[a]).round()
        } else {
            d
        }
    })
}

/// The in-plane axes `(horizontal, vertical)` of a section normal to axis `axis` (0 = x,
/// 1 = y, 2 = z): x → (y, z), y → (x, z), z → (x, y).
pub fn section_axes(axis: usize) -> [usize; 2] {
    match axis {
        0 => [1, 2],
        1 => [0, 2],
        _ => [0, 1],
    }
}

/// The outline of the container in a section plane.
#[derive(Clone, Debug, PartialEq)]
pub enum SectionOutline {
    /// A rectangle (a box, or a cylinder cut along its axis).
    Rectangle {
        /// Lower corner.
        min: [f64; 2],
        /// Upper corner.
        max: [f64; 2],
    },
    /// A circle (a cylinder cut across its axis).
    Circle {
        /// Centre.
        center: [f64; 2],
        /// Radius.
        radius: f64,
    },
}

/// A plane section of a packing.
#[derive(Clone, Debug, PartialEq)]
pub struct Section {
    /// The container's outline.
    pub outline: SectionOutline,
    /// Every cut particle, with the periodic images that reach into the container: along the
    /// plane normal an image of a particle across a periodic face may be what the plane cuts,
    /// and in the plane a cut that crosses a periodic face also appears at the opposite face.
    pub cuts: Vec<SectionCut>,
}

/// Why a section cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum SectionError {
    /// The plane misses the container.
    #[error("--at = {at}: the plane {axis} = {at} lies outside the container, whose {axis} range is [{lo}, {hi}]")]
    Outside {
        /// Axis name.
        axis: char,
        /// Plane position.
        at: f64,
        /// Container's lower bound on the axis.
        lo: f64,
        /// Upper bound.
        hi: f64,
    },
}

/// The section of `packing` by the plane `x[axis] = at` (`axis`: 0 = x, 1 = y, 2 = z).
/// Each particle (and each periodic image the plane may cut) is cut by
/// [`ParticleRecord::plane_cut`]: a sphere as a disc, an ellipsoid as an ellipse, a cylinder
/// as a polygon.
pub fn section(packing: &Packing, axis: usize, at: f64) -> Result<Section, SectionError> {
    let [h, v] = section_axes(axis);
    let (lo, hi) = container_bounds(&packing.container);
    if !(at >= lo[axis] && at <= hi[axis]) {
        return Err(SectionError::Outside {
            axis: ['x', 'y', 'z'][axis.min(2)],
            at,
            lo: lo[axis],
            hi: hi[axis],
        });
    }
    let outline = match &packing.container {
        ContainerRecord::Cylinder {
            base_center,
            radius,
            ..
        } if axis == 2 => SectionOutline::Circle {
            center: [base_center[0], base_center[1]],
            radius: *radius,
        },
        ContainerRecord::Cylinder {
            base_center,
            radius,
            ..
        } => {
            // Cut along the axis: a rectangle as wide as the chord at this plane.
            let half = (radius * radius - (at - base_center[axis]).powi(2))
                .max(0.0)
                .sqrt();
            SectionOutline::Rectangle {
                min: [base_center[h] - half, lo[2]],
                max: [base_center[h] + half, hi[2]],
            }
        }
        ContainerRecord::Box { min, max, .. } => SectionOutline::Rectangle {
            min: [min[h], min[v]],
            max: [max[h], max[v]],
        },
    };
    let periodic = periodic_axes(&packing.container);
    let length: Vec<f64> = (0..3).map(|k| hi[k] - lo[k]).collect();
    let images = |k: usize| -> &'static [f64] {
        if periodic[k] {
            &[-1.0, 0.0, 1.0]
        } else {
            &[0.0]
        }
    };
    let mut cuts = Vec::new();
    for (index, p) in packing.particles.iter().enumerate() {
        for &m in images(axis) {
            let center = p.center();
            // Distance of the plane from the (image's) centre along the normal.
            let t = at - (center[axis] + m * length[axis]);
            if let Some(cut) = p.plane_cut(index, [center[h], center[v]], [h, v, axis], t) {
                // In-plane images of a cut that crosses a periodic face.
                let extent = cut.half_extent();
                let c = cut.center();
                let shifts = |k: usize, n: usize| -> Vec<f64> {
                    let mut s = vec![0.0];
                    if periodic[n] && c[k] - extent[k] < lo[n] {
                        s.push(length[n]);
                    }
                    if periodic[n] && c[k] + extent[k] > hi[n] {
                        s.push(-length[n]);
                    }
                    s
                };
                for dx in shifts(0, h) {
                    for dy in shifts(1, v) {
                        cuts.push(cut.shifted([dx, dy]));
                    }
                }
            }
        }
    }
    Ok(Section { outline, cuts })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gap_histogram_puts_each_gap_in_its_decade() {
        let bins = gap_histogram(&[-1e-12, 0.0, 3e-13, 0.05, 0.5, 2.0, f64::INFINITY]);
        let count = |lo: f64| bins.iter().find(|b| b.lo == lo).unwrap().count;
        assert_eq!(count(f64::NEG_INFINITY), 2); // −1e-12 and 0
        assert_eq!(count(1e-13), 1);
        assert_eq!(count(1e-2), 1);
        assert_eq!(count(1e-1), 1);
        assert_eq!(count(1.0), 2);
        assert_eq!(bins.iter().map(|b| b.count).sum::<usize>(), 7);
    }
}
