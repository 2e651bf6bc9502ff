//! Tests of the typed sphere/cylinder intersection tests against constructed cases and
//! against an independent oracle: the distance between two convex bodies computed by GJK
//! on support maps (written here, sharing no code with the library).

use densepack::boundary::PeriodicBox;
use densepack::geometry::cylinder::{
    intersect_cylinder_cylinder, intersect_disk_disk, intersect_sphere_cylinder,
    intersect_sphere_sphere, overlaps, overlaps_decided_early, BaseContact, Cylinder,
    CylinderContact, DiskDiskKind, DiskSideKind, End, Shape, Sphere, SphereCylinderKind,
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
    let diff = |d: &V| support(a, d) - support(b, &-d);
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
        if vn - v.dot(&w) / vn <= 1e-14 * vn.max(1.0) {
            break;
        }
        simplex = sub;
        simplex.push(w);
    }
    v
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
    assert!(disagreements.is_empty());
    assert!(checked > 90_000 && overlapping > 10_000);
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
