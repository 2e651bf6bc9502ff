//! Independent verification of a packing: overlap, gap and containment.
//!
//! One module on purpose (about 1 650 lines with its tests): its worth is its independence
//! from the kernel, so the pair tests, cell levels, distances and report stay here, shared
//! with nothing the kernel uses (the analysis, also independent of the kernel, finds its
//! pairs through the same cell levels, `PairLevels`). The bodies it tests are those of the
//! written records ([`crate::io::record::RecordShape::body`]), never the kernel's shapes.
//!
//! This module shares no code with the kernel's prediction, cell grid or boundaries: it works
//! on the packing as written ([`Packing`]), finds candidate pairs through its own cell levels
//! and measures distances with its own minimum-image rule (`dx − L·round(dx/L)`).
//!
//! Nothing the file claims relaxes a check. The relative tolerance `tol` comes from the
//! caller ([`VerifyOptions`], default [`TOLERANCE`]; `densepack verify --tolerance`), never
//! from the file. A pair *overlaps* when `|c_i − c_j| < (1 − tol)·(r_i + r_j)`, a sphere
//! crosses a wall when its distance to it is below `(1 − tol)·r`, and a sphere in a periodic
//! box overlaps its own image when the shortest periodic edge is below `(1 − tol)·2r`. The
//! gaps the file claims (`min_gap`, `wall_gap`, default `min_gap/2`) are separate promises,
//! checked on top: a pair closer than `(1 − tol)·(r_i + r_j) + min_gap` (a wall closer than
//! `(1 − tol)·r + wall_gap`) that does not overlap is a *gap claim* violation. A claim that is
//! negative or not finite is a malformed file ([`Packing::check`]), as is a container of no
//! positive finite size; both are reported and the claim is then taken as 0.
//!
//! Packings with cylinders (sphere + cylinder mixtures, periodic box only) go to
//! `verify_convex_with`, which shares no code with `geometry::cylinder` either: a pair is
//! accepted only with a *separating-plane certificate* for the two bodies eroded by `tol`
//! times their radius — a direction `d` with `max_{x∈A} x·d < min_{y∈B} y·d`, evaluated with
//! the closed-form support functions — found by GJK on the support maps (the simplex's
//! nearest point by trying every face). A pair without a certificate is a violation, so the
//! check can reject a valid packing but never accept an overlapping one.
//!
//! Ellipsoids (and spheres paired with them) are checked with the Perram–Wertheim contact
//! function `F(λ) = λ(1−λ) dᵀ[(1−λ)M_i + λM_j]⁻¹d`, `M = R·diag(a², b², c²)·Rᵀ`, maximised over
//! `λ ∈ [0, 1]` by golden-section search: `√max F` is the factor by which both must be scaled
//! about their centres to touch, so a pair is accepted when it is at least `1 − tol`. Every
//! periodic image of a partner whose bounding sphere reaches the particle's is tested, and each
//! ellipsoid against its own images (needles may be nearly as long as the box). This is
//! a different method from the kernel's prediction (characteristic polynomial / certified
//! separating-axis steps) and shares no code with it: the rotation matrix, the 3×3 inverse and
//! the search are written here. An ellipsoid's distance to a box wall or a cylinder cap is the
//! closed form `|c − wall| − √(nᵀMn)`; against a cylinder mantle its bounding sphere is used
//! (conservative).

use crate::io::packing::{ContainerRecord, Packing};
use crate::io::record::{Body, Oriented, SupportMap};
use nalgebra::Vector3;
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

/// Default relative tolerance of the overlap test (rounding of the written coordinates and of
/// the kernel's time stepping stay far below it).
pub const TOLERANCE: f64 = 1e-9;

/// Largest relative tolerance accepted: beyond 1 % of the radii the check would no longer
/// tell an overlap from a contact.
pub const MAX_TOLERANCE: f64 = 1e-2;

/// How a packing is checked; chosen by the caller, never read from the packing.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VerifyOptions {
    /// Relative tolerance `tol` of the overlap and gap tests, in `[0, MAX_TOLERANCE]`.
    pub tolerance: f64,
}

impl Default for VerifyOptions {
    fn default() -> Self {
        Self {
            tolerance: TOLERANCE,
        }
    }
}

impl VerifyOptions {
    /// Whether the tolerance is a finite number in `[0, MAX_TOLERANCE]`; the error names it and
    /// the allowed range.
    pub fn check(&self) -> Result<(), String> {
        let t = self.tolerance;
        if t.is_finite() && (0.0..=MAX_TOLERANCE).contains(&t) {
            Ok(())
        } else {
            Err(format!(
                "tolerance = {t} must be a finite number in [0, {MAX_TOLERANCE:e}]"
            ))
        }
    }
}

/// The outcome of a verification.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Verification {
    /// Number of particles.
    pub particles: usize,
    /// The relative tolerance the checks applied.
    pub tolerance: f64,
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
    /// Smallest wall gap relative to the particle's radius (bounding radius for an ellipsoid):
    /// below `−tolerance` the particle crosses the wall.
    pub min_wall_gap_relative: Option<f64>,
    /// Human-readable violations (at most 20 listed).
    pub violations: Vec<String>,
    /// Total number of violations (overlaps, gap claims and malformed particles).
    pub violation_count: usize,
    /// Overlaps beyond the tolerance: pairs, a particle and its own periodic image, a
    /// particle and a wall.
    pub overlap_count: usize,
    /// Pairs (or walls) that do not overlap but are closer than the gap the file claims.
    pub gap_claim_count: usize,
    /// Per particle, the smallest relative gap `|c_i − c_j| / (r_i + r_j) − 1` to any
    /// neighbour found by the candidate search (`+∞` when none is near); for the gap
    /// histogram of [`crate::analysis`].
    #[serde(skip)]
    pub nearest_gap_relative: Vec<f64>,
}

impl Verification {
    /// A verification of `particles` particles that has found nothing yet, with a
    /// per-particle nearest-gap slot for each of `nearest` particles.
    fn new(particles: usize, nearest: usize, tolerance: f64) -> Self {
        Self {
            particles,
            tolerance,
            packing_fraction: 0.0,
            min_pair_gap_relative: None,
            min_pair_gap: None,
            min_wall_gap: None,
            min_wall_gap_relative: None,
            violations: Vec::new(),
            violation_count: 0,
            overlap_count: 0,
            gap_claim_count: 0,
            nearest_gap_relative: vec![f64::INFINITY; nearest],
        }
    }

    /// Counts an overlap beyond the tolerance.
    fn overlap(&mut self, message: String) {
        self.overlap_count += 1;
        self.violate(message);
    }

    /// Counts a broken gap claim (no overlap, but closer than the file promises).
    fn broken_claim(&mut self, message: String) {
        self.gap_claim_count += 1;
        self.violate(message);
    }

    /// Adds the findings of a check of other pairs (the particle count, tolerance, packing
    /// fraction and nearest gaps stay this one's): the smaller minima, the sums of the
    /// counts, and its violations after these, up to 20 in all.
    fn absorb(&mut self, other: Verification) {
        let least = |a: Option<f64>, b: Option<f64>| match (a, b) {
            (Some(x), Some(y)) => Some(if y < x { y } else { x }),
            (x, None) => x,
            (None, y) => y,
        };
        self.min_pair_gap_relative = least(self.min_pair_gap_relative, other.min_pair_gap_relative);
        self.min_pair_gap = least(self.min_pair_gap, other.min_pair_gap);
        self.min_wall_gap = least(self.min_wall_gap, other.min_wall_gap);
        self.min_wall_gap_relative = least(self.min_wall_gap_relative, other.min_wall_gap_relative);
        self.violation_count += other.violation_count;
        self.overlap_count += other.overlap_count;
        self.gap_claim_count += other.gap_claim_count;
        let room = 20usize.saturating_sub(self.violations.len());
        self.violations
            .extend(other.violations.into_iter().take(room));
    }

    /// Counts a violation; the first 20 are kept for the report.
    fn violate(&mut self, message: String) {
        self.violation_count += 1;
        if self.violations.len() < 20 {
            self.violations.push(message);
        }
    }

    /// Whether the packing satisfies all constraints.
    pub fn ok(&self) -> bool {
        self.violation_count == 0
    }
}

struct Ball {
    c: [f64; 3],
    r: f64,
}

impl SupportMap for Ball {
    fn center(&self) -> Vector3<f64> {
        Vector3::from(self.c)
    }

    fn radius(&self) -> f64 {
        self.r
    }

    fn bound(&self) -> f64 {
        self.r
    }

    fn volume(&self) -> f64 {
        4.0 / 3.0 * std::f64::consts::PI * self.r.powi(3)
    }

    fn shifted(&self, t: Vector3<f64>) -> Box<dyn SupportMap> {
        Box::new(Ball {
            c: (Vector3::from(self.c) + t).into(),
            r: self.r,
        })
    }

    fn eroded(&self, delta: f64) -> Box<dyn SupportMap> {
        Box::new(Ball {
            c: self.c,
            r: self.r - delta,
        })
    }

    fn support(&self, d: &Vector3<f64>) -> f64 {
        Vector3::from(self.c).dot(d) + self.r * d.norm()
    }

    fn support_point(&self, d: &Vector3<f64>) -> Vector3<f64> {
        let (c, n) = (Vector3::from(self.c), d.norm());
        if n > 0.0 {
            c + d * (self.r / n)
        } else {
            c
        }
    }

    fn as_ball(&self) -> Option<(Vector3<f64>, f64)> {
        Some((Vector3::from(self.c), self.r))
    }
}

/// The check a Gmsh export runs on the surfaces it writes
/// ([`crate::io::export::gmsh::write_geo`]): [`verify`] of those surfaces, summarised.
pub fn surface_check(surfaces: &Packing) -> crate::io::export::gmsh::SurfaceCheck {
    let v = verify(surfaces);
    crate::io::export::gmsh::SurfaceCheck {
        violation_count: v.violation_count,
        first_violation: v.violations.into_iter().next(),
        min_pair_gap: v.min_pair_gap,
        min_wall_gap: v.min_wall_gap,
    }
}

/// Checks a packing at the default tolerance ([`TOLERANCE`]); never trusts anything the
/// simulation computed.
pub fn verify(packing: &Packing) -> Verification {
    verify_with(packing, &VerifyOptions::default())
}

/// The tolerance and the gap claims a check works with, and what was wrong with them.
/// Invalid input is reported as a violation and replaced by values that keep every check
/// on (the default tolerance, no claimed gap): a bad file or option never passes silently.
struct Terms {
    tol: f64,
    gap: f64,
    wall_gap: f64,
    problems: Vec<String>,
}

impl Terms {
    fn of(packing: &Packing, options: &VerifyOptions) -> Self {
        let mut problems = Vec::new();
        let tol = match options.check() {
            Ok(()) => options.tolerance,
            Err(e) => {
                problems.push(e);
                TOLERANCE
            }
        };
        let (gap, wall_gap) = match packing.check() {
            Ok(()) => (packing.min_gap, packing.wall_gap()),
            Err(e) => {
                problems.push(format!("malformed packing: {e}"));
                let valid = |g: f64| if g.is_finite() && g >= 0.0 { g } else { 0.0 };
                (valid(packing.min_gap), valid(packing.wall_gap()))
            }
        };
        Self {
            tol,
            gap,
            wall_gap,
            problems,
        }
    }
}

/// Checks a packing with the tolerance of `options`; never trusts anything the simulation
/// computed or the file claims (see the module documentation).
pub fn verify_with(packing: &Packing, options: &VerifyOptions) -> Verification {
    let terms = Terms::of(packing, options);
    if let Err(e) = packing.container.check() {
        // No volume, wall or minimum image is defined: nothing else can be checked.
        let mut out = Verification::new(packing.particles.len(), 0, terms.tol);
        out.packing_fraction = f64::NAN;
        out.violate(format!("malformed packing: {e}"));
        return out;
    }
    // Boxed: a sphere costs 8 bytes here, not the 88 of an inline `Option<Oriented>` (the
    // verification of a 10⁶-sphere packing must not outgrow the simulation's memory). A
    // packing with any other convex body goes to the convex check.
    let mut balls = Vec::with_capacity(packing.particles.len());
    let mut oriented: Vec<Option<Box<Oriented>>> = Vec::with_capacity(packing.particles.len());
    for p in &packing.particles {
        let (c, r, o) = match p.body() {
            Body::Ball { center, radius } => (center, radius, None),
            Body::Ellipsoid {
                center,
                bound,
                oriented,
            } => (center, bound, Some(Box::new(oriented))),
            Body::Convex(_) => return verify_convex_with(packing, terms),
        };
        balls.push(Ball { c, r });
        oriented.push(o);
    }
    let (tol, gap, wall_gap) = (terms.tol, terms.gap, terms.wall_gap);
    let mut out = Verification::new(balls.len(), balls.len(), tol);
    for problem in terms.problems {
        out.violate(problem);
    }
    for (i, (p, b)) in packing.particles.iter().zip(&balls).enumerate() {
        if !b.c.iter().all(|x| x.is_finite()) {
            out.violate(format!("particle {i}: non-finite centre"));
        } else if let Some(e) = p.size_error() {
            out.violate(format!("particle {i}: {e}"));
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
        .zip(&oriented)
        .map(|(b, o)| match o {
            Some(e) => e.volume,
            None => 4.0 / 3.0 * std::f64::consts::PI * b.r.powi(3),
        })
        .sum();
    out.packing_fraction = sphere_volume / volume;

    // Containment.
    for (i, b) in balls.iter().enumerate() {
        // Half-width of the particle along axis k (the radius for a sphere).
        let half = |k: usize| oriented[i].as_ref().map_or(b.r, |e| e.m[k][k].sqrt());
        let wall_distance = match &packing.container {
            ContainerRecord::Box { .. } => (0..3)
                .filter(|&k| !periodic[k])
                .map(|k| (b.c[k] - lo[k]).min(hi[k] - b.c[k]) - half(k) + b.r)
                .fold(f64::INFINITY, f64::min),
            ContainerRecord::Cylinder {
                base_center,
                radius,
                height,
            } => {
                let rho = (b.c[0] - base_center[0]).hypot(b.c[1] - base_center[1]);
                let z = b.c[2] - base_center[2];
                (radius - rho).min(z.min(height - z) - half(2) + b.r)
            }
        };
        for k in 0..3 {
            if periodic[k] && !(b.c[k] >= lo[k] && b.c[k] <= hi[k]) {
                out.violate(format!(
                    "particle {i}: centre {:?} is not wrapped into the periodic box",
                    b.c
                ));
            }
        }
        if wall_distance.is_finite() {
            let g = wall_distance - b.r;
            out.min_wall_gap = Some(out.min_wall_gap.map_or(g, |m: f64| m.min(g)));
            let rel = g / b.r;
            if out.min_wall_gap_relative.is_none_or(|m| rel < m) {
                out.min_wall_gap_relative = Some(rel);
            }
            if wall_distance < (1.0 - tol) * b.r {
                out.overlap(format!(
                    "particle {i} (radius {}) crosses a wall: its surface gap {g:e} is {rel:.3e} \
                     of its radius, beyond the tolerance {tol:e}",
                    b.r
                ));
            } else if wall_distance < (1.0 - tol) * b.r + wall_gap {
                out.broken_claim(format!(
                    "particle {i} (radius {}) is {wall_distance} from a wall: the claimed \
                     wall_gap {wall_gap} needs ≥ {}",
                    b.r,
                    b.r + wall_gap
                ));
            }
        }
    }

    // Pairs through levels of cells ([`PairLevels`]): a conflict is closer than the sum of
    // the two contact radii `r + gap/2`. One level of cells as wide as the largest grain
    // would hold thousands of small grains per cell for concrete (size ratio 32): a quadratic
    // search at 10⁶ grains.
    let len = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    let pairs = PairLevels::new(
        lo,
        len,
        periodic,
        balls.len(),
        |i| balls[i].c,
        |i| 2.0 * balls[i].r + gap,
    );
    // A particle against its own images. An ellipsoid: every image its bounding sphere
    // reaches, claimed gap included (each pair of opposite shifts once), since a needle
    // longer than the box edge along its axis overlaps itself. A sphere: its nearest image,
    // one shortest periodic edge away (every other lattice vector is longer), once that
    // image is within the contact reach `2r + gap`.
    let nearest = Nearest::new(balls.len());
    let shortest_edge = (0..3)
        .filter(|&k| periodic[k])
        .map(|k| len[k])
        .fold(f64::INFINITY, f64::min);
    for (i, (b, o)) in balls.iter().zip(&oriented).enumerate() {
        let Some(e) = o else {
            if shortest_edge < 2.0 * b.r + gap {
                check_spheres(&mut out, &nearest, (i, i), shortest_edge, (b.r, b.r), gap);
            }
            continue;
        };
        let reach = 2.0 * b.r + gap;
        let Some(shifts) = lattice_shifts(&Vector3::zeros(), reach, &len, periodic) else {
            too_many_images(&mut out, i, i);
            continue;
        };
        for t in shifts {
            if t.iter()
                .copied()
                .find(|v| *v != 0.0)
                .is_some_and(|v| v > 0.0)
            {
                check_ellipsoids(&mut out, (i, i), &e.m, &e.m, &t, (gap, 2.0 * e.a_min));
            }
        }
    }
    // Pairs, in chunks of consecutive particles on all threads: each chunk reports its own
    // findings (merged in chunk order, so the report is that of one thread, violations in
    // particle order), and the nearest gap per particle is lowered through atomics.
    let chunk = (balls.len() / (8 * rayon::current_num_threads())).clamp(1, 1 << 16);
    let starts: Vec<usize> = (0..balls.len()).step_by(chunk).collect();
    let parts: Vec<Verification> = starts
        .into_par_iter()
        .map(|start| {
            let mut out = Verification::new(balls.len(), 0, tol);
            let mut seen: Vec<u32> = Vec::with_capacity(27);
            for i in start..(start + chunk).min(balls.len()) {
                let bi = &balls[i];
                pairs.for_each_pair_of(i, &bi.c, &mut seen, |j| {
                    let bj = &balls[j];
                    let mut d2 = 0.0;
                    let mut dv = [0.0; 3];
                    for k in 0..3 {
                        let mut d = bi.c[k] - bj.c[k];
                        if periodic[k] {
                            d -= len[k] * (d / len[k]).round();
                        }
                        dv[k] = d;
                        d2 += d * d;
                    }
                    if oriented[i].is_some() || oriented[j].is_some() {
                        // Every periodic image whose bounding sphere reaches `i`'s (a
                        // needle as long as the box meets several images of a partner).
                        let d = Vector3::from(dv);
                        let mi = shape_matrix_of(oriented[i].as_deref(), bi.r);
                        let mj = shape_matrix_of(oriented[j].as_deref(), bj.r);
                        // The gap claim is certified through the smallest semi-axes.
                        let inner = oriented[i].as_ref().map_or(bi.r, |e| e.a_min)
                            + oriented[j].as_ref().map_or(bj.r, |e| e.a_min);
                        // Bounding spheres more than the claimed gap apart keep every promise.
                        let reach = bi.r + bj.r + gap;
                        let Some(shifts) = lattice_shifts(&d, reach, &len, periodic) else {
                            too_many_images(&mut out, i, j);
                            return;
                        };
                        for t in shifts {
                            let image = d + t;
                            check_ellipsoids(&mut out, (i, j), &mi, &mj, &image, (gap, inner));
                        }
                        return;
                    }
                    check_spheres(&mut out, &nearest, (i, j), d2.sqrt(), (bi.r, bj.r), gap);
                });
            }
            out
        })
        .collect();
    for part in parts {
        out.absorb(part);
    }
    out.nearest_gap_relative = nearest.into_vec();
    out
}

/// The smallest relative gap of each particle to a neighbour, lowered from every thread of
/// the pair search: each `f64` is kept as a `u64` key whose unsigned order is the numbers'
/// order (sign bit flipped for `x ≥ 0`, every bit flipped for `x < 0`), so `fetch_min` is
/// `f64::min`. NaN is ignored, as `f64::min` ignores it.
struct Nearest(Vec<AtomicU64>);

impl Nearest {
    fn new(n: usize) -> Self {
        Self(
            (0..n)
                .map(|_| AtomicU64::new(Self::key(f64::INFINITY)))
                .collect(),
        )
    }

    fn key(x: f64) -> u64 {
        let bits = x.to_bits();
        if bits >> 63 == 0 {
            bits | 1 << 63
        } else {
            !bits
        }
    }

    fn value(key: u64) -> f64 {
        f64::from_bits(if key >> 63 == 1 {
            key & !(1 << 63)
        } else {
            !key
        })
    }

    fn lower(&self, i: usize, x: f64) {
        if !x.is_nan() {
            self.0[i].fetch_min(Self::key(x), Ordering::Relaxed);
        }
    }

    fn into_vec(self) -> Vec<f64> {
        self.0
            .into_iter()
            .map(|k| Self::value(k.into_inner()))
            .collect()
    }
}

/// Records the check of spheres `i` and `j` (`i == j`: a sphere and its own image) of radii
/// `r` whose centres are `dist` apart, against the claimed gap `gap`.
fn check_spheres(
    out: &mut Verification,
    nearest: &Nearest,
    (i, j): (usize, usize),
    dist: f64,
    r: (f64, f64),
    gap: f64,
) {
    let (sum, tol) = (r.0 + r.1, out.tolerance);
    let rel = dist / sum - 1.0;
    nearest.lower(i, rel);
    nearest.lower(j, rel);
    if out.min_pair_gap_relative.is_none_or(|m| rel < m) {
        out.min_pair_gap_relative = Some(rel);
    }
    let abs = dist - sum;
    if out.min_pair_gap.is_none_or(|m| abs < m) {
        out.min_pair_gap = Some(abs);
    }
    // Named only for a violation: formatting every checked pair cost a quarter of the
    // check's time at 10⁶ spheres.
    let whom = || {
        if i == j {
            format!("particle {i} (radius {}) and its own periodic image", r.0)
        } else {
            format!("particles {i} and {j} (radii {} + {})", r.0, r.1)
        }
    };
    if dist < (1.0 - tol) * sum {
        out.overlap(format!(
            "{} overlap: {dist} apart, relative gap {rel:.3e} beyond the tolerance {tol:e}",
            whom()
        ));
    } else if dist < (1.0 - tol) * sum + gap {
        out.broken_claim(format!(
            "{} are {dist} apart: the claimed min_gap {gap} needs ≥ {}",
            whom(),
            sum + gap
        ));
    }
}

/// Candidate pairs of balls through levels of cells, each counting-sorted by cell: the pair
/// search of [`verify`] and of the analysis ([`crate::analysis`]), both independent of the
/// kernel's cell grid and lists. A pair to find is closer than `(D_i + D_j)/2`, `D` each
/// ball's *reach diameter* (for the overlap check the contact diameter `2r + gap`).
///
/// Level 0 has cells at least as wide as the largest `D`, each finer level half as wide,
/// down to the smallest `D` or until a level would have more than about 2 cells per ball
/// (at most 64 levels). A ball belongs to the finest level whose cells are at least `D`
/// wide. A partner `j` at a level `l` no finer than `i`'s has `D_j ≤ h_l` and `D_i ≤ h_l`,
/// so a pair to find lies in the 3 × 3 × 3 cells around `i` at level `l`: each pair is found
/// from its finer ball (at one level, from the lower index), and a search costs the same
/// per ball whatever the size ratio. Memory: a byte per ball, 4 bytes per ball and per cell.
pub(crate) struct PairLevels {
    levels: Vec<PairLevel>,
    level_of: Vec<u8>,
}

impl PairLevels {
    /// The levels of `n` balls with centres `centre(i)` and reach diameters `diameter(i)` in
    /// the box `[lo, lo + len]` (axes `periodic` wrap).
    pub(crate) fn new(
        lo: [f64; 3],
        len: [f64; 3],
        periodic: [bool; 3],
        n: usize,
        centre: impl Fn(usize) -> [f64; 3],
        diameter: impl Fn(usize) -> f64,
    ) -> Self {
        let (d_min, d_max) = (0..n)
            .map(&diameter)
            .fold((f64::INFINITY, 0.0_f64), |m, d| (m.0.min(d), m.1.max(d)));
        let max_cells = 2 * n as i64 + 27;
        let cells_along = |h: f64| -> [i64; 3] {
            // A ratio that is not a number (an infinite extent over an infinite width) counts
            // one cell, so that the width search below always ends.
            std::array::from_fn(|k| {
                let cells = (len[k] / h).floor();
                if cells >= 1.0 {
                    cells.min(1e6) as i64
                } else {
                    1
                }
            })
        };
        let mut widths = vec![d_max.max(f64::MIN_POSITIVE)];
        while cells_along(widths[0]).iter().product::<i64>() > max_cells {
            widths[0] *= 1.25;
        }
        // Any prefix of the halvings is a valid set of levels, since every ball fits the
        // coarsest one. An infinite width (radii near `f64::MAX`) halves to itself and ends
        // the halving too.
        while widths.len() < 64 {
            let h = 0.5 * widths[widths.len() - 1];
            // Negated comparison: a NaN width ends the halving too.
            let holds_the_smallest = h >= d_min;
            if !holds_the_smallest
                || !h.is_finite()
                || cells_along(h).iter().product::<i64>() > max_cells
            {
                break;
            }
            widths.push(h);
        }
        let level_of: Vec<u8> = (0..n)
            .map(|i| {
                let d = diameter(i);
                widths.iter().rposition(|&h| h >= d).unwrap_or(0) as u8
            })
            .collect();
        let levels = widths
            .iter()
            .enumerate()
            .map(|(l, &h)| {
                let members = (0..n).filter(|&i| level_of[i] as usize == l);
                PairLevel::sorted(h, cells_along(h), lo, len, periodic, &centre, members)
            })
            .collect();
        Self { levels, level_of }
    }

    /// Calls `f(j)` for the candidate partners `j` of ball `i` (centre `c`) that find their
    /// pair from `i`: the balls of coarser levels and those of `i`'s level with `j > i`, in
    /// the cells around `i`. Over all `i` every pair closer than `(D_i + D_j)/2` is visited
    /// exactly once. `seen` is scratch.
    pub(crate) fn for_each_pair_of(
        &self,
        i: usize,
        c: &[f64; 3],
        seen: &mut Vec<u32>,
        mut f: impl FnMut(usize),
    ) {
        let own = self.level_of[i] as usize;
        for (l, level) in self.levels[..=own].iter().enumerate() {
            level.cells_within(c, level.width, seen);
            for &cell in seen.iter() {
                for j in level.members(cell).iter().map(|&j| j as usize) {
                    if l < own || j > i {
                        f(j);
                    }
                }
            }
        }
    }

    /// Calls `f(j)` once for every ball `j` (at any level, a ball at `c` itself included)
    /// that may be closer to the point `c` than `(d + D_j)/2`. `seen` is scratch.
    pub(crate) fn for_each_near(
        &self,
        c: &[f64; 3],
        d: f64,
        seen: &mut Vec<u32>,
        mut f: impl FnMut(usize),
    ) {
        for level in &self.levels {
            level.cells_within(c, 0.5 * (d + level.width), seen);
            for &cell in seen.iter() {
                level.members(cell).iter().for_each(|&j| f(j as usize));
            }
        }
    }
}

/// One level of [`PairLevels`]: a box of `ncell` cells per axis, each at least `width`
/// wide, and its balls counting-sorted by cell (the members of cell `c` are
/// `sorted[start[c]..start[c + 1]]`): 4 bytes per ball and per cell, no allocation per cell.
struct PairLevel {
    width: f64,
    lo: [f64; 3],
    len: [f64; 3],
    periodic: [bool; 3],
    ncell: [i64; 3],
    start: Vec<u32>,
    sorted: Vec<u32>,
}

impl PairLevel {
    /// The level of `ncell` cells (at least `width` wide) over the box `[lo, lo + len]`
    /// holding the balls `members` (ascending indices) with centres `centre(i)`.
    fn sorted(
        width: f64,
        ncell: [i64; 3],
        lo: [f64; 3],
        len: [f64; 3],
        periodic: [bool; 3],
        centre: impl Fn(usize) -> [f64; 3],
        members: impl Iterator<Item = usize> + Clone,
    ) -> Self {
        let mut level = Self {
            width,
            lo,
            len,
            periodic,
            ncell,
            start: vec![0u32; ncell.iter().product::<i64>() as usize + 1],
            sorted: Vec::new(),
        };
        for i in members.clone() {
            let c = level.linear(&level.key(&centre(i)));
            level.start[c + 1] += 1;
        }
        for c in 1..level.start.len() {
            level.start[c] += level.start[c - 1];
        }
        level.sorted = vec![0u32; level.start[level.start.len() - 1] as usize];
        let mut fill = level.start.clone();
        for i in members {
            let c = level.linear(&level.key(&centre(i)));
            level.sorted[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        level
    }

    /// Cell coordinates of point `c` (clamped to the box).
    fn key(&self, c: &[f64; 3]) -> [i64; 3] {
        std::array::from_fn(|k| {
            let x = ((c[k] - self.lo[k]) / (self.len[k] / self.ncell[k] as f64)).floor() as i64;
            x.clamp(0, self.ncell[k] - 1)
        })
    }

    fn linear(&self, k: &[i64; 3]) -> usize {
        ((k[0] * self.ncell[1] + k[1]) * self.ncell[2] + k[2]) as usize
    }

    /// The balls sorted into cell `c`.
    fn members(&self, c: u32) -> &[u32] {
        &self.sorted[self.start[c as usize] as usize..self.start[c as usize + 1] as usize]
    }

    /// The cells that meet the cube of half-width `rho` around point `c`, each once, into
    /// `out`. The block is counted from `c`'s cell ([`Self::key`], clamped to the box), so
    /// with `rho` up to the cell width it is the 3 × 3 × 3 block around that cell, clipped
    /// at walls; along a periodic axis a span of `ncell` cells or more gives each cell
    /// once. The extents are worked out in floating point and compared before any
    /// conversion, so that no point, reach or box size (huge, tiny, infinite or NaN) can
    /// make a span overflow: at worst the whole axis is taken.
    fn cells_within(&self, c: &[f64; 3], rho: f64, out: &mut Vec<u32>) {
        out.clear();
        let key = self.key(c);
        let span = |k: usize| -> (i64, i64) {
            let n = self.ncell[k];
            let width = self.len[k] / n as f64;
            let x = (c[k] - self.lo[k]) / width;
            let (fraction, reach) = (x - x.floor(), rho / width);
            // Cells below and above `c`'s own that the interval `x ± reach` meets.
            let below = (reach - fraction).ceil().max(0.0);
            let above = (fraction + reach).floor().max(0.0);
            // A span of the whole axis or more (or NaN): the whole axis.
            let shorter_than_the_axis = below + above + 1.0 < n as f64;
            if !shorter_than_the_axis {
                return (0, n - 1);
            }
            let centre = key[k] as f64;
            if self.periodic[k] {
                ((centre - below) as i64, (centre + above) as i64)
            } else {
                let clip = |v: f64| v.max(0.0).min((n - 1) as f64) as i64;
                (clip(centre - below), clip(centre + above))
            }
        };
        let (xs, ys, zs) = (span(0), span(1), span(2));
        let wrap = |k: usize, x: i64| x.rem_euclid(self.ncell[k]);
        for x in xs.0..=xs.1 {
            for y in ys.0..=ys.1 {
                for z in zs.0..=zs.1 {
                    out.push(self.linear(&[wrap(0, x), wrap(1, y), wrap(2, z)]) as u32);
                }
            }
        }
    }
}

/// Records the Perram–Wertheim check of ellipsoids (or spheres) `i` and `j` with shape matrices
/// `mi`, `mj` whose centres are `d` apart (`j`'s image as given), against the claimed gap
/// `claim.0`. Scaling a body by `s ≥ 1` about its centre covers it grown by `(s − 1)` times
/// its smallest semi-axis, so bodies that touch only when scaled by `s` are at least
/// `(s − 1)·inner` apart, `inner = claim.1` the sum of their smallest semi-axes: the claim
/// holds when `s − 1 ≥ gap/inner − tol` (exact for spheres; for other shapes it may reject a
/// kept claim, never accept a broken one).
fn check_ellipsoids(
    out: &mut Verification,
    (i, j): (usize, usize),
    mi: &[[f64; 3]; 3],
    mj: &[[f64; 3]; 3],
    d: &Vector3<f64>,
    claim: (f64, f64),
) {
    let tol = out.tolerance;
    let needed = if claim.0 > 0.0 {
        claim.0 / claim.1
    } else {
        0.0
    };
    // A pair that is neither an overlap, nor the new closest one, nor closer than the claim
    // needs no exact scale.
    let floor = out
        .min_pair_gap_relative
        .map_or(f64::INFINITY, |m| m.max(0.0).max(needed));
    let scale = contact_scale_above(mi, mj, &[d.x, d.y, d.z], floor);
    let rel = scale - 1.0;
    if out.min_pair_gap_relative.is_none_or(|m| rel < m) {
        out.min_pair_gap_relative = Some(rel);
    }
    // Named only for a violation (see `check_spheres`).
    let whom = || {
        if i == j {
            format!(
                "particle {i} and its own periodic image at {:?}",
                [d.x, d.y, d.z]
            )
        } else {
            format!("particles {i} and {j} (image at {:?})", [d.x, d.y, d.z])
        }
    };
    if scale.is_nan() || scale < 1.0 - tol {
        out.overlap(format!(
            "{} overlap: they touch only when scaled by {scale} (Perram–Wertheim), \
             beyond the tolerance {tol:e}",
            whom()
        ));
    } else if claim.0 > 0.0 && rel < needed - tol {
        out.broken_claim(format!(
            "{}: the claimed min_gap {} is not certified (they touch when scaled by \
             {scale}, at least {:e} apart)",
            whom(),
            claim.0,
            rel * claim.1
        ));
    }
}

/// Most lattice translations [`lattice_shifts`] enumerates for one pair: a needle as long as
/// a few box edges needs 10²; a file whose particles reach further (a box far smaller than
/// its particles) is reported as not checked instead of looping for ever.
const MAX_IMAGES: f64 = 1e5;

/// Reports a pair (`i == j`: a particle and its images) whose images are too many to test;
/// a violation, since the pair was not checked.
fn too_many_images(out: &mut Verification, i: usize, j: usize) {
    out.violate(format!(
        "particles {i} and {j}: more than {MAX_IMAGES:e} periodic images within reach (the \
         box is far smaller than the particles); not checked"
    ));
}

/// Lattice translations `t` (along the periodic axes of edges `len`) with `|d + t| < reach`,
/// for a separation `d` that is a minimum image on the periodic axes (`|d_k| ≤ L_k/2`);
/// `None` when more than [`MAX_IMAGES`] translations (or a non-finite number) would be
/// tested.
fn lattice_shifts(
    d: &Vector3<f64>,
    reach: f64,
    len: &[f64; 3],
    periodic: [bool; 3],
) -> Option<Vec<Vector3<f64>>> {
    let m: [f64; 3] = std::array::from_fn(|k| {
        if periodic[k] {
            (reach / len[k] + 0.5).floor()
        } else {
            0.0
        }
    });
    let count: f64 = m.iter().map(|x| 2.0 * x + 1.0).product();
    if count.is_nan() || count > MAX_IMAGES {
        return None;
    }
    let m = m.map(|x| x as i64);
    let mut all = Vec::new();
    for nx in -m[0]..=m[0] {
        for ny in -m[1]..=m[1] {
            for nz in -m[2]..=m[2] {
                let t = Vector3::new(nx as f64 * len[0], ny as f64 * len[1], nz as f64 * len[2]);
                if (d + t).norm() < reach {
                    all.push(t);
                }
            }
        }
    }
    Some(all)
}

/// The point of the convex hull of `pts` (1 to 4 points) nearest to the origin, and the
/// points spanning the face it lies on. Every non-empty subset is tried: its affine
/// minimiser (normal equations of the barycentric weights) is kept when all weights are
/// non-negative; the nearest kept point is the answer (it lies in the relative interior of
/// some face, where the affine minimiser is that point).
fn nearest_in_hull(pts: &[Vector3<f64>]) -> (Vector3<f64>, Vec<Vector3<f64>>) {
    let mut best: Option<(f64, Vector3<f64>, Vec<Vector3<f64>>)> = None;
    for mask in 1u32..(1 << pts.len()) {
        let face: Vec<Vector3<f64>> = (0..pts.len())
            .filter(|k| mask & (1 << k) != 0)
            .map(|k| pts[k])
            .collect();
        let base = face[0];
        let edges: Vec<Vector3<f64>> = face[1..].iter().map(|p| p - base).collect();
        let m = edges.len();
        // Gram system G μ = −Eᵀ base, at most 3×3.
        let mut g = nalgebra::Matrix3::<f64>::identity();
        let mut rhs = Vector3::zeros();
        for i in 0..m {
            for j in 0..m {
                g[(i, j)] = edges[i].dot(&edges[j]);
            }
            rhs[i] = -edges[i].dot(&base);
        }
        let Some(inv) = g.try_inverse() else {
            continue;
        };
        let mu = inv * rhs;
        let weight0 = 1.0 - (0..m).map(|i| mu[i]).sum::<f64>();
        if weight0 < 0.0 || (0..m).any(|i| mu[i] < 0.0) || !weight0.is_finite() {
            continue;
        }
        // For a triangle the minimiser is the foot of the perpendicular on its plane,
        // taken along the normal `e₁ × e₂`: the normal equations square the condition of a
        // thin triangle, and their error along the face turns the direction of a point
        // this near the origin (GJK then stalls short of a certificate for a body within
        // 10⁻⁶ of its size of a cylinder's side, as the relaxer leaves them).
        let normal = if m == 2 {
            edges[0].cross(&edges[1])
        } else {
            Vector3::zeros()
        };
        let point = if normal.norm_squared() > 0.0 {
            normal * (normal.dot(&base) / normal.norm_squared())
        } else {
            base + (0..m).map(|i| edges[i] * mu[i]).sum::<Vector3<f64>>()
        };
        let d = point.norm_squared();
        if best.as_ref().is_none_or(|b| d < b.0) {
            best = Some((d, point, face));
        }
    }
    let (_, point, face) = best.expect("a single point is always its own nearest point");
    (point, face)
}

/// Outcome of one pair.
enum PairCheck {
    /// Certified apart; the lower bound of the surface distance of the (uneroded) bodies
    /// along the certifying direction.
    Separated(f64),
    /// A common point of the eroded bodies was found.
    Overlapping,
    /// No certificate either way within the iteration budget.
    Undecided,
}

/// Separation of the eroded bodies `a`, `b` (see the module documentation); `a_full`,
/// `b_full` give the reported gap.
fn check_pair(a_full: &dyn SupportMap, b_full: &dyn SupportMap, tol: f64) -> PairCheck {
    let a = a_full.eroded(tol * a_full.radius());
    let b = b_full.eroded(tol * b_full.radius());
    let size = a_full.bound().max(b_full.bound());
    if let (Some((ca, ra)), Some((cb, rb))) = (a_full.as_ball(), b_full.as_ball()) {
        let gap = (cb - ca).norm() - ra - rb;
        return if gap > -tol * (ra + rb) {
            PairCheck::Separated(gap)
        } else {
            PairCheck::Overlapping
        };
    }
    // GJK on the Minkowski difference A − B: `v` is the point of the current simplex nearest
    // to the origin; `−v` is the candidate direction from A to B.
    let support = |d: &Vector3<f64>| a.support_point(d) - b.support_point(&-d);
    let mut v = a.center() - b.center();
    let mut simplex: Vec<Vector3<f64>> = Vec::with_capacity(4);
    for _ in 0..1000 {
        let n = v.norm();
        if n <= 1e-14 * size {
            return PairCheck::Overlapping;
        }
        let dir = -v / n;
        // The plane normal to `dir` separates iff min_B − max_A > 0.
        if -b.support(&-dir) - a.support(&dir) > 0.0 {
            return PairCheck::Separated(-b_full.support(&-dir) - a_full.support(&dir));
        }
        let w = support(&-v);
        if n * n - v.dot(&w) <= 1e-15 * size * size {
            // No progress: v is as near as floating point gets without a certificate.
            return PairCheck::Undecided;
        }
        simplex.push(w);
        let (nearest, face) = nearest_in_hull(&simplex);
        if face.len() == 4 {
            return PairCheck::Overlapping;
        }
        v = nearest;
        simplex = face;
    }
    PairCheck::Undecided
}

/// Checks a packing with cylinders (and spheres) in a periodic box: wrapped centres, valid
/// sizes, and every pair of bodies — every periodic image across faces, edges and corners,
/// and each body against its own images — certified apart by a separating plane of the
/// bodies eroded by the tolerance times their radius. A claimed `min_gap` holds for a pair
/// when the certificate's lower bound of the surface distance is at least
/// `min_gap − tol·(r_a + r_b)` (it may reject a kept claim, never accept a broken one). Pairs
/// are enumerated directly (`O(N²)` bounding-sphere tests: mixture RVEs hold hundreds of
/// bodies).
fn verify_convex_with(packing: &Packing, terms: Terms) -> Verification {
    let (tol, claimed) = (terms.tol, terms.gap);
    let mut out = Verification::new(packing.particles.len(), 0, tol);
    for problem in terms.problems {
        out.violate(problem);
    }
    let ContainerRecord::Box { min, max, periodic } = &packing.container else {
        out.violate(
            "cylinders (and other convex bodies) are checked in periodic boxes only".into(),
        );
        return out;
    };
    if periodic.iter().any(|p| !p) {
        out.violate(
            "cylinders (and other convex bodies) are checked in fully periodic boxes only".into(),
        );
        return out;
    }
    let lo = Vector3::from(*min);
    let len = Vector3::from(*max) - lo;
    let mut bodies = Vec::with_capacity(packing.particles.len());
    for (i, p) in packing.particles.iter().enumerate() {
        let body: Box<dyn SupportMap> = match p.body() {
            Body::Ball { center, radius } => Box::new(Ball {
                c: center,
                r: radius,
            }),
            Body::Convex(body) => body,
            Body::Ellipsoid { .. } => {
                out.violate(format!(
                    "particle {i}: {}s are not checked beside other convex bodies",
                    p.kind()
                ));
                continue;
            }
        };
        let c = body.center();
        if c.iter().any(|x| !x.is_finite()) {
            out.violate(format!("particle {i}: non-finite centre"));
            continue;
        }
        if let Some(e) = p.size_error() {
            out.violate(format!("particle {i}: {e}"));
            continue;
        }
        if (0..3).any(|k| !(c[k] >= lo[k] && c[k] <= lo[k] + len[k])) {
            out.violate(format!(
                "particle {i}: centre {c:?} is not wrapped into the periodic box"
            ));
        }
        bodies.push((i, body));
    }
    out.packing_fraction =
        bodies.iter().map(|(_, b)| b.volume()).sum::<f64>() / (len.x * len.y * len.z);
    let record =
        |out: &mut Verification, i: usize, j: usize, a: &dyn SupportMap, b: &dyn SupportMap| {
            let radii = a.radius() + b.radius();
            match check_pair(a, b, tol) {
                PairCheck::Separated(gap) => {
                    if out.min_pair_gap.is_none_or(|m| gap < m) {
                        out.min_pair_gap = Some(gap);
                    }
                    let rel = gap / radii;
                    if out.min_pair_gap_relative.is_none_or(|m| rel < m) {
                        out.min_pair_gap_relative = Some(rel);
                    }
                    if claimed > 0.0 && gap < claimed - tol * radii {
                        out.broken_claim(format!(
                            "particles {i} and {j} (or images): the claimed min_gap {claimed} is \
                         not certified (at least {gap:e} apart)"
                        ));
                    }
                }
                PairCheck::Overlapping => out.overlap(format!(
                    "particles {i} and {j} (or images) overlap beyond the tolerance {tol:e}"
                )),
                PairCheck::Undecided => out.violate(format!(
                    "particles {i} and {j}: separation could not be certified"
                )),
            }
        };
    let edges = [len.x, len.y, len.z];
    // Bodies whose bounding spheres are more than the claimed gap apart keep every promise.
    let shifts =
        |d: &Vector3<f64>, reach: f64| lattice_shifts(d, reach + claimed, &edges, [true; 3]);
    for (x, (i, a)) in bodies.iter().enumerate() {
        // A body against its own images (each ±t pair once).
        match shifts(&Vector3::zeros(), 2.0 * a.bound()) {
            None => too_many_images(&mut out, *i, *i),
            Some(own) => {
                for t in own {
                    let first = t.iter().copied().find(|v| *v != 0.0);
                    if first.is_some_and(|v| v > 0.0) {
                        record(&mut out, *i, *i, a.as_ref(), a.shifted(t).as_ref());
                    }
                }
            }
        }
        for (j, b) in &bodies[x + 1..] {
            let mut d = b.center() - a.center();
            for k in 0..3 {
                d[k] -= len[k] * (d[k] / len[k]).round();
            }
            let base = d - (b.center() - a.center());
            let Some(images) = shifts(&d, a.bound() + b.bound()) else {
                too_many_images(&mut out, *i, *j);
                continue;
            };
            for t in images {
                record(&mut out, *i, *j, a.as_ref(), b.shifted(base + t).as_ref());
            }
        }
    }
    out
}

/// `M` of a particle: its ellipsoid's, or `r²·I` for a sphere of radius `r`.
fn shape_matrix_of(o: Option<&Oriented>, r: f64) -> [[f64; 3]; 3] {
    match o {
        Some(e) => e.m,
        None => [[r * r, 0.0, 0.0], [0.0, r * r, 0.0], [0.0, 0.0, r * r]],
    }
}

/// `√max_λ F(λ)` of the Perram–Wertheim function for centres `d` apart: the factor by which
/// both particles must be scaled about their centres to touch (`< 1`: overlap).
/// `F` is concave in λ, so golden-section search finds the maximum.
pub fn contact_scale(mi: &[[f64; 3]; 3], mj: &[[f64; 3]; 3], d: &[f64; 3]) -> f64 {
    contact_scale_above(mi, mj, d, f64::INFINITY)
}

/// [`contact_scale`], or a lower bound `s` of it with `s − 1 > floor` as soon as the search
/// has seen one (`F(λ) ≤ max F` for every λ): such a pair neither overlaps (`floor ≥ 0`) nor
/// is closer than a pair at relative gap `floor`. Most pairs of a packing are far apart and
/// show it at the first evaluations; only the close ones need the 80 golden-section steps.
fn contact_scale_above(mi: &[[f64; 3]; 3], mj: &[[f64; 3]; 3], d: &[f64; 3], floor: f64) -> f64 {
    let f = |l: f64| -> f64 {
        let mut g = [[0.0; 3]; 3];
        for a in 0..3 {
            for b in 0..3 {
                g[a][b] = (1.0 - l) * mi[a][b] + l * mj[a][b];
            }
        }
        // dᵀG⁻¹d by the adjugate: G⁻¹ = adj(G)/det(G).
        let c = |a: usize, b: usize| {
            let (a1, a2) = ((a + 1) % 3, (a + 2) % 3);
            let (b1, b2) = ((b + 1) % 3, (b + 2) % 3);
            g[a1][b1] * g[a2][b2] - g[a1][b2] * g[a2][b1]
        };
        let det = g[0][0] * c(0, 0) + g[0][1] * c(0, 1) + g[0][2] * c(0, 2);
        let mut q = 0.0;
        for a in 0..3 {
            for b in 0..3 {
                q += d[a] * c(b, a) * d[b];
            }
        }
        l * (1.0 - l) * q / det
    };
    let ratio = 0.5 * (5f64.sqrt() - 1.0);
    let (mut lo, mut hi) = (0.0, 1.0);
    let mut x1 = hi - ratio * (hi - lo);
    let mut x2 = lo + ratio * (hi - lo);
    let (mut f1, mut f2) = (f(x1), f(x2));
    let above = |f: f64| (f.max(0.0).sqrt() - 1.0 > floor).then(|| f.sqrt());
    for _ in 0..80 {
        if let Some(bound) = above(f1.max(f2)) {
            return bound;
        }
        if f1 < f2 {
            lo = x1;
            x1 = x2;
            f1 = f2;
            x2 = lo + ratio * (hi - lo);
            f2 = f(x2);
        } else {
            hi = x2;
            x2 = x1;
            f2 = f1;
            x1 = hi - ratio * (hi - lo);
            f1 = f(x1);
        }
    }
    f1.max(f2).max(0.0).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_keys_order_as_the_numbers_and_ignore_nan() {
        let values = [
            f64::NEG_INFINITY,
            -1e300,
            -1.0,
            -f64::MIN_POSITIVE,
            -0.0,
            0.0,
            5e-324,
            1e-12,
            1.0,
            f64::INFINITY,
        ];
        for w in values.windows(2) {
            assert!(
                Nearest::key(w[0]) <= Nearest::key(w[1]),
                "{} {}",
                w[0],
                w[1]
            );
        }
        for &x in &values {
            assert_eq!(Nearest::value(Nearest::key(x)).to_bits(), x.to_bits());
        }
        let nearest = Nearest::new(2);
        nearest.lower(0, 0.5);
        nearest.lower(0, f64::NAN);
        nearest.lower(0, -0.25);
        nearest.lower(0, 0.1);
        assert_eq!(nearest.into_vec(), vec![-0.25, f64::INFINITY]);
    }

    /// The report does not depend on the number of threads: every field, the violations in
    /// the same order and every particle's nearest gap equal those of one thread, for a
    /// random, overlapping, polydisperse packing of 20 000 spheres and ellipsoids (one in
    /// ten) in a box periodic along x and y.
    #[test]
    fn the_check_on_many_threads_reports_what_one_thread_reports() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(11);
        let particles: Vec<ParticleRecord> = (0..20_000)
            .map(|i| {
                let center = std::array::from_fn(|_| rng.gen_range(0.0..40.0));
                let r = rng.gen_range(0.2..0.9);
                if i % 10 == 0 {
                    needle(center, 2.0 * r, rng.gen_range(0.0..180.0))
                } else {
                    ParticleRecord::sphere(center, r)
                }
            })
            .collect();
        let container = ContainerRecord::Box {
            min: [0.0; 3],
            max: [40.0; 3],
            periodic: [true, true, false],
        };
        let packing = Packing {
            min_gap: 0.01,
            ..Packing::new(container, particles)
        };
        let on = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| verify(&packing))
        };
        let one = on(1);
        assert!(one.overlap_count > 1000 && one.violations.len() == 20);
        for threads in [2, 3, 8] {
            let many = on(threads);
            assert_eq!(many.violations, one.violations);
            assert_eq!(
                (
                    many.violation_count,
                    many.overlap_count,
                    many.gap_claim_count
                ),
                (one.violation_count, one.overlap_count, one.gap_claim_count)
            );
            for (a, b) in [
                (many.min_pair_gap, one.min_pair_gap),
                (many.min_pair_gap_relative, one.min_pair_gap_relative),
                (many.min_wall_gap, one.min_wall_gap),
            ] {
                assert_eq!(a.map(f64::to_bits), b.map(f64::to_bits));
            }
            let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(
                bits(&many.nearest_gap_relative),
                bits(&one.nearest_gap_relative)
            );
        }
    }
    use crate::io::packing::ParticleRecord;
    use crate::io::record::{CylinderRecord, EllipsoidRecord, SphereRecord};

    /// A needle of semi-axes `a : 0.05 : 0.05` at `centre`, its long axis at `degrees` to x
    /// in the x-y plane.
    fn needle(centre: [f64; 3], a: f64, degrees: f64) -> ParticleRecord {
        let half = 0.5 * degrees.to_radians();
        ParticleRecord::Ellipsoid(EllipsoidRecord {
            center: centre,
            semi_axes: [a, 0.05, 0.05],
            orientation: [half.cos(), 0.0, 0.0, half.sin()],
        })
    }

    /// A cylinder whose bounding box reaches past `f64::MAX` (as a mutated packing can give)
    /// is refused as malformed, with a verdict: the cell grid's width search once never
    /// ended on its infinite extent.
    #[test]
    fn a_cylinder_reaching_past_the_largest_number_gets_a_verdict() {
        let container = ContainerRecord::Cylinder {
            base_center: [1.7e308, 0.0, 0.0],
            radius: 1e307,
            height: 10.0,
        };
        let particles = [[1.7e308, 0.0, 2.0], [1.7e308, 3.0, 2.0]]
            .map(|center| {
                ParticleRecord::Sphere(SphereRecord {
                    center,
                    radius: 1.0,
                })
            })
            .to_vec();
        let packing = Packing::new(container, particles);
        let refusal = packing.check().unwrap_err();
        assert!(
            refusal.starts_with(
                "container.base_center = [1.7e308, 0.0, 0.0] with radius 1e307 and height 10.0 \
                 reaches beyond ±1.7976931348623157e308"
            ),
            "{refusal}"
        );
        let report = verify(&packing);
        assert!(!report.ok());
        assert_eq!(report.particles, 2);
    }

    fn periodic_box(len: [f64; 3]) -> ContainerRecord {
        ContainerRecord::Box {
            min: [0.0; 3],
            max: len,
            periodic: [true; 3],
        }
    }

    /// The early exit of the contact scale: either the exact scale, or a lower bound of it
    /// beyond the floor (then the pair neither overlaps nor is the closest), on random
    /// pairs of needles and platelets at all distances, and the exact scale for the
    /// analytic side-by-side contact of two prolate spheroids `2 : 1 : 1` two apart.
    #[test]
    fn the_early_exit_of_the_contact_scale_is_exact_or_beyond_the_floor() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(5);
        let matrix = |rng: &mut rand_xoshiro::Xoshiro256PlusPlus| {
            let q = nalgebra::UnitQuaternion::from_scaled_axis(Vector3::from_fn(|_, _| {
                rng.gen_range(-3.0..3.0)
            }));
            let axes = if rng.gen_bool(0.5) {
                Vector3::new(1.0, 0.05, 0.05)
            } else {
                Vector3::new(1.0, 0.2, 1.0)
            };
            let r = q.to_rotation_matrix();
            let m = r.matrix()
                * nalgebra::Matrix3::from_diagonal(&axes.component_mul(&axes))
                * r.matrix().transpose();
            [0, 1, 2].map(|a| [0, 1, 2].map(|b| m[(a, b)]))
        };
        let (mut early, mut exact) = (0, 0);
        for _ in 0..2000 {
            let (mi, mj) = (matrix(&mut rng), matrix(&mut rng));
            let d = [0, 1, 2].map(|_| rng.gen_range(-2.0..2.0));
            let floor = rng.gen_range(0.0..0.5);
            let full = contact_scale(&mi, &mj, &d);
            let found = contact_scale_above(&mi, &mj, &d, floor);
            if found == full {
                exact += 1;
            } else {
                early += 1;
                assert!(
                    found - 1.0 > floor && found <= full,
                    "{found} {full} {floor}"
                );
            }
            if full - 1.0 <= floor {
                assert_eq!(found, full);
            }
        }
        assert!(early > 200 && exact > 200, "{early} early, {exact} exact");
        let m = [[4.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        let side = contact_scale_above(&m, &m, &[0.0, 2.0, 0.0], 0.0);
        assert!((side - 1.0).abs() < 1e-9, "{side}");
    }

    /// Every pair violation of spheres with radii 0.25–8 (log-uniform, size ratio 32: several
    /// search levels) is found, in a walled and in a partly periodic box: the count and the
    /// smallest gap equal those of the check of all `n (n − 1) / 2` pairs.
    #[test]
    fn spheres_of_size_ratio_32_are_checked_against_every_pair() {
        use rand::{Rng, SeedableRng};
        let len = [60.0, 50.0, 40.0];
        let gap = 0.3;
        for (seed, periodic, n) in [
            (1, [false; 3], 150),
            (2, [true, false, true], 150),
            (3, [false; 3], 400),
            (4, [true; 3], 400),
        ] {
            let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
            let balls: Vec<([f64; 3], f64)> = (0..n)
                .map(|_| {
                    let r = 0.25 * 32f64.powf(rng.gen::<f64>());
                    // Inside the walls with room for the wall gap: only pairs can violate.
                    let c = std::array::from_fn(|k| {
                        let m = if periodic[k] { 0.0 } else { r + gap };
                        m + rng.gen::<f64>() * (len[k] - 2.0 * m)
                    });
                    (c, r)
                })
                .collect();
            let mut expected = 0;
            let mut smallest = f64::INFINITY;
            for (i, (ci, ri)) in balls.iter().enumerate() {
                for (cj, rj) in &balls[i + 1..] {
                    let d2: f64 = (0..3)
                        .map(|k| {
                            let mut d = ci[k] - cj[k];
                            if periodic[k] {
                                d -= len[k] * (d / len[k]).round();
                            }
                            d * d
                        })
                        .sum();
                    let dist = d2.sqrt();
                    smallest = smallest.min(dist - (ri + rj));
                    expected += usize::from(dist < (1.0 - TOLERANCE) * (ri + rj) + gap);
                }
            }
            let container = ContainerRecord::Box {
                min: [0.0; 3],
                max: len,
                periodic,
            };
            let particles = balls
                .iter()
                .map(|&(center, radius)| ParticleRecord::Sphere(SphereRecord { center, radius }))
                .collect();
            let packing = Packing {
                min_gap: gap,
                ..Packing::new(container, particles)
            };
            let v = verify(&packing);
            assert!(
                expected > 0,
                "seed {seed}: the sample should hold violations"
            );
            assert_eq!(v.violation_count, expected, "seed {seed}");
            assert_eq!(v.min_pair_gap, Some(smallest), "seed {seed}");
        }
    }

    #[test]
    fn pair_levels_visit_every_near_pair_once() {
        use rand::{Rng, SeedableRng};
        // Reach diameters over a ratio of 40 (more than the concrete gradings' 32), boxes with
        // and without periodic axes, one of them only about two of the largest reaches wide
        // (a periodic axis of fewer than three cells at the coarse level).
        for (seed, len, periodic, n) in [
            (1, [12.0, 10.0, 8.0], [false; 3], 2000),
            (2, [12.0, 10.0, 8.0], [true, false, true], 2000),
            (3, [7.0, 12.0, 12.0], [true; 3], 2000),
        ] {
            let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
            let balls: Vec<([f64; 3], f64)> = (0..n)
                .map(|_| {
                    let d = 0.1 * 40f64.powf(rng.gen::<f64>());
                    let c = std::array::from_fn(|k| rng.gen::<f64>() * len[k]);
                    (c, d)
                })
                .collect();
            let distance = |a: &[f64; 3], b: &[f64; 3]| -> f64 {
                (0..3)
                    .map(|k| {
                        let mut d = a[k] - b[k];
                        if periodic[k] {
                            d -= len[k] * (d / len[k]).round();
                        }
                        d * d
                    })
                    .sum::<f64>()
                    .sqrt()
            };
            let levels =
                PairLevels::new([0.0; 3], len, periodic, n, |i| balls[i].0, |i| balls[i].1);
            assert!(
                levels.levels.len() >= 3,
                "seed {seed}: a hierarchy of levels"
            );
            let mut seen = Vec::new();
            let mut visits = vec![0u32; n * n];
            for (i, (c, _)) in balls.iter().enumerate() {
                levels.for_each_pair_of(i, c, &mut seen, |j| {
                    visits[i.min(j) * n + i.max(j)] += 1;
                });
            }
            assert!(
                (0..n).all(|i| visits[i * n + i] == 0),
                "seed {seed}: a ball paired with itself"
            );
            let mut near_pairs = 0;
            for i in 0..n {
                for j in i + 1..n {
                    let count = visits[i * n + j];
                    assert!(
                        count <= 1,
                        "seed {seed}: pair ({i}, {j}) visited {count} times"
                    );
                    if distance(&balls[i].0, &balls[j].0) < 0.5 * (balls[i].1 + balls[j].1) {
                        assert_eq!(count, 1, "seed {seed}: near pair ({i}, {j}) missed");
                        near_pairs += 1;
                    }
                }
            }
            assert!(near_pairs > n / 2, "seed {seed}: {near_pairs} near pairs");
            // Around points (not only ball centres) with reaches of every size.
            for _ in 0..200 {
                let c: [f64; 3] = std::array::from_fn(|k| rng.gen::<f64>() * len[k]);
                let d = 0.1 * 40f64.powf(rng.gen::<f64>());
                let mut count = vec![0u32; n];
                levels.for_each_near(&c, d, &mut seen, |j| count[j] += 1);
                for (j, (cj, dj)) in balls.iter().enumerate() {
                    assert!(
                        count[j] <= 1,
                        "seed {seed}: ball {j} visited {} times",
                        count[j]
                    );
                    if distance(&c, cj) < 0.5 * (d + dj) {
                        assert_eq!(count[j], 1, "seed {seed}: ball {j} near {c:?} missed");
                    }
                }
            }
        }
    }

    /// Points far outside the box, boxes far smaller than the balls and reaches that are
    /// infinite or NaN give bounded blocks of cells (a span once overflowed into an endless
    /// loop), and a ball still finds its partner.
    #[test]
    fn pair_levels_stay_bounded_for_extreme_input() {
        for (len, periodic, centres, diameters) in [
            (
                [1e-300; 3],
                [true; 3],
                [[1.0; 3], [1.0, 1.0, 1.5]],
                [1.0, 1.0],
            ),
            (
                [1e-300; 3],
                [false; 3],
                [[1.0; 3], [1.0, 1.0, 1.5]],
                [1.0, 1.0],
            ),
            (
                [10.0; 3],
                [true, false, true],
                [[1e300; 3], [-1e300; 3]],
                [1.0, 1.0],
            ),
            (
                [10.0; 3],
                [true; 3],
                [[5.0; 3], [5.0, 5.0, 5.5]],
                [f64::INFINITY, 1.0],
            ),
            (
                [10.0; 3],
                [false; 3],
                [[5.0; 3], [5.0, 5.0, 5.5]],
                [f64::NAN, 1.0],
            ),
        ] {
            let levels =
                PairLevels::new([0.0; 3], len, periodic, 2, |i| centres[i], |i| diameters[i]);
            let cells: usize = levels.levels.iter().map(|l| l.start.len() - 1).sum();
            let mut seen = Vec::new();
            let mut partners = 0;
            for (i, c) in centres.iter().enumerate() {
                levels.for_each_pair_of(i, c, &mut seen, |_| partners += 1);
                assert!(
                    seen.len() <= cells,
                    "{} cells visited of {cells}",
                    seen.len()
                );
                for d in [1.0, f64::INFINITY, f64::NAN, 1e300] {
                    levels.for_each_near(c, d, &mut seen, |_| {});
                    assert!(
                        seen.len() <= cells,
                        "{} cells visited of {cells}",
                        seen.len()
                    );
                }
            }
            if diameters.iter().all(|d| d.is_finite()) && centres[0][0] == 1.0 {
                assert_eq!(partners, 1, "the two balls of {len:?} are found as a pair");
            }
        }
    }

    #[test]
    fn an_overlap_through_a_non_minimum_image_is_caught() {
        // Two needles at 10° in a cube of edge 4: the image of the second shifted by +4 in x
        // lies on the first's axis 2.2 away (tips overlap once a > 1.1); the minimum image is
        // a parallel needle 0.69 off the axis.
        let u = [10f64.to_radians().cos(), 10f64.to_radians().sin()];
        let a = [0.5, 1.5, 2.0];
        // `a + 2.2 u − 4x`, wrapped into the box.
        let b = [a[0] + 2.2 * u[0], a[1] + 2.2 * u[1], 2.0];
        for (semi_axis, overlaps) in [(1.12, true), (1.08, false)] {
            let packing = Packing::new(
                periodic_box([4.0; 3]),
                vec![needle(a, semi_axis, 10.0), needle(b, semi_axis, 10.0)],
            );
            let v = verify(&packing);
            assert_eq!(!v.ok(), overlaps, "a = {semi_axis}: {:?}", v.violations);
        }
    }

    /// A sphere beside the curved side of a cylinder, at a surface gap of `gap` times
    /// `r_c + r_s` (negative: penetration), as the mixture relaxer leaves them (gaps of
    /// 10⁻⁶ of the size): certified apart at gaps of 10⁻⁷–10⁻⁶, caught overlapping at a
    /// penetration of 10⁻⁷. Before the triangle case of `nearest_in_hull` took its point
    /// along the face normal, GJK stalled here ("could not be certified") for 9 of these
    /// 60 pairs at 10⁻⁶ and 41 at 10⁻⁷; at 10⁻⁸ it still stalls for about half (rounding
    /// of the simplex points, ~10⁻¹⁷, then turns the direction by more than the gap allows
    /// along the flat side), so the relaxer's margin of 10⁻⁶ is kept well above that.
    #[test]
    fn a_sphere_just_off_a_cylinder_side_is_certified() {
        let (rc, rs, h) = (0.10987012750848114, 0.16838903009606299, 0.3296103825254436);
        let mut failures = Vec::new();
        for k in 0..60 {
            // Axis direction, a side normal orthogonal to it, an axial position.
            let (t, p) = (0.37 * k as f64, 0.11 * k as f64 + 0.3);
            let u = Vector3::new(p.sin() * t.cos(), p.sin() * t.sin(), p.cos());
            let side = u.cross(&Vector3::new(t.sin(), 0.5, t.cos())).normalize();
            let axial = h * ((k as f64 * 0.61).sin() * 0.9);
            let centre = Vector3::new(0.5, 0.5, 0.5);
            for (gap, overlaps) in [(1e-6, false), (3e-7, false), (1e-7, false), (-1e-7, true)] {
                let s = centre + u * axial + side * ((rc + rs) * (1.0 + gap));
                let packing = Packing::new(
                    periodic_box([1.0; 3]),
                    vec![
                        ParticleRecord::Cylinder(CylinderRecord {
                            center: centre.into(),
                            radius: rc,
                            half_axis: (u * h).into(),
                        }),
                        ParticleRecord::Sphere(SphereRecord {
                            center: s.into(),
                            radius: rs,
                        }),
                    ],
                );
                let v = verify(&packing);
                if v.ok() == overlaps {
                    failures.push((k, gap, v.violations));
                }
            }
        }
        let by_gap: Vec<(f64, usize)> = [1e-6, 3e-7, 1e-7, -1e-7]
            .iter()
            .map(|g| (*g, failures.iter().filter(|f| f.1 == *g).count()))
            .collect();
        assert!(failures.is_empty(), "{by_gap:?}");
    }

    #[test]
    fn a_needle_longer_than_the_box_edge_overlaps_its_own_image() {
        for (semi_axis, overlaps) in [(1.02, true), (0.98, false)] {
            let packing = Packing::new(
                periodic_box([2.0, 3.0, 3.0]),
                vec![needle([1.0, 1.5, 1.5], semi_axis, 0.0)],
            );
            let v = verify(&packing);
            assert_eq!(!v.ok(), overlaps, "a = {semi_axis}: {:?}", v.violations);
            if overlaps {
                assert!(v.violations[0].contains("its own periodic image"));
            }
        }
    }
}
