//! The structure of a packing for `densepack analyse`, computed from the written file alone:
//!
//! - **Radial distribution function** `g(s)` of a sphere packing over the scaled distance
//!   `s = |c_i − c_j| / (r_i + r_j)` (dimensionless: 1 is contact whatever the sizes; radii as
//!   written, so a packing with a claimed `min_gap` has its first peak just above 1), periodic
//!   axes by the minimum image. The count of pairs in a bin `[s_lo, s_hi)` around the
//!   reference particles is divided by its ideal-gas expectation
//!   `Σ_i ρ · (4π/3)(s_hi³ − s_lo³) · ⟨(r_i + r_j)³⟩_{j≠i}`, with `ρ = (N_ref − 1)/V_ref` the
//!   number density of the reference region and the mean over every other particle `j`
//!   (from the moments `Σ r_j^k`, exact for any size distribution). In a periodic box every
//!   particle is a reference and `V_ref` is the box, so an ideal gas has `g = 1` in
//!   expectation. With walls the references are the particles whose centres lie at least
//!   `s_max · 2 r_max` from every wall (the standard restriction: every shell around them lies
//!   inside the container), `V_ref` the volume of that inner region. Along a periodic axis the
//!   range is cut to half the box (`s_max · 2 r_max ≤ L/2`) so that the minimum image is the
//!   only image in reach. A jammed monodisperse packing has a delta peak at contact (`s = 1`)
//!   and a split second peak with sub-peaks at `√3` and `2` (Donev, Torquato & Stillinger,
//!   PRE 71, 011105, 2005). Above [`MAX_GR_REFERENCES`] candidates every k-th is a reference
//!   (a deterministic stride, `k = ⌈N_ref / MAX_GR_REFERENCES⌉`): the pairs around 10⁵
//!   references fill each bin of a dense packing with millions of counts, and the sum costs
//!   a tenth at 10⁶ particles; `ρ` stays the density of all the candidates.
//! - **Size classes**: the particles binned by diameter as in [`super::size_histogram`], with
//!   each class's count, share of the particle volume, and mean contact number and rattler
//!   fraction at the jamming report's cut-off (from its contact list).
//! - **Wall profiles**: the local packing fraction in slabs of width `d_mean/10` parallel to
//!   each wall (box faces on non-periodic axes; a cylinder's base, top and side), from the
//!   wall inwards to `5 d_mean` or half the container. A slab's fraction is the exact
//!   volume of the spheres inside it over the slab's volume: a plane slab cuts a sphere of
//!   radius `r` between signed heights `a < b` from its centre in
//!   `π [r² t − t³/3]_{t=a'}^{b'}` (`a', b'` clamped to `[−r, r]`, the spherical-cap
//!   formula); an annulus of the cylinder's side is the difference of two sphere–cylinder
//!   intersections ([`sphere_cylinder_volume`]).

use super::jamming::JammingReport;
use super::{separation, size_classes};
use crate::io::export::{container_bounds, packing_fraction, periodic_axes};
use crate::io::packing::{ContainerRecord, Packing, ParticleRecord};
use crate::io::record::SphereRecord;
use crate::verify::PairLevels;
use rayon::prelude::*;
use std::f64::consts::PI;

/// Most reference particles of g(r) (see the module docs).
pub const MAX_GR_REFERENCES: usize = 100_000;

/// References per task of the g(r) pair count on the thread pool.
const REFERENCES_PER_TASK: usize = 4096;

/// Default number of g(r) bins: width 0.02 over `s ∈ [0, 3)`.
pub const DEFAULT_GR_BINS: usize = 150;

/// Default upper end of the g(r) range, in `s = r/(r_i + r_j)`.
pub const DEFAULT_GR_RANGE: f64 = 3.0;

/// Most g(r) bins accepted.
pub const MAX_GR_BINS: usize = 1_000_000;

/// Number of diameter classes of [`SizeClass`] (equal width in `ln d`).
pub const SIZE_CLASSES: usize = 10;

/// Slabs of the wall profiles per mean diameter (slab width `d_mean/10`).
pub const SLABS_PER_DIAMETER: f64 = 10.0;

/// Depth of the wall profiles, in mean diameters.
pub const PROFILE_DEPTH: f64 = 5.0;

/// A distance this many bin widths below a bin edge counts in the bin above: a touching pair
/// at `s = 1 − 10⁻¹⁶` (rounding) belongs to the contact bin `[1, 1 + w)`.
const EDGE_SLACK: f64 = 1e-9;

/// End of the window of the second peak's sub-peak near 2 (see [`SecondPeak`]).
const SECOND_PEAK_END: f64 = 2.15;

/// One peak of g: the centre of its bin and the value there.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Peak {
    /// Bin centre, in `s = r/(r_i + r_j)`.
    pub position: f64,
    /// `g` in that bin.
    pub height: f64,
}

/// The second peak of g, looked for as two sub-peaks: the highest bin with centre in
/// `[1.5, (√3 + 2)/2)` and the highest in `[(√3 + 2)/2, 2.15)` (below the FCC shell at √5).
/// In a jammed packing g has a cusp at each of √3 and 2 and falls sharply beyond 2.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SecondPeak {
    /// The sub-peak near `√3` (edge-sharing tetrahedra, coplanar triangles).
    pub near_sqrt3: Peak,
    /// The sub-peak near `2` (three spheres in a line).
    pub near_2: Peak,
    /// Some bin between the two is lower than both: the peak is split.
    pub split: bool,
}

/// The radial distribution function of a sphere packing (see the module docs).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RadialDistribution {
    /// Bin width in `s` (the requested range over the requested bins).
    pub bin_width: f64,
    /// Upper end of the bins, `bins · bin_width`: the requested range, or less when half a
    /// periodic box cuts it (see [`RadialDistribution::range_cut`]).
    pub range: f64,
    /// The requested range was cut to half the smallest periodic box length.
    pub range_cut: bool,
    /// Bin centres, in `s`.
    pub centres: Vec<f64>,
    /// `g` per bin (dimensionless).
    pub g: Vec<f64>,
    /// Number of reference particles (at most [`MAX_GR_REFERENCES`]).
    pub references: usize,
    /// Smallest distance of a reference centre from every wall, in the packing's unit (0 in
    /// a periodic box: every particle is a reference).
    pub wall_margin: f64,
    /// The highest bin with centre below `s = 1.5` (contact, for a jammed packing).
    pub first_peak: Option<Peak>,
    /// The second peak, when the range reaches `s = 2.15`.
    pub second_peak: Option<SecondPeak>,
}

/// The particles of one diameter class.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SizeClass {
    /// Lower edge of the diameter class (sieve diameter, in the packing's unit).
    pub lo: f64,
    /// Upper edge.
    pub hi: f64,
    /// Number of particles.
    pub count: usize,
    /// Their share of the total particle volume (0 to 1).
    pub volume_share: f64,
    /// Mean contacts per particle at the report's cut-off (partners and walls, before
    /// rattlers are removed); `None` for an empty class.
    pub mean_contacts: Option<f64>,
    /// Fraction of the class that are rattlers at the report's cut-off; `None` if empty.
    pub rattler_fraction: Option<f64>,
}

/// The packing fraction in slabs parallel to one wall.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct WallProfile {
    /// The wall: `x-`, `x+`, `y-`, `y+`, `z-`, `z+` (box faces; a cylinder's base `z-` and
    /// top `z+`) or `side` (a cylinder's mantle: annuli).
    pub wall: String,
    /// Slab width, in the packing's unit (`d_mean/10`).
    pub slab_width: f64,
    /// Distance of each slab's middle from the wall, in mean diameters.
    pub distance: Vec<f64>,
    /// Packing fraction of each slab: sphere volume inside it over its volume.
    pub fraction: Vec<f64>,
}

/// Everything the structure part of the report says.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct StructureReport {
    /// Packing fraction of the whole packing (particle volume over container volume).
    pub packing_fraction: f64,
    /// Number-mean diameter (sieve diameter), in the packing's unit.
    pub mean_diameter: f64,
    /// g(s), for sphere packings with references (see [`StructureReport::notes`]).
    pub radial_distribution: Option<RadialDistribution>,
    /// The diameter classes ([`SIZE_CLASSES`] classes, one for equal sizes).
    pub size_classes: Vec<SizeClass>,
    /// One profile per wall (none in a periodic box); sphere packings only.
    pub wall_profiles: Vec<WallProfile>,
    /// What was left out and why.
    pub notes: Vec<String>,
}

/// Why the structure report cannot be made.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum StructureError {
    /// Number of g(r) bins out of range.
    #[error("--gr-bins = {0}: must be at least 1 and at most {MAX_GR_BINS}")]
    Bins(usize),
    /// Range of g(r) not a positive number.
    #[error("--gr-range = {0}: must be a finite number > 0 (the largest r/(r_i + r_j))")]
    Range(f64),
    /// g(r) is for spheres.
    #[error("g(r) is computed for sphere packings (particle {0} is not a sphere)")]
    NotSpheres(usize),
    /// Too few particles, or none far enough from the walls.
    #[error("g(r): {0}")]
    NoReferences(String),
}

/// Checks the g(r) arguments: `1 ≤ bins ≤` [`MAX_GR_BINS`], `range` finite and > 0.
pub fn check_gr(bins: usize, range: f64) -> Result<(), StructureError> {
    if bins == 0 || bins > MAX_GR_BINS {
        return Err(StructureError::Bins(bins));
    }
    if !(range.is_finite() && range > 0.0) {
        return Err(StructureError::Range(range));
    }
    Ok(())
}

/// The structure report of `packing`, whose jamming report (for the contacts at its
/// cut-off) is `jamming`, with g(s) in `bins` bins over `s ∈ [0, range)`.
pub fn structure_report(
    packing: &Packing,
    jamming: &JammingReport,
    bins: usize,
    range: f64,
) -> Result<StructureReport, StructureError> {
    check_gr(bins, range)?;
    let mut notes = Vec::new();
    let radial_distribution = match radial_distribution(packing, bins, range) {
        Ok(g) => Some(g),
        Err(e @ (StructureError::NotSpheres(_) | StructureError::NoReferences(_))) => {
            notes.push(e.to_string());
            None
        }
        Err(e) => return Err(e),
    };
    let n = packing.particles.len();
    let mean_diameter = packing
        .particles
        .iter()
        .map(ParticleRecord::sieve_diameter)
        .sum::<f64>()
        / n.max(1) as f64;
    let wall_profiles = match wall_profiles(packing) {
        Ok(p) => p,
        Err(e) => {
            notes.push(e);
            Vec::new()
        }
    };
    Ok(StructureReport {
        packing_fraction: packing_fraction(packing),
        mean_diameter,
        radial_distribution,
        size_classes: size_class_table(packing, jamming),
        wall_profiles,
        notes,
    })
}

/// The radial distribution function of the module docs: `bins` bins of width `range/bins`
/// over `s = r/(r_i + r_j) ∈ [0, range)` (fewer when half a periodic box cuts the range).
pub fn radial_distribution(
    packing: &Packing,
    bins: usize,
    range: f64,
) -> Result<RadialDistribution, StructureError> {
    check_gr(bins, range)?;
    let mut centers = Vec::with_capacity(packing.particles.len());
    let mut radii = Vec::with_capacity(packing.particles.len());
    for (i, p) in packing.particles.iter().enumerate() {
        match p {
            ParticleRecord::Sphere(SphereRecord { center, radius }) => {
                centers.push(*center);
                radii.push(*radius);
            }
            _ => return Err(StructureError::NotSpheres(i)),
        }
    }
    let n = centers.len();
    if n < 2 {
        return Err(StructureError::NoReferences(format!(
            "{n} particle(s): no pairs"
        )));
    }
    let width = range / bins as f64;
    let r_max = radii.iter().copied().fold(0.0, f64::max);
    let (lo, hi) = container_bounds(&packing.container);
    let periodic = periodic_axes(&packing.container);
    // Half the smallest periodic length bounds the reach: the minimum image only.
    let half = (0..3)
        .filter(|&k| periodic[k])
        .map(|k| 0.5 * (hi[k] - lo[k]))
        .fold(f64::INFINITY, f64::min);
    let mut bins_used = bins;
    if range * 2.0 * r_max > half {
        bins_used = ((half / (2.0 * r_max) / width).floor() as usize).min(bins);
    }
    let range_used = bins_used as f64 * width;
    let reach = range_used * 2.0 * r_max;
    // References: at least `reach` from every wall; the region they fill and its volume.
    let margin = if periodic.iter().all(|&p| p) {
        0.0
    } else {
        reach
    };
    type Inside = Box<dyn Fn(&[f64; 3]) -> bool>;
    let (inside, volume): (Inside, f64) = match &packing.container {
        ContainerRecord::Box { min, max, periodic } => {
            let (min, max, periodic) = (*min, *max, *periodic);
            let volume = (0..3)
                .map(|k| {
                    let l = max[k] - min[k];
                    if periodic[k] {
                        l
                    } else {
                        (l - 2.0 * margin).max(0.0)
                    }
                })
                .product();
            (
                Box::new(move |c: &[f64; 3]| {
                    (0..3).all(|k| {
                        periodic[k] || (c[k] >= min[k] + margin && c[k] <= max[k] - margin)
                    })
                }),
                volume,
            )
        }
        ContainerRecord::Cylinder {
            base_center: b,
            radius,
            height,
        } => {
            let (b, radius, height) = (*b, *radius, *height);
            let inner = (radius - margin).max(0.0);
            let volume = PI * inner * inner * (height - 2.0 * margin).max(0.0);
            (
                Box::new(move |c: &[f64; 3]| {
                    (c[0] - b[0]).hypot(c[1] - b[1]) <= inner
                        && c[2] >= b[2] + margin
                        && c[2] <= b[2] + height - margin
                }),
                volume,
            )
        }
    };
    let candidates: Vec<usize> = (0..n).filter(|&i| inside(&centers[i])).collect();
    let n_ref = candidates.len();
    if n_ref < 2 || volume <= 0.0 || bins_used == 0 {
        return Err(StructureError::NoReferences(format!(
            "{n_ref} particle(s) have their centres at least {margin:.4} (range × the largest \
             diameter) from every wall, of {n}: too few for g(r) (a smaller --gr-range \
             needs a smaller margin)"
        )));
    }
    let density = (n_ref - 1) as f64 / volume;
    let stride = n_ref.div_ceil(MAX_GR_REFERENCES);
    let references: Vec<usize> = candidates.into_iter().step_by(stride).collect();
    // Σ_j r_j^k, k = 1, 2, 3, for the mean of (r_i + r_j)³ over j ≠ i.
    let moment = |k: i32| radii.iter().map(|r| r.powi(k)).sum::<f64>();
    let (s1, s2, s3) = (moment(1), moment(2), moment(3));
    let others = (n - 1) as f64;
    // Σ_i ρ ⟨(r_i + r_j)³⟩_{j≠i}
    let weight: f64 = references
        .iter()
        .map(|&i| {
            let ri = radii[i];
            let cubes = others * ri.powi(3)
                + 3.0 * ri * ri * (s1 - ri)
                + 3.0 * ri * (s2 - ri * ri)
                + (s3 - ri.powi(3));
            density * cubes / others
        })
        .sum();
    // Pairs within the range of `σ = r_i + r_j`, through levels of cells by size (a pair
    // search at the largest diameter would be quadratic at concrete size ratios).
    let len: [f64; 3] = std::array::from_fn(|k| hi[k] - lo[k]);
    let stretch = 2.0 * range_used * (1.0 + 1e-6);
    let grid = PairLevels::new(lo, len, periodic, n, |i| centers[i], |i| stretch * radii[i]);
    let mut is_reference = vec![false; n];
    for &i in &references {
        is_reference[i] = true;
    }
    let reach2 = (range_used * (1.0 + 1e-6)).powi(2);
    // The references in chunks on all threads; the counts are integers, so their sum is
    // the same in any order and on any number of threads.
    let counts = references
        .par_chunks(REFERENCES_PER_TASK)
        .map(|chunk| {
            let mut counts = vec![0u64; bins_used];
            let mut seen = Vec::with_capacity(27);
            for &i in chunk {
                let (ci, ri) = (centers[i], radii[i]);
                grid.for_each_near(&ci, stretch * ri, &mut seen, |j| {
                    // A pair of references is counted once for both (at the smaller index).
                    let times = match is_reference[j] {
                        true if j <= i => return,
                        true => 2,
                        false => 1,
                    };
                    let d = separation(&len, &periodic, &ci, &centers[j]);
                    let sigma = ri + radii[j];
                    let d2 = d[0] * d[0] + d[1] * d[1] + d[2] * d[2];
                    // Beyond the range with room for the edge slack: no bin, no square root.
                    if d2 > reach2 * sigma * sigma {
                        return;
                    }
                    let k = (d2.sqrt() / sigma / width + EDGE_SLACK).floor();
                    if k < bins_used as f64 {
                        counts[k as usize] += times;
                    }
                });
            }
            counts
        })
        .reduce(
            || vec![0u64; bins_used],
            |mut a, b| {
                a.iter_mut().zip(&b).for_each(|(x, y)| *x += y);
                a
            },
        );
    let centres: Vec<f64> = (0..bins_used).map(|k| (k as f64 + 0.5) * width).collect();
    let g: Vec<f64> = (0..bins_used)
        .map(|k| {
            let (a, b) = (k as f64 * width, (k + 1) as f64 * width);
            let ideal = weight * 4.0 / 3.0 * PI * (b.powi(3) - a.powi(3));
            counts[k] as f64 / ideal
        })
        .collect();
    let (first_peak, second_peak) = peaks(&centres, &g);
    Ok(RadialDistribution {
        bin_width: width,
        range: range_used,
        range_cut: bins_used < bins,
        centres,
        g,
        references: references.len(),
        wall_margin: margin,
        first_peak,
        second_peak,
    })
}

/// The first peak (highest bin with centre below 1.5) and the two sub-peaks of the second
/// (see [`SecondPeak`]), when the bins reach [`SECOND_PEAK_END`].
fn peaks(centres: &[f64], g: &[f64]) -> (Option<Peak>, Option<SecondPeak>) {
    let highest = |lo: f64, hi: f64| -> Option<usize> {
        (0..g.len())
            .filter(|&k| centres[k] >= lo && centres[k] < hi)
            .fold(None, |best: Option<usize>, k| match best {
                Some(b) if g[b] >= g[k] => Some(b),
                _ => Some(k),
            })
    };
    let peak = |k: usize| Peak {
        position: centres[k],
        height: g[k],
    };
    let first = highest(0.0, 1.5).map(peak);
    let middle = 0.5 * (3f64.sqrt() + 2.0);
    // The last bin's upper edge (centre plus half a width) reaches the window's end.
    let reaches = centres
        .last()
        .is_some_and(|&c| c + centres[0] >= SECOND_PEAK_END - 1e-9);
    let second = match (highest(1.5, middle), highest(middle, SECOND_PEAK_END)) {
        (Some(a), Some(b)) if reaches => {
            let dip = g[a + 1..b].iter().copied().fold(f64::INFINITY, f64::min);
            Some(SecondPeak {
                near_sqrt3: peak(a),
                near_2: peak(b),
                split: dip < g[a].min(g[b]),
            })
        }
        _ => None,
    };
    (first, second)
}

/// The diameter classes of the module docs.
fn size_class_table(packing: &Packing, jamming: &JammingReport) -> Vec<SizeClass> {
    let (bins, class) = size_classes(packing, SIZE_CLASSES);
    let total: f64 = packing.particles.iter().map(ParticleRecord::volume).sum();
    let mut volume = vec![0.0; bins.len()];
    let mut contacts = vec![0u64; bins.len()];
    let mut rattlers = vec![0usize; bins.len()];
    for (i, p) in packing.particles.iter().enumerate() {
        let k = class[i];
        volume[k] += p.volume();
        contacts[k] += u64::from(jamming.contact_numbers.get(i).copied().unwrap_or(0));
        rattlers[k] += usize::from(jamming.rattlers.get(i).copied().unwrap_or(false));
    }
    bins.iter()
        .enumerate()
        .map(|(k, b)| {
            let per = |x: f64| (b.count > 0).then(|| x / b.count as f64);
            SizeClass {
                lo: b.lo,
                hi: b.hi,
                count: b.count,
                volume_share: volume[k] / total,
                mean_contacts: per(contacts[k] as f64),
                rattler_fraction: per(rattlers[k] as f64),
            }
        })
        .collect()
}

/// Volume of a sphere of radius `r` between the planes at signed heights `a ≤ b` from its
/// centre: `π [r² t − t³/3]` from `t = a` to `t = b`, both clamped to `[−r, r]` (the
/// spherical-cap formula). Units: the cube of the unit of `r`.
pub fn sphere_slab_volume(r: f64, a: f64, b: f64) -> f64 {
    let (a, b) = (a.clamp(-r, r), b.clamp(-r, r));
    if b <= a {
        return 0.0;
    }
    let f = |t: f64| r * r * t - t * t * t / 3.0;
    PI * (f(b) - f(a))
}

/// Volume of a sphere of radius `r` whose centre lies at distance `e` from the axis of an
/// infinite cylinder of radius `a`, inside the cylinder. On the axis (`e = 0`) it is
/// `(4π/3)(r³ − (r² − a²)^{3/2})` for `a < r`; otherwise
/// `2 ∫_0^r L(√(r² − z²), e, a) dz` with `L(ρ, e, a)` the area of the intersection of two
/// discs of radii `ρ` and `a` at distance `e` (the lens formula), integrated by 24-point
/// Gauss–Legendre on each piece between the heights where the disc of the sphere's slice
/// touches the cylinder (`ρ = a + e` and `ρ = |a − e|`), after the substitution
/// `z = p + (q − p)(3u² − 2u³)` that smooths the `(z − z_k)^{3/2}` behaviour at tangency:
/// relative error below 10⁻¹⁰.
pub fn sphere_cylinder_volume(r: f64, e: f64, a: f64) -> f64 {
    let full = 4.0 / 3.0 * PI * r.powi(3);
    if a <= 0.0 || e - r >= a {
        return 0.0;
    }
    if e + r <= a {
        return full;
    }
    if e == 0.0 {
        return full - 4.0 / 3.0 * PI * (r * r - a * a).max(0.0).powf(1.5);
    }
    let lens = |rho: f64| -> f64 {
        if rho <= 0.0 || e >= rho + a {
            return 0.0;
        }
        if e <= (a - rho).abs() {
            return PI * rho.min(a).powi(2);
        }
        let alpha = ((e * e + rho * rho - a * a) / (2.0 * e * rho)).clamp(-1.0, 1.0);
        let beta = ((e * e + a * a - rho * rho) / (2.0 * e * a)).clamp(-1.0, 1.0);
        let k = ((-e + rho + a) * (e + rho - a) * (e - rho + a) * (e + rho + a)).max(0.0);
        rho * rho * alpha.acos() + a * a * beta.acos() - 0.5 * k.sqrt()
    };
    let mut cuts = vec![0.0, r];
    for rho in [a + e, (a - e).abs()] {
        if rho < r {
            cuts.push((r * r - rho * rho).sqrt());
        }
    }
    cuts.sort_by(f64::total_cmp);
    let (nodes, weights) = gauss_legendre();
    let mut total = 0.0;
    for w in cuts.windows(2) {
        let (p, q) = (w[0], w[1]);
        if q <= p {
            continue;
        }
        for (u, wt) in nodes.iter().zip(weights) {
            let z = p + (q - p) * u * u * (3.0 - 2.0 * u);
            let dz = (q - p) * 6.0 * u * (1.0 - u);
            total += wt * dz * lens((r * r - z * z).max(0.0).sqrt());
        }
    }
    2.0 * total
}

/// Nodes and weights of 24-point Gauss–Legendre quadrature on `[0, 1]` (Newton's method on
/// the Legendre polynomial from the asymptotic guesses `cos(π(k − ¼)/(n + ½))`).
fn gauss_legendre() -> &'static ([f64; 24], [f64; 24]) {
    static RULE: std::sync::OnceLock<([f64; 24], [f64; 24])> = std::sync::OnceLock::new();
    RULE.get_or_init(|| {
        const N: usize = 24;
        let mut nodes = [0.0; N];
        let mut weights = [0.0; N];
        for k in 0..N {
            let mut x = (PI * (k as f64 + 0.75) / (N as f64 + 0.5)).cos();
            let mut derivative = 1.0;
            for _ in 0..100 {
                // P_N(x) and P_N'(x) by the three-term recurrence.
                let (mut p0, mut p1) = (1.0, x);
                for m in 2..=N {
                    let m = m as f64;
                    let p2 = ((2.0 * m - 1.0) * x * p1 - (m - 1.0) * p0) / m;
                    p0 = p1;
                    p1 = p2;
                }
                derivative = N as f64 * (x * p1 - p0) / (x * x - 1.0);
                let step = p1 / derivative;
                x -= step;
                if step.abs() < 1e-16 {
                    break;
                }
            }
            nodes[k] = 0.5 * (1.0 - x);
            weights[k] = 1.0 / ((1.0 - x * x) * derivative * derivative);
        }
        (nodes, weights)
    })
}

/// The wall profiles of the module docs, or why there are none.
fn wall_profiles(packing: &Packing) -> Result<Vec<WallProfile>, String> {
    if periodic_axes(&packing.container) == [true; 3] {
        return Ok(Vec::new());
    }
    let mut spheres = Vec::with_capacity(packing.particles.len());
    for (i, p) in packing.particles.iter().enumerate() {
        match p {
            ParticleRecord::Sphere(SphereRecord { center, radius }) => {
                spheres.push((*center, *radius))
            }
            _ => {
                return Err(format!(
                    "wall profiles are computed for sphere packings (particle {i} is not a sphere)"
                ))
            }
        }
    }
    if spheres.is_empty() {
        return Ok(Vec::new());
    }
    let d_mean = spheres.iter().map(|s| 2.0 * s.1).sum::<f64>() / spheres.len() as f64;
    let w = d_mean / SLABS_PER_DIAMETER;
    let slabs = |half: f64| {
        ((PROFILE_DEPTH * d_mean).min(half) / w + 1e-9)
            .floor()
            .max(1.0) as usize
    };
    let distance = |m: usize| (m as f64 + 0.5) * w / d_mean;
    // A profile of `count` slabs along a plane wall: `t` gives a centre's distance from the
    // wall, `area` the slab's cross-section.
    let planar = |name: &str, count: usize, area: f64, t: &dyn Fn(&[f64; 3]) -> f64| {
        let mut volume = vec![0.0; count];
        for (c, r) in &spheres {
            let t = t(c);
            let first = ((t - r) / w).floor().max(0.0) as usize;
            let last = (((t + r) / w).floor().max(0.0) as usize).min(count - 1);
            for (m, v) in volume.iter_mut().enumerate().take(last + 1).skip(first) {
                *v += sphere_slab_volume(*r, m as f64 * w - t, (m + 1) as f64 * w - t);
            }
        }
        WallProfile {
            wall: name.to_string(),
            slab_width: w,
            distance: (0..count).map(distance).collect(),
            fraction: volume.iter().map(|v| v / (area * w)).collect(),
        }
    };
    let mut out = Vec::new();
    match &packing.container {
        ContainerRecord::Box { min, max, periodic } => {
            for k in (0..3).filter(|&k| !periodic[k]) {
                let len = max[k] - min[k];
                let area: f64 = (0..3)
                    .filter(|&a| a != k)
                    .map(|a| max[a] - min[a])
                    .product();
                let count = slabs(0.5 * len);
                let axis = ['x', 'y', 'z'][k];
                let (lo, hi) = (min[k], max[k]);
                out.push(planar(&format!("{axis}-"), count, area, &|c| c[k] - lo));
                out.push(planar(&format!("{axis}+"), count, area, &|c| hi - c[k]));
            }
        }
        ContainerRecord::Cylinder {
            base_center: b,
            radius,
            height,
        } => {
            let (b, radius, height) = (*b, *radius, *height);
            let area = PI * radius * radius;
            let count = slabs(0.5 * height);
            out.push(planar("z-", count, area, &|c| c[2] - b[2]));
            out.push(planar("z+", count, area, &|c| b[2] + height - c[2]));
            // Annulus m: radii (R − (m + 1) w, R − m w].
            let count = slabs(radius);
            let mut volume = vec![0.0; count];
            for (c, r) in &spheres {
                let e = (c[0] - b[0]).hypot(c[1] - b[1]);
                let t = radius - e;
                let first = ((t - r) / w).floor().max(0.0) as usize;
                if first >= count {
                    continue;
                }
                let last = (((t + r) / w).floor().max(0.0) as usize).min(count - 1);
                let inside = |m: usize| sphere_cylinder_volume(*r, e, radius - m as f64 * w);
                let mut outer = inside(first);
                for (m, v) in volume.iter_mut().enumerate().take(last + 1).skip(first) {
                    let inner = inside(m + 1);
                    *v += outer - inner;
                    outer = inner;
                }
            }
            out.push(WallProfile {
                wall: "side".into(),
                slab_width: w,
                distance: (0..count).map(distance).collect(),
                fraction: volume
                    .iter()
                    .enumerate()
                    .map(|(m, v)| {
                        let (ro, ri) = (
                            radius - m as f64 * w,
                            (radius - (m + 1) as f64 * w).max(0.0),
                        );
                        v / (PI * (ro * ro - ri * ri) * height)
                    })
                    .collect(),
            });
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_of_degree_47_exactly() {
        let (x, w) = gauss_legendre();
        let sum: f64 = w.iter().sum();
        assert!((sum - 1.0).abs() < 1e-14);
        // ∫_0^1 u^46 du = 1/47.
        let m: f64 = x.iter().zip(w).map(|(u, w)| w * u.powi(46)).sum();
        assert!((m - 1.0 / 47.0).abs() < 1e-14, "{m}");
    }
}
