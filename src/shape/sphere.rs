//! The growing hard sphere.

use super::{
    first_falling_root, Collidable, Growth, Lanes, Lanes3, NoImages, NoPlaneContact, PairScreen,
    Vec3,
};
use std::f64::consts::PI;
use wide::{CmpGe, CmpLe, CmpLt};

/// A sphere of radius `r(t) = r0 + g·t` (paper 001, Eq. 20). Rotation-free: a sphere-only
/// scene carries no orientation state at all.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Sphere {
    /// Radius at kernel time 0 (length).
    pub r0: f64,
    /// Growth rate of the radius (length/time).
    pub g: f64,
}

impl Sphere {
    /// A sphere of radius `r` that does not grow.
    pub fn new(r: f64) -> Self {
        Self { r0: r, g: 0.0 }
    }

    /// Radius at kernel time `t`.
    #[inline]
    pub fn radius(&self, t: f64) -> f64 {
        self.r0 + self.g * t
    }
}

/// First contact time of two growing spheres (paper 001, Eq. 22).
///
/// With `σ(τ) = σ + G τ` the sum of the radii and `G` the sum of the growth rates, contact is
/// `|dr + dv τ|² = σ(τ)²`, i.e. `a τ² + 2 b τ + c = 0` with `a = dv² − G²`,
/// `b = dr·dv − σ G`, `c = dr² − σ²`; solved by [`first_falling_root`]. Returns `τ` within
/// `[0, max_tau]`.
#[inline]
pub fn predict_sphere_sphere(
    sigma: f64,
    growth: f64,
    dr: &Vec3,
    dv: &Vec3,
    max_tau: f64,
) -> Option<f64> {
    let tau = sphere_contact_time(sigma, growth, dr, dv, max_tau);
    (tau < f64::INFINITY).then_some(tau)
}

/// [`predict_sphere_sphere`] as a time, `+∞` for no contact within `[0, max_tau]`: the
/// first contact of the pair's gap quadratic ([`GapQuadratic::contact_time`]).
#[inline]
pub fn sphere_contact_time(sigma: f64, growth: f64, dr: &Vec3, dv: &Vec3, max_tau: f64) -> f64 {
    GapQuadratic::of(sigma, Some(growth), (*dr).into(), (*dv).into()).contact_time(max_tau)
}

/// The gap function `f(τ) = a τ² + 2 b τ + c` of a pair of growing spheres (paper 001,
/// Eq. 22), of one pair (`T = f64`) or of two, one per lane (`T = Lanes`). One formula
/// ([`GapQuadratic::of`]) for the contact time and the two-lane screen
/// (`sphere_contact_possible`), which hands its lanes on to the contact times of those that
/// pass ([`PairScreen::contact_time`]): they need no second look at the pair (index, state,
/// minimum image), and the handed-on time is the same number the scalar path computes.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GapQuadratic<T = f64> {
    /// `dv² − G²` (length²/time²).
    pub a: T,
    /// `dr·dv − σ G` (length²/time).
    pub b: T,
    /// `dr² − σ²` (length²).
    pub c: T,
}

impl<T> GapQuadratic<T>
where
    T: Copy + std::ops::Add<Output = T> + std::ops::Sub<Output = T> + std::ops::Mul<Output = T>,
{
    /// The quadratic of two growing spheres: `a = dv² − G²`, `b = dr·dv − σ G`,
    /// `c = dr² − σ²`, with `σ` the sum of the radii and `G` of the growth rates (`None`:
    /// `G = 0`, the same numbers without the terms that subtract `+0`), `dr` and `dv` by
    /// coordinate. The same operations in the same order for `f64` and for [`Lanes`] (dot
    /// products summed `(x + y) + z`), IEEE arithmetic per lane: the screen decides on the
    /// very numbers the time is computed from.
    #[inline(always)]
    pub fn of(sigma: T, growth: Option<T>, dr: [T; 3], dv: [T; 3]) -> Self {
        let dot = |x: [T; 3], y: [T; 3]| x[0] * y[0] + x[1] * y[1] + x[2] * y[2];
        let (a, b) = (dot(dv, dv), dot(dr, dv));
        let (a, b) = match growth {
            Some(g) => (a - g * g, b - sigma * g),
            None => (a, b),
        };
        Self {
            a,
            b,
            c: dot(dr, dr) - sigma * sigma,
        }
    }
}

impl GapQuadratic<Lanes> {
    /// The quadratic of lane `k`.
    #[inline]
    pub fn lane(&self, k: usize) -> GapQuadratic {
        GapQuadratic {
            a: self.a.as_array_ref()[k],
            b: self.b.as_array_ref()[k],
            c: self.c.as_array_ref()[k],
        }
    }
}

impl GapQuadratic {
    /// The first time `τ ∈ [0, max_tau]` at which the gap closes, `+∞` if none.
    ///
    /// For a pair apart (`c > 0`, the common case) both roots in use are the same number
    /// `τ = c / (√(b² − ac) − b) = (b + √(b² − ac)) / (−a)`: the first form is free of
    /// cancellation for an approaching pair (`b < 0`), the second for a receding one, which
    /// meets only when growth closes the gap (`a < 0`; without growth `a = dv² ≥ 0`, so only
    /// approaching pairs meet, by the first form). The form is picked by the sign of `b`, so
    /// one division serves both, and the time is kept or replaced by `+∞` by a select, not a
    /// jump (`pick`): whether a neighbour approaches is a coin flip, and a mispredicted
    /// jump per neighbour costs more than the arithmetic it saves.
    #[inline]
    pub fn contact_time(&self, max_tau: f64) -> f64 {
        let Self { a, b, c } = *self;
        if c <= 0.0 {
            // Touching or overlapping by rounding: rare, handled by the general rule.
            return first_falling_root(a, b, c)
                .filter(|&tau| tau <= max_tau)
                .unwrap_or(f64::INFINITY);
        }
        let disc = b * b - a * c;
        let root = disc.max(0.0).sqrt();
        let approaching = b < 0.0;
        let tau = pick(approaching, c, b + root) / pick(approaching, root - b, -a);
        let valid = (disc >= 0.0) & (approaching | (a < 0.0)) & (tau <= max_tau);
        pick(valid, tau, f64::INFINITY)
    }
}

/// Whether two growing spheres may touch within `[0, max_tau]`, for two pairs at once (pair
/// `k` in lane `k`, its answer in element `k`): a screen with the conditions of
/// [`sphere_contact_time`] but without its square root and division, the slow part of a
/// prediction (the divider is not pipelined), which 86 % of the neighbours in the φ = 0.5
/// fluid do not need: they recede, miss or meet after the barrier. It never rejects a pair that [`sphere_contact_time`] gives a time, so the kernel's
/// predictions are those without it. Two lanes because the kernel's pass screens two
/// neighbours per step. The lanes' quadratics come along: the
/// time of a pair that passes is its lane's [`GapQuadratic::contact_time`].
///
/// `growth` holds the sums of the pairs' growth rates, `None` when no particle grows (the
/// kernel knows it for each barrier interval, and then the rates are not read and no growth
/// term is computed). With the gap function `f(τ) = a τ² + 2 b τ + c` (apart: `c > 0`) and the
/// horizon `T`:
/// - without growth (`a ≥ 0`), `f(τ) ≥ c + 2 b τ ≥ c + 2 b T` on `[0, T]` for an
///   approaching pair (`b < 0`), so a contact within the horizon needs `c + 2 b T ≤ 0`
///   besides `b < 0` and `b² − ac ≥ 0`. This passes the pairs that meet by `2T` at worst
///   (the root lies between `c/(−2b)` and `c/(−b)`) and costs one product more than the
///   conditions themselves;
/// - with growth `a` may be negative and the test is exact: with `x = c + T b`, the
///   approaching root `τ = c / (√(b² − ac) − b)` lies within the horizon iff `x ≤ 0` or
///   `x² ≤ T² (b² − ac)`; a receding pair that growth brings together (`a < 0`) meets at
///   `τ = (b + √(b² − ac)) / (−a)`, within it iff `y = −a T − b ≥ 0` and `b² − ac ≤ y²`.
///
/// `a`, `b`, `c` and `b² − ac` are the same numbers the time is computed from
/// ([`GapQuadratic::of`]); the horizon is widened by a relative `1e-9`, far above the
/// rounding of the products, so that rounding never rejects a pair whose computed time lies
/// inside it. Touching pairs (`c ≤ 0`) always pass.
#[inline]
pub fn sphere_contact_possible(
    sigma: Lanes,
    growth: Option<Lanes>,
    dr: &Lanes3,
    dv: &Lanes3,
    max_tau: Lanes,
) -> ([bool; 2], GapQuadratic<Lanes>) {
    let zero = Lanes::ZERO;
    let gap = GapQuadratic::of(sigma, growth, *dr, *dv);
    let GapQuadratic { a, b, c } = gap;
    let disc = b * b - a * c;
    let horizon = max_tau * Lanes::splat(1.0 + 1e-9);
    let touching = c.cmp_le(zero);
    let approaching = b.cmp_lt(zero) & disc.cmp_ge(zero);
    // A lane without growth among growing ones takes the exact test, which holds for any
    // `a`: both tests pass every pair with a time.
    let pass = if growth.is_none() {
        touching | (approaching & (c + Lanes::splat(2.0) * b * horizon).cmp_le(zero))
    } else {
        let x = c + horizon * b;
        let approaching_in_time =
            approaching & (x.cmp_le(zero) | (x * x).cmp_le(horizon * horizon * disc));
        let y = -a * horizon - b;
        let receding_in_time =
            b.cmp_ge(zero) & a.cmp_lt(zero) & y.cmp_ge(zero) & disc.cmp_le(y * y);
        touching | approaching_in_time | receding_in_time
    };
    let bits = pass.move_mask();
    ([bits & 1 != 0, bits & 2 != 0], gap)
}

/// `if condition { x } else { y }`, marked unpredictable so that the compiler emits a select
/// rather than a jump (a plain `if` or a bit mask on `f64` compiles to a jump on x86-64, and
/// the condition is data-dependent, so the jump would be mispredicted half the time).
#[inline(always)]
fn pick(condition: bool, x: f64, y: f64) -> f64 {
    core::hint::select_unpredictable(condition, x, y)
}

impl Collidable for Sphere {
    type Spin = ();
    type Envelope = ();
    type Screened = GapQuadratic<Lanes>;
    type Images = NoImages;
    type PlaneContact = NoPlaneContact;

    #[inline]
    fn bounding_radius(&self, t: f64) -> f64 {
        self.radius(t)
    }

    #[inline]
    fn bounding_growth_rate(&self) -> f64 {
        self.g
    }

    #[inline]
    fn volume(&self, t: f64) -> f64 {
        let r = self.radius(t);
        4.0 / 3.0 * PI * r * r * r
    }

    fn rebase(&mut self, t0: f64) {
        self.r0 = self.radius(t0);
    }

    fn set_growth(&mut self, t: f64, growth: Growth) {
        self.r0 = self.radius(t);
        self.g = match growth {
            Growth::None => 0.0,
            Growth::Relative(rate) => rate * self.r0,
            Growth::Absolute(rate) => rate,
        };
        // r0 now refers to time t; express it at time 0 again.
        self.r0 -= self.g * t;
    }

    fn scale(&mut self, factor: f64) {
        self.r0 *= factor;
        self.g *= factor;
    }

    #[inline]
    fn collision_time(
        a: &Self,
        b: &Self,
        _: &(),
        _: &(),
        dr: &Vec3,
        dv: &Vec3,
        t: f64,
        max_tau: f64,
    ) -> f64 {
        sphere_contact_time(a.radius(t) + b.radius(t), a.g + b.g, dr, dv, max_tau)
    }

    #[inline]
    fn collision_impulse(
        a: &Self,
        b: &Self,
        _: &mut (),
        _: &mut (),
        dr: &Vec3,
        dv: &Vec3,
        t: f64,
        ma: f64,
        mb: f64,
    ) -> Vec3 {
        let dist = dr.norm();
        let n = dr / dist;
        let u = dv.dot(&n);
        let growth = a.g + b.g;
        // Reflect the gap velocity u − G: u' = 2G − u (Eq. 27 for G = 0). If rounding left
        // the centres closer than σ, make the gap open at least as fast as σ grows.
        let sigma = a.radius(t) + b.radius(t);
        let u_after = (2.0 * growth - u).max(growth * sigma / dist);
        let reduced_mass = ma * mb / (ma + mb);
        n * (reduced_mass * (u_after - u))
    }
}

/// The sphere's screen (`sphere_contact_possible`) hands on the two pairs' gap quadratics,
/// and a pair that passes is timed from its quadratic (the very numbers
/// [`Collidable::collision_time`] computes), so the pair is not looked at again.
impl PairScreen<Sphere> for GapQuadratic<Lanes> {
    #[inline]
    fn may_collide(
        a: &Sphere,
        b: [&Sphere; 2],
        _: &(),
        t: f64,
        max_tau: Lanes,
        grows: bool,
        relative: impl FnOnce() -> (Lanes3, Lanes3, [(); 2]),
    ) -> ([bool; 2], GapQuadratic<Lanes>) {
        let (dr, dv, _) = relative();
        // Without growth `r(t) = r0` exactly (`r0 + 0·t`), and the rates are not loaded.
        if !grows {
            let sigma = Lanes::splat(a.r0) + Lanes::new([b[0].r0, b[1].r0]);
            return sphere_contact_possible(sigma, None, &dr, &dv, max_tau);
        }
        let sigma = Lanes::splat(a.radius(t)) + Lanes::new([b[0].radius(t), b[1].radius(t)]);
        let growth = Lanes::splat(a.g) + Lanes::new([b[0].g, b[1].g]);
        sphere_contact_possible(sigma, Some(growth), &dr, &dv, max_tau)
    }

    #[inline]
    fn contact_time(&self, lane: usize, max_tau: f64, _unscreened: impl FnOnce() -> f64) -> f64 {
        self.lane(lane).contact_time(max_tau)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn head_on_unit_spheres_meet_when_gap_closes() {
        // centres 3 apart, radii 1, closing speed 2 → gap 1 closes at τ = 0.5.
        let a = Sphere::new(1.0);
        let dr = Vec3::new(3.0, 0.0, 0.0);
        let dv = Vec3::new(-2.0, 0.0, 0.0);
        let tau = Sphere::collision_time(&a, &a, &(), &(), &dr, &dv, 0.0, 10.0);
        assert!((tau - 0.5).abs() < 1e-15);
    }

    #[test]
    fn growing_resting_spheres_meet_when_radii_fill_gap() {
        let a = Sphere { r0: 1.0, g: 0.25 };
        let dr = Vec3::new(0.0, 3.0, 0.0);
        let tau = Sphere::collision_time(&a, &a, &(), &(), &dr, &Vec3::zeros(), 0.0, 10.0);
        assert!((tau - 2.0).abs() < 1e-14, "{tau}");
    }

    #[test]
    fn impulse_of_equal_masses_exchanges_normal_velocities() {
        let a = Sphere::new(0.5);
        let dr = Vec3::new(1.0, 0.0, 0.0);
        let dv = Vec3::new(-1.0, 0.3, 0.0);
        let j = Sphere::collision_impulse(&a, &a, &mut (), &mut (), &dr, &dv, 0.0, 1.0, 1.0);
        // Eq. 29: with equal masses the normal components swap, J = m·|u| along n.
        assert!((j - Vec3::new(1.0, 0.0, 0.0)).norm() < 1e-15);
    }
}
