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

pub mod ellipsoid;
pub mod quartic;
mod sphere;

pub use ellipsoid::Ellipsoid;
pub use sphere::{predict_sphere_sphere, GapQuadratic, Sphere};

/// Three-vector of `f64`, the only vector type of the kernel.
pub type Vec3 = nalgebra::Vector3<f64>;

/// Two `f64` lanes, one pair of particles per lane: the prediction pass screens two
/// neighbours with one packed instruction per operation ([`PairScreen::may_collide`]).
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
/// # Capabilities
/// What a shape may do beyond the bounding-sphere picture is named by an associated type
/// each, whose trait carries the methods of that capability, all of them required:
///
/// | type | trait | neutral (the sphere) | meaning of the neutral |
/// |---|---|---|---|
/// | [`Collidable::Spin`] | [`Rotation`] | `()` | no orientation, no rotational freedoms |
/// | [`Collidable::Envelope`] | [`EnvelopeModel`] | `()` | the neighbour-list sphere is the envelope |
/// | [`Collidable::Screened`] | [`PairScreen`] | `()` | every pair passes to [`Collidable::collision_time`] |
/// | [`Collidable::Images`] | [`PeriodicImages`] | [`NoImages`] | never reaches half a box edge |
/// | [`Collidable::PlaneContact`] | [`PlaneContact`] | [`NoPlaneContact`] | meets walls through its bounding sphere |
///
/// A shape that lacks a capability names the neutral type; the kernel calls the capability's
/// methods without knowing which it got. The neutrals' methods are constants or empty, so
/// after monomorphisation a sphere kernel stores and computes nothing for a capability it
/// lacks (its trajectories are bit-identical to a kernel without the notion). Where the
/// kernel has no sensible call to make without the capability (a contact with the
/// particle's own image, a shaped wall contact) the neutral has no value at all
/// ([`NoImages`], [`NoPlaneContact`]): the kernel reaches that code only through a value of
/// the type, so the compiler proves the neutral's methods are never called.
pub trait Collidable: Clone + Send + Sync + 'static {
    /// Rotational state: orientation (at the particle's update time) and angular velocity,
    /// advanced with the delayed state ([`Rotation::after`]), handed to the predictions at
    /// the prediction time and changed by the collision impulse. `()` for shapes without
    /// orientation (zero rotational freedoms).
    type Spin: Rotation<Self>;
    /// What a particle's neighbour *envelope* remembers of the particle when its list was
    /// built, and how the kernel's lists and list updates use it ([`EnvelopeModel`]). `()`:
    /// the neighbour-list sphere is the envelope.
    type Envelope: EnvelopeModel<Self>;
    /// What the screen of two pairs hands on to the contact times of those that pass
    /// ([`PairScreen`]): a sphere pair's gap quadratic ([`GapQuadratic`]); `()` for shapes
    /// that do not screen (every pair passes, and its time is [`Collidable::collision_time`]).
    type Screened: PairScreen<Self>;
    /// Whether and how a particle that reaches half a periodic box edge meets its own
    /// images ([`PeriodicImages`]). [`NoImages`] for shapes that never do (scenes keep
    /// spheres below half the box): image handling compiles out of the kernel.
    type Images: PeriodicImages<Self>;
    /// The shape's own contacts with flat walls ([`PlaneContact`]). [`NoPlaneContact`]: the
    /// container meets the shape through its bounding sphere (exact for spheres,
    /// conservative for other shapes).
    type PlaneContact: PlaneContact<Self>;

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
}

/// The rotational state of a shape `S` ([`Collidable::Spin`]): orientation and angular
/// velocity, stored like the centre by its value at kernel time 0 and advanced in free
/// flight. `()` is the state of a shape whose orientation does not matter: no rotational
/// freedoms, nothing stored, nothing computed.
pub trait Rotation<S>: Copy + Default + std::fmt::Debug + Send + Sync + 'static {
    /// Rotational degrees of freedom per particle, which the thermostat and the energy
    /// count besides the three of translation (0 for `()`: the kernel's rotational
    /// thermostat and energy then compile out).
    const FREEDOMS: u32;
    /// The rotational state `dt` later (free flight: constant angular velocity).
    fn after(&self, dt: f64) -> Self;
    /// Random angular velocity of temperature `kt` for a particle of shape `shape` and mass
    /// `mass` at time `t`, keeping the orientation.
    fn thermal<R: rand::Rng>(&self, shape: &S, mass: f64, kt: f64, t: f64, rng: &mut R) -> Self;
    /// Twice the rotational kinetic energy `ωᵀIω` of a particle of shape `shape` and mass
    /// `mass` at time `t`.
    fn kinetic_twice(&self, shape: &S, mass: f64, t: f64) -> f64;
    /// Multiplies the angular velocity by `factor` (thermostat).
    fn scale_angular_velocity(&mut self, factor: f64);
}

/// No orientation: the sphere's rotational state.
impl<S> Rotation<S> for () {
    const FREEDOMS: u32 = 0;
    #[inline(always)]
    fn after(&self, _dt: f64) -> Self {}
    #[inline(always)]
    fn thermal<R: rand::Rng>(&self, _: &S, _: f64, _: f64, _: f64, _: &mut R) -> Self {}
    #[inline(always)]
    fn kinetic_twice(&self, _: &S, _: f64, _: f64) -> f64 {
        0.0
    }
    #[inline(always)]
    fn scale_angular_velocity(&mut self, _factor: f64) {}
}

/// A shape's neighbour envelopes ([`Collidable::Envelope`]): what a particle's neighbour list
/// remembers of the particle beyond its list sphere, and how lists and list updates use it.
///
/// The kernel gives every particle a neighbour-list sphere (centre `c₀`, radius
/// `R = r₀ + δ`, `r₀` the bounding radius when the list was built, `δ` the skin width) and
/// keeps the particle inside it until its list-update event. A model with envelopes keeps
/// it inside a tighter region that lies within that sphere (its *envelope*) instead: two
/// particles are neighbours only if their spheres and their envelopes overlap, the
/// list-update event is the time the particle provably leaves its envelope (its *exit*,
/// recorded before each of its prediction passes), and pair predictions look no further
/// than the earlier exit of the two (whichever updates first predicts the pair again).
///
/// The kernel owns one array of envelopes and one of exit times (kernel times), both
/// [`EnvelopeModel::kept`] long, and touches them only through these methods. `()`, the
/// neutral, is the neighbour-list sphere itself: it keeps no arrays, passes every pair the
/// spheres pass, leaves the pair horizons alone and updates a list when the bounding
/// sphere leaves the list sphere (the kernel's own prediction, which it hands in).
pub trait EnvelopeModel<S: Collidable>:
    Copy
    + Default
    + std::fmt::Debug
    + Send
    + Sync
    + serde::Serialize
    + serde::de::DeserializeOwned
    + 'static
{
    /// How many envelopes (and exit times) the kernel keeps for `n` particles: `n`, or 0 when
    /// the list sphere is the envelope.
    fn kept(n: usize) -> usize;
    /// Builds particle `i`'s envelope in `envelopes`: the particle of shape `shape` with
    /// rotational state `spin` at kernel time `t`, centred where the particle is (the list
    /// centre), with skin width `skin` (length, `R − r₀` of its neighbour-list sphere). It
    /// must lie inside the list sphere.
    fn build(envelopes: &mut [Self], i: usize, shape: &S, spin: &S::Spin, t: f64, skin: f64);
    /// Whether the envelopes of particles `i` and `j`, whose centres are `d = c₀_i − c₀_j`
    /// apart (the image the kernel considers), may overlap. May answer `true` for disjoint
    /// envelopes (a longer list), never `false` for overlapping ones.
    fn may_overlap(envelopes: &[Self], i: usize, j: usize, d: &Vec3) -> bool;
    /// Records in `exits[i]` the kernel time up to which particle `i` provably stays inside
    /// its envelope (and hence its list sphere), `+∞` if beyond any window. `at` gives the
    /// particle at kernel time `t`: its shape, its rotational state, its offset `q = c(t) − c₀`
    /// from the list centre (minimum image) and its velocity; it is called only by models
    /// that record exits.
    fn record_exit<'a>(
        envelopes: &[Self],
        exits: &mut [f64],
        i: usize,
        t: f64,
        at: impl FnOnce() -> (&'a S, S::Spin, Vec3, Vec3),
    ) where
        S: 'a;
    /// The horizon `τ ≤ max_tau` of a prediction of the pair `i`, `j` at kernel time `t`:
    /// no further than the earlier recorded exit of the two (`max_tau` when no exits are
    /// recorded).
    fn pair_horizon(exits: &[f64], i: usize, j: usize, t: f64, max_tau: f64) -> f64;
    /// Time `τ ≥ 0` after `t` of particle `i`'s list update, `None` if beyond any window:
    /// its recorded exit, or for the neutral `list_sphere_exit`, when its bounding sphere
    /// leaves its list sphere.
    fn list_update(
        exits: &[f64],
        i: usize,
        t: f64,
        list_sphere_exit: impl FnOnce() -> Option<f64>,
    ) -> Option<f64>;
}

/// The neighbour-list sphere is the envelope.
impl<S: Collidable> EnvelopeModel<S> for () {
    #[inline(always)]
    fn kept(_n: usize) -> usize {
        0
    }
    #[inline(always)]
    fn build(_: &mut [Self], _: usize, _: &S, _: &S::Spin, _: f64, _: f64) {}
    #[inline(always)]
    fn may_overlap(_: &[Self], _: usize, _: usize, _: &Vec3) -> bool {
        true
    }
    #[inline(always)]
    fn record_exit<'a>(
        _: &[Self],
        _: &mut [f64],
        _: usize,
        _: f64,
        _: impl FnOnce() -> (&'a S, S::Spin, Vec3, Vec3),
    ) where
        S: 'a,
    {
    }
    #[inline(always)]
    fn pair_horizon(_: &[f64], _: usize, _: usize, _: f64, max_tau: f64) -> f64 {
        max_tau
    }
    #[inline(always)]
    fn list_update(
        _: &[f64],
        _: usize,
        _: f64,
        list_sphere_exit: impl FnOnce() -> Option<f64>,
    ) -> Option<f64> {
        list_sphere_exit()
    }
}

/// A cheap screen before the contact times ([`Collidable::Screened`]): the value is what the
/// screen of two pairs hands on to the contact times of those that pass, computed once.
///
/// The kernel's prediction pass screens every neighbour, two per step, and asks for a
/// contact time only for those that pass. `()`, the neutral, passes every pair and times
/// it with [`Collidable::collision_time`].
pub trait PairScreen<S: Collidable>: Copy + Default {
    /// Whether `a` and `b[k]` may touch within `[0, max_tau[k]]` (the arguments of
    /// [`Collidable::collision_time`], two pairs at once: pair `k` in lane `k` of `max_tau`
    /// and of the relative position `dr` and velocity `dv` that `relative` returns, with the
    /// partners' rotational states), and what their contact times then need. It may pass a
    /// pair that then does not meet, but must never reject one that
    /// [`Collidable::collision_time`] gives a time, and each lane's answer depends on that
    /// lane alone. `grows`: whether any particle may grow; `false` promises that every
    /// growth rate is zero (the kernel knows it for each barrier interval), so that the
    /// screen can leave the growth terms out. `relative` is computed only if the screen
    /// calls it: a screen that passes every pair costs the kernel nothing (for a rotating
    /// shape the partners' states are not cheap).
    fn may_collide(
        a: &S,
        b: [&S; 2],
        sa: &S::Spin,
        t: f64,
        max_tau: Lanes,
        grows: bool,
        relative: impl FnOnce() -> (Lanes3, Lanes3, [S::Spin; 2]),
    ) -> ([bool; 2], Self);
    /// The contact time of the pair in lane `lane` of a screen that it passed, with the
    /// horizon `max_tau` of the screen: bit for bit [`Collidable::collision_time`] of the
    /// pair, which `unscreened` computes from the pair's state (a screen that hands on what
    /// the time needs does not call it).
    fn contact_time(&self, lane: usize, max_tau: f64, unscreened: impl FnOnce() -> f64) -> f64;
}

/// No screen: every pair passes, and its time is [`Collidable::collision_time`].
impl<S: Collidable> PairScreen<S> for () {
    #[inline(always)]
    fn may_collide(
        _: &S,
        _: [&S; 2],
        _: &S::Spin,
        _: f64,
        _: Lanes,
        _: bool,
        _: impl FnOnce() -> (Lanes3, Lanes3, [S::Spin; 2]),
    ) -> ([bool; 2], Self) {
        ([true; 2], ())
    }
    #[inline(always)]
    fn contact_time(&self, _: usize, _: f64, unscreened: impl FnOnce() -> f64) -> f64 {
        unscreened()
    }
}

/// Contacts with periodic images ([`Collidable::Images`]) of a shape that may reach more
/// than half a periodic box edge, so that it can touch several images of a partner and its
/// own images. The kernel then tracks which image each neighbour is (switched on for good
/// at the barrier where list spheres reach half the shortest periodic edge) and resolves a
/// contact with the particle's own image by [`PeriodicImages::self_image_impulse`].
///
/// A value of the type is the licence to track images ([`PeriodicImages::tracking`]);
/// the kernel keeps it once tracking is on. [`NoImages`], the neutral, has no value: the
/// kernel's image branches are then constant `false` and compile out.
pub trait PeriodicImages<S: Collidable>: Copy + Send + Sync + 'static {
    /// The licence to track images, `None` for a shape that never reaches half a box edge.
    fn tracking() -> Option<Self>;
    /// Resolves a contact at time `t` of a particle of shape `shape` (mass `mass`) with its
    /// own periodic image displaced by `−dr` (`dr = c − c_image`, a lattice vector): the
    /// particle touches the image at `+(−dr)` with one point of its surface and, by
    /// periodicity, the image at `+dr` with another, receiving opposite impulses at the two
    /// points. Its linear momentum is unchanged; the angular part is applied to `spin`.
    /// Returns the impulse at the first contact (for the virial `J·dr`).
    fn self_image_impulse(
        self,
        shape: &S,
        spin: &mut S::Spin,
        dr: &Vec3,
        t: f64,
        mass: f64,
    ) -> Vec3;
}

/// The images of a shape that never reaches half a periodic box edge (the sphere): it never
/// touches two images of a partner nor its own, so there is nothing to track. No value.
#[derive(Clone, Copy, Debug)]
pub enum NoImages {}

impl<S: Collidable> PeriodicImages<S> for NoImages {
    #[inline(always)]
    fn tracking() -> Option<Self> {
        None
    }
    fn self_image_impulse(self, _: &S, _: &mut S::Spin, _: &Vec3, _: f64, _: f64) -> Vec3 {
        match self {}
    }
}

/// A shape's own contacts with flat walls ([`Collidable::PlaneContact`]), used when the
/// container's walls are all planes ([`crate::boundary::Boundary::planes`]) and the walls
/// see the whole growth; otherwise the container meets the shape through its bounding
/// sphere. A value of the type is the licence ([`PlaneContact::own`]); [`NoPlaneContact`],
/// the neutral, has none, and the shaped wall code compiles out.
pub trait PlaneContact<S: Collidable>: Copy + Send + Sync + 'static {
    /// The licence to ask the shape for its plane contacts, `None` for the bounding sphere.
    fn own() -> Option<Self>;
    /// First time `τ ∈ [0, max_tau]` after `t` at which the particle touches the plane with
    /// unit normal `n` (pointing from the plane into the container) at signed distance
    /// `distance` from its centre, approached by the centre at normal velocity `n·v`
    /// (`normal_velocity`).
    #[allow(clippy::too_many_arguments)]
    fn predict(
        self,
        shape: &S,
        spin: &S::Spin,
        n: &Vec3,
        distance: f64,
        normal_velocity: f64,
        t: f64,
        max_tau: f64,
    ) -> Option<f64>;
    /// Resolves a contact with a plane of unit normal `n` (into the container) at time `t`:
    /// returns the velocity change of the centre and the virial `J·ℓ` (impulse times the
    /// distance from the centre to the plane), and applies the angular part to `spin`.
    fn impulse(
        self,
        shape: &S,
        spin: &mut S::Spin,
        n: &Vec3,
        vel: &Vec3,
        t: f64,
        mass: f64,
    ) -> (Vec3, f64);
}

/// No plane contacts of its own: the container meets the shape through its bounding sphere
/// (exact for the sphere). No value.
#[derive(Clone, Copy, Debug)]
pub enum NoPlaneContact {}

impl<S: Collidable> PlaneContact<S> for NoPlaneContact {
    #[inline(always)]
    fn own() -> Option<Self> {
        None
    }
    fn predict(self, _: &S, _: &S::Spin, _: &Vec3, _: f64, _: f64, _: f64, _: f64) -> Option<f64> {
        match self {}
    }
    fn impulse(self, _: &S, _: &mut S::Spin, _: &Vec3, _: &Vec3, _: f64, _: f64) -> (Vec3, f64) {
        match self {}
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
