//! Containers: what surrounds the particles (DynamO's *locals*).
//!
//! A [`Boundary`] gives the kernel the minimum-image convention for periodic axes and its
//! walls ([`Walls`]): the prediction of a particle's next wall contact and the wall normal at
//! that contact. Wall code costs nothing in a scene without walls: the walls of a
//! [`PeriodicBox`] are [`NoWalls`], a type without value, so the kernel's wall branches are
//! removed at compile time.
//!
//! Wall contacts treat the particle through its bounding sphere, which is exact for spheres.
//! Distance functions follow paper 001, Eq. 23 (plane) and its cylinder analogue. A container
//! whose walls are all planes ([`Boundary::planes`]) lets a shape that knows its own plane
//! contacts ([`Collidable::PlaneContact`], e.g. the ellipsoid) predict them itself
//! ([`PlanarWalls::predict_shaped_wall`]); other containers keep the bounding sphere, which
//! is conservative for any shape.

use crate::shape::{exit_ball_time, Collidable, Lanes, Lanes3, PlaneContact, Vec3};
use rand::Rng;
use wide::{CmpGt, CmpLt};

/// Index of a wall of a container (box faces `2·axis + side`, cylinder mantle and caps).
pub type WallId = u8;

/// A container of the particles.
///
/// Implementers guarantee: [`Boundary::minimum_image`] returns the shortest periodic image
/// of a separation as long as it is shorter than half the box length on every periodic axis;
/// [`Walls::predict_wall`] never reports a contact later than the true first contact of
/// the growing bounding sphere with a wall.
pub trait Boundary: Clone + Send + Sync + 'static {
    /// The container's walls ([`Walls`]): the container itself when it has any,
    /// [`NoWalls`] (no value) for a fully periodic box, so wall events compile out of the
    /// kernel.
    type Walls: Walls;
    /// The walls ([`Boundary::Walls`]), `None` without walls.
    fn walls(&self) -> Option<&Self::Walls>;
    /// The container's walls as planes, which a shape with its own plane contacts is asked
    /// about one by one ([`PlanarWalls`]): the container itself when every wall is a plane,
    /// [`NotPlanar`] (no value) when a wall is curved or there is none.
    type Planes: PlanarWalls;
    /// The walls as planes ([`Boundary::Planes`]), `None` unless every wall is a plane.
    fn planes(&self) -> Option<&Self::Planes>;
    /// Lower corner of the axis-aligned bounding box of the container.
    fn min(&self) -> Vec3;
    /// Upper corner of the axis-aligned bounding box of the container.
    fn max(&self) -> Vec3;
    /// Which axes are periodic.
    fn periodic(&self) -> [bool; 3];
    /// Volume of the container.
    fn volume(&self) -> f64;
    /// Replaces a separation by its minimum image along periodic axes.
    fn minimum_image(&self, dr: &mut Vec3);
    /// [`Boundary::minimum_image`] of two separations, one per lane, giving in each lane
    /// exactly the scalar result (up to the sign of a zero).
    fn minimum_image_lanes(&self, dr: &mut Lanes3);
    /// Wraps a position into the box along periodic axes.
    fn wrap(&self, p: &mut Vec3);
    /// Smallest distance between the surface of a sphere (`p`, `r`) and any wall; negative
    /// when the sphere pokes through a wall, `+∞` without walls.
    fn clearance(&self, p: &Vec3, r: f64) -> f64;
    /// A uniformly distributed centre for a sphere of radius `r` that keeps clear of the walls,
    /// or `None` if no such centre exists.
    fn sample_center<R: Rng>(&self, r: f64, rng: &mut R) -> Option<Vec3>;
}

/// The walls of a container: wall contacts of a particle's bounding sphere.
pub trait Walls {
    /// First time `τ ∈ [0, max_tau]` at which a sphere of radius `r` growing at `g`, with
    /// centre `p` moving at `v`, touches a wall, and which wall.
    fn predict_wall(
        &self,
        p: &Vec3,
        v: &Vec3,
        r: f64,
        g: f64,
        max_tau: f64,
    ) -> Option<(f64, WallId)>;
    /// Unit normal of `wall` pointing into the container, at the contact of a sphere
    /// centred at `p`.
    fn wall_normal(&self, wall: WallId, p: &Vec3) -> Vec3;
}

/// The walls of a container without any: no value, so wall events compile out of the kernel.
#[derive(Clone, Copy, Debug)]
pub enum NoWalls {}

impl Walls for NoWalls {
    fn predict_wall(&self, _: &Vec3, _: &Vec3, _: f64, _: f64, _: f64) -> Option<(f64, WallId)> {
        match *self {}
    }
    fn wall_normal(&self, _: WallId, _: &Vec3) -> Vec3 {
        match *self {}
    }
}

/// A container whose walls are all planes, asked for a particle's first wall contact through
/// the shape's own plane contacts ([`PlaneContact`]) rather than its bounding sphere.
pub trait PlanarWalls {
    /// First contact of a particle of shape `S` (centre `p`, velocity `v`, rotational state
    /// `spin`, all at kernel time `t`) with a wall, within `[0, max_tau]`, asking the shape
    /// (its plane contacts `contact`) for each plane.
    #[allow(clippy::too_many_arguments)]
    fn predict_shaped_wall<S: Collidable>(
        &self,
        p: &Vec3,
        v: &Vec3,
        shape: &S,
        contact: S::PlaneContact,
        spin: &S::Spin,
        t: f64,
        max_tau: f64,
    ) -> Option<(f64, WallId)>;
}

/// The planes of a container with a curved wall or none: no value, so shaped wall contacts
/// compile out of the kernel.
#[derive(Clone, Copy, Debug)]
pub enum NotPlanar {}

impl PlanarWalls for NotPlanar {
    fn predict_shaped_wall<S: Collidable>(
        &self,
        _: &Vec3,
        _: &Vec3,
        _: &S,
        _: S::PlaneContact,
        _: &S::Spin,
        _: f64,
        _: f64,
    ) -> Option<(f64, WallId)> {
        match *self {}
    }
}

/// A cuboid periodic along all three axes: no walls at all.
#[derive(Clone, Debug, PartialEq)]
pub struct PeriodicBox {
    /// Lower corner.
    pub min: Vec3,
    /// Edge lengths (positive).
    pub len: Vec3,
}

impl Boundary for PeriodicBox {
    type Walls = NoWalls;
    type Planes = NotPlanar;

    #[inline(always)]
    fn walls(&self) -> Option<&NoWalls> {
        None
    }

    #[inline(always)]
    fn planes(&self) -> Option<&NotPlanar> {
        None
    }

    fn min(&self) -> Vec3 {
        self.min
    }
    fn max(&self) -> Vec3 {
        self.min + self.len
    }
    fn periodic(&self) -> [bool; 3] {
        [true; 3]
    }
    fn volume(&self) -> f64 {
        self.len.x * self.len.y * self.len.z
    }
    #[inline]
    fn minimum_image(&self, dr: &mut Vec3) {
        // Positions are wrapped, so |dr| < L and one correction suffices; near pairs rarely
        // straddle a face, so these branches are well predicted.
        for k in 0..3 {
            dr[k] = nearest_image(dr[k], self.len[k]);
        }
    }
    #[inline]
    fn minimum_image_lanes(&self, dr: &mut Lanes3) {
        for (d, &len) in dr.iter_mut().zip(self.len.iter()) {
            *d = nearest_image_lanes(*d, len);
        }
    }
    #[inline]
    fn wrap(&self, p: &mut Vec3) {
        for k in 0..3 {
            p[k] = wrap_coordinate(p[k], self.min[k], self.len[k]);
        }
    }
    fn clearance(&self, _: &Vec3, _: f64) -> f64 {
        f64::INFINITY
    }
    fn sample_center<R: Rng>(&self, _r: f64, rng: &mut R) -> Option<Vec3> {
        Some(self.min + self.len.map(|l| l * rng.gen::<f64>()))
    }
}

/// The earliest wall contact offered within `[0, max_tau]`.
struct FirstContact {
    max_tau: f64,
    best: Option<(f64, WallId)>,
}

impl FirstContact {
    fn within(max_tau: f64) -> Self {
        Self {
            max_tau,
            best: None,
        }
    }

    /// A contact after `tau` (negative by rounding means now).
    #[inline]
    fn offer(&mut self, tau: f64, wall: WallId) {
        let tau = tau.max(0.0);
        if tau <= self.max_tau && self.best.is_none_or(|(t, _)| tau < t) {
            self.best = Some((tau, wall));
        }
    }

    /// A plane whose gap to the sphere closes at `rate` (touching and closing: now).
    #[inline]
    fn plane(&mut self, gap: f64, rate: f64, wall: WallId) {
        if rate > 0.0 {
            self.offer(gap / rate, wall);
        }
    }
}

/// The image of a separation `d` (with `|d| < len`) nearest to zero.
#[inline]
fn nearest_image(d: f64, len: f64) -> f64 {
    if d > 0.5 * len {
        d - len
    } else if d < -0.5 * len {
        d + len
    } else {
        d
    }
}

/// [`nearest_image`] in each lane, without a jump: `d − L` where `d > L/2`, `d + L` where
/// `d < −L/2`, by adding masked lengths (which turns a separation of `−0` into `+0`, a
/// difference no product of the screen sees).
#[inline(always)]
fn nearest_image_lanes(d: Lanes, len: f64) -> Lanes {
    let (half, len) = (Lanes::splat(0.5 * len), Lanes::splat(len));
    (d - (d.cmp_gt(half) & len)) + (d.cmp_lt(-half) & len)
}

/// Wraps `x` into `[min, min + len)`.
#[inline]
fn wrap_coordinate(x: f64, min: f64, len: f64) -> f64 {
    let mut y = x;
    if y < min || y >= min + len {
        y -= len * ((y - min) / len).floor();
        if y >= min + len {
            y -= len;
        }
        if y < min {
            y = min;
        }
    }
    y
}

/// A cuboid with rigid walls on the axes that are not periodic (paper 001, Eq. 23–24).
#[derive(Clone, Debug, PartialEq)]
pub struct WalledBox {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
    /// Periodic axes (at least one axis is walled).
    pub periodic: [bool; 3],
}

impl Boundary for WalledBox {
    type Walls = Self;
    type Planes = Self;

    #[inline(always)]
    fn planes(&self) -> Option<&Self> {
        Some(self)
    }

    #[inline(always)]
    fn walls(&self) -> Option<&Self> {
        Some(self)
    }

    fn min(&self) -> Vec3 {
        self.min
    }
    fn max(&self) -> Vec3 {
        self.max
    }
    fn periodic(&self) -> [bool; 3] {
        self.periodic
    }
    fn volume(&self) -> f64 {
        let l = self.max - self.min;
        l.x * l.y * l.z
    }
    #[inline]
    fn minimum_image(&self, dr: &mut Vec3) {
        // One well-predicted branch for the common all-walls box (concrete specimens),
        // instead of three per pair in the kernel's prediction loop.
        if self.periodic == [false; 3] {
            return;
        }
        for k in 0..3 {
            if self.periodic[k] {
                dr[k] = nearest_image(dr[k], self.max[k] - self.min[k]);
            }
        }
    }
    #[inline]
    fn minimum_image_lanes(&self, dr: &mut Lanes3) {
        if self.periodic == [false; 3] {
            return;
        }
        for (k, d) in dr.iter_mut().enumerate() {
            if self.periodic[k] {
                *d = nearest_image_lanes(*d, self.max[k] - self.min[k]);
            }
        }
    }
    #[inline]
    fn wrap(&self, p: &mut Vec3) {
        for k in 0..3 {
            if self.periodic[k] {
                p[k] = wrap_coordinate(p[k], self.min[k], self.max[k] - self.min[k]);
            }
        }
    }
    fn clearance(&self, p: &Vec3, r: f64) -> f64 {
        (0..3)
            .filter(|&k| !self.periodic[k])
            .map(|k| (p[k] - self.min[k]).min(self.max[k] - p[k]) - r)
            .fold(f64::INFINITY, f64::min)
    }
    fn sample_center<R: Rng>(&self, r: f64, rng: &mut R) -> Option<Vec3> {
        let mut c = Vec3::zeros();
        for k in 0..3 {
            let (lo, hi) = if self.periodic[k] {
                (self.min[k], self.max[k])
            } else {
                (self.min[k] + r, self.max[k] - r)
            };
            if hi < lo {
                return None;
            }
            c[k] = lo + (hi - lo) * rng.gen::<f64>();
        }
        Some(c)
    }
}

impl Walls for WalledBox {
    #[inline]
    fn predict_wall(
        &self,
        p: &Vec3,
        v: &Vec3,
        r: f64,
        g: f64,
        max_tau: f64,
    ) -> Option<(f64, WallId)> {
        let mut first = FirstContact::within(max_tau);
        for k in 0..3 {
            if self.periodic[k] {
                continue;
            }
            // Gap p − min − r closes at g − v; gap max − p − r at v + g.
            first.plane(p[k] - self.min[k] - r, g - v[k], 2 * k as u8);
            first.plane(self.max[k] - p[k] - r, v[k] + g, 2 * k as u8 + 1);
        }
        first.best
    }
    #[inline]
    fn wall_normal(&self, wall: WallId, _: &Vec3) -> Vec3 {
        let mut n = Vec3::zeros();
        n[(wall / 2) as usize] = if wall.is_multiple_of(2) { 1.0 } else { -1.0 };
        n
    }
}

/// Every wall of a walled box is a face: the shape is asked for each non-periodic face.
impl PlanarWalls for WalledBox {
    #[inline]
    fn predict_shaped_wall<S: Collidable>(
        &self,
        p: &Vec3,
        v: &Vec3,
        shape: &S,
        contact: S::PlaneContact,
        spin: &S::Spin,
        t: f64,
        max_tau: f64,
    ) -> Option<(f64, WallId)> {
        let mut first = FirstContact::within(max_tau);
        for k in 0..3 {
            if self.periodic[k] {
                continue;
            }
            for (wall, distance, sign) in [
                (2 * k as u8, p[k] - self.min[k], 1.0),
                (2 * k as u8 + 1, self.max[k] - p[k], -1.0),
            ] {
                let mut n = Vec3::zeros();
                n[k] = sign;
                let window = first.best.map_or(max_tau, |(tau, _)| tau);
                if let Some(tau) =
                    contact.predict(shape, spin, &n, distance, sign * v[k], t, window)
                {
                    first.offer(tau, wall);
                }
            }
        }
        first.best
    }
}

/// A rigid cylindrical container with its axis along z: mantle and two flat caps, as for
/// concrete cylinder specimens (e.g. 150 × 300 mm).
#[derive(Clone, Debug, PartialEq)]
pub struct CylinderContainer {
    /// Centre of the bottom cap.
    pub base_center: Vec3,
    /// Radius of the mantle.
    pub radius: f64,
    /// Height (along +z).
    pub height: f64,
}

const MANTLE: WallId = 0;
const BOTTOM: WallId = 1;
const TOP: WallId = 2;

impl Boundary for CylinderContainer {
    type Walls = Self;
    type Planes = NotPlanar;

    #[inline(always)]
    fn planes(&self) -> Option<&NotPlanar> {
        None
    }

    #[inline(always)]
    fn walls(&self) -> Option<&Self> {
        Some(self)
    }

    fn min(&self) -> Vec3 {
        self.base_center - Vec3::new(self.radius, self.radius, 0.0)
    }
    fn max(&self) -> Vec3 {
        self.base_center + Vec3::new(self.radius, self.radius, self.height)
    }
    fn periodic(&self) -> [bool; 3] {
        [false; 3]
    }
    fn volume(&self) -> f64 {
        std::f64::consts::PI * self.radius * self.radius * self.height
    }
    fn minimum_image(&self, _: &mut Vec3) {}
    fn minimum_image_lanes(&self, _: &mut Lanes3) {}
    fn wrap(&self, _: &mut Vec3) {}
    fn clearance(&self, p: &Vec3, r: f64) -> f64 {
        let z = p.z - self.base_center.z;
        let rho = ((p.x - self.base_center.x).powi(2) + (p.y - self.base_center.y).powi(2)).sqrt();
        (self.radius - rho).min(z).min(self.height - z) - r
    }
    fn sample_center<R: Rng>(&self, r: f64, rng: &mut R) -> Option<Vec3> {
        let s = self.radius - r;
        let h = self.height - 2.0 * r;
        if s < 0.0 || h < 0.0 {
            return None;
        }
        let rho = s * rng.gen::<f64>().sqrt();
        let phi = std::f64::consts::TAU * rng.gen::<f64>();
        Some(
            self.base_center
                + Vec3::new(rho * phi.cos(), rho * phi.sin(), r + h * rng.gen::<f64>()),
        )
    }
}

impl Walls for CylinderContainer {
    fn predict_wall(
        &self,
        p: &Vec3,
        v: &Vec3,
        r: f64,
        g: f64,
        max_tau: f64,
    ) -> Option<(f64, WallId)> {
        let mut first = FirstContact::within(max_tau);
        // Caps: planes z = base and z = base + height.
        let z = p.z - self.base_center.z;
        first.plane(z - r, g - v.z, BOTTOM);
        first.plane(self.height - z - r, v.z + g, TOP);
        // Mantle: the axial offset q must stay within the free radius R − r(τ).
        let q = nalgebra::Vector2::new(p.x - self.base_center.x, p.y - self.base_center.y);
        let u = nalgebra::Vector2::new(v.x, v.y);
        if let Some(tau) = exit_ball_time(
            q.norm_squared(),
            q.dot(&u),
            u.norm_squared(),
            self.radius - r,
            g,
        ) {
            first.offer(tau, MANTLE);
        }
        first.best
    }
    fn wall_normal(&self, wall: WallId, p: &Vec3) -> Vec3 {
        match wall {
            BOTTOM => Vec3::z(),
            TOP => -Vec3::z(),
            _ => {
                let q = Vec3::new(p.x - self.base_center.x, p.y - self.base_center.y, 0.0);
                let n = q.norm();
                if n > 0.0 {
                    -q / n
                } else {
                    Vec3::x()
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn minimum_image_picks_nearest_copy() {
        let b = PeriodicBox {
            min: Vec3::zeros(),
            len: Vec3::new(10.0, 10.0, 10.0),
        };
        let mut dr = Vec3::new(9.0, -6.0, 2.0);
        b.minimum_image(&mut dr);
        assert_eq!(dr, Vec3::new(-1.0, 4.0, 2.0));
    }

    /// The two-lane minimum image shifts each lane by a whole period into `[−L/2, L/2]` on
    /// periodic axes and leaves the others, and gives exactly the scalar result (equal as
    /// numbers: only the sign of a zero may differ), for separations on both sides of and
    /// at half the box, with all, some and no axes periodic.
    #[test]
    fn minimum_image_in_lanes_matches_the_scalar_one() {
        use crate::shape::lanes3;
        use rand::SeedableRng;
        fn check<B: Boundary>(b: &B, len: &Vec3, rng: &mut rand_xoshiro::Xoshiro256PlusPlus) {
            let edges = [
                0.0,
                0.5,
                -0.5,
                0.49999999999999994,
                -0.5000000000000001,
                0.99,
            ];
            for _ in 0..2000 {
                let mut d = [0, 1].map(|_| {
                    Vec3::from_fn(|c, _| {
                        let u = if rng.gen::<f64>() < 0.2 {
                            edges[rng.gen_range(0..edges.len())]
                        } else {
                            rng.gen_range(-0.999..0.999)
                        };
                        u * len[c]
                    })
                });
                let mut lanes = lanes3(&d[0], &d[1]);
                b.minimum_image_lanes(&mut lanes);
                for (k, d) in d.iter_mut().enumerate() {
                    let before = *d;
                    let got = Vec3::from_fn(|c, _| lanes[c].to_array()[k]);
                    // The definition: a shift by a whole period, into [−L/2, L/2], along
                    // periodic axes only (exact: L/2 < |d| < L for a shifted one, Sterbenz).
                    for c in 0..3 {
                        let shift = before[c] - got[c];
                        if b.periodic()[c] {
                            assert!([-len[c], 0.0, len[c]].contains(&shift), "{before} → {got}");
                            assert!(got[c].abs() <= 0.5 * len[c], "{before} → {got}");
                        } else {
                            assert_eq!(shift, 0.0, "{before} → {got}");
                        }
                    }
                    b.minimum_image(d);
                    assert_eq!(got, *d);
                }
            }
        }
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(11);
        let (min, len) = (Vec3::new(-1.0, 0.0, 2.0), Vec3::new(10.0, 7.0, 3.5));
        check(&PeriodicBox { min, len }, &len, &mut rng);
        for periodic in [[true, false, true], [false; 3]] {
            let max = min + len;
            check(&WalledBox { min, max, periodic }, &len, &mut rng);
        }
        let cylinder = CylinderContainer {
            base_center: min,
            radius: 2.0,
            height: 5.0,
        };
        check(&cylinder, &len, &mut rng);
    }

    #[test]
    fn growing_sphere_meets_box_wall() {
        let b = WalledBox {
            min: Vec3::zeros(),
            max: Vec3::new(4.0, 4.0, 4.0),
            periodic: [false; 3],
        };
        // centre at x = 1, radius 0.5, moving −x at 0.25 and growing at 0.25: gap 0.5, rate 0.5.
        let (tau, wall) = b
            .predict_wall(
                &Vec3::new(1.0, 2.0, 2.0),
                &Vec3::new(-0.25, 0.0, 0.0),
                0.5,
                0.25,
                10.0,
            )
            .unwrap();
        assert_eq!(wall, 0);
        // y and z walls: gap 1.5 at rate 0.25 → 6; x: 1.0.
        assert!((tau - 1.0).abs() < 1e-15);
    }

    #[test]
    fn sphere_meets_cylinder_mantle() {
        let c = CylinderContainer {
            base_center: Vec3::zeros(),
            radius: 5.0,
            height: 100.0,
        };
        let (tau, wall) = c
            .predict_wall(
                &Vec3::new(1.0, 0.0, 50.0),
                &Vec3::new(2.0, 0.0, 0.0),
                1.0,
                0.0,
                10.0,
            )
            .unwrap();
        assert_eq!(wall, MANTLE);
        assert!((tau - 1.5).abs() < 1e-14, "{tau}");
    }
}
