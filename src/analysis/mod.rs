//! Descriptions of a packing for `densepack verify` and `densepack plot`: the gap histogram,
//! the sieve curve against a grading curve, the size histogram and plane sections. Pure
//! functions of the written packing. [`jamming`] says whether a sphere packing is jammed;
//! [`structure`] describes its structure (g(r), size classes, wall profiles).

pub mod jamming;
pub mod structure;

use crate::io::export::{bounding_sphere, container_bounds, periodic_axes, rotation_of};
use crate::io::packing::{ContainerRecord, Packing, ParticleRecord};
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

/// One bin of the size histogram: particles whose sieve diameter ([`sieve_diameter`]) lies
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
    let sizes: Vec<f64> = packing.particles.iter().map(sieve_diameter).collect();
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

/// A uniform grid of cells over a container's bounding box for pair searches: every pair of
/// centres closer than the `width` it was built with lies in neighbouring cells (periodic
/// axes wrap). Cells are at least `width` wide and at most about four per particle.
pub(crate) struct CellGrid {
    lo: [f64; 3],
    len: [f64; 3],
    periodic: [bool; 3],
    cells: [usize; 3],
    /// Particles of cell `c` are `sorted[start[c]..start[c + 1]]`.
    start: Vec<usize>,
    sorted: Vec<u32>,
}

impl CellGrid {
    /// The grid of `centers` in `container` with cells at least `width` wide.
    pub(crate) fn new(container: &ContainerRecord, centers: &[[f64; 3]], width: f64) -> Self {
        let (lo, hi) = container_bounds(container);
        let periodic = periodic_axes(container);
        let len: [f64; 3] = std::array::from_fn(|k| hi[k] - lo[k]);
        let mut cells: [usize; 3] =
            std::array::from_fn(|k| ((len[k] / width).floor() as usize).clamp(1, 1 << 20));
        while cells.iter().product::<usize>() > 4 * centers.len() + 64 {
            cells = cells.map(|c| (c / 2).max(1));
        }
        let mut grid = Self {
            lo,
            len,
            periodic,
            cells,
            start: vec![0; cells.iter().product::<usize>() + 1],
            sorted: vec![0; centers.len()],
        };
        for c in centers {
            let k = grid.linear(grid.key(c));
            grid.start[k + 1] += 1;
        }
        for c in 1..grid.start.len() {
            grid.start[c] += grid.start[c - 1];
        }
        let mut fill = grid.start.clone();
        for (i, c) in centers.iter().enumerate() {
            let k = grid.linear(grid.key(c));
            grid.sorted[fill[k]] = i as u32;
            fill[k] += 1;
        }
        grid
    }

    fn key(&self, c: &[f64; 3]) -> [usize; 3] {
        std::array::from_fn(|k| {
            let x = ((c[k] - self.lo[k]) / self.len[k] * self.cells[k] as f64).floor();
            (x.max(0.0) as usize).min(self.cells[k] - 1)
        })
    }

    fn linear(&self, k: [usize; 3]) -> usize {
        (k[0] * self.cells[1] + k[1]) * self.cells[2] + k[2]
    }

    /// Per axis, the distinct neighbouring cell coordinates of cell coordinate `x`.
    fn around(&self, k: usize, x: usize) -> Vec<usize> {
        let n = self.cells[k] as i64;
        let mut out: Vec<usize> = (-1..=1)
            .map(|o| x as i64 + o)
            .filter_map(|y| {
                if self.periodic[k] {
                    Some(y.rem_euclid(n) as usize)
                } else {
                    (0..n).contains(&y).then_some(y as usize)
                }
            })
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// Calls `f` with every particle in the cells around (and including) the cell of `c`,
    /// each once.
    pub(crate) fn for_each_near(&self, c: &[f64; 3], mut f: impl FnMut(u32)) {
        let k = self.key(c);
        for x in self.around(0, k[0]) {
            for y in self.around(1, k[1]) {
                for z in self.around(2, k[2]) {
                    let cell = self.linear([x, y, z]);
                    for &j in &self.sorted[self.start[cell]..self.start[cell + 1]] {
                        f(j);
                    }
                }
            }
        }
    }

    /// `cj − ci`, wrapped to the nearest image along periodic axes.
    pub(crate) fn separation(&self, ci: &[f64; 3], cj: &[f64; 3]) -> [f64; 3] {
        std::array::from_fn(|a| {
            let d = cj[a] - ci[a];
            // Near pairs rarely straddle a face: the rounding (a libm call) only then.
            if self.periodic[a] && d.abs() > 0.5 * self.len[a] {
                d - self.len[a] * (d / self.len[a]).round()
            } else {
                d
            }
        })
    }
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

/// What a section plane cuts out of one particle (or of one of its periodic images), in the
/// plane's coordinates ([`section_axes`]).
#[derive(Clone, Debug, PartialEq)]
pub enum SectionCut {
    /// A sphere cut as a disc.
    Disc {
        /// Centre.
        center: [f64; 2],
        /// Radius `√(r² − t²)` at distance `t` of the plane from the sphere's centre.
        radius: f64,
        /// Index of the particle in the packing.
        particle: usize,
    },
    /// An ellipsoid cut as an ellipse.
    Ellipse {
        /// Centre.
        center: [f64; 2],
        /// Semi-axes.
        semi_axes: [f64; 2],
        /// Angle of the first semi-axis from the horizontal axis (radians).
        angle: f64,
        /// Index of the particle in the packing.
        particle: usize,
    },
    /// A finite cylinder cut as a convex polygon: the plane's section of its side sampled at
    /// [`CYLINDER_SECTION_SAMPLES`] angles (an ellipse's arc, inscribed) and the chords of its
    /// end disks, in counter-clockwise order.
    Polygon {
        /// Vertices.
        vertices: Vec<[f64; 2]>,
        /// Index of the particle in the packing.
        particle: usize,
    },
}

/// Angles at which a cylinder's side is sampled for its section polygon.
pub const CYLINDER_SECTION_SAMPLES: usize = 96;

impl SectionCut {
    /// Index of the particle cut.
    pub fn particle(&self) -> usize {
        match self {
            Self::Disc { particle, .. }
            | Self::Ellipse { particle, .. }
            | Self::Polygon { particle, .. } => *particle,
        }
    }

    /// Centre of the cut (of its bounding box, for a polygon).
    pub fn center(&self) -> [f64; 2] {
        match self {
            Self::Disc { center, .. } | Self::Ellipse { center, .. } => *center,
            Self::Polygon { vertices, .. } => {
                let (lo, hi) = polygon_box(vertices);
                [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1])]
            }
        }
    }

    /// Half-widths of the cut's axis-aligned bounding box.
    pub fn half_extent(&self) -> [f64; 2] {
        match self {
            Self::Disc { radius, .. } => [*radius; 2],
            Self::Ellipse {
                semi_axes: [a, b],
                angle,
                ..
            } => {
                let (s, c) = angle.sin_cos();
                [
                    ((a * c).powi(2) + (b * s).powi(2)).sqrt(),
                    ((a * s).powi(2) + (b * c).powi(2)).sqrt(),
                ]
            }
            Self::Polygon { vertices, .. } => {
                let (lo, hi) = polygon_box(vertices);
                [0.5 * (hi[0] - lo[0]), 0.5 * (hi[1] - lo[1])]
            }
        }
    }

    /// The same cut moved by `offset`.
    fn shifted(&self, offset: [f64; 2]) -> Self {
        let mut cut = self.clone();
        match &mut cut {
            Self::Disc { center, .. } | Self::Ellipse { center, .. } => {
                center[0] += offset[0];
                center[1] += offset[1];
            }
            Self::Polygon { vertices, .. } => {
                for p in vertices {
                    p[0] += offset[0];
                    p[1] += offset[1];
                }
            }
        }
        cut
    }
}

/// The axis-aligned bounding box `(lower, upper)` of a polygon's vertices.
fn polygon_box(vertices: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
    vertices.iter().fold(
        ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
        |(lo, hi), p| {
            (
                [lo[0].min(p[0]), lo[1].min(p[1])],
                [hi[0].max(p[0]), hi[1].max(p[1])],
            )
        },
    )
}

/// The convex hull of `points`, counter-clockwise (Andrew's monotone chain); collinear
/// points are dropped. Written here: the only 2-D geometry the project needs, where a
/// crate (parry2d, geo) would add a dependency tree for twenty lines.
fn convex_hull(mut points: Vec<[f64; 2]>) -> Vec<[f64; 2]> {
    points.sort_by(|a, b| a[0].total_cmp(&b[0]).then(a[1].total_cmp(&b[1])));
    points.dedup();
    if points.len() < 3 {
        return points;
    }
    let cross = |o: [f64; 2], a: [f64; 2], b: [f64; 2]| {
        (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])
    };
    let mut hull: Vec<[f64; 2]> = Vec::with_capacity(2 * points.len());
    for pass in [points.clone(), points.into_iter().rev().collect()] {
        let floor = hull.len();
        for p in pass {
            while hull.len() >= floor + 2
                && cross(hull[hull.len() - 2], hull[hull.len() - 1], p) <= 0.0
            {
                hull.pop();
            }
            hull.push(p);
        }
        hull.pop();
    }
    hull
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
/// A sphere of radius `r` at distance `t` from the plane is cut as a disc of radius
/// `√(r² − t²)`. An ellipsoid `(x − c)ᵀ A (x − c) ≤ 1` with `A = R diag(a⁻²) Rᵀ` is cut as
/// the ellipse `(p − p*)ᵀ M (p − p*) ≤ ρ`, where `M` is the in-plane block of `A`, `b` its
/// in-plane column on the normal axis, `p* = −t M⁻¹ b` and `ρ = 1 − t² (A_nn − bᵀ M⁻¹ b)`
/// (completing the square in the in-plane coordinates); its semi-axes are `√(ρ/λ)` for the
/// eigenvalues `λ` of `M`.
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
            let (center, _) = bounding_sphere(p);
            // Distance of the plane from the (image's) centre along the normal.
            let t = at - (center[axis] + m * length[axis]);
            if let Some(cut) = plane_cut(p, index, [center[h], center[v]], [h, v, axis], t) {
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

/// The cut of particle `p` by a plane at signed distance `t` from its centre along axis
/// `axes[2]`, or `None` when the plane misses it; `center` is the particle's centre in the
/// plane coordinates `axes[0], axes[1]`.
fn plane_cut(
    p: &ParticleRecord,
    particle: usize,
    center: [f64; 2],
    axes: [usize; 3],
    t: f64,
) -> Option<SectionCut> {
    match p {
        ParticleRecord::Sphere { radius, .. } => {
            let r2 = radius * radius - t * t;
            (r2 > 0.0).then(|| SectionCut::Disc {
                center,
                radius: r2.sqrt(),
                particle,
            })
        }
        ParticleRecord::Ellipsoid {
            semi_axes,
            orientation,
            ..
        } => {
            let r = rotation_of(orientation).to_rotation_matrix();
            let inverse_squares = nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(
                semi_axes[0].powi(-2),
                semi_axes[1].powi(-2),
                semi_axes[2].powi(-2),
            ));
            let a = r.matrix() * inverse_squares * r.matrix().transpose();
            let [h, v, n] = axes;
            let m = nalgebra::Matrix2::new(a[(h, h)], a[(h, v)], a[(v, h)], a[(v, v)]);
            let b = nalgebra::Vector2::new(a[(h, n)], a[(v, n)]);
            // M is positive definite (a block of a positive definite matrix).
            let m_inv_b = m.cholesky()?.solve(&b);
            let rho = 1.0 - t * t * (a[(n, n)] - b.dot(&m_inv_b));
            if rho <= 0.0 {
                return None;
            }
            let offset = -t * m_inv_b;
            let eigen = nalgebra::SymmetricEigen::new(m);
            let first = eigen.eigenvectors.column(0);
            Some(SectionCut::Ellipse {
                center: [center[0] + offset[0], center[1] + offset[1]],
                semi_axes: [
                    (rho / eigen.eigenvalues[0]).sqrt(),
                    (rho / eigen.eigenvalues[1]).sqrt(),
                ],
                angle: first[1].atan2(first[0]),
                particle,
            })
        }
        ParticleRecord::Cylinder {
            radius, half_axis, ..
        } => cylinder_cut(*radius, *half_axis, particle, center, axes, t),
    }
}

/// The section of a finite cylinder (radius `r`, half axis `l`, centre at the in-plane
/// point `center`) by the plane at signed distance `t` from its centre along `axes[2]`.
/// Its points are `s·â + u·e₁ + v·e₂` from the centre, `|s| ≤ |l|`, `u² + v² ≤ r²`
/// (`â = l/|l|`, `e₁, e₂ ⊥ â`). The boundary is where the plane meets the side (for each
/// angle φ, `s = (t − r (cos φ e₁ₙ + sin φ e₂ₙ))/âₙ` if `|s| ≤ |l|`) and the end disks
/// (the chord `(u, v)·w = t ∓ |l| âₙ`, `w = (e₁ₙ, e₂ₙ)`, inside the circle); the section is
/// their convex hull. Along the axis (`âₙ = 0`) the side gives straight lines whose ends
/// are the chords' ends: the hull of the chords alone is the exact rectangle.
fn cylinder_cut(
    r: f64,
    l: [f64; 3],
    particle: usize,
    center: [f64; 2],
    axes: [usize; 3],
    t: f64,
) -> Option<SectionCut> {
    let axis = nalgebra::Vector3::from(l);
    let length = axis.norm();
    let a = axis / length;
    let helper = if a.x.abs() < 0.9 {
        nalgebra::Vector3::x()
    } else {
        nalgebra::Vector3::y()
    };
    let e1 = a.cross(&helper).normalize();
    let e2 = a.cross(&e1);
    let [h, v, n] = axes;
    let in_plane = |p: nalgebra::Vector3<f64>| [center[0] + p[h], center[1] + p[v]];
    let mut points = Vec::new();
    if a[n].abs() > 1e-12 {
        for k in 0..CYLINDER_SECTION_SAMPLES {
            let phi = std::f64::consts::TAU * k as f64 / CYLINDER_SECTION_SAMPLES as f64;
            let radial = r * (phi.cos() * e1 + phi.sin() * e2);
            let s = (t - radial[n]) / a[n];
            if s.abs() <= length {
                points.push(in_plane(s * a + radial));
            }
        }
    }
    let w = nalgebra::Vector2::new(e1[n], e2[n]);
    let q = w.norm();
    if q > 1e-12 {
        for end in [-length, length] {
            // The chord of this end disk: (u, v)·w = t − end·âₙ.
            let offset = (t - end * a[n]) / q;
            if offset.abs() <= r {
                let foot = offset * w / q;
                let half = (r * r - offset * offset).sqrt();
                let along = nalgebra::Vector2::new(-w[1], w[0]) / q;
                for sign in [-1.0, 1.0] {
                    let uv = foot + sign * half * along;
                    points.push(in_plane(end * a + uv[0] * e1 + uv[1] * e2));
                }
            }
        }
    }
    let vertices = convex_hull(points);
    (vertices.len() >= 3).then_some(SectionCut::Polygon { vertices, particle })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn polygon(cut: Option<SectionCut>) -> Vec<[f64; 2]> {
        match cut {
            Some(SectionCut::Polygon { vertices, .. }) => vertices,
            other => panic!("a polygon, got {other:?}"),
        }
    }

    /// Shoelace area of a counter-clockwise polygon.
    fn area(v: &[[f64; 2]]) -> f64 {
        (0..v.len())
            .map(|k| {
                let (p, q) = (v[k], v[(k + 1) % v.len()]);
                p[0] * q[1] - q[0] * p[1]
            })
            .sum::<f64>()
            / 2.0
    }

    #[test]
    fn cylinder_sections_are_the_exact_disc_rectangle_and_ellipse() {
        let cylinder = |half_axis: [f64; 3]| ParticleRecord::Cylinder {
            center: [0.0; 3],
            radius: 0.5,
            half_axis,
        };
        let k = CYLINDER_SECTION_SAMPLES as f64;
        let inscribed = k / (2.0 * std::f64::consts::PI) * (2.0 * std::f64::consts::PI / k).sin();
        // Across the axis (z = 0.3 of a cylinder along z): the disc of radius 0.5, as the
        // regular inscribed polygon, every vertex on the circle.
        let v = polygon(plane_cut(
            &cylinder([0.0, 0.0, 1.0]),
            0,
            [2.0, 3.0],
            [0, 1, 2],
            0.3,
        ));
        let exact = std::f64::consts::PI * 0.25 * inscribed;
        assert!((area(&v) / exact - 1.0).abs() < 1e-12, "{}", area(&v));
        for p in &v {
            assert!(((p[0] - 2.0).hypot(p[1] - 3.0) - 0.5).abs() < 1e-12);
        }
        // Along the axis (x = 0.3): the rectangle 2·√(0.25 − 0.09) wide, 2 high.
        let v = polygon(plane_cut(
            &cylinder([0.0, 0.0, 1.0]),
            0,
            [0.0, 0.0],
            [1, 2, 0],
            0.3,
        ));
        assert_eq!(v.len(), 4, "{v:?}");
        assert!((area(&v) - 2.0 * 0.4 * 2.0).abs() < 1e-12, "{}", area(&v));
        // Tilted by 30° from the plane normal and cut across its side only: an ellipse of
        // area π r² / cos 30°, semi-axes r and r / cos 30° (inscribed polygon: within 0.1 %).
        let (s, c) = (30f64.to_radians().sin(), 30f64.to_radians().cos());
        let v = polygon(plane_cut(
            &cylinder([3.0 * s, 0.0, 3.0 * c]),
            0,
            [0.0, 0.0],
            [0, 1, 2],
            0.2,
        ));
        let ellipse = std::f64::consts::PI * 0.25 / c;
        assert!(
            (area(&v) / ellipse - 1.0).abs() < 1e-3,
            "{} {ellipse}",
            area(&v)
        );
        // A plane past the end disks misses it.
        assert!(plane_cut(&cylinder([0.0, 0.0, 1.0]), 0, [0.0, 0.0], [0, 1, 2], 1.2).is_none());
    }

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
