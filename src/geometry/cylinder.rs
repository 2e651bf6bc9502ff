//! Exact, typed intersection tests between spheres and finite (flat-ended) cylinders.
//!
//! One module on purpose (about 1 300 lines with its tests): the four algorithms of the
//! paper and the exact sub-steps they call form one closed family of pure functions over one
//! contact type, each tested beside its code.
//!
//! # What
//!
//! The tests of Salnikov, Choï & Karamian-Surville (2014), *On efficient and reliable
//! stochastic generation of RVEs for analysis of composites within the framework of
//! homogenization*, §II (Algorithms 1–4). Every test is a pure function of the two shapes.
//! It returns `None` when the bodies do not intersect, and otherwise the intersection type
//! of the paper (`sc1`–`sc4`, `d1`/`d2`, `cd1`–`cd3`, `cc1`) together with a [`Contact`]:
//! an application point, a unit direction and a depth. These are the quantities Table I
//! of the paper needs to build the linear repulsive force of the relaxation (§IV):
//! the force on the *second* body is `depth * normal`, applied at `point`, and the force on
//! the first body is the opposite.
//!
//! # The algorithms
//!
//! * **Sphere–cylinder (Algorithm 1).** With `X` the axial coordinate of the sphere centre
//!   and `L` its distance from the axis, the sphere hits the curved face (`sc2`) when
//!   `|X| < h` and `L < r_s + r_c`, the flat base (`sc3`, `L < r_c`) or the base rim
//!   (`sc4`, `L ≥ r_c`) when `h ≤ |X| ≤ h + r_s` and `L < sqrt(r_s² − (|X| − h)²) + r_c`.
//!   `sc1` (the cylinder inside the sphere) is tested first.
//! * **Disk–disk (Algorithm 2).** The two disks meet iff their chords on the common line of
//!   their planes overlap.
//! * **Disk–cylinder side (Algorithm 3).** The point of the disk closest to the cylinder
//!   axis is computed exactly (a convex quadratic minimised over a disk, solved through its
//!   Lagrange multiplier); the disk meets the cylinder body away from the bases iff that
//!   point lies inside the cylinder. `cd1`: the axis misses the disk; `cd2`: the axis
//!   pierces the disk and the disk rim crosses the cylinder; `cd3`: the whole cylinder
//!   goes through the disk.
//! * **Cylinder–cylinder (Algorithm 4).** If the common perpendicular of the axes has both
//!   feet inside the cylinders and is shorter than `r₁ + r₂`, the curved faces intersect
//!   (`cc1`). Otherwise the bodies intersect iff some base disk of one meets the other body,
//!   which is decided by Algorithms 2 and 3 (the observation at the start of §II.B, whose
//!   proof is re-derived in the documentation of [`intersect_cylinder_cylinder`]).
//!
//! # Deviations from the printed paper
//!
//! The formulas were re-derived; the printed text (extracted from the PDF) differs in places:
//! * Algorithm 1, step 2(a) tests `sc1` only when `|X| > ‖l‖ + r_s`, where
//!   `‖p_c − p_s‖ ≥ |X| > r_s`, so `sc1` can never be reported. Here `sc1` means "the
//!   cylinder lies inside the sphere": `(|X| + h)² + (L + r_c)² < r_s²`.
//! * Algorithm 2 compares both disk centres with the projection of the *first* centre on the
//!   common line, and its `t` has the opposite sign of the one that puts `pt` on the second
//!   plane. Two disks meet iff their chords overlap, which is what is tested here.
//! * Algorithm 3 uses the rim point nearest, *in the disk plane*, to the point where the axis
//!   crosses the plane; for an inclined disk this is not the disk point nearest to the axis,
//!   so the test is neither necessary nor sufficient. The exact nearest point is used here;
//!   the paper's rim point is kept only to tell `cd2` from `cd3`.
//! * Table I gives the force `F_c` on the cylinder of Algorithm 1 and on the first body
//!   of Algorithms 2–4; here the force on the second argument of a test is
//!   `depth · normal`, so `F_c = depth · normal` for `sc*` and `−depth · normal` for the
//!   others. Entry by entry (`û = l_c/‖l_c‖`, `ŵ` the unit vector from the axis towards
//!   `p_s`, so `p_c − p_s + X û = −L ŵ`):
//!   - `sc2`, depth: the printed `√((r_s + r_c)² − L²)` is a half-chord, not a depth;
//!     the radial overlap `r_s + r_c − L` is used (the exact penetration depth when `p_s`
//!     is outside the cylinder, and the separating distance along `ŵ` when inside).
//!   - `sc2`, direction: the printed `F_c = −√(…) · (−ŵ)` points along `+ŵ`, i.e. it
//!     pulls the cylinder towards the sphere (a misprinted sign: every other entry is
//!     repulsive). The repulsive `F_c ∥ −ŵ` is used. With it and the radial depth, the
//!     printed point `p_s + (r_s − depth) F̂_c` is the cylinder surface point
//!     `p_s − (L − r_c) ŵ`; the middle of the overlap, `p_s − (r_s − depth/2) ŵ`, is used.
//!     Both lie on the line of action of `F_c`, so force and moment are the same.
//!   - `sc3`, point: the printed application point reduces to `p_s`; the projection of
//!     `p_s` on the base plane is used.
//!   - `sc4`, depth and direction: the printed `√(r_s² − (|X| − h)²) + r_c − L` along
//!     `(pt_c − p_s)/‖pt_c − p_s‖ = −ŵ` is the overlap, *in the base plane*, of the
//!     sphere's section with the base disk: a true separating distance, but only for a
//!     purely radial push. At `L → r_c` it tends to `√(r_s² − (|X| − h)²)` sideways
//!     (and its direction is `0/0` at `L = r_c`) while `sc3` pushes by `h + r_s − |X|`
//!     along the axis: the force jumps where the sphere centre crosses the side line.
//!     Here the exact minimal translation is used: with `q` the rim point nearest `p_s`,
//!     depth `r_s − ‖q − p_s‖` along `(q − p_s)/‖q − p_s‖`, applied at `q`. It equals
//!     `sc3` at `L = r_c` and `sc2` at `|X| = h`, so the force is continuous over all
//!     three types. (The printed point, at the axial height `X` of `p_s`, lies outside
//!     the cylinder.)
//!   - `cd1`, point (and the `b`, `pt_c` of its force): the printed `pt_c` is the rim
//!     point nearest, in the disk plane, to the point `a` where the axis crosses that
//!     plane; for an inclined disk it is not the disk point nearest the axis and may lie
//!     outside the cylinder while the disk meets it (pairs the exact test reports), where
//!     the printed magnitude `r_c − ‖b − pt_c‖` is negative (attraction). The exact
//!     nearest disk point `x` (see Algorithm 3 above) replaces `pt_c`: point `x`, depth
//!     `r_c − dist(x, axis)`, direction from the axis to `x`. Both points coincide when
//!     the disk is perpendicular to the axis.
//!   - `cd2`, depth: the printed `2r_c − ‖b − pt_c‖` jumps at both ends of the `cd2`
//!     range; the overlap `r_c + ‖b − pt_c‖` is continuous with `cd1` (depth `r_c` when
//!     the rim crosses the axis) and with `cd3` (depth `2r_c`).
//!   - `d1`/`d2`, magnitude: the printed `r_{d2} − ‖pt − p_{d2}‖` (`d1`) and
//!     `r_{d1} − ‖pt − p_{d1}‖` (`d2`) are lengths in the plane of the crossing disk,
//!     while the force acts along the *other* disk's normal, at an angle `θ` to that
//!     plane; they shrink as the crossing disk's centre goes deeper, and the `d1` one
//!     also measures from the foot `pt` of `p_{d1}`, not of `p_{d2}`, so it turns
//!     negative for disks whose chords overlap though `‖pt − p_{d2}‖ > r_{d2}` (the
//!     corrected Algorithm 2 above). Used instead: how far the crossing disk reaches
//!     through the plane of the other along that normal, `d1`:
//!     `max_{y ∈ D₂} (p_{d1} − y)·n_{d1} = (p_{d1} − p_{d2})·n_{d1} + r_{d2} sin θ`, `d2`:
//!     `(p_{d2} − p_{d1})·n_{d2} + r_{d1} sin θ` (when the crossing disk's centre lies on
//!     the outer side of the other plane, its in-plane overlap `r − dist(centre, L)`
//!     times `sin θ`, a penetration along the force). The application
//!     point is the middle of the common chord, which lies in both disks, instead of the
//!     foot `pt` of `p_{d1}`, which need not lie in the second disk.
//!   - `d2`, sign: the printed sign pushes the first cylinder into the second; the sign
//!     is mirrored from `d1`.
//!   - `sc1` (depth `2‖l_c‖`, along `p_c − p_s`, at `p_c`), `cc1` and `cd3` follow the
//!     table.
//! * The degenerate cases the paper leaves out (parallel axes, intersecting axes, coincident
//!   centres, an axis parallel to a disk) are handled explicitly; no division by a vanishing
//!   quantity is ever made, so no NaN is returned for valid shapes.
//!
//! # Tolerance
//!
//! Touching is *not* intersecting: every test requires a penetration larger than
//! [`RELATIVE_TOLERANCE`] times the size of the pair (the largest radius or half-length).
//!
//! # Example
//!
//! ```
//! use densepack::geometry::cylinder::{
//!     intersect_cylinder_cylinder, overlaps, CylinderContact, Cylinder, Shape, Sphere,
//!     SphereCylinderKind, intersect_sphere_cylinder,
//! };
//! use nalgebra::Vector3;
//!
//! // Two crossed rods of radius 0.5 whose axes are 0.9 apart: the curved faces meet (cc1).
//! let a = Cylinder::new(Vector3::zeros(), Vector3::new(2.0, 0.0, 0.0), 0.5);
//! let b = Cylinder::new(Vector3::new(0.0, 0.0, 0.9), Vector3::new(0.0, 2.0, 0.0), 0.5);
//! match intersect_cylinder_cylinder(&a, &b) {
//!     Some(CylinderContact::Cc1(c)) => {
//!         assert!((c.depth - 0.1).abs() < 1e-12);
//!         assert!((c.normal - Vector3::z()).norm() < 1e-12);
//!     }
//!     other => panic!("unexpected {other:?}"),
//! }
//! // A sphere above the top base, centre inside the infinite cylinder: type sc3.
//! let s = Sphere::new(Vector3::new(0.0, 0.1, 2.4), 0.5);
//! let c = Cylinder::new(Vector3::zeros(), Vector3::new(0.0, 0.0, 2.0), 0.5);
//! assert_eq!(intersect_sphere_cylinder(&s, &c).unwrap().kind, SphereCylinderKind::Sc3);
//! assert!(!overlaps(&Shape::Cylinder(a), &Shape::Sphere(Sphere::new(Vector3::new(0.0, 3.0, 0.0), 0.5))));
//! ```

use nalgebra::Vector3;

/// Touching tolerance, relative to the size of the pair: bodies whose penetration is at most
/// `RELATIVE_TOLERANCE * size` are reported as not intersecting.
pub const RELATIVE_TOLERANCE: f64 = 1e-12;

/// Below this sine of the angle between two directions they are treated as parallel.
/// The error made by that is at most this sine times the size of the pair.
const PARALLEL_SINE: f64 = 1e-12;

/// A sphere `S(p_s, r_s)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre `p_s`.
    pub center: Vector3<f64>,
    /// Radius `r_s > 0`.
    pub radius: f64,
}

impl Sphere {
    /// A sphere from its centre and radius.
    ///
    /// # Panics
    /// If the radius is not finite and positive.
    pub fn new(center: Vector3<f64>, radius: f64) -> Self {
        assert!(
            radius.is_finite() && radius > 0.0,
            "sphere radius must be positive"
        );
        Self { center, radius }
    }
}

/// A finite, flat-ended cylinder `C(p_c, r_c, l_c)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cylinder {
    /// Centre `p_c`.
    pub center: Vector3<f64>,
    /// Half axis `l_c`: from the centre to the centre of one end disk (not normalised; its
    /// length is the half-length `h` of the cylinder).
    pub half_axis: Vector3<f64>,
    /// Radius `r_c > 0`.
    pub radius: f64,
}

impl Cylinder {
    /// A cylinder from its centre, half axis and radius.
    ///
    /// # Panics
    /// If the radius is not finite and positive or the half axis is zero or not finite.
    pub fn new(center: Vector3<f64>, half_axis: Vector3<f64>, radius: f64) -> Self {
        assert!(
            radius.is_finite() && radius > 0.0,
            "cylinder radius must be positive"
        );
        let h = half_axis.norm();
        assert!(
            h.is_finite() && h > 0.0,
            "cylinder half axis must be non-zero"
        );
        Self {
            center,
            half_axis,
            radius,
        }
    }

    /// Half-length `h = ‖l_c‖`.
    pub fn half_length(&self) -> f64 {
        self.half_axis.norm()
    }

    /// Unit vector along the axis, `l_c / ‖l_c‖`.
    pub fn axis(&self) -> Vector3<f64> {
        self.half_axis / self.half_length()
    }

    /// Aspect ratio `a = ‖l_c‖ / r_c` as defined in the paper (half-length over radius,
    /// which equals length over diameter).
    pub fn aspect_ratio(&self) -> f64 {
        self.half_length() / self.radius
    }

    /// The base disk at `end`, with outward unit normal.
    pub fn end_disk(&self, end: End) -> Disk {
        let u = self.axis();
        let sign = end.sign();
        Disk {
            center: self.center + self.half_axis * sign,
            radius: self.radius,
            normal: u * sign,
        }
    }
}

/// One end of a cylinder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum End {
    /// The end at `p_c + l_c`.
    Plus,
    /// The end at `p_c − l_c`.
    Minus,
}

impl End {
    fn sign(self) -> f64 {
        match self {
            End::Plus => 1.0,
            End::Minus => -1.0,
        }
    }
}

/// A disk `D(p_d, r_d, n_d)` in space: a base of a cylinder.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Disk {
    /// Centre `p_d`.
    pub center: Vector3<f64>,
    /// Radius `r_d > 0`.
    pub radius: f64,
    /// Unit normal `n_d`; for a cylinder base it points out of the cylinder.
    pub normal: Vector3<f64>,
}

/// Either kind of particle.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// A sphere.
    Sphere(Sphere),
    /// A finite cylinder.
    Cylinder(Cylinder),
}

/// Which of the two bodies passed to a test.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Body {
    /// The first argument.
    First,
    /// The second argument.
    Second,
}

/// Geometry of one intersection, as needed by the force model of Table I.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Contact {
    /// Application point of the force (Table I, column `pt_c`).
    pub point: Vector3<f64>,
    /// Unit direction along which the second body is pushed out of the first
    /// (the first body is pushed the opposite way).
    pub normal: Vector3<f64>,
    /// Overlap measured along `normal` (positive); the force magnitude is proportional to it.
    pub depth: f64,
}

/// Intersection types of a sphere with a cylinder (Algorithm 1, Fig. 16–20).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SphereCylinderKind {
    /// `sc1`: the whole cylinder lies inside the sphere.
    Sc1,
    /// `sc2`: the sphere meets the curved face (Fig. 16, 17).
    Sc2,
    /// `sc3`: the sphere meets the flat base, its centre inside the infinite cylinder
    /// (Fig. 18, 19).
    Sc3,
    /// `sc4`: the sphere meets the rim of a base, its centre outside the infinite
    /// cylinder (Fig. 20).
    Sc4,
}

/// A typed sphere–cylinder intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereCylinderContact {
    /// The intersection type.
    pub kind: SphereCylinderKind,
    /// Force geometry; `normal` pushes the cylinder away from the sphere.
    pub contact: Contact,
}

/// Intersection types of two disks (Algorithm 2, Fig. 3 and 28).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiskDiskKind {
    /// `d1`: the chord of the first disk is the longer one; the rim of the second disk
    /// crosses the first disk.
    D1,
    /// `d2`: the chord of the second disk is the longer one; the rim of the first disk
    /// crosses the second disk.
    D2,
}

/// A typed disk–disk intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiskDiskContact {
    /// The intersection type.
    pub kind: DiskDiskKind,
    /// Force geometry; `normal` pushes the body of the second disk out of the first
    /// (for `d1` along the first normal, for `d2` against the second normal).
    pub contact: Contact,
}

/// Intersection types of a disk with a cylinder away from its bases (Algorithm 3,
/// Fig. 24–27, 29).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DiskSideKind {
    /// `cd1`: the disk meets the curved face but the axis misses the disk.
    Cd1,
    /// `cd2`: the axis pierces the disk and the disk rim lies across the cylinder.
    Cd2,
    /// `cd3`: the axis pierces the disk and the whole cylinder goes through it.
    Cd3,
}

/// A typed disk–cylinder-side intersection.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiskSideContact {
    /// The intersection type.
    pub kind: DiskSideKind,
    /// Force geometry; `normal` pushes the body of the disk away from the cylinder.
    pub contact: Contact,
}

/// One intersection involving a base disk of two cylinders (several can occur at once).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BaseContact {
    /// A base of one cylinder meets the other cylinder away from its bases
    /// (`cd1`–`cd3`). `contact.normal` pushes the second cylinder out of the first.
    DiskSide {
        /// The cylinder the disk belongs to.
        disk_of: Body,
        /// Which base of that cylinder.
        end: End,
        /// The typed intersection.
        contact: DiskSideContact,
    },
    /// A base of the first cylinder meets a base of the second (`d1`, `d2`).
    /// `contact.normal` pushes the second cylinder out of the first.
    DiskDisk {
        /// Base of the first cylinder.
        first_end: End,
        /// Base of the second cylinder.
        second_end: End,
        /// The typed intersection.
        contact: DiskDiskContact,
    },
}

/// A typed cylinder–cylinder intersection (Algorithm 4).
#[derive(Clone, Debug, PartialEq)]
pub enum CylinderContact {
    /// `cc1`: the curved faces intersect (Fig. 21–23; parallel axes, Fig. 25, and
    /// intersecting axes, Fig. 29, are the degenerate cases). `normal` pushes the second
    /// cylinder out of the first.
    Cc1(Contact),
    /// Intersections involving the bases: every `cd1`–`cd3` and `d1`/`d2` intersection
    /// found, never empty.
    Bases(Vec<BaseContact>),
}

/// `a*b − c*d` with one rounding error (Kahan's fused difference of products), so that the
/// cross product of nearly parallel vectors keeps full relative accuracy.
fn diff_of_products(a: f64, b: f64, c: f64, d: f64) -> f64 {
    let cd = c * d;
    let err = (-c).mul_add(d, cd);
    a.mul_add(b, -cd) + err
}

/// Accurate cross product.
fn cross(a: &Vector3<f64>, b: &Vector3<f64>) -> Vector3<f64> {
    Vector3::new(
        diff_of_products(a.y, b.z, a.z, b.y),
        diff_of_products(a.z, b.x, a.x, b.z),
        diff_of_products(a.x, b.y, a.y, b.x),
    )
}

/// A unit vector orthogonal to the unit vector `u`.
fn any_perpendicular(u: &Vector3<f64>) -> Vector3<f64> {
    let helper = if u.x.abs() <= u.y.abs() && u.x.abs() <= u.z.abs() {
        Vector3::x()
    } else if u.y.abs() <= u.z.abs() {
        Vector3::y()
    } else {
        Vector3::z()
    };
    cross(u, &helper).normalize()
}

/// `v / |v|`, or `fallback()` when `v` vanishes. The fallback is computed only then: most
/// are cross products (software `fma` on the baseline x86-64 target), which the exact
/// tests would otherwise pay on every call.
fn unit_or(v: Vector3<f64>, fallback: impl FnOnce() -> Vector3<f64>) -> Vector3<f64> {
    let n = v.norm();
    if n > 0.0 && n.is_finite() {
        v / n
    } else {
        fallback()
    }
}

/// `√(a² + b²)`: the arguments are lengths of the scene (no overflow to guard against, so
/// no `hypot`, a library call several times slower in the RSA inner loop).
fn norm2(a: f64, b: f64) -> f64 {
    (a * a + b * b).sqrt()
}

/// Tolerance of a pair of sizes.
fn tolerance(size: f64) -> f64 {
    RELATIVE_TOLERANCE * size
}

fn sphere_size(s: &Sphere) -> f64 {
    s.radius
}

fn cylinder_size(c: &Cylinder) -> f64 {
    c.radius.max(c.half_length())
}

fn disk_size(d: &Disk) -> f64 {
    d.radius
}

/// Sphere–sphere test (§IV): the spheres intersect iff `‖p₁ − p₂‖ < r₁ + r₂`.
/// The normal points from the first centre to the second (an arbitrary unit vector when
/// the centres coincide); the point is the middle of the overlap along it.
pub fn intersect_sphere_sphere(a: &Sphere, b: &Sphere) -> Option<Contact> {
    let d = b.center - a.center;
    let dist = d.norm();
    let depth = a.radius + b.radius - dist;
    if depth <= tolerance(sphere_size(a).max(sphere_size(b))) {
        return None;
    }
    let normal = unit_or(d, Vector3::x);
    Some(Contact {
        point: a.center + normal * (a.radius - 0.5 * depth),
        normal,
        depth,
    })
}

/// Sphere–cylinder test (Algorithm 1, Fig. 16–20), corrected as in the module
/// documentation. The contact normal pushes the cylinder away from the sphere.
pub fn intersect_sphere_cylinder(s: &Sphere, c: &Cylinder) -> Option<SphereCylinderContact> {
    let tol = tolerance(sphere_size(s).max(cylinder_size(c)));
    let h = c.half_length();
    let u = c.axis();
    let w = s.center - c.center;
    // Step 1: axial coordinate X; L from the perpendicular component (no cancellation).
    let x = w.dot(&u);
    let w_perp = w - u * x;
    let l = w_perp.norm();
    let ax = x.abs();
    let axial_sign = if x >= 0.0 { 1.0 } else { -1.0 };
    // Radial unit vector from the axis towards the sphere centre (computed only for a
    // contact on the curved face or the rim).
    let radial = || unit_or(w_perp, || any_perpendicular(&u));
    // sc1: the farthest point of the cylinder from p_s is a rim point, at a distance
    // `far ≥ |X| + h`: only possible when `|X| + h < r_s` (which spares the square root
    // of `far` in the common case).
    if ax + h < s.radius && s.radius - norm2(ax + h, l + c.radius) > tol {
        let normal = unit_or(c.center - s.center, || u);
        return Some(SphereCylinderContact {
            kind: SphereCylinderKind::Sc1,
            contact: Contact {
                point: c.center,
                normal,
                depth: 2.0 * h,
            },
        });
    }
    // Step 2: beyond the slab widened by r_s.
    if ax >= h + s.radius {
        return None;
    }
    if ax < h {
        // Step 3: the nearest cylinder point is on the curved face (or p_s is inside).
        let depth = s.radius + c.radius - l;
        if depth <= tol {
            return None;
        }
        let normal = -radial();
        return Some(SphereCylinderContact {
            kind: SphereCylinderKind::Sc2,
            contact: Contact {
                point: s.center + normal * (s.radius - 0.5 * depth),
                normal,
                depth,
            },
        });
    }
    // Step 4: h ≤ |X| < h + r_s, the nearest point is on the base.
    let base_center = c.center + u * (axial_sign * h);
    if l < c.radius {
        let depth = h + s.radius - ax;
        if depth <= tol {
            return None;
        }
        return Some(SphereCylinderContact {
            kind: SphereCylinderKind::Sc3,
            contact: Contact {
                point: base_center + w_perp,
                normal: -u * axial_sign,
                depth,
            },
        });
    }
    // sc4: the nearest point is the rim point q; intersect iff ‖p_s − q‖ < r_s, i.e.
    // L − r_c < sqrt(r_s² − (|X| − h)²).
    let dist = norm2(ax - h, l - c.radius);
    let depth = s.radius - dist;
    if depth <= tol {
        return None;
    }
    let radial = radial();
    let q = base_center + radial * c.radius;
    let normal = unit_or(q - s.center, || -radial);
    Some(SphereCylinderContact {
        kind: SphereCylinderKind::Sc4,
        contact: Contact {
            point: q,
            normal,
            depth,
        },
    })
}

/// Disk–disk test (Algorithm 2, Fig. 3, 28), corrected: the disks meet iff their chords
/// on the common line `L` of their planes overlap. Parallel planes meet only when they
/// coincide and the outward normals agree (opposite normals mean the two bodies lie on
/// opposite sides of the plane and merely touch). The normal pushes the body of the
/// second disk out of the first.
pub fn intersect_disk_disk(a: &Disk, b: &Disk) -> Option<DiskDiskContact> {
    let tol = tolerance(disk_size(a).max(disk_size(b)));
    let d = b.center - a.center;
    // Step 1: direction of L.
    let c = cross(&a.normal, &b.normal);
    let sine = c.norm();
    if sine <= PARALLEL_SINE {
        let dz = d.dot(&a.normal);
        if dz.abs() > tol || a.normal.dot(&b.normal) < 0.0 {
            return None;
        }
        let lateral = d - a.normal * dz;
        let dist = lateral.norm();
        let depth = a.radius + b.radius - dist;
        if depth <= tol {
            return None;
        }
        let normal = unit_or(lateral, || any_perpendicular(&a.normal));
        let kind = if a.radius >= b.radius {
            DiskDiskKind::D1
        } else {
            DiskDiskKind::D2
        };
        return Some(DiskDiskContact {
            kind,
            contact: Contact {
                point: a.center + normal * (a.radius - 0.5 * depth),
                normal,
                depth,
            },
        });
    }
    let e = c / sine;
    // Step 2: foot pt of p_{d1} on L, pt = p_{d1} + t v with v = e × n_{d1} in the first
    // plane; n_{d2}·(pt − p_{d2}) = 0 gives t = n_{d2}·(p_{d2} − p_{d1}) / (n_{d2}·v), and
    // n_{d2}·v = e·(n_{d1} × n_{d2}) = sine > 0.
    let v = cross(&e, &a.normal);
    let t = b.normal.dot(&d) / sine;
    let pt = a.center + v * t;
    // Step 3 (corrected): chords [−h₁, h₁] and [s₂ − h₂, s₂ + h₂] along e from pt.
    let dist1 = t.abs();
    let q = b.center - pt;
    let s2 = q.dot(&e);
    let dist2 = (q - e * s2).norm();
    if a.radius - dist1 <= tol || b.radius - dist2 <= tol {
        return None;
    }
    let h1 = ((a.radius - dist1) * (a.radius + dist1)).sqrt();
    let h2 = ((b.radius - dist2) * (b.radius + dist2)).sqrt();
    let lo = (-h1).max(s2 - h2);
    let hi = h1.min(s2 + h2);
    if hi - lo <= tol {
        return None;
    }
    let point = pt + e * (0.5 * (lo + hi));
    // Depth: how far one disk reaches through the plane of the other, into its body.
    let sin_ab = sine;
    let (kind, normal, depth) = if h1 >= h2 {
        // d1: disk 2 crosses disk 1; push body 2 along the outward normal of disk 1.
        (
            DiskDiskKind::D1,
            a.normal,
            -d.dot(&a.normal) + b.radius * sin_ab,
        )
    } else {
        // d2: disk 1 crosses disk 2; push body 2 into its own side, against n_{d2}.
        (
            DiskDiskKind::D2,
            -b.normal,
            d.dot(&b.normal) + a.radius * sin_ab,
        )
    };
    Some(DiskDiskContact {
        kind,
        contact: Contact {
            point,
            normal,
            depth: depth.max(tol),
        },
    })
}

/// The point of the disk nearest to the axis line of `c`, and whether the axis pierces
/// the disk.
///
/// With `y` the offset from the disk centre in the disk plane, the squared distance to the
/// axis is `|w⊥|² + 2 b·y + λ₁ y₁² + y₂²` in the basis `e₁` (projection of the axis on the
/// plane), `e₂ = n × e₁`, where `λ₁ = (u·n)²`. Its minimiser over `|y| ≤ r` is
/// `y(μ) = −(b₁/(λ₁ + μ), b₂/(1 + μ))` with the Lagrange multiplier `μ ≥ 0` the root of
/// the decreasing function `|y(μ)| = r` (or `μ = 0` when the free minimiser is inside).
fn disk_point_nearest_axis(c: &Cylinder, d: &Disk) -> (Vector3<f64>, bool) {
    let u = c.axis();
    let n = d.normal;
    let un = u.dot(&n);
    let u_plane = u - n * un;
    let e1 = unit_or(u_plane, || any_perpendicular(&n));
    let e2 = cross(&n, &e1);
    // An axis parallel to the disk within `PARALLEL_SINE` is taken as parallel: there `b₁`
    // (exactly `−u·n (w⊥·n)/|u − (u·n)n|`, about `u·n` times a length) is rounding noise
    // of the same order, and `−b₁/λ₁` would put a spurious piercing point anywhere.
    let lam1 = if un.abs() > PARALLEL_SINE {
        un * un
    } else {
        0.0
    };
    let w = d.center - c.center;
    let w_perp = w - u * w.dot(&u);
    let b1 = w_perp.dot(&e1);
    let b2 = w_perp.dot(&e2);
    let r = d.radius;
    let free1 = if lam1 > 0.0 {
        -b1 / lam1
    } else if b1 == 0.0 {
        0.0
    } else {
        f64::INFINITY
    };
    let free = (free1, -b2);
    if free.0.is_finite() && norm2(free.0, free.1) <= r {
        return (d.center + e1 * free.0 + e2 * free.1, lam1 > 0.0);
    }
    // The root μ* of ψ(μ) = 1/|y(μ)| − 1/r (increasing) is bracketed by
    // lo = max(0, |b₁|/r − λ₁, |b₂|/r − 1) (each term of |y| alone reaches r there) and
    // hi = |b|/r (|y(μ)| ≤ |b|/μ). Newton steps on ψ, which is nearly linear in μ (the
    // secular equation of trust-region methods), kept inside the bracket (else bisection):
    // a handful of steps instead of some sixty bisections.
    let bnorm = norm2(b1, b2);
    let y_of = |mu: f64| (-b1 / (lam1 + mu), -b2 / (1.0 + mu));
    let (mut lo, mut hi) = (
        (b1.abs() / r - lam1).max(b2.abs() / r - 1.0).max(0.0),
        bnorm / r,
    );
    let mut mu = lo;
    for _ in 0..100 {
        let (a1, a2) = (lam1 + mu, 1.0 + mu);
        let (q1, q2) = (b1 * b1 / (a1 * a1), b2 * b2 / (a2 * a2));
        let s = q1 + q2;
        let psi = 1.0 / s.sqrt() - 1.0 / r;
        if psi < 0.0 {
            lo = mu;
        } else if psi > 0.0 {
            hi = mu;
        } else if psi == 0.0 {
            break;
        }
        // ψ' = −½ s^{−3/2} s', s' = −2 (q₁/a₁ + q₂/a₂).
        let dpsi = (q1 / a1 + q2 / a2) / (s * s.sqrt());
        let mut next = mu - psi / dpsi;
        // (Also a NaN step, e.g. at μ = 0 with λ₁ = b₁ = 0.)
        if !(next > lo && next < hi) {
            next = 0.5 * (lo + hi);
        }
        let step = (next - mu).abs();
        mu = next;
        if step <= 4.0 * f64::EPSILON * mu || hi <= lo {
            break;
        }
    }
    let y = y_of(mu);
    let norm = norm2(y.0, y.1);
    let scale = if norm > r { r / norm } else { 1.0 };
    (d.center + e1 * (y.0 * scale) + e2 * (y.1 * scale), false)
}

/// Disk–cylinder-side test (Algorithm 3, Fig. 24–27, 29), made exact: the disk meets the
/// cylinder away from its bases iff the disk point `x` nearest to the axis is closer than
/// `r_c` to it and projects strictly inside the cylinder length (if `x` projects outside
/// while the disk meets the body, the disk crosses a base plane inside the cylinder and
/// meets that base, which [`intersect_disk_disk`] reports). Types: `cd1` if the axis
/// misses the disk; otherwise, with `a` the point where the axis pierces the disk and
/// `pt_c = p_d + r_d (a − p_d)/‖a − p_d‖` the rim point nearest to it, `cd2` if `pt_c` is
/// within `r_c` of the axis, else `cd3`. The normal pushes the body of the disk away from
/// the cylinder.
pub fn intersect_disk_cylinder_side(c: &Cylinder, d: &Disk) -> Option<DiskSideContact> {
    let tol = tolerance(cylinder_size(c).max(disk_size(d)));
    let u = c.axis();
    let h = c.half_length();
    let (x, pierced) = disk_point_nearest_axis(c, d);
    let rel = x - c.center;
    let s = rel.dot(&u);
    let radial = rel - u * s;
    let dist = radial.norm();
    if c.radius - dist <= tol || h - s.abs() <= tol {
        return None;
    }
    if !pierced {
        let fallback = || {
            unit_or(
                (d.center - c.center) - u * (d.center - c.center).dot(&u),
                || any_perpendicular(&u),
            )
        };
        return Some(DiskSideContact {
            kind: DiskSideKind::Cd1,
            contact: Contact {
                point: x,
                normal: unit_or(radial, fallback),
                depth: c.radius - dist,
            },
        });
    }
    // x is the piercing point a.
    let a = x;
    let towards_a = unit_or(a - d.center, || {
        cross(
            &d.normal,
            &unit_or(u - d.normal * u.dot(&d.normal), || {
                any_perpendicular(&d.normal)
            }),
        )
    });
    let pt_c = d.center + towards_a * d.radius;
    let rel_c = pt_c - c.center;
    let b_c = c.center + u * rel_c.dot(&u);
    let dist_c = (pt_c - b_c).norm();
    if dist_c < c.radius {
        // The rim lies dist_c beyond the axis: the cylinder must move r_c + dist_c past it.
        let normal = unit_or(b_c - pt_c, || -towards_a);
        return Some(DiskSideContact {
            kind: DiskSideKind::Cd2,
            contact: Contact {
                point: pt_c,
                normal,
                depth: c.radius + dist_c,
            },
        });
    }
    Some(DiskSideContact {
        kind: DiskSideKind::Cd3,
        contact: Contact {
            point: a,
            normal: unit_or(d.center - c.center, || -d.normal),
            depth: 2.0 * c.radius,
        },
    })
}

/// Flips a contact whose normal pushes the first body into one pushing the second.
fn flipped(c: Contact) -> Contact {
    Contact {
        normal: -c.normal,
        ..c
    }
}

/// Parallel axes (the degenerate `cc1` of Fig. 25): the intersection is the product of the
/// intersections of the cross-sections and of the axial intervals, so it is non-empty iff
/// both overlap. The contact takes the shallower of the lateral and axial overlaps.
fn parallel_cylinders(a: &Cylinder, b: &Cylinder, tol: f64) -> Option<CylinderContact> {
    let u = a.axis();
    let d = b.center - a.center;
    let s = d.dot(&u);
    let lateral = d - u * s;
    let rho = lateral.norm();
    let (ha, hb) = (a.half_length(), b.half_length());
    let axial_depth = ha + hb - s.abs();
    let lateral_depth = a.radius + b.radius - rho;
    if axial_depth <= tol || lateral_depth <= tol {
        return None;
    }
    let e = unit_or(lateral, || any_perpendicular(&u));
    let mid = 0.5 * ((-ha).max(s - hb) + ha.min(s + hb));
    let point = a.center + u * mid + e * (a.radius - 0.5 * lateral_depth);
    let contact = if lateral_depth <= axial_depth {
        Contact {
            point,
            normal: e,
            depth: lateral_depth,
        }
    } else {
        let sign = if s >= 0.0 { 1.0 } else { -1.0 };
        Contact {
            point,
            normal: u * sign,
            depth: axial_depth,
        }
    };
    Some(CylinderContact::Cc1(contact))
}

/// Squared distance between the segments `p ± h_p u` and `q ± h_q w` (unit `u`, `w`;
/// `h = 0` gives a point): the convex quadratic in the two segment parameters minimised
/// over the rectangle `[−h_p, h_p] × [−h_q, h_q]` (interior stationary point, else the
/// best of the edges). Two capsules of radii `r_p`, `r_q` about these segments intersect
/// iff it is below `(r_p + r_q)²`.
pub fn segment_distance_squared(
    p: &Vector3<f64>,
    u: &Vector3<f64>,
    hp: f64,
    q: &Vector3<f64>,
    w: &Vector3<f64>,
    hq: f64,
) -> f64 {
    segment_closest_points(p, u, hp, q, w, hq).2
}

/// [`segment_distance_squared`] with the parameters `(s, t)` of a closest pair of points
/// `p + s u`, `q + t w`: `(s, t, distance²)`.
fn segment_closest_points(
    p: &Vector3<f64>,
    u: &Vector3<f64>,
    hp: f64,
    q: &Vector3<f64>,
    w: &Vector3<f64>,
    hq: f64,
) -> (f64, f64, f64) {
    let d = p - q;
    let b = u.dot(w);
    let (e, f) = (u.dot(&d), w.dot(&d));
    let dist2 = |s: f64, t: f64| (d + u * s - w * t).norm_squared();
    // Best t for a given s on the second segment, and vice versa (unit directions).
    let t_of = |s: f64| (f + b * s).clamp(-hq, hq);
    let s_of = |t: f64| (b * t - e).clamp(-hp, hp);
    let denom = 1.0 - b * b;
    if denom > 1e-12 {
        let s = (b * f - e) / denom;
        let t = (f - b * e) / denom;
        if s.abs() <= hp && t.abs() <= hq {
            return (s, t, dist2(s, t));
        }
    }
    // The minimum lies on an edge of the rectangle.
    [
        (-hp, t_of(-hp)),
        (hp, t_of(hp)),
        (s_of(-hq), -hq),
        (s_of(hq), hq),
    ]
    .into_iter()
    .map(|(s, t)| (s, t, dist2(s, t)))
    .fold((0.0, 0.0, f64::INFINITY), |best, x| {
        if x.2 < best.2 {
            x
        } else {
            best
        }
    })
}

/// What the steps of Algorithm 4 before the base tests found.
enum Early {
    /// The cylinders are disjoint (or touch within the tolerance).
    Apart,
    /// They intersect: the typed contact, or `None` when only the verdict was asked for
    /// and a sufficient test decided it (never `None` otherwise).
    Meet(Option<CylinderContact>),
    /// Only the base tests ([`base_contacts`]) can tell.
    Undecided,
}

impl From<Option<CylinderContact>> for Early {
    fn from(found: Option<CylinderContact>) -> Self {
        found.map_or(Early::Apart, |c| Early::Meet(Some(c)))
    }
}

/// Algorithm 4 up to the base tests: bounding spheres, bounding capsules, a separating
/// axis along either cylinder axis, parallel axes, the axis distance or `cc1` decide, or
/// the base tests are needed ([`Early::Undecided`]). With `verdict_only`, a sufficient
/// test runs right after the capsules: inscribed balls about the closest points of the
/// axis segments (see below), which decides most intersecting pairs without the cross
/// products of the common normal.
fn cylinder_cylinder_early(a: &Cylinder, b: &Cylinder, verdict_only: bool) -> Early {
    let tol = tolerance(cylinder_size(a).max(cylinder_size(b)));
    let d = b.center - a.center;
    let (ha, hb) = (a.half_length(), b.half_length());
    // Bounding spheres: an exact early exit.
    let ra = (ha * ha + a.radius * a.radius).sqrt();
    let rb = (hb * hb + b.radius * b.radius).sqrt();
    if d.norm_squared() >= (ra + rb) * (ra + rb) {
        return Early::Apart;
    }
    let (u1, u2) = (a.half_axis / ha, b.half_axis / hb);
    // Bounding capsules (each cylinder lies within its radius of its axis segment): an
    // exact early exit, with the touching tolerance on the safe side.
    let reach = a.radius + b.radius + tol;
    // First the axis lines, far cheaper than the segments: their distance `|d · e| / |e|`
    // (`e = u₁ × u₂`) is at most the segments', so lines farther apart than the reach
    // (with a relative margin of 10⁻⁹ above the rounding of this plain cross product,
    // and only when the axes are not nearly parallel) separate the capsules too.
    let e = u1.cross(&u2);
    let (de, e2) = (d.dot(&e), e.norm_squared());
    if e2 > 1e-6 && de * de > reach * reach * e2 * (1.0 + 1e-9) {
        return Early::Apart;
    }
    let (s_near, t_near, gap2) = segment_closest_points(&a.center, &u1, ha, &b.center, &u2, hb);
    if gap2 >= reach * reach {
        return Early::Apart;
    }
    // Inscribed balls (a sufficient condition for an intersection): the ball about the
    // axis point `x_a = c_a + s u₁` (`|s| ≤ h_a`) of radius `ρ_a = min(r_a, h_a − |s|)` lies
    // in the first cylinder, likewise `ρ_b` about `x_b`. If `|x_a − x_b| < ρ_a + ρ_b − 2δ`
    // with `ρ_a, ρ_b > δ` (`δ` the margin of [`share_a_deep_point`]), the point `y` of
    // `[x_a, x_b]` at `max(0, |x_a − x_b| − ρ_b + δ)` from `x_a` has its ball of radius
    // `δ` in both balls, hence in both cylinders: a penetration far above the touching
    // tolerance, which the exact tests report. Taken at the closest points of the axes,
    // where the capsules meet deepest.
    if verdict_only {
        let margin = 1e-6 * cylinder_size(a).max(cylinder_size(b));
        let (rho_a, rho_b) = (
            a.radius.min(ha - s_near.abs()),
            b.radius.min(hb - t_near.abs()),
        );
        let room = rho_a + rho_b - 2.0 * margin;
        if rho_a > margin && rho_b > margin && gap2 < room * room {
            return Early::Meet(None);
        }
    }
    // Separating axes along either cylinder axis: the projection of a cylinder `(u, h, r)`
    // on a unit `n` is its centre's ± `h |u·n| + r √(1 − (u·n)²)`, so a gap between the
    // projections proves the bodies disjoint (an exact early exit that spares the base
    // tests below for most near-miss pairs, e.g. end-to-end or end-to-side).
    let half_extent = |u: &Vector3<f64>, h: f64, r: f64, n: &Vector3<f64>| {
        let c = u.dot(n).abs();
        h * c + r * (1.0 - c * c).max(0.0).sqrt()
    };
    let separates = |n: &Vector3<f64>| {
        d.dot(n).abs() - half_extent(&u1, ha, a.radius, n) - half_extent(&u2, hb, b.radius, n) > 0.0
    };
    if separates(&u1) || separates(&u2) {
        return Early::Apart;
    }
    // Step 1: common normal of the axes.
    let c = cross(&u1, &u2);
    let sine = c.norm();
    if sine <= PARALLEL_SINE {
        return parallel_cylinders(a, b, tol).into();
    }
    let n = c / sine;
    // Step 2, 3: distance between the axes.
    let rho = d.dot(&n).abs();
    if a.radius + b.radius - rho <= tol {
        return Early::Apart;
    }
    // Step 3(b): feet of the common perpendicular, in length units along the unit axes:
    // s₁ = c·(d × u₂)/|c|², s₂ = c·(d × u₁)/|c|² (equal to the paper's t₁‖l₁‖, t₂‖l₂‖).
    let s1 = c.dot(&cross(&d, &u2)) / (sine * sine);
    let s2 = c.dot(&cross(&d, &u1)) / (sine * sine);
    if s1.abs() <= ha && s2.abs() <= hb {
        // Step 3(c): cc1.
        let pt1 = a.center + u1 * s1;
        let pt2 = b.center + u2 * s2;
        let sign = if d.dot(&n) >= 0.0 { 1.0 } else { -1.0 };
        // `pt₂ − pt₁ = (d·n) n`. When the axes (nearly) cross, its computed value is
        // rounding noise pointing anywhere, not along the axes' common normal: the exact
        // `±n` is used whenever the two disagree (elsewhere they agree to rounding).
        let along = n * sign;
        let normal = match (pt2 - pt1).try_normalize(0.0) {
            Some(v) if v.dot(&along) > 1.0 - 1e-9 => v,
            _ => along,
        };
        return Early::Meet(Some(CylinderContact::Cc1(Contact {
            point: 0.5 * (pt1 + pt2),
            normal,
            depth: a.radius + b.radius - rho,
        })));
    }
    // Before the base tests: three more candidate separating axes (unit, same exact
    // projection test), from the closest points `x_a`, `x_b` of the axis segments: their
    // difference `g = x_b − x_a`, and `g` without its component along either axis (the
    // normal of the curved face at the point nearest the other body). They separate most
    // pairs whose bounding capsules meet near an end, e.g. end-to-side and skew ends.
    let g = (b.center + u2 * t_near) - (a.center + u1 * s_near);
    for n in [g, g - u1 * u1.dot(&g), g - u2 * u2.dot(&g)] {
        let norm = n.norm();
        if norm > 0.0 && separates(&(n / norm)) {
            return Early::Apart;
        }
    }
    Early::Undecided
}

/// Algorithm 4, steps 3(c) i–iii: all intersections involving a base (or the first one
/// with `first_only`).
fn base_contacts(a: &Cylinder, b: &Cylinder, first_only: bool) -> Option<CylinderContact> {
    let mut found = Vec::new();
    for end in [End::Plus, End::Minus] {
        if let Some(contact) = intersect_disk_cylinder_side(a, &b.end_disk(end)) {
            found.push(BaseContact::DiskSide {
                disk_of: Body::Second,
                end,
                contact,
            });
            if first_only {
                return Some(CylinderContact::Bases(found));
            }
        }
    }
    for end in [End::Plus, End::Minus] {
        if let Some(mut contact) = intersect_disk_cylinder_side(b, &a.end_disk(end)) {
            contact.contact = flipped(contact.contact);
            found.push(BaseContact::DiskSide {
                disk_of: Body::First,
                end,
                contact,
            });
            if first_only {
                return Some(CylinderContact::Bases(found));
            }
        }
    }
    for first_end in [End::Plus, End::Minus] {
        for second_end in [End::Plus, End::Minus] {
            if let Some(contact) =
                intersect_disk_disk(&a.end_disk(first_end), &b.end_disk(second_end))
            {
                found.push(BaseContact::DiskDisk {
                    first_end,
                    second_end,
                    contact,
                });
                if first_only {
                    return Some(CylinderContact::Bases(found));
                }
            }
        }
    }
    if found.is_empty() {
        None
    } else {
        Some(CylinderContact::Bases(found))
    }
}

/// A sufficient condition for an intersection, tried before the base tests when only the
/// verdict is wanted: some point `y` lies inside both cylinders at a depth of more than
/// `δ = 10⁻⁶ · size` (axially and radially), so the ball of radius `δ` about `y` lies in
/// both and the pair penetrates by far more than the touching tolerance — the exact tests
/// would report it. Candidates for `y`: the four base centres, and the point dividing the
/// shortest segment between the axes in the ratio of the radii (within `r₁` of the first
/// axis and `r₂` of the second whenever the capsules meet).
fn share_a_deep_point(a: &Cylinder, b: &Cylinder) -> bool {
    let (ha, hb) = (a.half_length(), b.half_length());
    let margin = 1e-6 * cylinder_size(a).max(cylinder_size(b));
    let (u1, u2) = (a.half_axis / ha, b.half_axis / hb);
    let inside = |c: &Cylinder, u: &Vector3<f64>, h: f64, y: &Vector3<f64>| {
        let w = y - c.center;
        let x = w.dot(u);
        let r = c.radius - margin;
        x.abs() < h - margin && (w - u * x).norm_squared() < r * r
    };
    let (s, t, _) = segment_closest_points(&a.center, &u1, ha, &b.center, &u2, hb);
    let (xa, xb) = (a.center + u1 * s, b.center + u2 * t);
    let y = xa + (xb - xa) * (a.radius / (a.radius + b.radius));
    let in_both = |y: &Vector3<f64>| inside(a, &u1, ha, y) && inside(b, &u2, hb, y);
    in_both(&y)
        || [1.0, -1.0].iter().any(|&sign| {
            inside(a, &u1, ha, &(b.center + b.half_axis * sign))
                || inside(b, &u2, hb, &(a.center + a.half_axis * sign))
        })
}

/// Cylinder–cylinder test (Algorithm 4, Fig. 21–29).
///
/// Exactness rests on the observation of §II.B, re-derived here. Let `K = I₁ ∩ I₂` be the
/// intersection of the infinite cylinders and suppose the bodies intersect while no base of
/// either meets the other body. Then `C₁ ∩ C₂` never reaches a base plane, so by convexity
/// `K ∩ slab₂` lies in the open slab of `C₁`, hence `K ∩ slab₁ ∩ slab₂ = K ∩ slab₁`, and
/// again by convexity `K` lies inside both open slabs. `K` is symmetric under the half-turn
/// about the common perpendicular of the axes and contains the point of `[pt₁, pt₂]` at
/// distance `min(r₁, ρ)` from `pt₁`, so `pt₁`, `pt₂` lie inside the cylinders: that is `cc1`.
/// For parallel axes `K` is unbounded along the axes, so the case cannot occur and the
/// bodies intersect iff both cross-sections and axial intervals overlap.
pub fn intersect_cylinder_cylinder(a: &Cylinder, b: &Cylinder) -> Option<CylinderContact> {
    match cylinder_cylinder_early(a, b, false) {
        Early::Apart => None,
        Early::Meet(found) => {
            debug_assert!(found.is_some(), "a typed test without its contact");
            found
        }
        Early::Undecided => base_contacts(a, b, false),
    }
}

/// Whether two shapes intersect (touching within [`RELATIVE_TOLERANCE`] does not count).
/// Agrees with the typed tests: it is `true` iff the corresponding `intersect_*` function
/// returns `Some` (for two cylinders it stops at the first intersection found).
pub fn overlaps(a: &Shape, b: &Shape) -> bool {
    match (a, b) {
        (Shape::Sphere(s), Shape::Sphere(t)) => intersect_sphere_sphere(s, t).is_some(),
        (Shape::Sphere(s), Shape::Cylinder(c)) | (Shape::Cylinder(c), Shape::Sphere(s)) => {
            intersect_sphere_cylinder(s, c).is_some()
        }
        (Shape::Cylinder(c), Shape::Cylinder(e)) => match cylinder_cylinder_early(c, e, true) {
            Early::Apart => false,
            Early::Meet(_) => true,
            Early::Undecided => share_a_deep_point(c, e) || base_contacts(c, e, true).is_some(),
        },
    }
}

/// [`overlaps`] without the base tests of two cylinders (disk–side and disk–disk, the
/// costly part of Algorithm 4): `Some(answer)` when the cheaper steps decide, which they do
/// for every pair involving a sphere; `None` when only [`overlaps`] can tell. A caller
/// with many pairs can look for a decided intersection first.
pub fn overlaps_decided_early(a: &Shape, b: &Shape) -> Option<bool> {
    match (a, b) {
        (Shape::Cylinder(c), Shape::Cylinder(e)) => match cylinder_cylinder_early(c, e, true) {
            Early::Apart => Some(false),
            Early::Meet(_) => Some(true),
            Early::Undecided => None,
        },
        _ => Some(overlaps(a, b)),
    }
}

impl Shape {
    /// Centre of the body.
    pub fn center(&self) -> Vector3<f64> {
        match self {
            Shape::Sphere(s) => s.center,
            Shape::Cylinder(c) => c.center,
        }
    }

    /// Moves the centre to `center`.
    pub fn set_center(&mut self, center: Vector3<f64>) {
        match self {
            Shape::Sphere(s) => s.center = center,
            Shape::Cylinder(c) => c.center = center,
        }
    }

    /// The same body moved by `shift`.
    pub fn translated(&self, shift: Vector3<f64>) -> Shape {
        let mut moved = *self;
        moved.set_center(self.center() + shift);
        moved
    }

    /// The body scaled about its centre by `factor` (radius and half axis), which contains
    /// the original for `factor ≥ 1`.
    pub fn scaled(&self, factor: f64) -> Shape {
        match self {
            Shape::Sphere(s) => Shape::Sphere(Sphere {
                radius: s.radius * factor,
                ..*s
            }),
            Shape::Cylinder(c) => Shape::Cylinder(Cylinder {
                radius: c.radius * factor,
                half_axis: c.half_axis * factor,
                ..*c
            }),
        }
    }

    /// Radius of the smallest sphere about the centre containing the body:
    /// `r_s`, or `sqrt(h² + r_c²)` for a cylinder.
    pub fn bounding_radius(&self) -> f64 {
        match self {
            Shape::Sphere(s) => s.radius,
            Shape::Cylinder(c) => (c.half_axis.norm_squared() + c.radius * c.radius).sqrt(),
        }
    }

    /// Volume: `4/3 π r³`, or `2π r² h` for a cylinder.
    pub fn volume(&self) -> f64 {
        match self {
            Shape::Sphere(s) => 4.0 / 3.0 * std::f64::consts::PI * s.radius.powi(3),
            Shape::Cylinder(c) => 2.0 * std::f64::consts::PI * c.radius.powi(2) * c.half_length(),
        }
    }
}

/// Calls `f` with every intersection of `a` and `b` found by the typed tests (one for
/// spheres, `sc*` and `cc1`; every `cd*`/`d*` base intersection for two cylinders, which
/// §IV combines), each oriented so that `normal` pushes `b` out of `a`. Calls nothing iff
/// [`overlaps`] is `false`.
pub fn for_each_contact(a: &Shape, b: &Shape, mut f: impl FnMut(Contact)) {
    match (a, b) {
        (Shape::Sphere(s), Shape::Sphere(t)) => {
            if let Some(c) = intersect_sphere_sphere(s, t) {
                f(c);
            }
        }
        (Shape::Sphere(s), Shape::Cylinder(c)) => {
            if let Some(c) = intersect_sphere_cylinder(s, c) {
                f(c.contact);
            }
        }
        (Shape::Cylinder(c), Shape::Sphere(s)) => {
            if let Some(c) = intersect_sphere_cylinder(s, c) {
                f(flipped(c.contact));
            }
        }
        (Shape::Cylinder(c), Shape::Cylinder(e)) => match intersect_cylinder_cylinder(c, e) {
            None => {}
            Some(CylinderContact::Cc1(contact)) => f(contact),
            Some(CylinderContact::Bases(all)) => {
                for base in all {
                    f(match base {
                        BaseContact::DiskSide { contact, .. } => contact.contact,
                        BaseContact::DiskDisk { contact, .. } => contact.contact,
                    });
                }
            }
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_xoshiro::Xoshiro256PlusPlus;

    /// Crossing axes: `pt₂ − pt₁` is rounding noise, the `cc1` normal must still be the
    /// common normal of the axes (perpendicular to both), and moving the second cylinder
    /// by the depth along it must bring the curved faces to touching (axes `r₁ + r₂` apart).
    #[test]
    fn crossing_axes_push_along_the_common_normal() {
        let a = Cylinder::new(
            Vector3::new(0.1, 0.2, 0.3),
            Vector3::new(0.3, 0.7, -0.2),
            0.5,
        );
        let s = 0.37;
        let u2 = Vector3::new(-0.6, 0.1, 0.9).normalize();
        let b = Cylinder::new(a.center + a.axis() * s - u2 * 0.2, u2 * 0.8, 0.3);
        let Some(CylinderContact::Cc1(c)) = intersect_cylinder_cylinder(&a, &b) else {
            panic!("crossing axes inside both cylinders are cc1");
        };
        assert!(c.normal.dot(&a.axis()).abs() < 1e-12 && c.normal.dot(&b.axis()).abs() < 1e-12);
        assert!((c.depth - 0.8).abs() < 1e-12);
        let moved = Cylinder::new(b.center + c.normal * c.depth, b.half_axis, b.radius);
        let d = moved.center - a.center;
        let n = a.axis().cross(&b.axis()).normalize();
        assert!((d.dot(&n).abs() - 0.8).abs() < 1e-12);
    }

    /// An axis parallel to a disk (to rounding: `u·n = 4·10⁻¹⁷`) and off its plane never
    /// pierces it: the disk cuts the cylinder lengthwise, `cd1`, with depth `r_c` minus
    /// the distance of the plane from the axis. (A pair from the random oracle test; the
    /// rounding noise of `b₁` over `λ₁ = (u·n)²` used to report `cd2`, depth 1.54.)
    #[test]
    fn axis_parallel_to_a_disk_does_not_pierce_it() {
        let c = Cylinder::new(
            Vector3::new(-0.7826017686483331, -0.9613558590781257, 0.8574187671653681),
            Vector3::new(1.0539734210285803, 0.23260460922391146, -0.7380784487003673),
            0.9889950808401174,
        );
        let d = Disk {
            center: Vector3::new(-0.9772649379005542, -0.9931136662000853, 0.749987769300805),
            radius: 0.7473048764632226,
            normal: Vector3::new(0.2949123338338394, -0.9476412695185086, 0.1224856712355668),
        };
        assert!(c.axis().dot(&d.normal).abs() < 1e-15);
        let found = intersect_disk_cylinder_side(&c, &d).expect("the disk cuts the cylinder");
        assert_eq!(found.kind, DiskSideKind::Cd1);
        let plane = d.normal.dot(&(d.center - c.center)).abs();
        assert!((found.contact.depth - (c.radius - plane)).abs() < 1e-9);
    }

    /// The plain verdict of Algorithm 4: the early steps (without the inscribed balls),
    /// else the base tests.
    fn plain(a: &Cylinder, b: &Cylinder) -> bool {
        match cylinder_cylinder_early(a, b, false) {
            Early::Apart => false,
            Early::Meet(found) => found.is_some(),
            Early::Undecided => base_contacts(a, b, false).is_some(),
        }
    }

    /// The sufficient tests never claim an intersection that the plain verdict denies —
    /// [`share_a_deep_point`] (before the base tests) and the inscribed balls of
    /// [`cylinder_cylinder_early`] with `verdict_only` — and [`overlaps`] (which tries
    /// both) agrees with the plain verdict: random cylinder pairs, and for each one the
    /// pair moved along its centre line to within `10⁻⁷` of the last separation at which
    /// the plain verdict changes (found by bisection), where a shortcut that is too bold
    /// would show.
    #[test]
    fn deep_point_shortcut_agrees_with_the_base_tests() {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(0xdee9_0017);
        let direction = |rng: &mut Xoshiro256PlusPlus| {
            let v = Vector3::from_fn(|_, _| rng.gen_range(-1.0..1.0));
            v / v.norm()
        };
        let (mut shortcut, mut base_needed, mut balls) = (0usize, 0usize, 0usize);
        for _ in 0..4000 {
            let (ua, ub, ud) = (
                direction(&mut rng),
                direction(&mut rng),
                direction(&mut rng),
            );
            let [ha, ra, hb, rb] = [0; 4].map(|_| rng.gen_range(0.2..2.5));
            let a = Cylinder::new(Vector3::zeros(), ua * ha, ra);
            let far = 2.0 * (a.half_length() + a.radius + hb + rb);
            let at = |lambda: f64| Cylinder::new(ud * (lambda * far), ub * hb, rb);
            // Last λ ∈ [0, 1] where the plain verdict changes (it holds at 0, not at 1).
            let (mut lo, mut hi) = (0.0, 1.0);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if plain(&a, &at(mid)) {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            for lambda in [lo * (1.0 - 1e-7), hi * (1.0 + 1e-7), 0.5 * lo, lo * 0.9] {
                let b = at(lambda);
                let truth = plain(&a, &b);
                assert_eq!(
                    overlaps(&Shape::Cylinder(a), &Shape::Cylinder(b)),
                    truth,
                    "{a:?} {b:?}"
                );
                if let Early::Meet(None) = cylinder_cylinder_early(&a, &b, true) {
                    balls += 1;
                    assert!(truth, "inscribed balls claim an intersection: {a:?} {b:?}");
                }
                if let Early::Undecided = cylinder_cylinder_early(&a, &b, false) {
                    base_needed += 1;
                    if share_a_deep_point(&a, &b) {
                        shortcut += 1;
                        assert!(truth, "shortcut claims an intersection: {a:?} {b:?}");
                    }
                }
            }
        }
        println!(
            "base tests needed {base_needed}, decided by the shortcut {shortcut}; \
             decided by the inscribed balls {balls}"
        );
        assert!(shortcut > 500 && base_needed > shortcut + 500 && balls > 500);
    }
}
