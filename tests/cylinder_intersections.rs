//! Tests of the typed sphere/cylinder intersection tests against constructed cases and
//! against an independent oracle: the distance between two convex bodies computed by GJK
//! on support maps (written here, sharing no code with the library), and, for intersecting
//! pairs, the intersection type, depth, direction and point recomputed from the geometry.

use densepack::boundary::PeriodicBox;
use densepack::geometry::cylinder::{
    intersect_cylinder_cylinder, intersect_disk_disk, intersect_sphere_cylinder,
    intersect_sphere_sphere, overlaps, overlaps_decided_early, BaseContact, Body, Contact,
    Cylinder, CylinderContact, Disk, DiskDiskKind, DiskSideKind, End, Shape, Sphere,
    SphereCylinderKind,
};
use densepack::protocol::mixture::rsa::{CapsuleGrid, ImageScan};
use nalgebra::Vector3;
use rand::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;
use std::time::Instant;

type V = Vector3<f64>;

// ---------------------------------------------------------------- oracle: GJK distance

/// Support point of a shape in direction `d` (any point maximising `x·d`).
fn support(s: &Shape, d: &V) -> V {
    match s {
        Shape::Sphere(s) => {
            let n = d.norm();
            if n > 0.0 {
                s.center + d * (s.radius / n)
            } else {
                s.center
            }
        }
        Shape::Cylinder(c) => {
            let h = c.half_axis.norm();
            let u = c.half_axis / h;
            let du = d.dot(&u);
            let mut perp = d - u * du;
            perp -= u * perp.dot(&u);
            let pn = perp.norm();
            let axial = if du >= 0.0 { u * h } else { -u * h };
            // A (near-)axial direction: the base centre is a support point.
            let radial = if pn > 1e-12 * d.norm() {
                perp * (c.radius / pn)
            } else {
                V::zeros()
            };
            c.center + axial + radial
        }
    }
}

/// Closest point to the origin of the convex hull of `pts` (at most 4 points), by brute
/// force over all faces of the simplex, and the points of the supporting sub-simplex.
fn closest_on_simplex(pts: &[V]) -> (V, Vec<V>) {
    let mut best = (pts[0], vec![pts[0]]);
    let consider = |p: V, sub: Vec<V>, best: &mut (V, Vec<V>)| {
        if p.norm_squared() < best.0.norm_squared() {
            *best = (p, sub);
        }
    };
    let n = pts.len();
    for &p in pts.iter().skip(1) {
        consider(p, vec![p], &mut best);
    }
    for i in 0..n {
        for j in i + 1..n {
            let (a, b) = (pts[i], pts[j]);
            let ab = b - a;
            let l2 = ab.norm_squared();
            if l2 > 0.0 {
                let t = -a.dot(&ab) / l2;
                if t > 0.0 && t < 1.0 {
                    consider(a + ab * t, vec![a, b], &mut best);
                }
            }
        }
    }
    for i in 0..n {
        for j in i + 1..n {
            for k in j + 1..n {
                let (a, b, c) = (pts[i], pts[j], pts[k]);
                let nrm = (b - a).cross(&(c - a));
                let n2 = nrm.norm_squared();
                if n2 <= 0.0 {
                    continue;
                }
                let p = nrm * (a.dot(&nrm) / n2);
                // Barycentric coordinates of p in abc.
                let wa = (b - p).cross(&(c - p)).dot(&nrm);
                let wb = (c - p).cross(&(a - p)).dot(&nrm);
                let wc = (a - p).cross(&(b - p)).dot(&nrm);
                if wa > 0.0 && wb > 0.0 && wc > 0.0 {
                    consider(p, vec![a, b, c], &mut best);
                }
            }
        }
    }
    if n == 4 {
        let (a, b, c, d) = (pts[0], pts[1], pts[2], pts[3]);
        let m = nalgebra::Matrix3::from_columns(&[b - a, c - a, d - a]);
        let vol = m.determinant();
        let edge = [b - a, c - a, d - a, c - b, d - b, d - c]
            .iter()
            .map(|e| e.norm())
            .fold(0.0_f64, f64::max);
        // Nearly flat tetrahedra give meaningless barycentric signs: leave them to the faces.
        if vol.abs() > 1e-9 * edge.powi(3) {
            let det = |x: V, y: V, z: V| nalgebra::Matrix3::from_columns(&[x, y, z]).determinant();
            let beta = det(-a, c - a, d - a) / vol;
            let gamma = det(b - a, -a, d - a) / vol;
            let delta = det(b - a, c - a, -a) / vol;
            let alpha = 1.0 - beta - gamma - delta;
            if alpha >= 0.0 && beta >= 0.0 && gamma >= 0.0 && delta >= 0.0 {
                return (V::zeros(), pts.to_vec());
            }
        }
    }
    best
}

/// Distance between two convex shapes by GJK: returns (lower bound, upper bound); both are
/// 0 when the origin is enclosed (the shapes intersect).
fn gjk_distance(a: &Shape, b: &Shape) -> (f64, f64) {
    let diff = |d: &V| support(a, d) - support(b, &-d);
    let mut simplex = vec![diff(&V::x())];
    let mut lower = 0.0_f64;
    for _ in 0..2000 {
        let (v, sub) = closest_on_simplex(&simplex);
        let vn = v.norm();
        if vn < 1e-15 {
            return (0.0, 0.0);
        }
        let w = diff(&-v);
        lower = lower.max(v.dot(&w) / vn);
        if vn - lower <= 1e-12 * vn.max(1.0) || sub.iter().any(|p| (p - w).norm() < 1e-15) {
            return (lower.max(0.0), vn);
        }
        simplex = sub;
        simplex.push(w);
    }
    let (v, _) = closest_on_simplex(&simplex);
    (lower.max(0.0), v.norm())
}

/// The closest-point difference vector `v = x_a − x_b` (for placing bodies).
fn gjk_vector(a: &Shape, b: &Shape) -> V {
    gjk_vector_of(&|d| support(a, d), &|d| support(b, d), 1e-14)
}

fn eroded(s: &Shape, delta: f64) -> Shape {
    match s {
        Shape::Sphere(s) => Shape::Sphere(Sphere {
            radius: s.radius - delta,
            ..*s
        }),
        Shape::Cylinder(c) => {
            let h = c.half_axis.norm();
            Shape::Cylinder(Cylinder {
                half_axis: c.half_axis * ((h - delta) / h),
                radius: c.radius - delta,
                ..*c
            })
        }
    }
}

/// Oracle verdict: Some(true) if the bodies overlap by more than `tol` (the bodies eroded by
/// `tol` still intersect), Some(false) if they are more than `tol` apart, None otherwise.
fn oracle(a: &Shape, b: &Shape, tol: f64) -> Option<bool> {
    let (lower, _) = gjk_distance(a, b);
    if lower > tol {
        return Some(false);
    }
    let (_, upper) = gjk_distance(&eroded(a, tol), &eroded(b, tol));
    if upper == 0.0 {
        return Some(true);
    }
    None
}

fn center(s: &Shape) -> V {
    match s {
        Shape::Sphere(s) => s.center,
        Shape::Cylinder(c) => c.center,
    }
}

fn translated(s: &Shape, t: V) -> Shape {
    match s {
        Shape::Sphere(s) => Shape::Sphere(Sphere {
            center: s.center + t,
            ..*s
        }),
        Shape::Cylinder(c) => Shape::Cylinder(Cylinder {
            center: c.center + t,
            ..*c
        }),
    }
}

// ---------------------------------------------------------------- constructed cases

fn cyl(c: [f64; 3], l: [f64; 3], r: f64) -> Cylinder {
    Cylinder::new(V::from(c), V::from(l), r)
}

fn sph(c: [f64; 3], r: f64) -> Sphere {
    Sphere::new(V::from(c), r)
}

/// Translates `b` along `dir` from an overlapping position to the boundary of overlap
/// (bisection on the oracle), plus `gap`; checks `overlaps` is false there and the oracle
/// distance is tiny.
fn assert_separated_counterpart(a: &Shape, b: &Shape, dir: V, far: f64) {
    let dir = dir.normalize();
    assert!(overlaps(a, b), "start must overlap");
    let (mut lo, mut hi) = (0.0, far);
    assert!(
        gjk_distance(a, &translated(b, dir * hi)).0 > 0.0,
        "far must be separated"
    );
    for _ in 0..80 {
        let mid = 0.5 * (lo + hi);
        if gjk_distance(a, &translated(b, dir * mid)).0 > 0.0 {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    let gap = 1e-8;
    let moved = translated(b, dir * (hi + gap));
    let (lower, upper) = gjk_distance(a, &moved);
    assert!(
        lower > 0.0 && upper < 1e-6,
        "distance in [{lower}, {upper}]"
    );
    assert!(
        !overlaps(a, &moved),
        "separated counterpart reported overlapping"
    );
    assert!(!overlaps(&moved, a));
    // And slightly inside, it does overlap.
    let inside = translated(b, dir * (lo - 1e-7));
    assert!(overlaps(a, &inside) && overlaps(&inside, a));
}

#[test]
fn sphere_sphere() {
    let a = sph([0.0, 0.0, 0.0], 1.0);
    let b = sph([1.5, 0.0, 0.0], 0.6);
    let c = intersect_sphere_sphere(&a, &b).unwrap();
    assert!((c.depth - 0.1).abs() < 1e-12);
    assert!((c.normal - V::x()).norm() < 1e-12);
    // Coincident centres: a finite normal.
    let c = intersect_sphere_sphere(&a, &a).unwrap();
    assert!(c.normal.iter().all(|x| x.is_finite()));
    assert_separated_counterpart(&Shape::Sphere(a), &Shape::Sphere(b), V::x(), 10.0);
}

fn sc_case(s: Sphere, kind: SphereCylinderKind, dir: V) {
    let c = cyl([0.0, 0.0, 0.0], [0.0, 0.0, 2.0], 0.5);
    let got = intersect_sphere_cylinder(&s, &c).expect("intersection expected");
    assert_eq!(got.kind, kind);
    assert!(got.contact.depth > 0.0 && got.contact.normal.norm() > 0.999);
    assert_separated_counterpart(&Shape::Cylinder(c), &Shape::Sphere(s), dir, 20.0);
}

#[test]
fn sphere_cylinder_types() {
    // Fig. 16: sc2, sphere at the curved face.
    sc_case(sph([0.9, 0.0, 0.3], 0.5), SphereCylinderKind::Sc2, V::x());
    // Fig. 17: sc2, cylinder turned.
    sc_case(
        sph([0.6, 0.6, 1.9], 0.5),
        SphereCylinderKind::Sc2,
        V::new(1.0, 1.0, 0.0),
    );
    // Fig. 18/19: sc3, above the base, centre inside the infinite cylinder.
    sc_case(sph([0.0, 0.0, 2.3], 0.5), SphereCylinderKind::Sc3, V::z());
    sc_case(
        sph([0.1, -0.2, -2.4], 0.5),
        SphereCylinderKind::Sc3,
        -V::z(),
    );
    // Fig. 20: sc4, at the rim.
    sc_case(
        sph([0.8, 0.0, 2.2], 0.5),
        SphereCylinderKind::Sc4,
        V::new(1.0, 0.0, 1.0),
    );
    // sc1: the cylinder inside the sphere.
    sc_case(sph([0.0, 0.0, 0.1], 3.0), SphereCylinderKind::Sc1, V::x());
    // Sphere centre on the axis inside the cylinder: still typed, finite.
    let c = cyl([0.0, 0.0, 0.0], [0.0, 0.0, 2.0], 0.5);
    let got = intersect_sphere_cylinder(&sph([0.0, 0.0, 0.0], 0.1), &c).unwrap();
    assert_eq!(got.kind, SphereCylinderKind::Sc2);
    assert!(got.contact.normal.iter().all(|x| x.is_finite()));
}

fn kinds(c: &CylinderContact) -> (Vec<DiskSideKind>, Vec<DiskDiskKind>) {
    let mut side = Vec::new();
    let mut disk = Vec::new();
    if let CylinderContact::Bases(v) = c {
        for b in v {
            match b {
                BaseContact::DiskSide { contact, .. } => side.push(contact.kind),
                BaseContact::DiskDisk { contact, .. } => disk.push(contact.kind),
            }
        }
    }
    (side, disk)
}

fn check_finite(c: &CylinderContact) {
    let all: Vec<_> = match c {
        CylinderContact::Cc1(c) => vec![*c],
        CylinderContact::Bases(v) => v
            .iter()
            .map(|b| match b {
                BaseContact::DiskSide { contact, .. } => contact.contact,
                BaseContact::DiskDisk { contact, .. } => contact.contact,
            })
            .collect(),
    };
    for c in all {
        assert!(c.point.iter().chain(c.normal.iter()).all(|x| x.is_finite()));
        assert!(c.depth.is_finite() && c.depth > 0.0);
        assert!((c.normal.norm() - 1.0).abs() < 1e-9);
    }
}

fn cc_case(a: Cylinder, b: Cylinder, dir: V, check: impl Fn(&CylinderContact)) {
    let got = intersect_cylinder_cylinder(&a, &b).expect("intersection expected");
    check_finite(&got);
    check(&got);
    assert_separated_counterpart(&Shape::Cylinder(a), &Shape::Cylinder(b), dir, 20.0);
}

fn is_cc1(c: &CylinderContact) {
    assert!(
        matches!(c, CylinderContact::Cc1(_)),
        "expected cc1, got {c:?}"
    );
}

#[test]
fn cylinder_cylinder_types() {
    // Fig. 21: cc1, crossed rods.
    cc_case(
        cyl([0.0; 3], [2.0, 0.0, 0.0], 0.5),
        cyl([0.0, 0.0, 0.9], [0.0, 2.0, 0.0], 0.5),
        V::z(),
        is_cc1,
    );
    // Fig. 22/23: cc1, turned cylinders.
    cc_case(
        cyl([0.0; 3], [2.0, 0.3, 0.1], 0.5),
        cyl([0.2, -0.1, 0.8], [0.4, 2.0, -0.3], 0.4),
        V::new(0.1, 0.0, 1.0),
        is_cc1,
    );
    // Fig. 25: parallel axes, degenerate cc1.
    cc_case(
        cyl([0.0; 3], [0.0, 0.0, 2.0], 0.5),
        cyl([0.9, 0.0, 0.3], [0.0, 0.0, -2.0], 0.5),
        V::x(),
        is_cc1,
    );
    // Fig. 29: intersecting axes, coincident centres, degenerate cc1.
    cc_case(
        cyl([0.0; 3], [0.0, 0.0, 2.0], 0.5),
        cyl([0.0; 3], [2.0, 0.0, 0.0], 0.5),
        V::z(),
        is_cc1,
    );
    // Fig. 24: cd1, a rod lying across the top base (its axis parallel to that disk).
    cc_case(
        cyl([0.0; 3], [0.0, 0.0, 2.0], 0.5),
        cyl([0.0, 0.0, 2.4], [2.0, 0.0, 0.0], 0.5),
        V::z(),
        |c| assert_eq!(kinds(c).0, vec![DiskSideKind::Cd1]),
    );
    // Fig. 26/27: cd1 with non-coplanar axes: the top rim digs into an inclined rod.
    cc_case(
        cyl([0.0; 3], [0.0, 0.0, 2.0], 0.5),
        cyl([0.3, 0.7, 2.5], [2.0, 0.2, 0.6], 0.5),
        V::new(0.0, 0.3, 1.0),
        |c| assert!(kinds(c).0.contains(&DiskSideKind::Cd1), "{c:?}"),
    );
    // cd2: a slightly tilted coin whose lower base covers the rod axis, its rim crossing it.
    cc_case(
        cyl([0.0; 3], [0.0, 0.0, 2.0], 0.5),
        cyl([0.8, 0.0, 2.0], [0.005, 0.0, 0.1], 1.0),
        V::z(),
        |c| assert!(kinds(c).0.contains(&DiskSideKind::Cd2), "{c:?}"),
    );
    // cd3: a thin rod through a tilted coin.
    cc_case(
        cyl([0.0; 3], [0.0, 0.0, 2.0], 0.2),
        cyl([0.1, 0.0, 1.0], [0.03, 0.0, 0.1], 1.0),
        V::z(),
        |c| assert!(kinds(c).0.contains(&DiskSideKind::Cd3), "{c:?}"),
    );
    // Fig. 28: d1, a horizontal rod whose base dips into the top base of a wide cylinder.
    let wide = cyl([0.0; 3], [0.0, 0.0, 1.0], 1.0);
    let rod = cyl([1.5, 0.0, 1.2], [1.0, 0.0, 0.0], 0.3);
    cc_case(wide, rod, V::z(), |c| {
        assert_eq!(kinds(c).1, vec![DiskDiskKind::D1], "{c:?}")
    });
    // d2: the same pair swapped.
    cc_case(rod, wide, -V::z(), |c| {
        assert_eq!(kinds(c).1, vec![DiskDiskKind::D2], "{c:?}")
    });
    // Coaxial cylinders stacked end to end: touching is not overlapping.
    let a = cyl([0.0; 3], [0.0, 0.0, 1.0], 0.5);
    let b = cyl([0.0, 0.0, 2.0], [0.0, 0.0, 1.0], 0.5);
    assert!(intersect_cylinder_cylinder(&a, &b).is_none());
}

#[test]
fn disk_disk_helper() {
    let a = cyl([0.0; 3], [0.0, 0.0, 1.0], 1.0).end_disk(End::Plus);
    let b = cyl([1.5, 0.0, 1.2], [1.0, 0.0, 0.0], 0.3).end_disk(End::Minus);
    let c = intersect_disk_disk(&a, &b).unwrap();
    assert_eq!(c.kind, DiskDiskKind::D1);
    assert!((c.contact.normal - V::z()).norm() < 1e-12);
    assert!((c.contact.depth - 0.1).abs() < 1e-12);
    assert_eq!(intersect_disk_disk(&b, &a).unwrap().kind, DiskDiskKind::D2);
}

// ---------------------------------------------------------------- oracle: types and depths
//
// For a pair the library reports intersecting, the intersection type is recomputed here
// from the geometry and, where the quantity is defined, the depth, direction and
// application point. Tolerances (all bodies have sizes between 0.05 and 2.5):
// * `AMBIGUOUS = 1e-7`: a pair whose classifying quantity lies within this of a type
//   boundary (or, for quantities divided by a small sine, within it times the inverse
//   sine) is counted as ambiguous and its type is not compared: the library and this
//   test compute the boundary by different formulas, whose rounding may fall either side.
// * `CLOSED_FORM = 1e-9`: depth, direction and point computed here by other formulas
//   (clamped nearest point, 2×2 normal equations, support maps, a 3×3 solve for the
//   common line) agree with the library to rounding (about 1e-15 times sizes of order 1
//   and conditioning below 1e3 where it is compared).
// * `GJK_VALUE = 1e-6`: the `cd1` depth against the GJK distance between the disk and the
//   axis line (a thin tube around it): GJK converges slowly between two curved rims and
//   this simple GJK is not exact near degenerate simplices; the largest difference over
//   the run is printed (7e-8 when written; in the pairs checked by a golden-section
//   search along the rim, the library was the exact one, to rounding).
// * `DIRECTION_GJK = 1e-4`: a unit direction from GJK closest points, compared only when
//   the distance exceeds 1e-3. On a curved rim GJK pins the distance far better than the
//   closest points (a distance gap of 1e-13 leaves them uncertain by about its square
//   root); the direction is also checked to `CLOSED_FORM` against the reported point.
// * `SEPARATION = 1e-7`: for the types whose depth is a penetration along the reported
//   direction (sphere–sphere, `sc2`–`sc4`, `cc1`), body 2 moved by `depth + 1e-7` along the
//   normal is apart and moved by `depth − 1e-7` still overlaps (see
//   `assert_touching_after`): the depth is exact to 1e-7, well above the rounding of the
//   exact gaps and the GJK accuracy (1e-12), and far below any depth worth a force.

const AMBIGUOUS: f64 = 1e-7;
const CLOSED_FORM: f64 = 1e-9;
const GJK_VALUE: f64 = 1e-6;
const DIRECTION_GJK: f64 = 1e-4;
const SEPARATION: f64 = 1e-7;

/// Counts of the contact checks, per intersection type.
#[derive(Default, Debug)]
struct ContactStats {
    /// Types compared with the independent classification, by name.
    typed: std::collections::BTreeMap<&'static str, usize>,
    /// Pairs within `AMBIGUOUS` of a type boundary (type not compared).
    ambiguous: usize,
    /// Depth/direction/point comparisons made.
    values: usize,
    /// Separation searches along the reported direction.
    separations: usize,
    /// Largest `cd1` depth difference from the GJK value.
    cd1_gjk_error: f64,
}

impl ContactStats {
    fn typed(&mut self, name: &'static str) {
        *self.typed.entry(name).or_default() += 1;
    }
}

fn close(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b} (tolerance {tol})");
}

fn close_v(a: &V, b: &V, tol: f64, what: &str) {
    assert!(
        (a - b).norm() <= tol,
        "{what}: {a:?} vs {b:?} (tolerance {tol})"
    );
}

/// Closest-point difference `x_a − x_b` of two convex sets given by support maps (GJK),
/// stopped when a step gains less than `tol` (relative) or finds no new support point.
fn gjk_vector_of(sa: &dyn Fn(&V) -> V, sb: &dyn Fn(&V) -> V, tol: f64) -> V {
    let diff = |d: &V| sa(d) - sb(&-d);
    let mut simplex = vec![diff(&V::x())];
    let mut v = simplex[0];
    for _ in 0..2000 {
        let (vv, sub) = closest_on_simplex(&simplex);
        v = vv;
        let vn = v.norm();
        if vn < 1e-15 {
            return V::zeros();
        }
        let w = diff(&-v);
        if vn - v.dot(&w) / vn <= tol * vn.max(1.0) || sub.iter().any(|p| (p - w).norm() < 1e-15) {
            break;
        }
        simplex = sub;
        simplex.push(w);
    }
    v
}

/// Support map of a disk (centre, unit normal, radius).
fn disk_support(c: V, n: V, r: f64, d: &V) -> V {
    let inplane = d - n * d.dot(&n);
    let m = inplane.norm();
    if m > 0.0 {
        c + inplane * (r / m)
    } else {
        c
    }
}

/// Exact signed gap between a sphere and a body (negative: they overlap), from the point
/// of the body nearest the centre (clamped axial and radial coordinates for a cylinder).
fn sphere_gap(s: &Sphere, b: &Shape) -> f64 {
    match b {
        Shape::Sphere(t) => (t.center - s.center).norm() - s.radius - t.radius,
        Shape::Cylinder(c) => {
            let h = c.half_axis.norm();
            let u = c.half_axis / h;
            let w = s.center - c.center;
            let x = w.dot(&u);
            let l = (w - u * x).norm();
            let (dx, dl) = ((x.abs() - h).max(0.0), (l - c.radius).max(0.0));
            if dx == 0.0 && dl == 0.0 {
                -s.radius - (h - x.abs()).min(c.radius - l)
            } else {
                dx.hypot(dl) - s.radius
            }
        }
    }
}

/// Whether `y` lies in the cylinder (strictly inside radially).
fn in_cylinder(c: &Cylinder, y: &V) -> bool {
    let h = c.half_axis.norm();
    let u = c.half_axis / h;
    let w = y - c.center;
    let x = w.dot(&u);
    x.abs() <= h * (1.0 + 1e-12) && (w - u * x).norm() < c.radius
}

/// Moving `b` by `depth` along `n` brings the pair to touching: `SEPARATION` further it is
/// apart, `SEPARATION` less it still overlaps. With a sphere first: the exact signed gap.
/// Two cylinders (`cc1`, non-parallel axes): apart by the GJK lower bound (> 0 proves it);
/// overlapping by a witness, the point of the common perpendicular of the axes dividing it
/// in the ratio of the radii, inside both. (For parallel axes only the first half.)
fn assert_touching_after(a: &Shape, b: &Shape, n: V, depth: f64, what: &str) {
    let out = translated(b, n * (depth + SEPARATION));
    let inn = translated(b, n * (depth - SEPARATION));
    match (a, &inn) {
        (Shape::Sphere(s), _) => {
            let (g_out, g_in) = (sphere_gap(s, &out), sphere_gap(s, &inn));
            assert!(
                g_out > 0.0,
                "{what}: gap {g_out} after depth + {SEPARATION}: {a:?} {b:?}"
            );
            assert!(
                g_in < 0.0,
                "{what}: gap {g_in} at depth − {SEPARATION}: {a:?} {b:?}"
            );
        }
        (Shape::Cylinder(c1), Shape::Cylinder(c2)) => {
            let (lower, _) = gjk_distance(a, &out);
            assert!(
                lower > 0.0,
                "{what}: not apart after depth + {SEPARATION}: {a:?} {b:?}"
            );
            let (u1, u2) = (c1.half_axis.normalize(), c2.half_axis.normalize());
            let d = c2.center - c1.center;
            let cs = u1.dot(&u2);
            let denom = 1.0 - cs * cs;
            if denom > 1e-12 {
                let s1 = (d.dot(&u1) - cs * d.dot(&u2)) / denom;
                let s2 = (cs * d.dot(&u1) - d.dot(&u2)) / denom;
                let (p1, p2) = (c1.center + u1 * s1, c2.center + u2 * s2);
                let y = p1 + (p2 - p1) * (c1.radius / (c1.radius + c2.radius));
                assert!(
                    in_cylinder(c1, &y) && in_cylinder(c2, &y),
                    "{what}: no common point at depth − {SEPARATION}: {a:?} {b:?}"
                );
            }
        }
        _ => unreachable!("a sphere comes first"),
    }
}

fn check_sphere_sphere(a: &Sphere, b: &Sphere, st: &mut ContactStats) {
    let Some(c) = intersect_sphere_sphere(a, b) else {
        return;
    };
    st.typed("sphere-sphere");
    let d = b.center - a.center;
    close(
        c.depth,
        a.radius + b.radius - d.norm(),
        CLOSED_FORM,
        "sphere depth",
    );
    if d.norm() > 1e-6 {
        close_v(&c.normal, &d.normalize(), CLOSED_FORM, "sphere normal");
    }
    st.values += 1;
    let (sa, sb) = (Shape::Sphere(*a), Shape::Sphere(*b));
    assert_touching_after(&sa, &sb, c.normal, c.depth, "sphere-sphere");
    st.separations += 1;
}

/// Type from where the sphere centre lies: `sc1` if the farthest cylinder point is inside
/// the sphere, else by the nearest point of the solid cylinder (clamped axial and radial
/// coordinates): within the side's slab `sc2` (also for a centre inside), on a base face
/// `sc3`, on a rim `sc4`. Depth and direction: for a centre outside the cylinder the exact
/// minimal translation, `r_s − ‖q − p_s‖` along `q − p_s` (`q` the nearest point).
fn check_sphere_cylinder(s: &Sphere, c: &Cylinder, st: &mut ContactStats) {
    let Some(found) = intersect_sphere_cylinder(s, c) else {
        return;
    };
    let h = c.half_axis.norm();
    let u = c.half_axis / h;
    let w = s.center - c.center;
    let x = w.dot(&u);
    let l = w.cross(&u).norm();
    let perp = w - u * x;
    let radial = if perp.norm() > 0.0 {
        perp.normalize()
    } else {
        V::zeros()
    };
    let far = (x.abs() + h).hypot(l + c.radius);
    let (expected, margin) = if far < s.radius {
        (SphereCylinderKind::Sc1, s.radius - far)
    } else if x.abs() < h {
        (SphereCylinderKind::Sc2, (h - x.abs()).min(far - s.radius))
    } else if l < c.radius {
        (SphereCylinderKind::Sc3, (x.abs() - h).min(c.radius - l))
    } else {
        (SphereCylinderKind::Sc4, (x.abs() - h).min(l - c.radius))
    };
    if margin < AMBIGUOUS {
        st.ambiguous += 1;
    } else {
        assert_eq!(found.kind, expected, "sphere-cylinder type: {s:?} {c:?}");
        st.typed(match expected {
            SphereCylinderKind::Sc1 => "sc1",
            SphereCylinderKind::Sc2 => "sc2",
            SphereCylinderKind::Sc3 => "sc3",
            SphereCylinderKind::Sc4 => "sc4",
        });
    }
    let k = found.contact;
    if found.kind == SphereCylinderKind::Sc1 {
        // Table I: depth 2‖l_c‖ along p_c − p_s, at p_c (not a penetration depth).
        close(k.depth, 2.0 * h, CLOSED_FORM, "sc1 depth");
        close_v(&k.point, &c.center, CLOSED_FORM, "sc1 point");
        let d = c.center - s.center;
        if d.norm() > 1e-6 {
            close_v(&k.normal, &d.normalize(), CLOSED_FORM, "sc1 normal");
        }
        st.values += 1;
        return;
    }
    let q = c.center + u * x.clamp(-h, h) + radial * l.min(c.radius);
    let inside = x.abs() < h && l < c.radius;
    if !inside {
        let gap = q - s.center;
        close(k.depth, s.radius - gap.norm(), CLOSED_FORM, "sc depth");
        if gap.norm() > 1e-6 {
            close_v(&k.normal, &gap.normalize(), CLOSED_FORM, "sc normal");
        }
        st.values += 1;
    }
    // `sc2` puts the point on the line of action through `p_s` (the middle of
    // `[L − r_c, r_s]` along it, which lies beyond the cylinder when the sphere reaches
    // past it; only the moment matters). `sc3`, `sc4`: the point lies in both bodies.
    if found.kind == SphereCylinderKind::Sc2 {
        let off = (k.point - s.center).cross(&k.normal).norm();
        close(off, 0.0, CLOSED_FORM, "sc2 point off the line of action");
    } else {
        let kp = k.point - c.center;
        let kx = kp.dot(&u);
        assert!(
            (k.point - s.center).norm() <= s.radius + CLOSED_FORM
                && kx.abs() <= h + CLOSED_FORM
                && (kp - u * kx).norm() <= c.radius + CLOSED_FORM,
            "sc point outside a body: {s:?} {c:?} {k:?}"
        );
    }
    assert_touching_after(
        &Shape::Sphere(*s),
        &Shape::Cylinder(*c),
        k.normal,
        k.depth,
        "sphere-cylinder",
    );
    st.separations += 1;
}

fn check_cylinder_cylinder(a: &Cylinder, b: &Cylinder, st: &mut ContactStats) {
    let Some(found) = intersect_cylinder_cylinder(a, b) else {
        return;
    };
    let (h1, h2) = (a.half_axis.norm(), b.half_axis.norm());
    let (u1, u2) = (a.half_axis / h1, b.half_axis / h2);
    let d = b.center - a.center;
    let cs = u1.dot(&u2);
    let denom = 1.0 - cs * cs;
    // Closest points of the axis lines from the 2×2 normal equations of
    // min ‖d + t u₂ − s u₁‖²: s − cs t = d·u₁, t − cs s = −d·u₂.
    let parallel = denom < 1e-20;
    let (s1, s2) = if parallel {
        (0.0, 0.0)
    } else {
        (
            (d.dot(&u1) - cs * d.dot(&u2)) / denom,
            (cs * d.dot(&u1) - d.dot(&u2)) / denom,
        )
    };
    let margin = ((h1 - s1.abs()).abs()).min((h2 - s2.abs()).abs());
    let is_cc1 = matches!(found, CylinderContact::Cc1(_));
    if !parallel && margin < AMBIGUOUS / denom.min(1.0) {
        st.ambiguous += 1;
    } else {
        let expected = parallel || (s1.abs() <= h1 && s2.abs() <= h2);
        assert_eq!(is_cc1, expected, "cc1 or bases: {a:?} {b:?} {found:?}");
        if is_cc1 {
            st.typed("cc1");
        }
    }
    match found {
        CylinderContact::Cc1(k) => {
            if !parallel && denom > 1e-6 {
                let (p1, p2) = (a.center + u1 * s1, b.center + u2 * s2);
                let rho = (p2 - p1).norm();
                close(k.depth, a.radius + b.radius - rho, CLOSED_FORM, "cc1 depth");
                close_v(&k.point, &(0.5 * (p1 + p2)), CLOSED_FORM, "cc1 point");
                if rho > 1e-6 {
                    close_v(&k.normal, &(p2 - p1).normalize(), CLOSED_FORM, "cc1 normal");
                }
                st.values += 1;
            }
            let (sa, sb) = (Shape::Cylinder(*a), Shape::Cylinder(*b));
            assert_touching_after(&sa, &sb, k.normal, k.depth, "cc1");
            st.separations += 1;
        }
        CylinderContact::Bases(list) => {
            for base in &list {
                match base {
                    BaseContact::DiskSide {
                        disk_of,
                        end,
                        contact,
                    } => {
                        let (cyl, disk, sign) = match disk_of {
                            Body::Second => (a, b.end_disk(*end), 1.0),
                            Body::First => (b, a.end_disk(*end), -1.0),
                        };
                        check_disk_side(cyl, &disk, contact.kind, &contact.contact, sign, st);
                    }
                    BaseContact::DiskDisk {
                        first_end,
                        second_end,
                        contact,
                    } => {
                        let (d1, d2) = (a.end_disk(*first_end), b.end_disk(*second_end));
                        check_disk_disk(&d1, &d2, contact.kind, &contact.contact, st);
                    }
                }
            }
        }
    }
}

/// `cd1`–`cd3` from the point `a` where the axis crosses the disk plane (line–plane
/// intersection): `cd1` if `a` is outside the disk; else, with `pt_c` the rim point towards
/// `a`, `cd2` if `pt_c` is within `r_c` of the axis, `cd3` otherwise. `cd1` depth and
/// direction from the GJK distance between the disk and the axis line; `cd2`, `cd3` (overlap
/// measures, not penetration depths) from their definitions. `sign` turns the reported
/// normal into the one pushing the disk's body away from the cylinder.
fn check_disk_side(
    c: &Cylinder,
    disk: &Disk,
    kind: DiskSideKind,
    k: &Contact,
    sign: f64,
    st: &mut ContactStats,
) {
    let h = c.half_axis.norm();
    let u = c.half_axis / h;
    let nd = disk.normal;
    let un = u.dot(&nd);
    let normal = k.normal * sign;
    let to_axis = |p: &V| (p - c.center).cross(&u).norm();
    // The axis point where it crosses the disk plane, if the axis is not (nearly) in it.
    let cross_point =
        (un.abs() > 1e-9).then(|| c.center + u * (nd.dot(&(disk.center - c.center)) / un));
    let off = cross_point.map(|a| (a - disk.center).norm());
    let expected = match (cross_point, off) {
        (Some(a), Some(off)) if off < disk.radius => {
            let pt_c = disk.center + (a - disk.center) * (disk.radius / off);
            let dist_c = to_axis(&pt_c);
            let m = (disk.radius - off).min(off).min((dist_c - c.radius).abs());
            (
                if dist_c < c.radius {
                    DiskSideKind::Cd2
                } else {
                    DiskSideKind::Cd3
                },
                m,
            )
        }
        (_, Some(off)) => (DiskSideKind::Cd1, off - disk.radius),
        // Axis parallel to the disk: it misses it unless it lies in its plane.
        _ => (
            DiskSideKind::Cd1,
            if nd.dot(&(disk.center - c.center)).abs() > AMBIGUOUS {
                f64::INFINITY
            } else {
                0.0
            },
        ),
    };
    let scale = if cross_point.is_some() {
        1.0 + 1.0 / un.abs()
    } else {
        1.0
    };
    if expected.1 < AMBIGUOUS * scale {
        st.ambiguous += 1;
    } else {
        assert_eq!(kind, expected.0, "disk-side type: {c:?} {disk:?} {k:?}");
        st.typed(match kind {
            DiskSideKind::Cd1 => "cd1",
            DiskSideKind::Cd2 => "cd2",
            DiskSideKind::Cd3 => "cd3",
        });
    }
    match kind {
        DiskSideKind::Cd1 => {
            let w = disk.center - c.center;
            if cross_point.is_none() {
                // Axis parallel to the disk: its distance to the disk is exact from the
                // plane offset and the in-plane gap between the projected axis and the disk.
                let plane = nd.dot(&w);
                let inplane = (w - nd * plane).cross(&u).norm();
                let dist = plane.abs().hypot((inplane - disk.radius).max(0.0));
                close(
                    k.depth,
                    c.radius - dist,
                    CLOSED_FORM,
                    "cd1 depth (parallel)",
                );
                if inplane > disk.radius + 1e-6 {
                    // Unique nearest point, on the rim.
                } else {
                    close_v(&normal, &(nd * plane.signum()), CLOSED_FORM, "cd1 normal");
                }
            } else {
                // GJK between the disk and the axis line made a long thin tube of radius
                // `TUBE` (a segment alone makes the Minkowski difference flat when the axis
                // is nearly parallel to the disk); the tube radius is added back.
                const TUBE: f64 = 1e-3;
                let reach = w.norm() + disk.radius + 10.0;
                let v = gjk_vector_of(
                    &|dir: &V| disk_support(disk.center, nd, disk.radius, dir),
                    &|dir: &V| {
                        c.center
                            + u * (reach * dir.dot(&u).signum())
                            + disk_support(V::zeros(), u, TUBE, dir)
                    },
                    1e-13,
                );
                if v.norm() == 0.0 {
                    // Within the tube of the axis: not compared.
                    return;
                }
                let dist = v.norm() + TUBE;
                // GJK converges slowly between the rim and the tube: `GJK_VALUE`.
                let excess = (k.depth - (c.radius - dist)).abs();
                st.cd1_gjk_error = st.cd1_gjk_error.max(excess);
                close(k.depth, c.radius - dist, GJK_VALUE, "cd1 depth");
                if dist > 1e-3 {
                    close_v(&normal, &v.normalize(), DIRECTION_GJK, "cd1 normal (GJK)");
                }
            }
            // The point is on the disk, at the reported depth inside the cylinder.
            let off = k.point - disk.center;
            close(off.dot(&nd), 0.0, CLOSED_FORM, "cd1 point off the plane");
            assert!(
                off.norm() <= disk.radius + CLOSED_FORM,
                "cd1 point off the disk"
            );
            close(
                to_axis(&k.point),
                c.radius - k.depth,
                CLOSED_FORM,
                "cd1 point depth",
            );
            let radial = (k.point - c.center) - u * (k.point - c.center).dot(&u);
            if radial.norm() > 1e-6 {
                close_v(&normal, &radial.normalize(), CLOSED_FORM, "cd1 normal");
            }
            st.values += 1;
        }
        DiskSideKind::Cd2 => {
            let (Some(a), Some(off)) = (cross_point, off) else {
                return;
            };
            if un.abs() < 1e-3 || off < 1e-3 {
                return;
            }
            let pt_c = disk.center + (a - disk.center) * (disk.radius / off);
            let foot = c.center + u * (pt_c - c.center).dot(&u);
            close(
                k.depth,
                c.radius + (foot - pt_c).norm(),
                CLOSED_FORM,
                "cd2 depth",
            );
            close_v(&k.point, &pt_c, CLOSED_FORM, "cd2 point");
            if (foot - pt_c).norm() > 1e-6 {
                close_v(
                    &normal,
                    &(foot - pt_c).normalize(),
                    CLOSED_FORM,
                    "cd2 normal",
                );
            }
            st.values += 1;
        }
        DiskSideKind::Cd3 => {
            close(k.depth, 2.0 * c.radius, CLOSED_FORM, "cd3 depth");
            let dc = disk.center - c.center;
            if dc.norm() > 1e-6 {
                close_v(&normal, &dc.normalize(), CLOSED_FORM, "cd3 normal");
            }
            if let Some(a) = cross_point {
                if un.abs() > 1e-3 {
                    close_v(&k.point, &a, CLOSED_FORM, "cd3 point");
                }
            }
            st.values += 1;
        }
    }
}

/// `d1`/`d2` from the chords of the disks on the common line of their planes (found by a
/// 3×3 solve): `d1` iff the first chord is the longer. Depth from the support maps: how far
/// the crossing disk reaches through the other plane, along that plane's normal (`d1`: `n₁`,
/// `d2`: `−n₂`). The point lies in both disks.
fn check_disk_disk(d1: &Disk, d2: &Disk, kind: DiskDiskKind, k: &Contact, st: &mut ContactStats) {
    let (n1, n2) = (d1.normal, d2.normal);
    let e = n1.cross(&n2);
    if e.norm() < 1e-6 {
        st.ambiguous += 1;
        return;
    }
    let m = nalgebra::Matrix3::from_rows(&[n1.transpose(), n2.transpose(), e.transpose()]);
    let rhs = V::new(n1.dot(&d1.center), n2.dot(&d2.center), e.dot(&d1.center));
    let p0 = m.lu().solve(&rhs).expect("planes not parallel");
    let eu = e.normalize();
    let chord2 = |d: &Disk| {
        let dist = (d.center - p0).cross(&eu).norm();
        d.radius * d.radius - dist * dist
    };
    let (q1, q2) = (chord2(d1), chord2(d2));
    assert!(
        q1 > -AMBIGUOUS && q2 > -AMBIGUOUS,
        "disk-disk reported but a plane misses the other disk: {d1:?} {d2:?}"
    );
    if (q1 - q2).abs() < AMBIGUOUS {
        st.ambiguous += 1;
    } else {
        let expected = if q1 > q2 {
            DiskDiskKind::D1
        } else {
            DiskDiskKind::D2
        };
        assert_eq!(kind, expected, "disk-disk type: {d1:?} {d2:?}");
        st.typed(if q1 > q2 { "d1" } else { "d2" });
    }
    let (depth, normal) = match kind {
        DiskDiskKind::D1 => {
            let y = disk_support(d2.center, n2, d2.radius, &-n1);
            ((d1.center - y).dot(&n1), n1)
        }
        DiskDiskKind::D2 => {
            let y = disk_support(d1.center, n1, d1.radius, &-n2);
            ((d2.center - y).dot(&n2), -n2)
        }
    };
    close(k.depth, depth.max(0.0), CLOSED_FORM, "disk-disk depth");
    close_v(&k.normal, &normal, CLOSED_FORM, "disk-disk normal");
    for d in [d1, d2] {
        let off = k.point - d.center;
        close(
            off.dot(&d.normal),
            0.0,
            CLOSED_FORM,
            "disk-disk point off a plane",
        );
        assert!(
            off.norm() <= d.radius + CLOSED_FORM,
            "disk-disk point off a disk"
        );
    }
    st.values += 1;
}

fn check_contacts(a: &Shape, b: &Shape, st: &mut ContactStats) {
    match (a, b) {
        (Shape::Sphere(s), Shape::Sphere(t)) => check_sphere_sphere(s, t, st),
        (Shape::Sphere(s), Shape::Cylinder(c)) | (Shape::Cylinder(c), Shape::Sphere(s)) => {
            check_sphere_cylinder(s, c, st)
        }
        (Shape::Cylinder(c), Shape::Cylinder(e)) => check_cylinder_cylinder(c, e, st),
    }
}

// ---------------------------------------------------------------- random pairs vs oracle

#[derive(Clone, Copy)]
enum Degeneracy {
    General,
    ParallelAxes,
    CrossingAxes,
    CoincidentCentres,
    AxisParallelToDisk,
}

fn unit(rng: &mut Xoshiro256PlusPlus) -> V {
    loop {
        let v = V::new(
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
            rng.gen_range(-1.0..1.0),
        );
        let n = v.norm();
        if n > 0.1 && n <= 1.0 {
            return v / n;
        }
    }
}

fn random_cylinder(rng: &mut Xoshiro256PlusPlus, center: V, axis: V) -> Cylinder {
    Cylinder::new(
        center,
        axis * rng.gen_range(0.05..2.5),
        rng.gen_range(0.1..1.0),
    )
}

fn random_pair(rng: &mut Xoshiro256PlusPlus, kind: usize, deg: Degeneracy) -> (Shape, Shape) {
    let p1 = V::new(
        rng.gen_range(-1.0..1.0),
        rng.gen_range(-1.0..1.0),
        rng.gen_range(-1.0..1.0),
    );
    let mut p2 = V::new(
        rng.gen_range(-2.0..2.0),
        rng.gen_range(-2.0..2.0),
        rng.gen_range(-2.0..2.0),
    );
    let u1 = unit(rng);
    let u2 = match deg {
        Degeneracy::ParallelAxes => {
            if rng.gen_bool(0.5) {
                u1
            } else {
                -u1
            }
        }
        Degeneracy::AxisParallelToDisk => {
            let w = unit(rng);
            (w - u1 * w.dot(&u1)).normalize()
        }
        _ => unit(rng),
    };
    match deg {
        Degeneracy::CoincidentCentres => p2 = p1,
        Degeneracy::CrossingAxes => {
            p2 = p1 + u1 * rng.gen_range(-3.0..3.0) + u2 * rng.gen_range(-3.0..3.0);
        }
        _ => {}
    }
    match kind {
        0 => (
            Shape::Sphere(Sphere::new(p1, rng.gen_range(0.1..1.5))),
            Shape::Sphere(Sphere::new(p2, rng.gen_range(0.1..1.5))),
        ),
        1 => {
            let s = Shape::Sphere(Sphere::new(p2, rng.gen_range(0.1..1.5)));
            let c = Shape::Cylinder(random_cylinder(rng, p1, u1));
            if rng.gen_bool(0.5) {
                (s, c)
            } else {
                (c, s)
            }
        }
        _ => (
            Shape::Cylinder(random_cylinder(rng, p1, u1)),
            Shape::Cylinder(random_cylinder(rng, p2, u2)),
        ),
    }
}

/// Moves `b` so that the distance to `a` becomes about `target` (negative: overlap along
/// the separating direction).
fn place_near_touching(a: &Shape, b: &Shape, target: f64) -> Shape {
    let v = gjk_vector(a, b);
    let d = v.norm();
    if d == 0.0 {
        // Overlapping: move b away along the centre line first.
        let dir = (center(b) - center(a)).try_normalize(0.0).unwrap_or(V::x());
        let far = translated(b, dir * 20.0);
        return place_near_touching(a, &far, target);
    }
    translated(b, v * ((d - target) / d))
}

/// 100 000 random pairs (every degeneracy, a third within ±1e-6 of touching): the
/// overlap verdict agrees with GJK, and for every pair reported intersecting the typed
/// contacts agree with the independent checks of `check_contacts` (type, and where defined
/// depth, direction, point, and touching after a push by the depth).
#[test]
fn random_pairs_agree_with_gjk_oracle() {
    let start = Instant::now();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(0x5eed_c711);
    let degs = [
        Degeneracy::General,
        Degeneracy::ParallelAxes,
        Degeneracy::CrossingAxes,
        Degeneracy::CoincidentCentres,
        Degeneracy::AxisParallelToDisk,
    ];
    let total = 100_000;
    let tol = 1e-9;
    let (mut checked, mut skipped, mut overlapping) = (0usize, 0usize, 0usize);
    let mut disagreements = Vec::new();
    let mut stats = ContactStats::default();
    for i in 0..total {
        let kind = i % 3;
        let deg = degs[(i / 3) % degs.len()];
        let (a, b) = random_pair(&mut rng, kind, deg);
        // A third of the pairs are placed at ±1e-6 from touching.
        let b = match i % 9 {
            0..=2 => place_near_touching(&a, &b, if i % 2 == 0 { 1e-6 } else { -1e-6 }),
            _ => b,
        };
        let ours = overlaps(&a, &b);
        assert_eq!(ours, overlaps(&b, &a), "asymmetric on {a:?} {b:?}");
        let shift = V::new(3.7, -1.3, 12.5);
        assert_eq!(
            ours,
            overlaps(&translated(&a, shift), &translated(&b, shift)),
            "not translation invariant: {a:?} {b:?}"
        );
        if ours {
            check_contacts(&a, &b, &mut stats);
        }
        match oracle(&a, &b, tol) {
            None => skipped += 1,
            Some(truth) => {
                checked += 1;
                overlapping += usize::from(truth);
                if truth != ours {
                    disagreements.push((a, b, truth));
                }
            }
        }
    }
    let secs = start.elapsed().as_secs_f64();
    println!(
        "oracle pairs: {total}, checked {checked}, overlapping {overlapping}, skipped (|dist| < {tol}) {skipped}, disagreements {}, {secs:.2} s",
        disagreements.len()
    );
    for (a, b, truth) in disagreements.iter().take(5) {
        println!("oracle says overlap={truth}: {a:?} {b:?}");
    }
    println!("contact checks: {stats:?}");
    assert!(disagreements.is_empty());
    assert!(checked > 90_000 && overlapping > 10_000);
    // Every intersection type was compared with its independent classification.
    for kind in [
        "sphere-sphere",
        "sc1",
        "sc2",
        "sc3",
        "sc4",
        "cc1",
        "cd1",
        "cd2",
        "cd3",
        "d1",
        "d2",
    ] {
        let n = stats.typed.get(kind).copied().unwrap_or(0);
        assert!(n >= 100, "only {n} pairs of type {kind} compared");
    }
    assert!(stats.ambiguous < 2_000 && stats.values > 30_000 && stats.separations > 30_000);
}

/// The RSA broad phase (`CapsuleGrid` cells or the `ImageScan` of bounding spheres, then the
/// cheap steps of the exact tests) never
/// drops an image the exact test finds intersecting: random pairs (every degeneracy, a
/// third within ±1e-6 of touching, so also the pairs the separating-axis exit sees at the
/// margin) in a periodic box of edge 6 (bodies up to 5 long), against every lattice image
/// `n ∈ {−2, …, 2}³` of the placed body. `overlaps_decided_early` must agree with
/// `overlaps` whenever it decides (`overlaps` itself is checked against GJK above).
#[test]
fn rsa_broad_phase_keeps_every_intersecting_image() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(0xb40a_d9a5);
    let degs = [
        Degeneracy::General,
        Degeneracy::ParallelAxes,
        Degeneracy::CrossingAxes,
        Degeneracy::CoincidentCentres,
        Degeneracy::AxisParallelToDisk,
    ];
    let edge = 6.0;
    let boundary = PeriodicBox {
        min: V::repeat(-1.0),
        len: V::repeat(edge),
    };
    let wrap = |s: &Shape| {
        let c = center(s);
        let w = c.map(|x| (x + 1.0).rem_euclid(edge) - 1.0);
        translated(s, w - c)
    };
    let (mut intersecting_images, mut decided, mut undecided) = (0usize, 0usize, 0usize);
    for i in 0..20_000 {
        let (a, b) = random_pair(&mut rng, i % 3, degs[(i / 3) % degs.len()]);
        let b = match i % 9 {
            0..=2 => place_near_touching(&a, &b, if i % 2 == 0 { 1e-6 } else { -1e-6 }),
            _ => b,
        };
        let (a, b) = (wrap(&a), wrap(&b));
        // Both bodies' capsule radii are below 1.5; pads and grid sizes vary.
        let pad = [1.5, 2.0, 4.0][i % 3];
        let mut grid = CapsuleGrid::new(&boundary, pad, [1, 2, 8][(i / 3) % 3]);
        grid.insert(0, &a);
        let mut listed = Vec::new();
        grid.any_image(&b, |j, offset| {
            assert_eq!(j, 0);
            listed.push(offset);
            false
        });
        let mut scan = ImageScan::new(&boundary);
        scan.push(&a);
        let mut scanned = Vec::new();
        scan.any_image(&b, |j, offset| {
            assert_eq!(j, 0);
            scanned.push(offset);
            false
        });
        for n in 0..125 {
            let t = V::new(
                (n % 5) as f64 - 2.0,
                ((n / 5) % 5) as f64 - 2.0,
                (n / 25) as f64 - 2.0,
            ) * edge;
            let image = translated(&a, t);
            let truth = overlaps(&b, &image);
            match overlaps_decided_early(&b, &image) {
                Some(early) => {
                    decided += 1;
                    assert_eq!(early, truth, "early verdict differs: {b:?} {image:?}");
                }
                None => undecided += 1,
            }
            if truth {
                intersecting_images += 1;
                assert!(
                    listed.contains(&t),
                    "broad phase dropped the intersecting image {t:?}: {b:?} vs {a:?}"
                );
                assert!(
                    scanned.contains(&t),
                    "image scan dropped the intersecting image {t:?}: {b:?} vs {a:?}"
                );
            }
        }
    }
    println!(
        "intersecting images {intersecting_images}, decided early {decided}, undecided {undecided}"
    );
    assert!(intersecting_images > 5_000 && undecided > 100);
}
