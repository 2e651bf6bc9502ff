//! Random sequential adsorption of spheres and cylinders (§III, Algorithm 5).
//!
//! One module on purpose (about 1 450 lines with its tests): the cost devices below all
//! serve the one placement loop and share its invariant (they never change which candidate
//! is accepted); none is used elsewhere.
//!
//! Bodies are placed one after the other in the given order (see
//! [`super::MixtureSpec::sizes`] for the paper's generation orders): a uniformly random
//! centre in the box and, for a cylinder, a uniformly random axis direction; the candidate
//! is rejected if the exact tests ([`overlaps`]) find it intersecting any image of a placed
//! body, or — for a body longer than half the box — one of its own images. After
//! `max_attempts_per_body` consecutive rejections of one body the configuration is declared
//! stuck and, as the paper advises ("relaunch the program in the case of stagnating
//! configuration"), generation starts again from an empty box, up to `max_restarts` times.
//! The random generator is the caller's (Xoshiro256++ in the CLI), so a seed fixes the
//! result unless the optional wall-clock limit strikes.
//!
//! # Cost of a candidate
//!
//! Four devices make a candidate cheap without changing which candidates are accepted:
//! * [`ImageScan`]: while candidates are seldom rejected, every placed body is scanned
//!   (minimum image, bounding spheres); nothing is registered, so a body costs nothing
//!   beyond its own candidates.
//! * [`CapsuleGrid`]: once a body has been rejected 256 times in a row, a periodic cell
//!   index over the bodies' capsules (cells about one cylinder radius wide, each body
//!   registered along its whole axis with the lattice shift of every image), so a
//!   candidate meets only the images near its own axis — unless its cells are too coarse
//!   to spare the scan anything (`grid_prunes`).
//! * Two passes over those images: first the pairs that the cheap steps of the exact tests
//!   decide ([`overlaps_decided_early`]: bounding spheres, capsules, a separating axis along
//!   either cylinder axis, `cc1`), stopping at the first intersection; then, only if none
//!   was found, the full tests on the pairs that need the base tests of Algorithm 4.
//! * `ExclusionMap`: once a body has been rejected 2000 times in a row,
//!   centres are drawn from the voxels not yet known to be excluded for every orientation.
//!   The accepted body keeps its law (uniform over the free configurations); the attempt
//!   limit counts the uniform draws over the box each drawn centre stands for, so it means
//!   what it meant without the map. A body with no live voxel left is stuck at once.
//!   The map is built sooner when it is cheap, after about half its cost in rejections
//!   (one per 64 voxels of the box and one per 50 voxels the placed bodies' kills visit,
//!   at least 64 rejections; once a start has got stuck, as early as the box's voxels
//!   allow, and with narrower voxels: `voxel_width`), and while it has at most 4096
//!   live voxels it is refined (voxels halved,
//!   at most 6 times) after as many further rejections as it has live voxels (at least
//!   64): the dead test is sharper for narrower voxels, so saturated starts are proven
//!   jammed, and the last free pockets found, in a few thousand candidates instead of
//!   10⁵–10⁶ (10 + 10 spheres of radius 0.19: 147 000 → 2900 candidates per packing).
//!
//! What these address: without them the typed base tests (disk–side, disk–disk) of pairs
//! whose capsules overlap and the image enumeration over every body in reach take most of
//! a candidate's time; saturated cells are dominated by the number of candidates of the last
//! cylinders.

use super::{random_direction, self_image_offsets, BodySize, MixtureError, Rve};
use crate::boundary::PeriodicBox;
use crate::geometry::cylinder::{overlaps, overlaps_decided_early, Shape};
use crate::shape::Vec3;
use crate::spatial::floor_to_i64;
use rand::Rng;
use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

/// Limits of random sequential adsorption.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RsaLimits {
    /// Consecutive rejections of one body before the attempt is declared stuck, counted as
    /// uniform draws over the box (a centre drawn from the exclusion map counts as the
    /// draws it stands for).
    pub max_attempts_per_body: u64,
    /// Fresh starts after a stuck attempt (0: fail at the first stuck body).
    pub max_restarts: u32,
    /// Wall-clock limit over all attempts (`None`: only the attempt limits apply).
    pub time_limit: Option<Duration>,
}

impl Default for RsaLimits {
    fn default() -> Self {
        Self {
            max_attempts_per_body: 100_000,
            max_restarts: 20,
            time_limit: None,
        }
    }
}

/// What a successful adsorption did.
#[derive(Clone, Debug)]
pub struct RsaOutcome {
    /// The intersection-free configuration (bodies in placement order).
    pub rve: Rve,
    /// Candidates drawn over all starts.
    pub candidates: u64,
    /// Fresh starts that were needed.
    pub restarts: u32,
    /// Wall-clock seconds.
    pub seconds: f64,
}

/// Which limit stopped an adsorption.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RsaStop {
    /// Every start got stuck on one body.
    Attempts,
    /// The wall-clock limit.
    Time,
    /// Every start got stuck, the last one on a body for which no centre was left free
    /// (its exclusion map of live centres emptied).
    Jammed,
}

/// Random sequential adsorption could not place every body.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error(
    "random sequential adsorption placed {placed} of {total} bodies ({spheres_placed} of \
     {spheres} spheres, {cylinders_placed} of {cylinders} cylinders; fractions reached \
     f_s = {sphere_fraction:.4}, f_c = {cylinder_fraction:.4}) in its best of {starts} starts \
     before {reason}; lower the fractions, use the relaxer (method = \"md\") or raise the limits"
)]
pub struct RsaFailure {
    /// Bodies placed in the best start.
    pub placed: usize,
    /// Bodies requested.
    pub total: usize,
    /// Spheres placed.
    pub spheres_placed: usize,
    /// Spheres requested.
    pub spheres: usize,
    /// Cylinders placed.
    pub cylinders_placed: usize,
    /// Cylinders requested.
    pub cylinders: usize,
    /// Sphere fraction reached.
    pub sphere_fraction: f64,
    /// Cylinder fraction reached.
    pub cylinder_fraction: f64,
    /// Starts made (1 + restarts).
    pub starts: u32,
    /// Which limit struck.
    pub stop: RsaStop,
    /// The per-body rejection limit.
    pub max_attempts_per_body: u64,
    /// Wall-clock seconds spent.
    pub seconds: f64,
    /// The stop in words.
    pub reason: String,
}

/// Either bad sizes or a failed adsorption.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum RsaError {
    /// A size does not fit the box.
    #[error(transparent)]
    Invalid(#[from] MixtureError),
    /// The limits struck.
    #[error(transparent)]
    Failed(#[from] RsaFailure),
    /// The cancel flag was set ([`crate::cancel`]).
    #[error("random sequential adsorption was cancelled")]
    Cancelled,
}

/// Whether `candidate` intersects one of its own periodic images.
fn meets_own_image(boundary: &PeriodicBox, candidate: &Shape) -> bool {
    let mut hit = false;
    self_image_offsets(boundary, candidate.bounding_radius(), |t| {
        hit = hit || overlaps(candidate, &candidate.translated(t));
    });
    hit
}

/// The capsule (spherocylinder) containing a body: its axis half vector (zero for a sphere)
/// and radius. A sphere is the capsule itself; a cylinder lies within its radius of its
/// axis segment.
fn capsule(shape: &Shape) -> (Vec3, f64) {
    match shape {
        Shape::Sphere(s) => (Vec3::zeros(), s.radius),
        Shape::Cylinder(c) => (c.half_axis, c.radius),
    }
}

/// Lattice shift of a periodic image in box edges, `(n_x, n_y, n_z)`.
type Shift = [i8; 3];

/// Periodic cell index of the capsules of placed bodies: the candidate search of RSA.
///
/// The box is tiled by `m_k` cells per axis of width `w_k = L_k / m_k` (half diagonal
/// `h_d = ½‖w‖`). Each placed body `j`, with axis segment `σ_j` and capsule radius `ρ_j`,
/// is registered in every cell — unwrapped, i.e. of the infinite periodic tiling — whose
/// centre `x` satisfies `dist(x, σ_j) ≤ ρ_j + pad + h_d`, together with the lattice shift
/// that brings that cell back into the box (so the entry names the image of `j` that
/// reaches the box cell). A query for a candidate with capsule `(σ_q, ρ_q)`, `ρ_q ≤ pad`,
/// visits the cells whose centre satisfies `dist(x, σ_q) ≤ h_d` (every cell the segment
/// crosses) and tests each image listed there once.
///
/// Completeness: if the candidate meets an image `B_j + T` then the capsules meet, so some
/// point `y ∈ σ_q` has `dist(y, σ_j + T) < ρ_j + ρ_q ≤ ρ_j + pad`. The cell containing
/// `y` has its centre within `h_d` of `y`, so the query visits it, and within
/// `ρ_j + pad + h_d` of `σ_j + T`; its translate by `−T` (the grid is invariant under the
/// lattice) was registered for `j` with the shift that the query turns back into `T`.
/// Hence every image the exact tests could find intersecting is tested: the index changes
/// the cost of Algorithm 5, never its acceptance rule. Both distance tests carry a slack of
/// `10⁻⁹ w` against rounding.
#[derive(Clone, Debug)]
pub struct CapsuleGrid {
    tiling: Tiling,
    len: Vec3,
    pad: f64,
    /// Per box cell: the first of its entries in `entries` (`u32::MAX`: none).
    heads: Vec<u32>,
    /// (body, shift of the image of the body that reaches the cell, next entry of the
    /// cell): singly linked lists in one arena, so registering allocates nothing per cell.
    entries: Vec<(u32, Shift, u32)>,
    /// Per body: the last query that tested it and the shift tested (deduplication).
    seen: Vec<(u64, Shift)>,
    query: u64,
}

/// The cells of a [`CapsuleGrid`]: `counts[k]` cells of width `width[k]` per box edge from
/// `origin`, repeated periodically.
#[derive(Clone, Copy, Debug)]
struct Tiling {
    origin: Vec3,
    counts: [i64; 3],
    width: Vec3,
    half_diagonal: f64,
}

impl Tiling {
    /// Cells about `width` wide (at least one, at most `max_per_axis` per axis).
    fn new(boundary: &PeriodicBox, width: f64, max_per_axis: f64) -> Self {
        let counts =
            [0, 1, 2].map(|k| (boundary.len[k] / width).floor().min(max_per_axis).max(1.0) as i64);
        let width = Vec3::from_fn(|k, _| boundary.len[k] / counts[k] as f64);
        Self {
            origin: boundary.min,
            counts,
            width,
            half_diagonal: 0.5 * width.norm(),
        }
    }

    fn cell_count(&self) -> usize {
        (self.counts[0] * self.counts[1] * self.counts[2]) as usize
    }

    /// The unwrapped cell containing `p`.
    fn cell_of(&self, p: &Vec3) -> [i64; 3] {
        let i = (p - self.origin).component_div(&self.width);
        [i.x, i.y, i.z].map(floor_to_i64)
    }

    /// The box cell of the unwrapped cell `i` and the lattice shift (in box edges) from
    /// the box cell to `i`.
    fn wrapped(&self, i: [i64; 3]) -> (usize, Shift) {
        let [(c0, s0), (c1, s1), (c2, s2)] = [0, 1, 2].map(|k| wrap_index(i[k], self.counts[k]));
        let [m0, m1, _] = self.counts;
        ((c0 + m0 * (c1 + m1 * c2)) as usize, [s0, s1, s2])
    }

    /// Calls `visit(cell, shift, x)` (as [`Self::wrapped`], `x` the centre of the unwrapped
    /// cell) for each unwrapped cell whose centre lies within `reach + h_d` of the segment
    /// `center ± half_axis`; stops when `visit` returns `true` and returns whether it did.
    fn cells_near_segment(
        &self,
        center: &Vec3,
        half_axis: &Vec3,
        reach: f64,
        mut visit: impl FnMut(usize, Shift, &Vec3) -> bool,
    ) -> bool {
        self.rows_near_segment(center, half_axis, reach, |row| {
            row.any(row.first..=row.last, |cell, shift, x| visit(cell, shift, x))
        })
    }

    /// The cells of [`Self::cells_near_segment`] row by row: calls `visit(row)` for each
    /// row (cells along the axis `a₂` in which the segment extends least) with at least one
    /// such cell; stops when `visit` returns `true` and returns whether it did.
    ///
    /// The centres of a row within the distance of the segment form one interval (the
    /// capsule is convex), found in closed form by [`CapsuleRows::interval`], so no cell
    /// outside it is visited or tested.
    fn rows_near_segment(
        &self,
        center: &Vec3,
        half_axis: &Vec3,
        reach: f64,
        mut visit: impl FnMut(&Row) -> bool,
    ) -> bool {
        let r = reach + self.half_diagonal + 1e-9 * self.width.max();
        // A centre `x` within `r` of the segment has its nearest segment point
        // `p(t) = center + t half_axis`, `t ∈ [−1, 1]`, with `|x_a − p_a(t)| ≤ r` on every
        // axis `a`. Scanning the axes in decreasing `|half_axis_a|`, each coordinate of a
        // cell centre narrows the interval of `t`, which bounds the next coordinate; the
        // cells of a row are then those in its exact interval.
        let order = {
            let mut o = [0usize, 1, 2];
            o.sort_by(|&a, &b| half_axis[b].abs().total_cmp(&half_axis[a].abs()));
            o
        };
        // Reciprocals instead of divisions per row and cell (an error of an ulp is far
        // inside the slack of `r`).
        let inv_width = self.width.map(|w| 1.0 / w);
        let inv_half_axis = half_axis.map(|l| if l == 0.0 { 0.0 } else { 1.0 / l });
        let index = |a: usize, v: f64| floor_to_i64((v - self.origin[a]) * inv_width[a]);
        let centre_of = |a: usize, i: i64| self.origin[a] + (i as f64 + 0.5) * self.width[a];
        // Cell indices along axis `a` within `r` of `p_a(t)` for some `t ∈ [ta, tb]`.
        let span = |a: usize, (ta, tb): (f64, f64)| {
            let (p, q) = (center[a] + half_axis[a] * ta, center[a] + half_axis[a] * tb);
            index(a, p.min(q) - r)..=index(a, p.max(q) + r)
        };
        // The `t ∈ [ta, tb]` with `|x_a − p_a(t)| ≤ r`.
        let narrow = |a: usize, xa: f64, (ta, tb): (f64, f64)| {
            let inv = inv_half_axis[a];
            if inv == 0.0 {
                return (ta, tb);
            }
            let (p, q) = ((xa - r - center[a]) * inv, (xa + r - center[a]) * inv);
            (ta.max(p.min(q)), tb.min(p.max(q)))
        };
        let strides = [1, self.counts[0], self.counts[0] * self.counts[1]];
        let wrap = |a: usize, i: i64| wrap_index(i, self.counts[a]);
        let [a0, a1, a2] = order;
        let capsule = CapsuleRows::new(half_axis, a2, r * r);
        let mut row = Row {
            base: 0,
            stride: strides[a2],
            count: self.counts[a2],
            first: 0,
            last: 0,
            shift: [0; 3],
            axis: a2,
            x: Vec3::zeros(),
            along: Vec3::from_fn(|a, _| if a == a2 { 1.0 } else { 0.0 }),
            origin: self.origin[a2],
            width: self.width[a2],
        };
        for i0 in span(a0, (-1.0, 1.0)) {
            row.x[a0] = centre_of(a0, i0);
            let t0 = narrow(a0, row.x[a0], (-1.0, 1.0));
            if t0.0 > t0.1 {
                continue;
            }
            let (c0, s0) = wrap(a0, i0);
            row.shift[a0] = s0;
            for i1 in span(a1, t0) {
                row.x[a1] = centre_of(a1, i1);
                let t1 = narrow(a1, row.x[a1], t0);
                if t1.0 > t1.1 {
                    continue;
                }
                let (c1, s1) = wrap(a1, i1);
                row.shift[a1] = s1;
                row.base = c0 * strides[a0] + c1 * strides[a1];
                let q = row.x - center + row.along * center[a2];
                let Some((lo, hi)) = capsule.interval(&q) else {
                    continue;
                };
                // Cells whose centre `o + (i + ½) w` lies in `center_{a2} + [lo, hi]`.
                let cell_at = |z: f64| (center[a2] + z - self.origin[a2]) * inv_width[a2] - 0.5;
                (row.first, row.last) = (-floor_to_i64(-cell_at(lo)), floor_to_i64(cell_at(hi)));
                if row.first <= row.last && visit(&row) {
                    return true;
                }
            }
        }
        false
    }
}

/// `(i mod m, ⌊i / m⌋)` (Euclidean): the box index of the unwrapped index `i` along an
/// axis of `m` cells and its lattice shift. Without an integer division for the indices
/// inside the box (most of them; a division costs tens of cycles, several per row).
fn wrap_index(i: i64, m: i64) -> (i64, i8) {
    if (0..m).contains(&i) {
        (i, 0)
    } else {
        (i.rem_euclid(m), i.div_euclid(m) as i8)
    }
}

/// One row of cells of [`Tiling::rows_near_segment`]: the unwrapped cells `first..=last`
/// along `axis` through the point `x` (whose `axis` component is zero), in the box cells
/// `base + stride · (i mod count)` with the lattice shift `shift` (its `axis` component
/// set per cell).
#[derive(Clone, Copy, Debug)]
struct Row {
    base: i64,
    stride: i64,
    count: i64,
    first: i64,
    last: i64,
    shift: Shift,
    axis: usize,
    x: Vec3,
    /// The unit vector along `axis`.
    along: Vec3,
    /// Origin and cell width of the tiling along `axis`.
    origin: f64,
    width: f64,
}

impl Row {
    /// Centre of the unwrapped cell `i` of the row (built by arithmetic rather than by
    /// storing into one component: a store-forwarding stall per cell).
    fn centre(&self, i: i64) -> Vec3 {
        self.x + self.along * (self.origin + (i as f64 + 0.5) * self.width)
    }

    /// Calls `visit(cell, shift, x)` for the unwrapped cells `range` of the row (as
    /// [`Tiling::cells_near_segment`]); stops at the first `true` and returns whether there
    /// was one. The box index is wrapped incrementally (no division per cell).
    fn any(
        &self,
        range: std::ops::RangeInclusive<i64>,
        mut visit: impl FnMut(usize, Shift, &Vec3) -> bool,
    ) -> bool {
        let (mut c, mut s) = wrap_index(*range.start(), self.count);
        let mut shift = self.shift;
        for i in range {
            if c == self.count {
                (c, s) = (0, s + 1);
            }
            let cell = (self.base + c * self.stride) as usize;
            c += 1;
            shift[self.axis] = s;
            if visit(cell, shift, &self.centre(i)) {
                return true;
            }
        }
        false
    }
}

/// The rows of a capsule along the axis `a₂`: the segment `± half_axis` (`l2` its squared
/// half length; a point when zero) and the squared radius `r2`, with the constants of
/// [`Self::interval`] computed once per capsule rather than per row.
struct CapsuleRows {
    half_axis: Vec3,
    r2: f64,
    l2: f64,
    /// `ℓ = half_axis_{a₂}`, its reciprocal (zero when `ℓ = 0`), `1 / l2`.
    ell: f64,
    inv_ell: f64,
    inv_l2: f64,
    /// Leading coefficient `1 − ℓ² / l2` of the quadratic on the cylinder and `1 / 2a`.
    a: f64,
    inv_2a: f64,
}

impl CapsuleRows {
    fn new(half_axis: &Vec3, a2: usize, r2: f64) -> Self {
        let l2 = half_axis.norm_squared();
        let ell = half_axis[a2];
        let inv_l2 = if l2 > 0.0 { 1.0 / l2 } else { 0.0 };
        let a = 1.0 - ell * ell * inv_l2;
        Self {
            half_axis: *half_axis,
            r2,
            l2,
            ell,
            inv_ell: if ell != 0.0 { 1.0 / ell } else { 0.0 },
            inv_l2,
            a,
            inv_2a: 0.5 / a,
        }
    }

    /// The `z` with `dist(q + z e_{a₂}, σ)² ≤ r2`, `σ` the segment and `q` a point with
    /// `q_{a₂} = 0`: an interval (the capsule is convex), `None` when empty. It is the hull
    /// of the intervals of the capsule's three pieces — the balls about both ends, and the
    /// infinite cylinder of radius `√r2` about the axis line cut by the slab
    /// `|y · half_axis| ≤ l2` — since their union is the capsule. On the cylinder, with
    /// `p = q · half_axis`, `|q|² + z² − (p + z ℓ)² / l2 ≤ r2` is a quadratic in `z` whose
    /// leading coefficient `1 − ℓ² / l2` is at least ⅔ when `a₂` is the axis along which
    /// the segment extends least (the callers' choice).
    fn interval(&self, q: &Vec3) -> Option<(f64, f64)> {
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        let q2 = q.norm_squared();
        let mut ball = |end: f64, across: f64| {
            // `across`: squared distance from the row to the end point, across the row.
            let w = self.r2 - across;
            if w >= 0.0 {
                let s = w.sqrt();
                lo = lo.min(end - s);
                hi = hi.max(end + s);
            }
        };
        if self.l2 == 0.0 {
            ball(0.0, q2);
            return (lo <= hi).then_some((lo, hi));
        }
        let (ell, l2) = (self.ell, self.l2);
        let p = q.dot(&self.half_axis);
        // |q ∓ L|² without the a₂ component: |q|² ∓ 2 p + l2 − ℓ².
        let across = q2 + l2 - ell * ell;
        ball(ell, across - 2.0 * p);
        ball(-ell, across + 2.0 * p);
        let b = -2.0 * ell * p * self.inv_l2;
        let c = q2 - p * p * self.inv_l2 - self.r2;
        let disc = b * b - 4.0 * self.a * c;
        if disc >= 0.0 {
            let s = disc.sqrt();
            let (mut z0, mut z1) = ((-b - s) * self.inv_2a, (-b + s) * self.inv_2a);
            if ell != 0.0 {
                let (u, v) = ((-l2 - p) * self.inv_ell, (l2 - p) * self.inv_ell);
                z0 = z0.max(u.min(v));
                z1 = z1.min(u.max(v));
            } else if p.abs() > l2 {
                z1 = f64::NEG_INFINITY;
            }
            if z0 <= z1 {
                lo = lo.min(z0);
                hi = hi.max(z1);
            }
        }
        (lo <= hi).then_some((lo, hi))
    }
}

impl CapsuleGrid {
    /// An empty index for `boundary` and candidates of capsule radius at most `pad`, with
    /// cells about `pad` wide (the capsule radius, so a long cylinder spans many cells and
    /// meets only the bodies along its axis) but at most `max_per_axis` per axis (few
    /// bodies are cheaper to register in a coarse grid).
    pub fn new(boundary: &PeriodicBox, pad: f64, max_per_axis: usize) -> Self {
        let tiling = Tiling::new(boundary, pad, max_per_axis as f64);
        Self {
            tiling,
            len: boundary.len,
            pad,
            heads: vec![u32::MAX; tiling.cell_count()],
            entries: Vec::new(),
            seen: Vec::new(),
            query: 0,
        }
    }

    /// Registers body `j` (ids `0, 1, 2, …` in order).
    pub fn insert(&mut self, j: usize, body: &Shape) {
        let (half_axis, radius) = capsule(body);
        let (heads, entries) = (&mut self.heads, &mut self.entries);
        self.tiling.cells_near_segment(
            &body.center(),
            &half_axis,
            radius + self.pad,
            |cell, n, _| {
                entries.push((j as u32, n.map(|x| -x), heads[cell]));
                heads[cell] = (entries.len() - 1) as u32;
                false
            },
        );
        if self.seen.len() <= j {
            self.seen.resize(j + 1, (0, [0; 3]));
        }
    }

    /// Whether `hit(j, offset)` holds for some registered body `j` and lattice vector
    /// `offset` such that the image of `j` moved by `offset` may meet `probe` (capsule
    /// radius at most `pad`); tests each such image once, the ones listed in the cell of
    /// the probe's centre first, and stops at the first hit (RSA rejections).
    ///
    /// # Panics
    /// If the probe's capsule radius exceeds the pad.
    pub fn any_image(&mut self, probe: &Shape, mut hit: impl FnMut(usize, Vec3) -> bool) -> bool {
        let (half_axis, radius) = capsule(probe);
        assert!(
            radius <= self.pad,
            "probe capsule radius {radius} above the pad"
        );
        self.query += 1;
        let (query, len, tiling) = (self.query, self.len, self.tiling);
        let (heads, entries, seen) = (&self.heads, &self.entries, &mut self.seen);
        let mut test = |cell: usize, n: Shift| {
            let mut e = heads[cell];
            while e != u32::MAX {
                let (j, shift, next) = entries[e as usize];
                e = next;
                let s = [shift[0] + n[0], shift[1] + n[1], shift[2] + n[2]];
                let mark = &mut seen[j as usize];
                if *mark == (query, s) {
                    continue;
                }
                *mark = (query, s);
                if hit(j as usize, Vec3::from_fn(|k, _| f64::from(s[k]) * len[k])) {
                    return true;
                }
            }
            false
        };
        let c = probe.center();
        let (home, n) = tiling.wrapped(tiling.cell_of(&c));
        test(home, n) || tiling.cells_near_segment(&c, &half_axis, 0.0, |cell, n, _| test(cell, n))
    }
}

/// The plain candidate search: every placed body, each image whose bounding sphere meets
/// the probe's. Nothing is registered but a centre, so it is the search of choice while
/// candidates are seldom rejected (a few nanoseconds per placed body and candidate, against
/// hundreds of cells to register per body in a [`CapsuleGrid`]).
///
/// Centres (of bodies and probes) must lie in the box `[min, min + L)`, as RSA draws them:
/// then a separation `d` has `|d_k| < L_k` and one conditional shift per axis gives the
/// minimum image `d*`. The image `d* + t` of a body can meet the probe only if
/// `‖d* + t‖ < R_q + R_j` (bounding radii). When `R_q + R_j ≤ L_min / 2` the minimum
/// image is the only candidate (any other has `‖d* + t‖ ≥ ‖t‖ − ‖d*‖ ≥ L_min − ‖d*‖`, above
/// the reach whenever `‖d*‖` is below it), otherwise every lattice vector within reach is
/// tried. Completeness is that of the bounding-sphere exit of the exact tests, so the scan
/// changes the cost of Algorithm 5, never its acceptance rule.
#[derive(Clone, Debug)]
pub struct ImageScan {
    min: Vec3,
    len: Vec3,
    /// Per body: centre and bounding radius.
    balls: Vec<[f64; 4]>,
    max_radius: f64,
}

impl ImageScan {
    /// An empty scan of `boundary`.
    pub fn new(boundary: &PeriodicBox) -> Self {
        Self {
            min: boundary.min,
            len: boundary.len,
            balls: Vec::new(),
            max_radius: 0.0,
        }
    }

    /// Registers the next body (ids `0, 1, 2, …` in order).
    pub fn push(&mut self, body: &Shape) {
        let (c, r) = (body.center(), body.bounding_radius());
        debug_assert!((0..3).all(|k| c[k] >= self.min[k] && c[k] < self.min[k] + self.len[k]));
        self.balls.push([c.x, c.y, c.z, r]);
        self.max_radius = self.max_radius.max(r);
    }

    /// Whether `hit(j, offset)` holds for some registered body `j` and lattice vector
    /// `offset` whose image's bounding sphere meets the probe's; tries the bodies in
    /// order, each image once, and stops at the first hit.
    pub fn any_image(&self, probe: &Shape, mut hit: impl FnMut(usize, Vec3) -> bool) -> bool {
        let (c, rq) = (probe.center(), probe.bounding_radius());
        debug_assert!((0..3).all(|k| c[k] >= self.min[k] && c[k] < self.min[k] + self.len[k]));
        let len = self.len;
        let inv = len.map(|l| 1.0 / l);
        let one_image = 2.0 * (rq + self.max_radius) <= len.min();
        for (j, &[x, y, z, r]) in self.balls.iter().enumerate() {
            // Minimum image per axis, `n_k = round(d_k / L_k) ∈ {−1, 0, 1}`, without a
            // branch (the sign of a separation is a coin flip, so branches mispredict).
            let mut d = Vec3::new(x - c.x, y - c.y, z - c.z);
            let n = Vec3::from_fn(|k, _| nearest_integer(d[k] * inv[k]));
            let t = -n.component_mul(&len);
            d += t;
            let reach = rq + r;
            if one_image {
                if d.norm_squared() < reach * reach && hit(j, t) {
                    return true;
                }
                continue;
            }
            let mut found = false;
            super::for_each_lattice_vector(&len, &d, reach, |s| {
                found = found || hit(j, t + s);
            });
            if found {
                return true;
            }
        }
        false
    }
}

/// Radius of the largest ball about the centre inside the body: `r_s`, or `min(r_c, h)`.
fn inscribed_radius(shape: &Shape) -> f64 {
    match shape {
        Shape::Sphere(s) => s.radius,
        Shape::Cylinder(c) => c.radius.min(c.half_length()),
    }
}

/// The test `dist(x, body) < limit` (distance zero inside), with the body's constants
/// computed once: `‖x − p‖ < r_s + limit` for a sphere; for a cylinder, with `X` the
/// axial coordinate and `L` the distance from the axis,
/// `max(|X| − h, 0)² + max(L − r_c, 0)² < limit²`.
fn closer_than(body: &Shape, limit: f64) -> impl Fn(&Vec3) -> bool {
    let (center, half_axis, radius) = match body {
        Shape::Sphere(s) => (s.center, Vec3::zeros(), s.radius),
        Shape::Cylinder(c) => (c.center, c.half_axis, c.radius),
    };
    let h = half_axis.norm();
    let u = if h > 0.0 {
        half_axis / h
    } else {
        Vec3::zeros()
    };
    move |x: &Vec3| {
        let w = x - center;
        let axial = w.dot(&u);
        let radial = (w - u * axial).norm();
        let (dx, dr) = ((axial.abs() - h).max(0.0), (radial - radius).max(0.0));
        dx * dx + dr * dr < limit * limit
    }
}

/// Centres that no body with an inscribed radius of at least `inscribed` can take: a
/// periodic grid of voxels (width about [`voxel_width`], at most 96 per axis, half
/// diagonal `h_v`), of which a
/// voxel is dead once some placed body `B` has `dist(x_v, B) + h_v < inscribed − m`
/// (`x_v` the voxel centre, `m = 10⁻⁶ · inscribed`). Then every point `y` of the voxel has
/// `dist(y, B) < inscribed − m` (distance is 1-Lipschitz), so the ball of radius
/// `inscribed` about `y`, and with it a candidate centred at `y`, penetrates `B` by more
/// than `m`: the exact tests reject every candidate centred in a dead voxel, whatever its
/// orientation.
///
/// Drawing the centre uniformly from the live voxels instead of the box therefore leaves
/// Algorithm 5 unchanged in law: the accepted body is still uniform over the free
/// configurations, because only candidates that would have been rejected are never drawn.
/// It is the standard voxel acceleration of saturated RSA (Zhang & Torquato 2013), here
/// for positions only.
#[derive(Clone, Debug)]
struct ExclusionMap {
    tiling: Tiling,
    /// Box edges.
    len: Vec3,
    inscribed: f64,
    /// Per voxel of the first level: its index in `live`, or `u32::MAX` once dead; empty
    /// once the map has been refined (then `kill_near` filters `live` instead).
    slot: Vec<u32>,
    live: Vec<u32>,
    /// Refinements so far (the voxels are `2^level` times narrower than at the start).
    level: u32,
    /// Candidates rejected since the last build or refinement.
    rejected: u64,
}

impl ExclusionMap {
    /// The map for candidates of inscribed radius `inscribed` among `bodies`, with voxels
    /// about `voxel` wide.
    fn new(boundary: &PeriodicBox, inscribed: f64, voxel: f64, bodies: &[Shape]) -> Self {
        let tiling = Tiling::new(boundary, voxel, 96.0);
        let n = tiling.cell_count();
        let limit = limit_for(inscribed, tiling.half_diagonal);
        // Mark first (a store per dead voxel), list after: the live voxels in increasing
        // order.
        let mut dead = vec![false; n];
        for b in bodies {
            dead_rows(&tiling, limit, b, |row, range| {
                row.any(range, |v, _, _| {
                    dead[v] = true;
                    false
                });
            });
        }
        let mut slot = vec![u32::MAX; n];
        let mut live = Vec::with_capacity(n);
        for (v, _) in dead.iter().enumerate().filter(|(_, &d)| !d) {
            slot[v] = live.len() as u32;
            live.push(v as u32);
        }
        Self {
            tiling,
            len: boundary.len,
            inscribed,
            slot,
            live,
            level: 0,
            rejected: 0,
        }
    }

    /// Consecutive rejections of one body after which a map for it is built among
    /// `bodies`: about its cost in candidates (the rule of renting skis: a body rejected
    /// that often is likely to be rejected as often again), one per
    /// [`VOXELS_PER_CANDIDATE`] voxels of the box and one per [`VISITS_PER_CANDIDATE`]
    /// voxels the bodies' kills visit (the voxels within `ρ_j + limit + h_v` of each axis,
    /// `ρ_j` the capsule radius), within `[REFINE_AFTER, EXCLUSION_MAP_AFTER]`, for
    /// voxels about `voxel` wide. Pass no
    /// bodies to build as early as the box's voxels allow (saturated cells, where maps
    /// prove starts jammed).
    fn build_after(boundary: &PeriodicBox, inscribed: f64, voxel: f64, bodies: &[Shape]) -> u64 {
        let tiling = Tiling::new(boundary, voxel, 96.0);
        let voxels = tiling.cell_count() as f64;
        // Voxels visited by the bodies' kills: those within the capsule of radius
        // ρ + limit + h_v about each axis.
        let reach = limit_for(inscribed, tiling.half_diagonal) + tiling.half_diagonal;
        let cell = tiling.width.x * tiling.width.y * tiling.width.z;
        let visits: f64 = bodies
            .iter()
            .map(|b| {
                let (half_axis, radius) = capsule(b);
                let rho = radius + reach;
                std::f64::consts::PI * rho * rho * (2.0 * half_axis.norm() + 4.0 / 3.0 * rho) / cell
            })
            .sum();
        ((voxels / VOXELS_PER_CANDIDATE as f64 + visits / VISITS_PER_CANDIDATE) as u64)
            .clamp(REFINE_AFTER, EXCLUSION_MAP_AFTER)
    }

    /// `limit` of the dead test, `dist(x_v, B) < limit`, for voxels of half diagonal
    /// `half_diagonal`: `inscribed − m − h_v`.
    fn limit(&self, half_diagonal: f64) -> f64 {
        limit_for(self.inscribed, half_diagonal)
    }

    /// Centre of voxel `v`.
    fn centre(&self, v: u32) -> Vec3 {
        let v = i64::from(v);
        let [m0, m1, _] = self.tiling.counts;
        let i = [v % m0, (v / m0) % m1, v / (m0 * m1)];
        self.tiling.origin + Vec3::from_fn(|k, _| (i[k] as f64 + 0.5) * self.tiling.width[k])
    }

    /// Marks the voxels `body` makes dead.
    fn kill_near(&mut self, body: &Shape) {
        let limit = self.limit(self.tiling.half_diagonal);
        if limit <= 0.0 {
            return;
        }
        if self.slot.is_empty() {
            // Refined: the live voxels are few, filter them (every image of the body).
            let near = closer_than(body, limit);
            let len = self.len;
            let reach = body.bounding_radius() + limit;
            let c = body.center();
            let mut live = std::mem::take(&mut self.live);
            live.retain(|&v| {
                let x = self.centre(v);
                let d = minimum_image(&len, &(x - c));
                let mut dead = false;
                for_images_within(&len, &d, reach, |t| {
                    // dist(x, B + T) = dist(x − T, B), and x − T = c + d + t.
                    dead = dead || near(&(c + d + t));
                });
                !dead
            });
            self.live = live;
            return;
        }
        let (slot, live) = (&mut self.slot, &mut self.live);
        dead_rows(&self.tiling, limit, body, |row, range| {
            row.any(range, |v, _, _| {
                if slot[v] != u32::MAX {
                    let at = slot[v] as usize;
                    let last = *live.last().expect("a live voxel is listed");
                    live.swap_remove(at);
                    if last as usize != v {
                        slot[last as usize] = at as u32;
                    }
                    slot[v] = u32::MAX;
                }
                false
            });
        });
    }

    /// Whether the map should be refined now: it has been refined fewer than
    /// [`MAX_REFINEMENTS`] times and has seen as many rejections since the last build or
    /// refinement as a refinement costs in candidates (about its live voxels, at least
    /// [`REFINE_AFTER`]).
    fn wants_refinement(&self) -> bool {
        self.level < MAX_REFINEMENTS
            && self.rejected >= REFINE_AFTER.max(self.live.len() as u64)
            && self.live.len() <= REFINE_MAX_LIVE
            && self.tiling.cell_count() <= (u32::MAX / 8) as usize
    }

    /// Halves the voxels: each live voxel becomes eight, of which those that some periodic
    /// image of a placed body makes dead (the test of the type documentation with the
    /// smaller half diagonal) are dropped. A child of a live voxel is within `h'` (its own
    /// half diagonal) of the parent's centre, so only the images whose bounding sphere
    /// comes within `R_j + limit' + h'` of the parent's centre are tried.
    fn refine(&mut self, bodies: &[Shape]) {
        let old = self.tiling;
        let fine = Tiling {
            origin: old.origin,
            counts: old.counts.map(|m| 2 * m),
            width: old.width / 2.0,
            half_diagonal: old.half_diagonal / 2.0,
        };
        let limit = self.limit(fine.half_diagonal);
        let len = self.len;
        let near: Vec<_> = bodies.iter().map(|b| closer_than(b, limit)).collect();
        let mut images: Vec<(usize, Vec3)> = Vec::new();
        let mut live = Vec::with_capacity(8 * self.live.len());
        let [m0, m1, _] = old.counts;
        let [f0, f1, _] = fine.counts;
        for &v in &self.live {
            let x = self.centre(v);
            // The images (body, position of the body's centre relative to x) in reach.
            images.clear();
            for (j, b) in bodies.iter().enumerate() {
                let d = minimum_image(&len, &(b.center() - x));
                let reach = b.bounding_radius() + limit + fine.half_diagonal;
                for_images_within(&len, &d, reach, |t| images.push((j, d + t)));
            }
            let v = i64::from(v);
            let i = [v % m0, (v / m0) % m1, v / (m0 * m1)];
            for child in 0..8 {
                let o = [child & 1, (child >> 1) & 1, child >> 2];
                let n = [0, 1, 2].map(|k| 2 * i[k] + o[k]);
                // The child's centre is `x + dx`; seen from the image's centre `x + rel`
                // it is `dx − rel`, i.e. the point `c_j + dx − rel` against the body.
                let dx = Vec3::from_fn(|k, _| (o[k] as f64 - 0.5) * fine.width[k]);
                let dead = images
                    .iter()
                    .any(|&(j, rel)| near[j](&(bodies[j].center() + dx - rel)));
                if !dead {
                    live.push((n[0] + f0 * (n[1] + f1 * n[2])) as u32);
                }
            }
        }
        self.tiling = fine;
        self.slot = Vec::new();
        self.live = live;
        self.level += 1;
        self.rejected = 0;
    }

    /// Share of the box still live.
    fn live_fraction(&self) -> f64 {
        self.live.len() as f64 / self.tiling.cell_count() as f64
    }

    /// A uniform point of the live voxels (`None`: every centre is excluded).
    fn sample<R: Rng>(&self, rng: &mut R) -> Option<Vec3> {
        if self.live.is_empty() {
            return None;
        }
        let v = self.live[rng.gen_range(0..self.live.len())] as i64;
        let [m0, m1, _] = self.tiling.counts;
        let i = [v % m0, (v / m0) % m1, v / (m0 * m1)];
        Some(
            self.tiling.origin
                + Vec3::from_fn(|k, _| (i[k] as f64 + rng.gen::<f64>()) * self.tiling.width[k]),
        )
    }
}

/// `limit` of the dead test of an [`ExclusionMap`], `dist(x_v, B) < limit`, for voxels of
/// half diagonal `half_diagonal` and candidates of inscribed radius `inscribed`:
/// `inscribed − m − h_v`, `m = 10⁻⁶ · inscribed`.
fn limit_for(inscribed: f64, half_diagonal: f64) -> f64 {
    inscribed * (1.0 - 1e-6) - half_diagonal
}

/// Calls `dead(row, range)` for each row of `tiling` (see [`Tiling::rows_near_segment`])
/// in which `body` makes voxels dead, i.e. has `dist(x_v, B) < limit` at their centres:
/// `range` those voxels, consecutive because the set `dist(x, B) < limit` is convex, so
/// the test runs only from either end of the row up to the first dead voxel.
fn dead_rows(
    tiling: &Tiling,
    limit: f64,
    body: &Shape,
    mut dead: impl FnMut(&Row, std::ops::RangeInclusive<i64>),
) {
    if limit <= 0.0 {
        return;
    }
    let (half_axis, radius) = capsule(body);
    let near = closer_than(body, limit);
    // dist(x, B) < limit implies dist(x, axis) < radius + limit: the reach passed leaves
    // out the half diagonal that the tiling adds.
    let reach = radius + limit - tiling.half_diagonal;
    tiling.rows_near_segment(&body.center(), &half_axis, reach, |row| {
        if let Some(lo) = (row.first..=row.last).find(|&i| near(&row.centre(i))) {
            let hi = (lo..=row.last)
                .rev()
                .find(|&i| near(&row.centre(i)))
                .unwrap_or(lo);
            dead(row, lo..=hi);
        }
        false
    });
}

/// The minimum image of a separation `d` with `|d_k| < L_k` in a periodic box of edges
/// `len` (`|d_k| ≤ L_k / 2`).
fn minimum_image(len: &Vec3, d: &Vec3) -> Vec3 {
    Vec3::from_fn(|k, _| d[k] - nearest_integer(d[k] / len[k]) * len[k])
}

/// The integer nearest to `x` (ties to even), for `|x| < 2⁵¹`: adding and subtracting
/// `1.5 · 2⁵²` leaves no fractional bits, so the addition rounds in the floating-point
/// unit — two additions, where `f64::round` is a library call on the baseline x86-64
/// target and a saturating `as i64` conversion costs a compare and a select per axis.
fn nearest_integer(x: f64) -> f64 {
    const SHIFT: f64 = 6_755_399_441_055_744.0;
    (x + SHIFT) - SHIFT
}

/// Calls `f(t)` for each lattice vector `t` with `‖d + t‖ < reach`, `d` a minimum image:
/// only `t = 0` can qualify when `2 reach ≤ L_min`.
fn for_images_within(len: &Vec3, d: &Vec3, reach: f64, mut f: impl FnMut(Vec3)) {
    if 2.0 * reach <= len.min() {
        if d.norm_squared() < reach * reach {
            f(Vec3::zeros());
        }
    } else {
        super::for_each_lattice_vector(len, d, reach, f);
    }
}

/// Rejections, since the last build or refinement of an [`ExclusionMap`], before it is
/// refined (at least; more when it has more live voxels than this).
const REFINE_AFTER: u64 = 64;

/// Live voxels of an [`ExclusionMap`] above which it is not refined: its `kill_near`
/// then filters every live voxel per placed body, and a refinement tests eight children
/// per live voxel (with long cylinders most bodies reach every voxel).
const REFINE_MAX_LIVE: usize = 4096;

/// Refinements of one [`ExclusionMap`] at most (voxels `2⁴` times narrower).
const MAX_REFINEMENTS: u32 = 6;

/// Voxel width of an [`ExclusionMap`] for candidates of inscribed radius `inscribed`:
/// `inscribed / 2` when `coarse`, else `inscribed / 3`. The dead test
/// `dist(x_v, B) < inscribed − m − h_v` is sharper for narrower voxels (more of the
/// excluded region is dead) but a build visits `∝ 1/w²` rows per body. Coarse in the
/// first start when every body is short (`4 R_max ≤ L_min`, so each one reaches a voxel
/// in one image and a refinement is cheap): there the map serves a body or two of a start
/// that completes, and the cheaper build pays most in the small sphere-heavy cells. Not
/// with long bodies (the coarse map is refined, and a refinement tests every image of
/// every long body per live voxel), nor once a start has got stuck (saturated cells, where
/// maps must prove starts jammed).
fn voxel_width(inscribed: f64, coarse: bool) -> f64 {
    inscribed / if coarse { 2.0 } else { 3.0 }
}

/// Consecutive rejections of one body after which its centres are drawn from an
/// [`ExclusionMap`] at the latest (building one of 96³ voxels costs about as much as this
/// many candidates).
const EXCLUSION_MAP_AFTER: u64 = 2000;

/// Voxels of an [`ExclusionMap`] that cost about one candidate to build.
const VOXELS_PER_CANDIDATE: u64 = 64;

/// Voxel visits of the bodies' kills in building an [`ExclusionMap`] counted as one
/// candidate by [`ExclusionMap::build_after`]. A visit costs about a twenty-fifth of a
/// candidate; counting fifty builds the map once the rejections have cost about half of
/// the build, which wastes at most a constant factor either way (as in renting skis before
/// buying them) and was the fastest of 25, 50 and 100 over seven cells.
const VISITS_PER_CANDIDATE: f64 = 50.0;

/// Consecutive rejections of one body after which the [`ImageScan`] gives way to a
/// [`CapsuleGrid`] of [`FINE_CELLS_PER_AXIS`] (registering the bodies costs about this many
/// candidates), if [`grid_prunes`].
const FINE_GRID_AFTER: u64 = 256;

/// Whether a [`CapsuleGrid`] for `boundary` and `pad` would spare a candidate much of the
/// [`ImageScan`] among `bodies`, for probes of half length at most `probe_half_length`
/// and bounding radius at most `probe_bounding`. Not when the scan needs only the minimum
/// image of every body (`2 (R_q + R_max) ≤ L_min`: a few nanoseconds per body) and a
/// query would still meet at least half the bodies: body `j` is listed in the cells
/// within `ρ_j + pad + h_d` of its axis and a query visits the cells within `h_d` of its
/// own, so it meets the body from about the capsule of radius `ρ_j + pad + 2 h_d` about
/// the axis lengthened by the probe's, of volume `v_j`: with probability
/// `min(1, v_j / V)` for a uniform centre. Either way the same images are tested exactly
/// (each structure lists every image that can meet the probe), so the choice changes the
/// cost of a candidate, never its verdict. In small cells where a query meets every body
/// the grid only adds its registration.
fn grid_prunes(
    boundary: &PeriodicBox,
    pad: f64,
    probe_half_length: f64,
    probe_bounding: f64,
    bodies: &[Shape],
) -> bool {
    let len = boundary.len;
    let max_bounding = bodies
        .iter()
        .map(Shape::bounding_radius)
        .fold(0.0, f64::max);
    if 2.0 * (probe_bounding + max_bounding) > len.min() || bodies.is_empty() {
        return true;
    }
    let tiling = Tiling::new(boundary, pad, FINE_CELLS_PER_AXIS as f64);
    let volume = len.x * len.y * len.z;
    let met: f64 = bodies
        .iter()
        .map(|b| {
            let (half_axis, radius) = capsule(b);
            let r = radius + pad + 2.0 * tiling.half_diagonal;
            let h = half_axis.norm() + probe_half_length;
            let v = std::f64::consts::PI * r * r * (2.0 * h + 4.0 / 3.0 * r);
            (v / volume).min(1.0)
        })
        .sum();
    met < 0.5 * bodies.len() as f64
}

/// Cap on the cells per axis of the [`CapsuleGrid`] that replaces the [`ImageScan`] once
/// candidates are often rejected.
const FINE_CELLS_PER_AXIS: usize = 48;

/// The candidate search of one start: [`ImageScan`] until some body has been rejected
/// [`FINE_GRID_AFTER`] times in a row and [`grid_prunes`], then a [`CapsuleGrid`] of cells
/// about one capsule radius wide.
enum Search {
    Scan(ImageScan),
    Grid(CapsuleGrid),
}

impl Search {
    fn insert(&mut self, j: usize, body: &Shape) {
        match self {
            Search::Scan(s) => s.push(body),
            Search::Grid(g) => g.insert(j, body),
        }
    }

    fn any_image(&mut self, probe: &Shape, hit: impl FnMut(usize, Vec3) -> bool) -> bool {
        match self {
            Search::Scan(s) => s.any_image(probe, hit),
            Search::Grid(g) => g.any_image(probe, hit),
        }
    }
}

/// Places bodies of the given sizes, in this order, in `boundary` (Algorithm 5). `cancel`
/// is checked at every candidate.
pub fn rsa_mixture<R: Rng>(
    boundary: &PeriodicBox,
    sizes: &[BodySize],
    limits: &RsaLimits,
    cancel: Option<&AtomicBool>,
    rng: &mut R,
) -> Result<RsaOutcome, RsaError> {
    for s in sizes {
        s.check_fits(boundary)?;
    }
    let start = Instant::now();
    // Each size once as a body at the origin (its capsule, bounding and inscribed radii).
    let probes: Vec<Shape> = sizes
        .iter()
        .map(|s| s.at(Vec3::zeros(), Vec3::z()))
        .collect();
    let pad = probes.iter().map(|p| capsule(p).1).fold(0.0, f64::max);
    // Every body reaches a point in at most one image (see `voxel_width`).
    let short = 4.0
        * probes
            .iter()
            .map(Shape::bounding_radius)
            .fold(0.0, f64::max)
        <= boundary.len.min();
    let mut candidates = 0u64;
    let mut deferred: Vec<Shape> = Vec::new();
    let mut best: Vec<Shape> = Vec::new();
    let mut starts = 0u32;
    let stop = loop {
        starts += 1;
        let mut search = Search::Scan(ImageScan::new(boundary));
        let mut bodies: Vec<Shape> = Vec::with_capacity(sizes.len());
        let mut bounding: Vec<f64> = Vec::with_capacity(sizes.len());
        let mut stuck = None;
        let mut map: Option<ExclusionMap> = None;
        'bodies: for (size, probe_size) in sizes.iter().zip(&probes) {
            let inscribed = inscribed_radius(probe_size);
            let voxel = voxel_width(inscribed, starts == 1 && short);
            if map.as_ref().is_some_and(|m| m.inscribed > inscribed) {
                map = None;
            }
            // Draws so far, and the uniform draws over the whole box they stand for: a draw
            // from the live voxels replaces 1/f_live uniform ones (the others would have
            // fallen in dead voxels and been rejected), so the attempt limit means the
            // same with and without the map.
            let (mut rejections, mut attempts) = (0u64, 0.0f64);
            // (Computed once the body has been rejected often: it is at least REFINE_AFTER.)
            let mut map_after = None;
            loop {
                if crate::cancel::is_set(cancel) {
                    return Err(RsaError::Cancelled);
                }
                // (Asked once per body, at its FINE_GRID_AFTER-th rejection in a row.)
                if matches!(search, Search::Scan(_))
                    && rejections == FINE_GRID_AFTER
                    && grid_prunes(
                        boundary,
                        pad,
                        capsule(probe_size).0.norm(),
                        probe_size.bounding_radius(),
                        &bodies,
                    )
                {
                    let mut grid = CapsuleGrid::new(boundary, pad, FINE_CELLS_PER_AXIS);
                    for (j, b) in bodies.iter().enumerate() {
                        grid.insert(j, b);
                    }
                    search = Search::Grid(grid);
                }
                if map.is_none()
                    && rejections >= REFINE_AFTER
                    && rejections
                        >= *map_after.get_or_insert_with(|| {
                            // After a stuck start the cell is known to saturate:
                            // maps are built as early as their voxel count allows.
                            let counted: &[Shape] = if starts > 1 { &[] } else { &bodies };
                            ExclusionMap::build_after(boundary, inscribed, voxel, counted)
                        })
                {
                    map = Some(ExclusionMap::new(boundary, inscribed, voxel, &bodies));
                }
                let center = match &map {
                    None => boundary.min + boundary.len.map(|l| l * rng.gen::<f64>()),
                    Some(m) => match m.sample(rng) {
                        Some(c) => c,
                        None => {
                            stuck = Some(RsaStop::Jammed);
                            break 'bodies;
                        }
                    },
                };
                candidates += 1;
                let direction = if size.is_cylinder() {
                    random_direction(rng)
                } else {
                    Vec3::z()
                };
                let candidate = size.at(center, direction);
                // Two passes: the pairs the cheap steps of the exact tests decide, stopping
                // at the first intersection; then the pairs that need the base tests.
                deferred.clear();
                let reach = candidate.bounding_radius();
                let free = !meets_own_image(boundary, &candidate)
                    && !search.any_image(&candidate, |j, offset| {
                        // Bounding spheres apart: no intersection (the cheapest exit).
                        let apart = reach + bounding[j];
                        if (bodies[j].center() + offset - center).norm_squared() >= apart * apart {
                            return false;
                        }
                        let partner = bodies[j].translated(offset);
                        overlaps_decided_early(&candidate, &partner).unwrap_or_else(|| {
                            deferred.push(partner);
                            false
                        })
                    })
                    && !deferred.iter().any(|partner| overlaps(&candidate, partner));
                if free {
                    search.insert(bodies.len(), &candidate);
                    if let Some(m) = &mut map {
                        m.kill_near(&candidate);
                    }
                    bodies.push(candidate);
                    bounding.push(reach);
                    continue 'bodies;
                }
                rejections += 1;
                attempts += map.as_ref().map_or(1.0, |m| 1.0 / m.live_fraction());
                if let Some(m) = &mut map {
                    m.rejected += 1;
                    if m.wants_refinement() {
                        m.refine(&bodies);
                    }
                }
                if limits
                    .time_limit
                    .is_some_and(|t| rejections % 1024 == 0 && start.elapsed() > t)
                {
                    stuck = Some(RsaStop::Time);
                    break 'bodies;
                }
                if attempts >= limits.max_attempts_per_body as f64 {
                    stuck = Some(RsaStop::Attempts);
                    break 'bodies;
                }
            }
        }
        match stuck {
            None => {
                return Ok(RsaOutcome {
                    rve: Rve {
                        boundary: boundary.clone(),
                        bodies,
                    },
                    candidates,
                    restarts: starts - 1,
                    seconds: start.elapsed().as_secs_f64(),
                })
            }
            Some(stop) => {
                if bodies.len() > best.len() {
                    best = bodies;
                }
                if stop == RsaStop::Time || starts > limits.max_restarts {
                    break stop;
                }
                // Many short starts (each ending jammed) must not outlast the limit either.
                if limits.time_limit.is_some_and(|t| start.elapsed() > t) {
                    break RsaStop::Time;
                }
            }
        }
    };
    let rve = Rve {
        boundary: boundary.clone(),
        bodies: best,
    };
    let (sphere_fraction, cylinder_fraction) = rve.fractions();
    let cylinders_placed = rve
        .bodies
        .iter()
        .filter(|b| matches!(b, Shape::Cylinder(_)))
        .count();
    let cylinders = sizes.iter().filter(|s| s.is_cylinder()).count();
    Err(RsaFailure {
        placed: rve.bodies.len(),
        total: sizes.len(),
        spheres_placed: rve.bodies.len() - cylinders_placed,
        spheres: sizes.len() - cylinders,
        cylinders_placed,
        cylinders,
        sphere_fraction,
        cylinder_fraction,
        starts,
        stop,
        max_attempts_per_body: limits.max_attempts_per_body,
        seconds: start.elapsed().as_secs_f64(),
        reason: match stop {
            RsaStop::Attempts => format!(
                "{} consecutive rejections of one body",
                limits.max_attempts_per_body
            ),
            RsaStop::Jammed => {
                "a body found no free centre left (every centre within its inscribed radius \
                 of a placed body)"
                    .to_string()
            }
            RsaStop::Time => format!(
                "the time limit of {:.3} s",
                limits.time_limit.unwrap_or_default().as_secs_f64()
            ),
        },
    }
    .into())
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// [`CapsuleRows::interval`] against the distance to the segment by its nearest point
    /// (the clamped projection): for random segments (also along a coordinate axis, and
    /// points), radii and rows, points of the row inside the interval are within the
    /// radius, points outside it beyond, up to 10⁻⁹ at the ends.
    #[test]
    fn capsule_row_interval_is_the_row_inside_the_capsule() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(11);
        let dist2 = |x: &Vec3, l: &Vec3| {
            let l2 = l.norm_squared();
            let t = if l2 > 0.0 {
                (x.dot(l) / l2).clamp(-1.0, 1.0)
            } else {
                0.0
            };
            (x - l * t).norm_squared()
        };
        let (mut inside, mut outside) = (0, 0);
        for case in 0..3000 {
            let mut half_axis = Vec3::from_fn(|_, _| rng.gen_range(-1.0..1.0));
            match case % 5 {
                0 => half_axis = Vec3::zeros(),
                1 => half_axis = Vec3::new(0.0, 0.0, half_axis.z),
                2 => half_axis.z = 0.0,
                _ => {}
            }
            let mut order = [0usize, 1, 2];
            order.sort_by(|&a, &b| half_axis[b].abs().total_cmp(&half_axis[a].abs()));
            let a2 = order[2];
            let r = rng.gen_range(0.05..1.0);
            let mut q = Vec3::from_fn(|_, _| rng.gen_range(-1.5..1.5));
            q[a2] = 0.0;
            let interval = CapsuleRows::new(&half_axis, a2, r * r).interval(&q);
            let along = Vec3::from_fn(|a, _| if a == a2 { 1.0 } else { 0.0 });
            for k in 0..200 {
                let z = -3.0 + 6.0 * f64::from(k) / 199.0;
                let d2 = dist2(&(q + along * z), &half_axis);
                match interval {
                    Some((lo, hi)) if z >= lo && z <= hi => {
                        inside += 1;
                        assert!(d2 <= r * r + 1e-9, "case {case}: z {z} in [{lo}, {hi}]");
                    }
                    _ => {
                        outside += 1;
                        let near_end = interval
                            .is_some_and(|(lo, hi)| (z - lo).abs() < 1e-9 || (z - hi).abs() < 1e-9);
                        assert!(near_end || d2 > r * r - 1e-9, "case {case}: z {z} outside");
                    }
                }
            }
        }
        assert!(inside > 10_000 && outside > 10_000, "{inside} {outside}");
    }

    /// A dead voxel of the [`ExclusionMap`] holds no acceptable centre: every candidate
    /// drawn in one, in any orientation, meets some periodic image of a placed body by the
    /// exact tests. Random sparse and dense scenes (so the kills reach across faces, edges
    /// and corners), points at random in the box, so also at the rim of the dead region.
    #[test]
    fn dead_voxels_hold_only_rejected_candidates() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(0x5eed_0e8c);
        let boundary = PeriodicBox {
            min: Vec3::new(-0.5, 0.0, 0.25),
            len: Vec3::new(1.0, 1.2, 0.9),
        };
        let (mut dead, mut live, mut refined) = (0usize, 0usize, 0usize);
        for scene in 0..12 {
            let rc = [0.04, 0.06, 0.09][scene % 3];
            let sizes = [
                BodySize::Cylinder {
                    radius: rc,
                    half_length: [1.0, 3.0, 5.0][scene % 3] * rc,
                },
                BodySize::Sphere { radius: 1.3 * rc },
            ];
            let bodies: Vec<Shape> = (0..[8, 30][scene % 2])
                .map(|i| {
                    let c = boundary.min + boundary.len.map(|l| l * rng.gen::<f64>());
                    sizes[i % 2].at(c, random_direction(&mut rng))
                })
                .collect();
            let candidate = sizes[scene % 2];
            let inscribed = inscribed_radius(&candidate.at(Vec3::zeros(), Vec3::z()));
            // Both voxel widths (first start, after a stuck start).
            let voxel = voxel_width(inscribed, (scene / 2) % 2 == 0);
            let mut map = ExclusionMap::new(&boundary, inscribed, voxel, &bodies);
            // Scenes 4–11 also check refined maps (once, twice), where few voxels are live.
            for _ in 0..scene / 4 {
                if map.live.len() <= 60_000 {
                    map.refine(&bodies);
                }
            }
            refined += usize::from(map.level > 0);
            for _ in 0..2000 {
                let x = boundary.min + boundary.len.map(|l| l * rng.gen::<f64>());
                let (v, _) = map.tiling.wrapped(map.tiling.cell_of(&x));
                let is_live = if map.slot.is_empty() {
                    map.live.contains(&(v as u32))
                } else {
                    map.slot[v] != u32::MAX
                };
                if is_live {
                    live += 1;
                    continue;
                }
                dead += 1;
                for _ in 0..4 {
                    let probe = candidate.at(x, random_direction(&mut rng));
                    let rejected = bodies.iter().any(|b| {
                        (0..27).any(|n| {
                            let t = Vec3::new(
                                (n % 3) as f64 - 1.0,
                                ((n / 3) % 3) as f64 - 1.0,
                                (n / 9) as f64 - 1.0,
                            )
                            .component_mul(&boundary.len);
                            overlaps(&probe, &b.translated(t))
                        })
                    });
                    assert!(rejected, "a candidate in a dead voxel is free: {probe:?}");
                }
            }
        }
        println!("dead {dead}, live {live}, refined maps {refined}");
        assert!(dead > 2000 && live > 2000 && refined >= 4);
    }
}
