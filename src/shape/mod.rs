//! Shapes as the kernel sees them: the collidable traits.
//!
//! The EDMD kernel ([`crate::kernel::Edmd`]) never names a concrete shape. A particle type
//! plugs in by implementing [`Collidable`]: its bounding radius and volume as functions of
//! time (particles grow), the prediction of the first contact of two moving, growing
//! particles, and the impulse that resolves a contact. A shape that cannot predict collisions
//! does not implement the trait, and the compiler refuses to build a kernel for it.
//!
//! Time convention: a shape's size is a function of the kernel time `t` (time since the last
//! time barrier). At every barrier the kernel calls [`Collidable::rebase`] so that the stored
//! size refers to the new origin and `t` stays small (precision does not decay in long runs).

mod ellipsoid;
pub mod quartic;
mod sphere;

pub use ellipsoid::{
    contact_point_and_normal, ellipsoid_pair_impulse, ellipsoid_self_image_impulse,
    predict_ellipsoid_pair, prediction_failures, support_curvature_bound, Ellipsoid, Envelope,
    Predictor, Spin, CONTACT_TOLERANCE, MAX_CONTACT_TOLERANCE, MAX_STEPS,
};
pub use sphere::{predict_sphere_sphere, GapQuadratic, Sphere};

/// Three-vector of `f64`, the only vector type of the kernel.
pub type Vec3 = nalgebra::Vector3<f64>;

/// Two `f64` lanes, one pair of particles per lane: the prediction pass screens two
/// neighbours with one packed instruction per operation ([`Collidable::may_collide`]).
/// Lane arithmetic is IEEE arithmetic on each lane, so a lane holds exactly the number the
/// same scalar operations give.
pub type Lanes = wide::f64x2;

/// A three-vector per lane, by coordinate: `[x, y, z]`, each holding two pairs' values.
pub type Lanes3 = [Lanes; 3];

/// Two three-vectors as lanes: `a` in lane 0, `b` in lane 1.
#[inline(always)]
pub fn lanes3(a: &Vec3, b: &Vec3) -> Lanes3 {
    [0, 1, 2].map(|k| Lanes::new([a[k], b[k]]))
}

/// How particle masses are assigned (paper 001, §5.3).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum MassRule {
    /// All masses equal to 1 (Eq. 29, Kansal et al.).
    #[default]
    Equal,
    /// Mass proportional to the particle volume, normalised so that a particle of the
    /// reference volume has mass 1 (Eq. 27).
    Volume,
}

/// How the particles grow during a stage (Lubachevsky–Stillinger).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Growth {
    /// No growth: equilibrium molecular dynamics.
    None,
    /// Each linear size grows at `rate` times its size at the start of the stage
    /// (unit: 1/time). All particles reach `(1 + rate·t)` times their size together (Eq. 30).
    Relative(f64),
    /// Each radius grows at the same absolute `rate` (unit: length/time; Eq. 31).
    Absolute(f64),
}

impl Growth {
    /// The rate (1/time for relative growth, length/time for absolute growth; 0 for none).
    pub fn rate(self) -> f64 {
        match self {
            Self::None => 0.0,
            Self::Relative(r) | Self::Absolute(r) => r,
        }
    }

    /// The same kind of growth at another rate.
    pub fn with_rate(self, rate: f64) -> Self {
        match self {
            Self::None => Self::None,
            Self::Relative(_) => Self::Relative(rate),
            Self::Absolute(_) => Self::Absolute(rate),
        }
    }
}

/// A moving, growing hard particle shape that the EDMD kernel can drive.
///
/// Implementers guarantee: sizes are non-negative and non-decreasing in `t` over any window
/// the kernel asks about; [`Collidable::collision_time`] never reports a time later than
/// the true first contact (it may report an earlier one only if the pair is then resolved
/// with zero impulse, which the sphere never needs); predictions are symmetric under swapping
/// the two particles with `dr → −dr`, `dv → −dv`.
///
/// # Rotation
/// A shape whose orientation matters carries a [`Collidable::Spin`]: its orientation at the
/// particle's update time and its angular velocity, advanced with the delayed state
/// ([`Collidable::spin_after`]), handed to the predictions at the prediction time and changed
/// by the collision impulse. Shapes without orientation (the sphere) use `()` and keep the
/// default methods: after monomorphisation a sphere kernel stores and computes nothing for
/// rotation, and its trajectories are bit-identical to a kernel without the notion.
pub trait Collidable: Clone + Send + Sync + 'static {
    /// Rotational state: orientation (at the particle's update time) and angular velocity.
    /// `()` for shapes without orientation.
    type Spin: Copy + Default + std::fmt::Debug + Send + Sync + 'static;
    /// Whether the shape has rotational kinetic energy (3 more degrees of freedom per
    /// particle for the thermostat and the energy).
    const ROTATES: bool = false;
    /// Whether the shape predicts and resolves its own contacts with flat walls
    /// ([`Collidable::predict_plane_contact`], [`Collidable::plane_impulse`]). Otherwise the
    /// container treats it through its bounding sphere (exact for spheres, conservative for
    /// other shapes).
    const SHAPED_PLANE_CONTACT: bool = false;
    /// Whether a particle may reach more than half a periodic box edge, so that it can touch
    /// several periodic images of a partner, and its own images. The kernel then tracks which
    /// image each neighbour is (only when the box is that small, decided at barriers) and
    /// resolves contacts with the particle's own images by
    /// [`Collidable::self_image_impulse`]. `false` (the sphere: scenes keep spheres below half
    /// the box) compiles image handling out of the kernel.
    const PERIODIC_IMAGES: bool = false;

    /// What a particle's neighbour *envelope* remembers of the particle when its list was
    /// built (`()` for shapes whose envelope is the kernel's neighbour-list sphere).
    ///
    /// The kernel gives every particle a neighbour-list sphere (centre `c₀`, radius
    /// `R = r₀ + δ`, `r₀` the bounding radius when the list was built, `δ` the skin width)
    /// and keeps the particle inside it until its list-update event. A shape with
    /// [`Collidable::ENVELOPES`] keeps it inside a tighter region that lies within that
    /// sphere (its *envelope*) instead, and two particles are neighbours only if their
    /// spheres and their envelopes overlap. Two particles outside each other's envelopes
    /// cannot touch before one of them updates its list.
    type Envelope: Copy
        + Default
        + std::fmt::Debug
        + Send
        + Sync
        + serde::Serialize
        + serde::de::DeserializeOwned
        + 'static;
    /// Whether neighbour lists are filtered by [`Collidable::envelopes_overlap`] (with
    /// `false`, the sphere, the filter and the envelope array compile out of the kernel).
    const ENVELOPES: bool = false;

    /// The envelope of a particle at kernel time `t` with rotational state `spin` at `t`,
    /// centred where the particle is (the list centre) with skin width `skin` (length,
    /// `R − r₀` of its neighbour-list sphere). It must lie inside the list sphere.
    #[inline]
    fn envelope(&self, _spin: &Self::Spin, _t: f64, _skin: f64) -> Self::Envelope {
        Self::Envelope::default()
    }
    /// Whether envelopes `a` and `b` whose centres are `d = c₀_a − c₀_b` apart (the image
    /// the kernel considers) may overlap. May answer `true` for disjoint envelopes (a longer
    /// list), never `false` for overlapping ones.
    #[inline]
    fn envelopes_overlap(_a: &Self::Envelope, _b: &Self::Envelope, _d: &Vec3) -> bool {
        true
    }
    /// Time `τ ≥ 0` after `t` up to which the particle provably stays inside its envelope
    /// (and hence its list sphere), or `None` if it stays inside beyond any window.
    /// `q = c(t) − c₀` (minimum image), `vel` its velocity, `spin` its rotational state at
    /// `t`. Only called when [`Collidable::ENVELOPES`] (the kernel otherwise computes when the
    /// bounding sphere leaves the list sphere, [`exit_ball_time`]).
    fn envelope_exit_time(
        &self,
        _spin: &Self::Spin,
        _envelope: &Self::Envelope,
        _q: &Vec3,
        _vel: &Vec3,
        _t: f64,
    ) -> Option<f64> {
        unreachable!("only shapes with ENVELOPES have envelope events")
    }

    /// Numerical failures of this shape's predictions on the current thread so far (a
    /// monotone counter; a prediction that gave up and answered conservatively). The kernel
    /// adds what its intervals contribute to `EventCounts::prediction_failures`. Exact
    /// predictors (the sphere) never fail.
    #[inline]
    fn numerical_failures() -> u64 {
        0
    }

    /// Radius of a sphere around the centre that contains the particle at time `t`.
    fn bounding_radius(&self, t: f64) -> f64;
    /// Length the kernel's neighbour-list skin is relative to, at time `t` (at most the
    /// bounding radius): the skin width is `skin·min(l, l̄)`. Default: the bounding radius.
    #[inline]
    fn skin_length(&self, t: f64) -> f64 {
        self.bounding_radius(t)
    }
    /// Rate of change of [`Collidable::bounding_radius`] (length/time).
    fn bounding_growth_rate(&self) -> f64;
    /// Volume at time `t`.
    fn volume(&self, t: f64) -> f64;
    /// Moves the time origin to `t0`: afterwards `f(0)` equals what `f(t0)` was before.
    fn rebase(&mut self, t0: f64);
    /// Sets the growth for a stage starting at time `t`.
    fn set_growth(&mut self, t: f64, growth: Growth);
    /// Multiplies the size at time `t` by `factor` and keeps the growth rate relative to it
    /// (used to scale a seeding to a requested packing fraction).
    fn scale(&mut self, factor: f64);

    /// The rotational state `dt` later (free flight: constant angular velocity).
    #[inline]
    fn spin_after(spin: &Self::Spin, _dt: f64) -> Self::Spin {
        *spin
    }
    /// Random angular velocity of temperature `kt` for a particle of mass `mass` at time `t`,
    /// keeping the orientation of `spin`.
    #[inline]
    fn thermal_spin<R: rand::Rng>(
        &self,
        spin: &Self::Spin,
        _mass: f64,
        _kt: f64,
        _t: f64,
        _rng: &mut R,
    ) -> Self::Spin {
        *spin
    }
    /// Twice the rotational kinetic energy `ωᵀIω` at time `t` for mass `mass`.
    #[inline]
    fn rotational_kinetic_twice(&self, _spin: &Self::Spin, _mass: f64, _t: f64) -> f64 {
        0.0
    }
    /// Multiplies the angular velocity by `factor` (thermostat).
    #[inline]
    fn scale_angular_velocity(_spin: &mut Self::Spin, _factor: f64) {}

    /// First contact time `τ ∈ [0, max_tau]` after time `t` of particles `a` and `b`, whose
    /// centres are at relative position `dr = c_a − c_b` (minimum image) and relative velocity
    /// `dv = v_a − v_b` at time `t`, with rotational states `sa`, `sb` at time `t`; `+∞` if
    /// they do not touch within the window. A time rather than an `Option`: the kernel's
    /// prediction pass keeps the finite ones without a branch per pair, and a shape whose
    /// predictor can run without branches (spheres: `sphere::sphere_contact_time`) keeps
    /// the whole pass free of them.
    #[allow(clippy::too_many_arguments)]
    fn collision_time(
        a: &Self,
        b: &Self,
        sa: &Self::Spin,
        sb: &Self::Spin,
        dr: &Vec3,
        dv: &Vec3,
        t: f64,
        max_tau: f64,
    ) -> f64;
    /// What the screen of two pairs ([`Collidable::may_collide`]) hands on to the contact
    /// times of those that pass ([`Collidable::screened_time`]): the numbers of both pairs
    /// that their times need, computed once (`()` for shapes that do not screen).
    type Screened: Copy + Default;
    /// Whether the shape screens pairs ([`Collidable::may_collide`] is more than the
    /// default): without, the kernel skips the screen and its pass, and a pair's relative
    /// state (for rotating shapes not cheap) is computed once.
    const SCREENS_PAIRS: bool = false;
    /// Whether `a` and `b[k]` may touch within `[0, max_tau[k]]` (the arguments of
    /// [`Self::collision_time`], two pairs at once: pair `k` in lane `k` of `dr`, `dv` and
    /// `max_tau`), and what their contact times then need: a cheap screen that the
    /// kernel's prediction pass runs on every neighbour, asking [`Self::screened_time`]
    /// only for those that pass. It may pass a pair that then does not meet, but must never
    /// reject one that [`Self::collision_time`] gives a time, and each lane's answer depends
    /// on that lane alone. `grows`: whether any particle may grow; `false` promises that
    /// every growth rate is zero (the kernel knows it for each barrier interval), so that
    /// the screen can leave the growth terms out. The default passes every pair (and is not
    /// called unless [`Collidable::SCREENS_PAIRS`]).
    #[allow(clippy::too_many_arguments)]
    #[inline]
    fn may_collide(
        _a: &Self,
        _b: [&Self; 2],
        _sa: &Self::Spin,
        _sb: [&Self::Spin; 2],
        _dr: &Lanes3,
        _dv: &Lanes3,
        _t: f64,
        _max_tau: Lanes,
        _grows: bool,
    ) -> ([bool; 2], Self::Screened) {
        ([true; 2], Self::Screened::default())
    }
    /// The contact time of the pair in lane `lane` of a screen that it passed, from what
    /// [`Collidable::may_collide`] handed on, with the same horizon: bit for bit
    /// [`Self::collision_time`] of the pair. Shapes with [`Collidable::SCREENS_PAIRS`] only.
    #[inline]
    fn screened_time(_screened: &Self::Screened, _lane: usize, _max_tau: f64) -> f64 {
        unreachable!("only shapes with SCREENS_PAIRS hand on screened pairs")
    }
    /// Resolves a contact at time `t`: returns the linear impulse on `a` (the impulse on `b`
    /// is its negative) for masses `ma`, `mb`, and applies the angular part to `sa`, `sb`.
    /// Elastic in the frame of the growing surfaces: the normal gap velocity is reflected, so
    /// the pair always separates.
    #[allow(clippy::too_many_arguments)]
    fn collision_impulse(
        a: &Self,
        b: &Self,
        sa: &mut Self::Spin,
        sb: &mut Self::Spin,
        dr: &Vec3,
        dv: &Vec3,
        t: f64,
        ma: f64,
        mb: f64,
    ) -> Vec3;

    /// Resolves a contact at time `t` of a particle (mass `mass`) with its own periodic image
    /// displaced by `−dr` (`dr = c − c_image`, a lattice vector): the particle touches the image
    /// at `+(−dr)` with one point of its surface and, by periodicity, the image at `+dr` with
    /// another, receiving opposite impulses at the two points. Its linear momentum is
    /// unchanged; the angular part is applied to `spin`. Returns the impulse at the first
    /// contact (for the virial `J·dr`). Only called when [`Collidable::PERIODIC_IMAGES`].
    fn self_image_impulse(&self, _spin: &mut Self::Spin, _dr: &Vec3, _t: f64, _mass: f64) -> Vec3 {
        unreachable!("only shapes with PERIODIC_IMAGES meet their own images")
    }

    /// First time `τ ∈ [0, max_tau]` after `t` at which the particle touches the plane with
    /// unit normal `n` (pointing from the plane into the container) at signed distance
    /// `distance` from its centre, approached by the centre at normal velocity `n·v`
    /// (`normal_velocity`). Default: the bounding sphere.
    #[inline]
    fn predict_plane_contact(
        &self,
        _spin: &Self::Spin,
        _n: &Vec3,
        distance: f64,
        normal_velocity: f64,
        t: f64,
        max_tau: f64,
    ) -> Option<f64> {
        let rate = self.bounding_growth_rate() - normal_velocity;
        let tau = ((distance - self.bounding_radius(t)) / rate).max(0.0);
        (rate > 0.0 && tau <= max_tau).then_some(tau)
    }
    /// Resolves a contact with a plane of unit normal `n` (into the container) at time `t`:
    /// returns the velocity change of the centre and the virial `J·ℓ` (impulse times the
    /// distance from the centre to the plane), and applies the angular part to `spin`.
    /// Default: the bounding sphere.
    #[inline]
    fn plane_impulse(
        &self,
        _spin: &mut Self::Spin,
        n: &Vec3,
        vel: &Vec3,
        t: f64,
        mass: f64,
    ) -> (Vec3, f64) {
        bounding_sphere_wall_impulse(
            self.bounding_radius(t),
            self.bounding_growth_rate(),
            n,
            vel,
            mass,
        )
    }
}

/// Wall response of a particle through a sphere of radius `r` growing at `g` (length/time)
/// around its centre — its bounding sphere, or the sphere the walls see in a stage with
/// [`crate::kernel::Stage::wall_growth`] below 1 (paper 001, Eq. 24 for a sphere that does
/// not grow): the gap velocity `n·v − g` is reflected, and never left closing. Returns the
/// velocity change and the virial `J·r` (`mass` times the velocity change times `r`).
#[inline]
pub fn bounding_sphere_wall_impulse(
    r: f64,
    g: f64,
    n: &Vec3,
    vel: &Vec3,
    mass: f64,
) -> (Vec3, f64) {
    let u = vel.dot(n);
    let u_after = (2.0 * g - u).max(g);
    (n * (u_after - u), mass * (u_after - u) * r)
}

/// First time `τ ≥ 0` at which a gap-like quadratic `f(τ) = a τ² + 2 b τ + c` reaches zero
/// while decreasing (`f > 0`: apart, `f ≤ 0`: touching or overlapping), or `None`.
///
/// Written to be free of catastrophic cancellation: the root near `τ = 0` is computed as
/// `c / (−b + √(b² − ac))`, never as a difference of nearly equal numbers. A pair that touches
/// (`c ≤ 0`) while approaching (`b < 0`) collides at once (`τ = 0`), so nothing tunnels.
/// A pair that overlaps by rounding while separating (`c ≤ 0`, `b ≥ 0`) is given its next
/// falling root (or the time of closest approach of the gap to zero if rounding leaves none).
#[inline]
pub fn first_falling_root(a: f64, b: f64, c: f64) -> Option<f64> {
    if c <= 0.0 {
        if b < 0.0 {
            return Some(0.0);
        }
        if a >= 0.0 {
            return None;
        }
        let disc = b * b - a * c;
        if disc < 0.0 {
            return Some(b / -a);
        }
        return Some((b + disc.sqrt()) / -a);
    }
    let disc = b * b - a * c;
    if b < 0.0 {
        if disc < 0.0 {
            return None;
        }
        return Some(c / (-b + disc.sqrt()));
    }
    if a >= 0.0 {
        return None;
    }
    Some((b + disc.sqrt()) / -a)
}

/// First time `τ ≥ 0` at which a point at offset `q` from the centre of a ball of radius
/// `s` shrinking at rate `g`, and moving at velocity `v`, reaches the ball's surface:
/// `|q + v τ| = s − g τ`. Arguments are `q·q`, `q·v`, `v·v`. Used for a sphere leaving its
/// neighbour-list sphere (the particle's radius grows, so the free radius shrinks) and, in
/// two dimensions, for a sphere meeting the mantle of a cylindrical container.
///
/// Gap-like form `f = (s − gτ)² − |q + vτ|²`: `a = g² − v²`, `b = −(s g + q·v)`,
/// `c = s² − q²`; `f` is zero at `τ = s/g` at the latest, so a root always exists when `g > 0`.
#[inline]
pub fn exit_ball_time(q2: f64, qv: f64, v2: f64, s: f64, g: f64) -> Option<f64> {
    first_falling_root(g * g - v2, -(s * g + qv), s * s - q2)
}

/// Whether a point at offset `q` from the centre of a ball of radius `s` shrinking at rate
/// `g` (`g ≥ 0`), moving at velocity `v`, stays inside it throughout `[0, horizon]`: then
/// [`exit_ball_time`] has no root there, and needs not be computed (its square root and
/// division are the slow part of predicting a neighbour-list update, and most updates lie
/// beyond the barrier).
///
/// The point is inside at time `τ` iff `h(τ) = |q + v τ| + g τ ≤ s`, and `h` is convex, so
/// it stays inside on `[0, T]` iff it is inside at both ends. Checked with a relative margin
/// of `1e-9` on the squares, far above their rounding: `true` means that the exact exit
/// lies beyond the horizon.
#[inline]
pub fn stays_in_ball(q: &Vec3, v: &Vec3, s: f64, g: f64, horizon: f64) -> bool {
    let shrunk = s - g * horizon;
    let inside_at_end = (q + v * horizon).norm_squared() < shrunk * shrunk * (1.0 - 1e-9);
    (q.norm_squared() < s * s * (1.0 - 1e-9)) & (shrunk > 0.0) & inside_at_end
}

#[cfg(test)]
mod tests {
    use super::{exit_ball_time, first_falling_root};

    #[test]
    fn exit_time_of_a_point_leaving_a_shrinking_ball() {
        // From the centre at speed 1 through a ball of radius 2 shrinking at 1: |τ| = 2 − τ.
        assert_eq!(exit_ball_time(0.0, 0.0, 1.0, 2.0, 1.0), Some(1.0));
        // At rest in a ball that does not shrink: never.
        assert_eq!(exit_ball_time(0.25, 0.0, 0.0, 1.0, 0.0), None);
    }

    #[test]
    fn falling_root_matches_closed_form() {
        // f = τ² − 4τ + 3 = (τ − 1)(τ − 3): first falling root at 1.
        assert_eq!(first_falling_root(1.0, -2.0, 3.0), Some(1.0));
        // apart and separating, no growth: never.
        assert_eq!(first_falling_root(1.0, 2.0, 3.0), None);
        // touching and approaching: now.
        assert_eq!(first_falling_root(1.0, -1.0, 0.0), Some(0.0));
        // growth dominates (a < 0), currently separating: f = −τ² + 2τ + 3 → root 3.
        assert_eq!(first_falling_root(-1.0, 1.0, 3.0), Some(3.0));
        // Tiny gap: the textbook form 1 − √(1 − 10⁻²⁰) rounds to 0; the exact root is
        // c/(2|b|)·(1 + O(c)) = 5·10⁻²¹.
        let tau = first_falling_root(1.0, -1.0, 1e-20).unwrap();
        assert!((tau - 5e-21).abs() < 1e-15 * 5e-21, "{tau}");
    }
}
