//! Descriptions of a packing for `densepack verify`: the gap histogram and the sieve curve
//! against a grading curve. Pure functions of the written packing.

use crate::io::packing::{Packing, ParticleRecord};
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

/// Diameter used for sieving a particle (the smallest square mesh it passes: for a sphere its
/// diameter, for a cylinder its diameter too, passed axis first; for an ellipsoid twice its
/// middle semi-axis).
pub fn sieve_diameter(p: &ParticleRecord) -> f64 {
    match p {
        ParticleRecord::Sphere { radius, .. } | ParticleRecord::Cylinder { radius, .. } => {
            2.0 * radius
        }
        ParticleRecord::Ellipsoid { semi_axes, .. } => {
            let mut a = *semi_axes;
            a.sort_by(f64::total_cmp);
            2.0 * a[1]
        }
    }
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
        .map(|p| (sieve_diameter(p), crate::io::export::particle_volume(p)))
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
