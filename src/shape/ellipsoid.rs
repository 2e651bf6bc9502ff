//! The growing, rotating hard ellipsoid (paper 004, Ghossein & Lévesque).
//!
//! One module on purpose (about 1 700 lines with its tests): the state, the certified
//! predictor, the impulse, the envelope and the own-image contact all work on the same
//! Perram–Wertheim quantities (`M`, `G(λ)`, the support function and its curvature bound),
//! and each derivation below is needed whole by several of them.
//!
//! # State
//! An [`Ellipsoid`] holds its semi-axes as a fixed shape (`axes`, largest entry 1) times a
//! linearly growing scale `s(t) = s0 + g·t` (Eq. 9 with growth rates proportional to the
//! semi-axes, as in the paper: `b0 = a0/R1`, `c0 = a0/R2`). Its [`Spin`] holds the unit
//! quaternion at the particle's update time (body frame → world frame; the body axes carry
//! the semi-axes) and the angular velocity in the world frame; free flight keeps the angular
//! velocity constant and composes the orientation with the rotation `ω·Δt` (Eq. 10–11).
//! Mass comes from the kernel's mass rule, the inertia tensor from Eq. 27b–28.
//!
//! # Collision prediction
//! The bounding spheres (radius `s(t)`, Eq. 15–16) reject most pairs analytically. For the
//! others the first contact is found by *certified stepping along a separating axis*:
//!
//! 1. at the current time, the Perram–Wertheim function `F(λ) = λ(1−λ) rᵀG(λ)⁻¹r`,
//!    `G = (1−λ)M_a + λM_b`, `M = R·diag(semi-axes²)·Rᵀ`, is maximised over λ by a few
//!    Newton steps from the previous λ; `n ∝ G⁻¹r` is the normal of the plane that separates
//!    the two ellipsoids scaled by `√F` (the common tangent plane at their contact);
//! 2. along that fixed `n` the gap `g_n(τ) = n·r(τ) − h_a(n,τ) − h_b(n,τ)` (`h(n) = √(nᵀMn)`,
//!    the support function; the closed form of the plane distance) is a lower bound of the
//!    true distance for *every* τ, so its first root never lies after the first contact;
//! 3. `g_n` is bounded below by `g + g'δ − Kδ²/2`, with `g, g'` exact at the current time and
//!    `K` a bound of `|h_a''| + |h_b''|` from the angular velocities, growth and aspect ratios
//!    ([`support_curvature_bound`]); the first root of that quadratic is the step: no contact
//!    can occur inside it (translation is exact; rotation and growth enter through `K`);
//! 4. repeat until the gap is below [`Ellipsoid::contact_tolerance`] (default
//!    [`CONTACT_TOLERANCE`]) times the smallest semi-axis
//!    (contact) or the time leaves the window.
//!
//! Any fixed unit `n` gives such a bound, so step 1 is skipped while a cheaper axis shows a
//! gap: the first axis joins the closest points of the two long-axis segments (for needles
//! nearly the common normal; the centre line for platelets and spheres), and the
//! Perram–Wertheim axis is computed when the gap along the current axis is gone or has
//! shrunk to a quarter of its value at the last refresh.
//!
//! The steps shrink like Newton steps near a contact (the separating axis converges to the
//! contact normal), a grazing pair walks past its closest approach in steps of `√(2g/K)`, and
//! an enter-and-exit within one step is impossible by construction, so a first contact is
//! never stepped over. A prediction that exceeds [`MAX_STEPS`] is counted
//! ([`prediction_failures`]) and returned as an early event at the time reached, which the
//! impulse resolves with zero impulse (the pair is re-predicted from there).
//!
//! The paper's own test, the roots of `η1(t)` of the characteristic polynomial
//! `det(λA + B)` (Eq. 13, Table 1), is in [`crate::shape::quartic`]; the
//! [`Predictor::Characteristic`] mode uses it, with Brent's method, for the final approach.
//!
//! # Collision response
//! Frictionless impulse `j·n` at the contact point `x_c = c_a + (1−λ)M_a G⁻¹r` (Eq. 14: the
//! kernel vector of the singular pencil at the double root) along the normal of Eq. 26, with
//! `j` chosen so that the normal velocity of the contact point, measured against the growth of
//! the two surfaces, is reflected (Eq. 32 with `e = 1`). This closed form is the solution of
//! the 12 equations of Eq. 29–32 (tested against a direct solve).

use super::quartic::{self, Configuration};
use super::{
    first_falling_root, predict_sphere_sphere, Collidable, EnvelopeModel, Growth, PeriodicImages,
    PlaneContact, Rotation, Vec3,
};
use nalgebra::{Matrix3, UnitQuaternion};
use rand::Rng;
use rand_distr::StandardNormal;
use std::cell::Cell;
use std::f64::consts::PI;

/// Default gap below which two ellipsoids (or an ellipsoid and a wall) count as touching,
/// relative to the smallest semi-axis involved (the scene key
/// `particles.ellipsoid.contact_tolerance`). Near contact the certified steps converge like
/// Newton steps, so looser tolerances save little time; below about 1e-12 the steps chase
/// rounding. The sweep is in BENCHMARKS.md, "Defaults and the measurements behind them".
pub const CONTACT_TOLERANCE: f64 = 1e-12;

/// Largest contact tolerance a scene may set: a contact is resolved while its gap is below
/// `max(10⁻⁶, 10·tolerance)` of the smallest semi-axis, so looser tolerances would blur
/// early (failed) predictions with contacts.
pub const MAX_CONTACT_TOLERANCE: f64 = 1e-5;

/// Gap (relative to the smallest semi-axis) up to which an impulse treats a pair as touching
/// for predictions made with `tolerance`.
#[inline]
fn resolved_gap(tolerance: f64) -> f64 {
    (10.0 * tolerance).max(1e-6)
}

/// Most certified steps of one prediction before it is counted as a numerical failure.
pub const MAX_STEPS: u32 = 500;

thread_local! {
    /// Per thread, so that kernels running side by side (tests, parallel studies) count
    /// only their own failures: a kernel runs on one thread.
    static PREDICTION_FAILURES: Cell<u64> = const { Cell::new(0) };
}

/// Number of ellipsoid predictions on this thread that hit [`MAX_STEPS`] or met a singular
/// configuration since the thread started (each was handled conservatively, never by a
/// panic). The kernel accumulates its share in `EventCounts::prediction_failures`.
pub fn prediction_failures() -> u64 {
    PREDICTION_FAILURES.with(Cell::get)
}

fn count_failure() {
    PREDICTION_FAILURES.with(|c| c.set(c.get() + 1));
}

/// Which collision predictor an ellipsoid uses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Predictor {
    /// Certified steps along the Perram–Wertheim separating axis to contact (never late).
    #[default]
    SeparatingAxis,
    /// The paper's method for the final approach: certified steps until the gap is below
    /// 10⁻³ of the smallest semi-axis, then Brent's method on `η1(t)` in a bracket whose end
    /// is found by doubling probes, accepted where the pair is externally tangent (Table 1).
    /// Faster near contact, but a dip between two probes can be missed.
    Characteristic,
}

/// A hard ellipsoid whose semi-axes grow in proportion: semi-axes `axes·s(t)`,
/// `s(t) = s0 + g·t`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Ellipsoid {
    /// Semi-axes along the body x, y, z axes relative to the largest (largest entry 1).
    pub axes: Vec3,
    /// Largest semi-axis at kernel time 0 (length).
    pub s0: f64,
    /// Growth rate of the largest semi-axis (length/time); the others grow in proportion.
    pub g: f64,
    /// Collision predictor.
    pub predictor: Predictor,
    /// Gap, relative to the smallest semi-axis, below which a predicted approach counts as a
    /// contact ([`CONTACT_TOLERANCE`] by default; at most [`MAX_CONTACT_TOLERANCE`]).
    pub contact_tolerance: f64,
}

/// Orientation and angular velocity of an ellipsoid (serialised bit for bit in checkpoints).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Spin {
    /// Rotation from the body frame to the world frame at the particle's update time.
    pub orientation: UnitQuaternion<f64>,
    /// Angular velocity in the world frame (rad/time).
    pub omega: Vec3,
}

impl Default for Spin {
    fn default() -> Self {
        Self {
            orientation: UnitQuaternion::identity(),
            omega: Vec3::zeros(),
        }
    }
}

impl Spin {
    /// Rotation matrix body → world.
    #[inline]
    pub fn rotation(&self) -> Matrix3<f64> {
        *self.orientation.to_rotation_matrix().matrix()
    }
}

impl Ellipsoid {
    /// The envelope ([`Envelope`]) of the ellipsoid with rotational state `spin` at kernel
    /// time `t`, centred where it is, with skin width `skin`.
    #[inline]
    pub fn envelope(&self, spin: &Spin, t: f64, skin: f64) -> Envelope {
        let rot = spin.rotation();
        let (mid, half_length) = self.mid_and_spine_length(t);
        Envelope {
            root: self.root_matrix(&rot, t),
            m: self.shape_matrix(&rot, t),
            spine: rot.column(self.axes.imax()) * half_length,
            skin,
            capsule: mid + skin,
            half_length,
        }
    }

    /// An ellipsoid with the given semi-axes (along body x, y, z) that does not grow.
    ///
    /// # Panics
    /// If a semi-axis is not finite and positive.
    pub fn new(semi_axes: Vec3) -> Self {
        assert!(
            semi_axes.iter().all(|a| a.is_finite() && *a > 0.0),
            "semi-axes must be finite and positive"
        );
        let s = semi_axes.max();
        Self {
            axes: semi_axes / s,
            s0: s,
            g: 0.0,
            predictor: Predictor::SeparatingAxis,
            contact_tolerance: CONTACT_TOLERANCE,
        }
    }

    /// Largest semi-axis at kernel time `t`.
    #[inline]
    pub fn scale_at(&self, t: f64) -> f64 {
        self.s0 + self.g * t
    }

    /// Semi-axes at kernel time `t`.
    #[inline]
    pub fn semi_axes(&self, t: f64) -> Vec3 {
        self.axes * self.scale_at(t)
    }

    /// Smallest semi-axis at kernel time `t`.
    #[inline]
    pub fn min_semi_axis(&self, t: f64) -> f64 {
        self.axes.min() * self.scale_at(t)
    }

    /// `M = R·diag(a², b², c²)·Rᵀ` at time `t` for rotation `rot`: the inverse of the
    /// quadric matrix, `h(n) = √(nᵀMn)` is the support function.
    #[inline]
    fn shape_matrix(&self, rot: &Matrix3<f64>, t: f64) -> Matrix3<f64> {
        let d = self.semi_axes(t);
        rot * Matrix3::from_diagonal(&d.component_mul(&d)) * rot.transpose()
    }

    /// Body-frame principal moments of inertia for mass `m` at time `t` (Eq. 27b).
    #[inline]
    pub fn principal_inertia(&self, m: f64, t: f64) -> Vec3 {
        let d = self.semi_axes(t);
        let d2 = d.component_mul(&d);
        Vec3::new(d2.y + d2.z, d2.x + d2.z, d2.x + d2.y) * (m / 5.0)
    }

    /// `I⁻¹·x` in the world frame (Eq. 28) for rotation `rot`.
    #[inline]
    fn inverse_inertia_times(&self, rot: &Matrix3<f64>, m: f64, t: f64, x: &Vec3) -> Vec3 {
        let body = rot.transpose() * x;
        rot * body.component_div(&self.principal_inertia(m, t))
    }

    /// Growth rate of the semi-axes relative to their size, `ṡ/s`, at time `t`: a surface
    /// point at support distance `h` moves outwards at `h·ṡ/s`.
    #[inline]
    fn relative_growth(&self, t: f64) -> f64 {
        self.g / self.scale_at(t)
    }
}

/// Neighbour envelope of an ellipsoid ([`Collidable::Envelope`], [`EnvelopeModel`]): the
/// ellipsoid `E₀` as it was when its neighbour list was built, thickened by the skin width
/// `δ`, `E₀ ⊕ B(δ)` (all points within `δ` of `E₀`). It lies inside the list sphere (`E₀`
/// lies inside the bounding sphere of radius `r₀`, so `E₀ ⊕ B(δ)` inside the ball of radius
/// `r₀ + δ`).
///
/// This is the paper's near-neighbour ellipsoid (§4.2, the neighbourhood `N_i` with semi-axes
/// scaled by `μ`) made certifiable in the sense of Donev et al. (2005): the region is fixed
/// when the list is built and the particle provably stays in it until its list-update event
/// ([`EnvelopeModel::record_exit`]). The `μ`-scaled ellipsoid contains `E₀ ⊕ B(δ)` for
/// `δ = (μ − 1)·a_min` and no more is certified by a rotation bound, so the thickened
/// ellipsoid is the tighter region for the same guarantee. `δ` follows the kernel's adaptive
/// skin, which shrinks near jamming (the paper's `μ → 1`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Envelope {
    /// `S₀ = R·diag(a, b, c)·Rᵀ` at the build time: `E₀ = {c₀ + S₀u : |u| ≤ 1}` and the
    /// support function of `E₀ − c₀` is `|S₀n|`.
    root: Matrix3<f64>,
    /// `M₀ = S₀²` (for the Perram–Wertheim separating axis).
    m: Matrix3<f64>,
    /// Half of the segment along the longest axis, `(a_max − a_mid)·e_max` (world frame): the
    /// ellipsoid lies in the capsule of radius `a_mid` around it, so the closest points of two
    /// such segments give a good trial axis for needles.
    spine: Vec3,
    /// Skin width `δ` (length).
    skin: f64,
    /// Radius `a_mid + δ` of the capsule around the spine that holds the envelope.
    capsule: f64,
    /// Length `|spine|` (`a_max − a_mid`).
    half_length: f64,
}

impl Default for Envelope {
    fn default() -> Self {
        Self {
            root: Matrix3::zeros(),
            m: Matrix3::zeros(),
            spine: Vec3::zeros(),
            skin: 0.0,
            capsule: 0.0,
            half_length: 0.0,
        }
    }
}

impl Ellipsoid {
    /// The unit symmetry axis (world frame) of a prolate spheroid (one long semi-axis, the
    /// other two equal) in orientation `spin`; `None` for other shapes.
    #[inline]
    fn is_prolate(&self) -> bool {
        let long = self.axes.imax();
        let (j, k) = ((long + 1) % 3, (long + 2) % 3);
        self.axes[j] == self.axes[k] && self.axes[j] < 1.0
    }

    /// The unit longest axis (world frame) in orientation `spin`.
    #[inline]
    fn long_axis(&self, spin: &Spin) -> Vec3 {
        spin.orientation * Vec3::ith(self.axes.imax(), 1.0)
    }

    /// Half of the segment along the longest axis (unit `axis`, [`Ellipsoid::long_axis`]) at
    /// time `t`, `(a_max − a_mid)·e_max` ([`Envelope::spine`]; zero for platelets and spheres).
    #[inline]
    fn spine(&self, axis: &Vec3, t: f64) -> Vec3 {
        axis * self.mid_and_spine_length(t).1
    }

    /// `(a_mid, a_max − a_mid)` at time `t`: the middle semi-axis (the capsule radius of
    /// [`Envelope`] without its skin) and the half-length of the spine.
    #[inline]
    fn mid_and_spine_length(&self, t: f64) -> (f64, f64) {
        let axes = self.semi_axes(t);
        let mid = axes.sum() - axes.max() - axes.min();
        (mid, axes.max() - mid)
    }

    /// `S = R·diag(semi-axes)·Rᵀ` at time `t`: the symmetric square root of the shape matrix.
    #[inline]
    fn root_matrix(&self, rot: &Matrix3<f64>, t: f64) -> Matrix3<f64> {
        rot * Matrix3::from_diagonal(&self.semi_axes(t)) * rot.transpose()
    }
}

/// Parameters `(s, t) ∈ [−1, 1]²` of the closest points `p + s·u` and `q + t·w` of two segments
/// (`d = p − q`): the minimiser of the convex quadratic `|d + s·u − t·w|²`, by clamping the
/// unconstrained minimiser in `s`, then taking the best clamped `t` for it and the best
/// clamped `s` for that `t` (exact for segments). Degenerate segments (points) get 0.
#[inline]
fn closest_on_segments(u: &Vec3, w: &Vec3, d: &Vec3) -> (f64, f64) {
    let (uu, uw, ww) = (u.dot(u), u.dot(w), w.dot(w));
    let (ud, wd) = (u.dot(d), w.dot(d));
    let best_s = |t: f64| {
        if uu > 0.0 {
            ((uw * t - ud) / uu).clamp(-1.0, 1.0)
        } else {
            0.0
        }
    };
    let best_t = |s: f64| {
        if ww > 0.0 {
            ((uw * s + wd) / ww).clamp(-1.0, 1.0)
        } else {
            0.0
        }
    };
    let det = uu * ww - uw * uw;
    let s = if det > 1e-12 * uu * ww {
        ((uw * wd - ww * ud) / det).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let t = best_t(s);
    (best_s(t), t)
}

/// Whether two envelopes whose centres are `d = c₀_a − c₀_b` apart may overlap.
///
/// For any unit `n`, `E_a ⊕ B(δ_a)` and `E_b ⊕ B(δ_b)` are disjoint if
/// `n·(c₀_a − c₀_b) − |S_a n| − |S_b n| > δ_a + δ_b` (the plane normal to `n` separates them:
/// support functions), so the test is certified whichever axes are tried, and only the
/// length of the lists depends on their choice. Two are: the line joining the closest
/// points of the spines (the long axes; for needles nearly the common normal, for
/// spheroids of low aspect ratio nearly the centre line), then the Perram–Wertheim
/// separating axis of the two ellipsoids (a few Newton steps). A margin of `10⁻¹²` of the
/// lengths involved covers rounding.
///
/// Most pairs that the list spheres let through are far apart (a needle's sphere holds
/// `~R²` times its volume), so cheaper tests with the capsules that hold the envelopes (radius
/// `a_mid + δ` around the spine, [`Envelope::capsule`]) come first: `b`'s centre farther
/// from `a`'s spine than `a`'s capsule radius plus `b`'s half-length and capsule radius, then
/// the support functions of the capsules along the first trial axis (`|n·spine| + ρ`, three
/// dot products instead of two matrix products and roots). Both only reject pairs that the
/// envelopes' own test along that axis rejects too (the capsule contains the envelope).
fn envelopes_may_overlap(a: &Envelope, b: &Envelope, d: &Vec3) -> bool {
    let reach = a.skin + b.skin;
    let margin = |along: f64, sum: f64| 1e-12 * (along.abs() + sum);
    // `b`'s centre against `a`'s spine segment.
    let uu = a.spine.norm_squared();
    let s = if uu > 0.0 {
        (-d.dot(&a.spine) / uu).clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let apart = (d + a.spine * s).norm();
    let sum = a.capsule + b.half_length + b.capsule;
    if apart > sum + margin(apart, sum) {
        return false;
    }
    let separated = |n: &Vec3| {
        let along = n.dot(d);
        let capsules = n.dot(&a.spine).abs() + n.dot(&b.spine).abs() + a.capsule + b.capsule;
        if along > capsules + margin(along, capsules) {
            return true;
        }
        let (ha, hb) = ((a.root * n).norm(), (b.root * n).norm());
        along - ha - hb > reach + 1e-12 * (along.abs() + ha + hb + reach)
    };
    let (s, t) = closest_on_segments(&a.spine, &b.spine, d);
    if let Some(n) = (d + a.spine * s - b.spine * t).try_normalize(0.0) {
        if separated(&n) {
            return false;
        }
    }
    // `pw_maximise` takes `r = c_b − c_a` and gives an axis from a to b.
    let Some((_, x)) = pw_maximise(&a.m, &b.m, &-d, 0.5, 12, 1e-6) else {
        return true;
    };
    match x.try_normalize(0.0) {
        Some(n) => !separated(&-n),
        None => true,
    }
}

/// Largest eigenvalue magnitude (the spectral norm) of a symmetric 3×3 matrix, rounded up:
/// the closed-form (trigonometric) eigenvalues of `A = qI + pB` (`q = tr A / 3`,
/// `p² = tr (A − qI)² / 6`, `det B = 2 cos 3φ`), with a margin of `10⁻⁶·(|q| + p)` against
/// rounding (near a double eigenvalue `det B / 2` is within rounding of ±1, where `acos`
/// amplifies an error `ε` to `√ε`: eigenvalues off by ~`10⁻⁸·p`), never above the Frobenius
/// norm (itself a bound).
fn symmetric_spectral_norm(a: &Matrix3<f64>) -> f64 {
    let frobenius = a.norm();
    let q = a.trace() / 3.0;
    let b = a - Matrix3::identity() * q;
    let p = (b.norm_squared() / 6.0).sqrt();
    if p.is_nan() || p <= 0.0 {
        return frobenius.min(q.abs());
    }
    let r = ((b / p).determinant() / 2.0).clamp(-1.0, 1.0);
    let phi = r.acos() / 3.0;
    let largest = q + 2.0 * p * phi.cos();
    let smallest = q + 2.0 * p * (phi + 2.0 * PI / 3.0).cos();
    let norm = largest.abs().max(smallest.abs());
    frobenius.min(norm + 1e-6 * (q.abs() + p))
}

/// Bound of `‖[Ω, S]‖₂ / s` (`Ω` the cross-product matrix of `ω`, `S` the root matrix, `s` the
/// scale): the rate at which rotation changes `S`, per unit scale. In the body frame
/// `[Ω, S] = s·R[Ω_b, D]Rᵀ` with `ω_b = Rᵀω` (constant in free flight: the body turns about
/// `ω`), a symmetric matrix with zero diagonal and entries `(Ω_b)_jk (d_k − d_j)`; its
/// spectral norm is taken in closed form ([`symmetric_spectral_norm`]). For a prolate
/// spheroid it is `ω⊥(1 − e)` (`ω⊥` the spin across the axis, `e` the relative thickness):
/// spin about a symmetry axis costs nothing.
fn commutator_bound(shape: &Ellipsoid, spin: &Spin) -> f64 {
    let w = spin.orientation.inverse_transform_vector(&spin.omega);
    let d = shape.axes;
    let (c01, c02, c12) = (-w.z * (d.y - d.x), w.y * (d.z - d.x), -w.x * (d.z - d.y));
    let c = Matrix3::new(0.0, c01, c02, c01, 0.0, c12, c02, c12, 0.0);
    symmetric_spectral_norm(&c)
}

/// Time up to which an ellipsoid stays inside its envelope (see [`Envelope`]).
///
/// With `S(t) = R(t)·diag(a(t))·R(t)ᵀ` the body is `{c(t) + S(t)u : |u| ≤ 1}`, and its support
/// function exceeds that of `E₀` by at most `|c(t) − c₀| + ‖S(t) − S₀‖₂` in every direction
/// (`|S n| − |S₀n| ≤ |(S − S₀)n|`), so it lies in `E₀ ⊕ B(D(t))` with
/// `D(t) = |c(t) − c₀| + ‖S(t) − S₀‖₂` ([`symmetric_spectral_norm`]; the Frobenius norm, also
/// a bound, charges a needle turned by `θ` with `√2·aθ` instead of `aθ`). In free flight
/// `Ṡ = [Ω, S] + R·ȧ·Rᵀ` (`Ω` the cross-product matrix of the constant `ω`); as
/// `‖[Ω, S]‖₂ ≤ κ·s` ([`commutator_bound`], `s` the scale) and `‖R·ȧ·Rᵀ‖₂ = |g|`. Hence,
/// `τ` later, `D ≤ D(t) + (|v| + |g| + κ·s(t))·τ + ½κ|g|·τ²`, and the particle stays inside
/// until this bound reaches `δ` (the returned time; 0 if it already has).
fn envelope_exit(
    shape: &Ellipsoid,
    spin: &Spin,
    envelope: &Envelope,
    q: &Vec3,
    vel: &Vec3,
    t: f64,
) -> Option<f64> {
    let drift = q.norm()
        + symmetric_spectral_norm(&(shape.root_matrix(&spin.rotation(), t) - envelope.root));
    let room = envelope.skin - drift;
    if room <= 0.0 {
        return Some(0.0);
    }
    let turn = commutator_bound(shape, spin);
    let b = vel.norm() + shape.g.abs() + turn * shape.scale_at(t);
    let a = 0.5 * turn * shape.g.abs();
    // Positive root of a·τ² + b·τ − room, free of cancellation.
    (b > 0.0).then(|| 2.0 * room / (b + (b * b + 4.0 * a * room).sqrt()))
}

/// Bound of `|d²h/dτ²|` for the support function `h(n, τ)` of an ellipsoid along a fixed unit
/// `n`, while it rotates at the constant `ω` of `spin` and its scale grows at `g` up to
/// `s_max`.
///
/// With `h = s·φ(u)`, `φ(u) = |D u|` (`D` = relative semi-axes, largest 1, smallest `e`) and
/// `u = Rᵀn` turning at `|u'| ≤ |ω|`, `|u''| ≤ |ω|²`: `|∇φ| ≤ 1`, `‖∇²φ‖ ≤ 1/e`, hence
/// `|φ''| ≤ |ω|²(1 + 1/e)` and `|h''| ≤ 2g|ω| + s_max|ω|²(1 + 1/e)`.
///
/// A prolate spheroid (`D = diag(1, e, e)` up to order) is blind to its spin about its axis
/// `ê`: `φ = ψ(x)`, `x = n·ê`, `ψ(x) = √(e² + (1 − e²)x²)`, with `|ψ'| ≤ 1`, `0 ≤ ψ'' ≤ 1/e`.
/// As `ê' = ω × ê`, `ê'' = ω × (ω × ê)`, `|x'| ≤ ω⊥ = |ω × ê|` (constant in free flight) and
/// `|x''| ≤ |ω|ω⊥`, so `|φ''| ≤ ω⊥²/e + |ω|ω⊥` and `|h''| ≤ 2gω⊥ + s_max(ω⊥²/e + |ω|ω⊥)`; the
/// smaller bound is returned. (Thermal needles spin fast about their axis: `I_∥ ≪ I_⊥`.)
#[inline]
pub fn support_curvature_bound(shape: &Ellipsoid, spin: &Spin, s_max: f64) -> f64 {
    curvature_bound_with_axis(shape, spin, &shape.long_axis(spin), s_max)
}

/// [`support_curvature_bound`] with the unit longest axis `axis` ([`Ellipsoid::long_axis`])
/// given (a prediction needs it for the spine too).
#[inline]
fn curvature_bound_with_axis(shape: &Ellipsoid, spin: &Spin, axis: &Vec3, s_max: f64) -> f64 {
    let e = shape.axes.min();
    let omega = spin.omega.norm();
    let general = 2.0 * shape.g.abs() * omega + s_max * omega * omega * (1.0 + 1.0 / e);
    if shape.is_prolate() {
        let across = spin.omega.cross(axis).norm();
        let prolate = 2.0 * shape.g.abs() * across + s_max * (across * across / e + omega * across);
        general.min(prolate)
    } else {
        general
    }
}

/// The pose of one ellipsoid at a trial time: centre offset, rotation and `M`.
struct Pose {
    rot: Matrix3<f64>,
    m: Matrix3<f64>,
}

impl Pose {
    #[inline]
    fn of(shape: &Ellipsoid, spin: &Spin, dt: f64, t: f64) -> Self {
        let rot = spin.after(dt).rotation();
        let m = shape.shape_matrix(&rot, t);
        Self { rot, m }
    }
}

/// Support function `h = √(nᵀMn)` and its time derivative along a fixed `n` for an ellipsoid
/// rotating at `omega` and growing at relative rate `rel`: `ḣ = h·rel − ω·(n × Mn)/h`.
#[inline]
fn support_and_rate(m: &Matrix3<f64>, n: &Vec3, omega: &Vec3, rel: f64) -> (f64, f64) {
    let mn = m * n;
    let h = n.dot(&mn).sqrt();
    (h, h * rel - omega.dot(&n.cross(&mn)) / h)
}

/// Support function along unit `n` of an ellipsoid `dt` after its spin state `spin`, at
/// kernel time `t`, and its rate along the fixed `n` ([`support_and_rate`] without forming
/// `M`: `Mn = R·D²·Rᵀn`).
#[inline]
fn support_along(shape: &Ellipsoid, spin: &Spin, dt: f64, t: f64, n: &Vec3) -> (f64, f64) {
    let q = spin.after(dt).orientation;
    let body = q.inverse_transform_vector(n);
    let d = shape.semi_axes(t);
    let d2 = d.component_mul(&d);
    let mn = q.transform_vector(&d2.component_mul(&body));
    let h = n.dot(&mn).sqrt();
    (
        h,
        h * shape.relative_growth(t) - spin.omega.dot(&n.cross(&mn)) / h,
    )
}

/// The Perram–Wertheim function and its first two λ-derivatives for separation `r`
/// (from a to b), or `None` if `G` is not positive definite (degenerate input).
///
/// `F = λ(1−λ) r·x`, `x = G⁻¹r`, `Δ = M_b − M_a`:
/// `F' = (1−2λ) r·x − λ(1−λ) xᵀΔx`,
/// `F'' = −2 r·x − 2(1−2λ) xᵀΔx + 2λ(1−λ) (Δx)ᵀG⁻¹(Δx)`.
#[inline]
fn pw_newton(
    ma: &Matrix3<f64>,
    mb: &Matrix3<f64>,
    r: &Vec3,
    lambda: f64,
) -> Option<(Vec3, f64, f64)> {
    let g = ma * (1.0 - lambda) + mb * lambda;
    let inverse = symmetric_inverse(&g)?;
    let x = inverse * r;
    let delta = mb - ma;
    let dx = delta * x;
    let y = inverse * dx;
    let rx = r.dot(&x);
    let xdx = x.dot(&dx);
    let l1 = lambda * (1.0 - lambda);
    let f1 = (1.0 - 2.0 * lambda) * rx - l1 * xdx;
    let f2 = -2.0 * rx - 2.0 * (1.0 - 2.0 * lambda) * xdx + 2.0 * l1 * dx.dot(&y);
    Some((x, f1, f2))
}

/// Inverse of a symmetric positive definite 3×3 matrix by its adjugate (cheaper than a
/// general factorisation for this size), or `None` if it is not positive definite.
#[inline]
fn symmetric_inverse(g: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let c00 = g[(1, 1)] * g[(2, 2)] - g[(1, 2)] * g[(1, 2)];
    let c01 = g[(1, 2)] * g[(0, 2)] - g[(0, 1)] * g[(2, 2)];
    let c02 = g[(0, 1)] * g[(1, 2)] - g[(1, 1)] * g[(0, 2)];
    let det = g[(0, 0)] * c00 + g[(0, 1)] * c01 + g[(0, 2)] * c02;
    if !(det > 0.0 && g[(0, 0)] > 0.0 && c00 > 0.0) {
        return None;
    }
    let c11 = g[(0, 0)] * g[(2, 2)] - g[(0, 2)] * g[(0, 2)];
    let c12 = g[(0, 1)] * g[(0, 2)] - g[(0, 0)] * g[(1, 2)];
    let c22 = g[(0, 0)] * g[(1, 1)] - g[(0, 1)] * g[(0, 1)];
    let k = 1.0 / det;
    Some(Matrix3::new(c00, c01, c02, c01, c11, c12, c02, c12, c22) * k)
}

/// Maximises the Perram–Wertheim function by safeguarded Newton steps from `lambda`
/// (`F` is concave on `[0, 1]`, `F'(0) > 0 > F'(1)`) until a step is below `precision`.
/// Returns the last λ evaluated and `G⁻¹r` there; `iterations` bounds the work (a warm
/// start needs one or two). Any λ gives a valid separating axis for the prediction; only
/// the contact point needs it converged.
fn pw_maximise(
    ma: &Matrix3<f64>,
    mb: &Matrix3<f64>,
    r: &Vec3,
    mut lambda: f64,
    iterations: u32,
    precision: f64,
) -> Option<(f64, Vec3)> {
    let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
    let mut last = None;
    for _ in 0..iterations {
        let (x, f1, f2) = pw_newton(ma, mb, r, lambda)?;
        last = Some((lambda, x));
        if f1 > 0.0 {
            lo = lambda;
        } else {
            hi = lambda;
        }
        let mut next = if f2 < 0.0 { lambda - f1 / f2 } else { f64::NAN };
        if !(next >= lo && next <= hi) {
            next = 0.5 * (lo + hi);
        }
        let step = (next - lambda).abs();
        lambda = next;
        if step < precision {
            break;
        }
    }
    last
}

/// First time `δ > 0` at which `g + g'δ − Kδ²/2` reaches zero (`g > 0`, `K ≥ 0`), `∞` if never.
#[inline]
fn certified_step(gap: f64, rate: f64, curvature: f64) -> f64 {
    if curvature <= 0.0 {
        return if rate < 0.0 {
            gap / -rate
        } else {
            f64::INFINITY
        };
    }
    let root = (rate * rate + 2.0 * curvature * gap).sqrt();
    if rate < 0.0 {
        2.0 * gap / (root - rate)
    } else {
        (rate + root) / curvature
    }
}

/// Where two ellipsoids touch (or nearly): contact point, unit normal from `a` to `b`, the
/// projected gap along it and the support distances of both centres along the normal.
struct ContactGeometry {
    point: Vec3,
    normal: Vec3,
    gap: f64,
    ha: f64,
    hb: f64,
}

/// Contact geometry of `a` (centre 0) and `b` (centre `r`) from the maximiser of the
/// Perram–Wertheim function.
fn contact_geometry(ma: &Matrix3<f64>, mb: &Matrix3<f64>, r: &Vec3) -> Option<ContactGeometry> {
    let (lambda, x) = pw_maximise(ma, mb, r, 0.5, 60, 1e-15)?;
    let normal = x.normalize();
    let point = ma * x * (1.0 - lambda);
    let ha = normal.dot(&(ma * normal)).sqrt();
    let hb = normal.dot(&(mb * normal)).sqrt();
    Some(ContactGeometry {
        point,
        normal,
        gap: normal.dot(r) - ha - hb,
        ha,
        hb,
    })
}

/// Contact point (relative to the centre of `a`) and unit normal (from `b` to `a`) of two
/// touching ellipsoids at time `t`, `dr = c_a − c_b`: the point and normal that
/// [`ellipsoid_pair_impulse`] uses (Eq. 14 and 26). `None` if the configuration is degenerate.
pub fn contact_point_and_normal(
    a: &Ellipsoid,
    b: &Ellipsoid,
    sa: &Spin,
    sb: &Spin,
    dr: &Vec3,
    t: f64,
) -> Option<(Vec3, Vec3)> {
    let ma = a.shape_matrix(&sa.rotation(), t);
    let mb = b.shape_matrix(&sb.rotation(), t);
    contact_geometry(&ma, &mb, &-dr).map(|c| (c.point, -c.normal))
}

/// The relative motion of a pair during one prediction.
struct PairMotion<'a> {
    a: &'a Ellipsoid,
    b: &'a Ellipsoid,
    sa: &'a Spin,
    sb: &'a Spin,
    /// `c_b − c_a` at the prediction time.
    r0: Vec3,
    /// `v_b − v_a`.
    w: Vec3,
    t: f64,
}

impl PairMotion<'_> {
    /// Shape matrices at `t + τ` and the separation.
    #[inline]
    fn at(&self, tau: f64) -> (Pose, Pose, Vec3) {
        let pa = Pose::of(self.a, self.sa, tau, self.t + tau);
        let pb = Pose::of(self.b, self.sb, tau, self.t + tau);
        (pa, pb, self.r0 + self.w * tau)
    }

    /// The Perram–Wertheim separating axis at `t + τ` (unit, from a to b) and the improved
    /// λ; `None` if the configuration is degenerate.
    #[inline]
    fn separating_axis(&self, tau: f64, lambda: f64, iterations: u32) -> Option<(Vec3, f64)> {
        let (pa, pb, r) = self.at(tau);
        let precision = if iterations > 8 { 1e-15 } else { 1e-8 };
        let (lambda, x) = pw_maximise(&pa.m, &pb.m, &r, lambda, iterations, precision)?;
        let norm = x.norm();
        (norm > 0.0 && norm.is_finite()).then(|| (x / norm, lambda))
    }

    /// Projected gap along the fixed unit axis `n` at `t + τ` and its rate: a lower bound of
    /// the distance for any `n`.
    #[inline]
    fn gap_along(&self, tau: f64, n: &Vec3) -> (f64, f64) {
        let t = self.t + tau;
        let (ha, ha_rate) = support_along(self.a, self.sa, tau, t, n);
        let (hb, hb_rate) = support_along(self.b, self.sb, tau, t, n);
        let r = self.r0 + self.w * tau;
        (n.dot(&r) - ha - hb, n.dot(&self.w) - ha_rate - hb_rate)
    }

    /// [`PairMotion::separating_axis`] and the gap along it.
    #[cfg(test)]
    fn gap_and_rate(&self, tau: f64, lambda: f64, iterations: u32) -> Option<(f64, f64, f64)> {
        let (n, lambda) = self.separating_axis(tau, lambda, iterations)?;
        let (gap, rate) = self.gap_along(tau, &n);
        Some((gap, rate, lambda))
    }

    /// Bound of the second derivative of the projected gap over `[t, t + max_tau]`.
    fn curvature_bound(&self, max_tau: f64, axis_a: &Vec3, axis_b: &Vec3) -> f64 {
        let end = self.t + max_tau;
        curvature_bound_with_axis(self.a, self.sa, axis_a, self.a.scale_at(end))
            + curvature_bound_with_axis(self.b, self.sb, axis_b, self.b.scale_at(end))
    }

    /// `η1` of the characteristic polynomial at `t + τ` and the configuration (Table 1).
    fn characteristic(&self, tau: f64) -> (f64, Configuration) {
        let (pa, pb, r) = self.at(tau);
        let t = self.t + tau;
        let p = quartic::pencil_coefficients(
            &pa.rot,
            &self.a.semi_axes(t),
            &pb.rot,
            &self.b.semi_axes(t),
            &r,
        );
        let eta = quartic::Eta::of(&p);
        (eta.eta1, quartic::classify(&p))
    }
}

/// First contact time of two moving, rotating, growing ellipsoids within `[0, max_tau]`
/// (see the module documentation). `dr = c_a − c_b`, `dv = v_a − v_b`, spins at time `t`.
#[allow(clippy::too_many_arguments)]
pub fn predict_ellipsoid_pair(
    a: &Ellipsoid,
    b: &Ellipsoid,
    sa: &Spin,
    sb: &Spin,
    dr: &Vec3,
    dv: &Vec3,
    t: f64,
    max_tau: f64,
) -> Option<f64> {
    // Bounding spheres (Eq. 15–16): no contact before they touch.
    let sigma = a.scale_at(t) + b.scale_at(t);
    let start = if dr.norm_squared() <= sigma * sigma {
        0.0
    } else {
        predict_sphere_sphere(sigma, a.g + b.g, dr, dv, max_tau)?
    };
    let motion = PairMotion {
        a,
        b,
        sa,
        sb,
        r0: -dr,
        w: -dv,
        t,
    };
    let (axis_a, axis_b) = (a.long_axis(sa), b.long_axis(sb));
    let curvature = motion.curvature_bound(max_tau, &axis_a, &axis_b);
    let relative = a.contact_tolerance.max(b.contact_tolerance);
    let tolerance = relative * a.min_semi_axis(t).min(b.min_semi_axis(t));
    let switch = 1e-3 * a.min_semi_axis(t).min(b.min_semi_axis(t));
    let mut tau = start;
    let mut lambda = 0.5;
    // Cheap steps along a fixed axis until they have closed most of the gap; then the
    // Perram–Wertheim axis is refreshed (the expensive part). The first axis joins the
    // closest points of the spines (as in [`envelopes_may_overlap`]): for needles nearly the
    // common normal, where the centre line shows no gap at all and cost a Perram–Wertheim
    // refresh in every prediction; the centre line for platelets and spheres (no spine).
    let (spine_a, spine_b) = (a.spine(&axis_a, t), b.spine(&axis_b, t));
    let r_start = motion.r0 + motion.w * tau;
    let (s, u) = closest_on_segments(&spine_a, &spine_b, &-r_start);
    let mut axis = (r_start - spine_a * s + spine_b * u).try_normalize(0.0);
    let mut fresh = false;
    let mut reference = f64::INFINITY;
    for _ in 0..MAX_STEPS {
        let n = match axis {
            Some(n) => n,
            None => {
                let Some((n, l)) = motion.separating_axis(tau, lambda, 8) else {
                    count_failure();
                    return Some(tau);
                };
                lambda = l;
                fresh = true;
                axis = Some(n);
                n
            }
        };
        let (mut gap, mut rate) = motion.gap_along(tau, &n);
        if gap <= tolerance {
            if !fresh {
                // Perhaps only a stale axis: look again along the converged one.
                axis = None;
                continue;
            }
            let (n, l) = motion.separating_axis(tau, lambda, 60)?;
            lambda = l;
            axis = Some(n);
            // The step below must be certified along this axis: a few Newton steps can leave
            // λ far from the maximiser, whose axis then shows a negative gap (no bound at
            // all) while the pair is still apart.
            (gap, rate) = motion.gap_along(tau, &n);
            if gap <= tolerance {
                if rate < 0.0 {
                    return Some(tau);
                }
                // Touching but separating (just after a collision): step on from the
                // contact, where the bound `g'δ − Kδ²/2` certifies the gap stays open.
                let step = certified_step(gap.max(0.0), rate, curvature);
                if step <= 0.0 {
                    return Some(tau);
                }
                tau += step;
                if tau > max_tau {
                    return None;
                }
                fresh = false;
                reference = f64::INFINITY;
                continue;
            }
        }
        if fresh || !reference.is_finite() {
            reference = gap;
        }
        if fresh && a.predictor == Predictor::Characteristic && gap < switch {
            if let Some(found) = characteristic_contact(&motion, tau, gap, rate, max_tau) {
                return found;
            }
        }
        tau += certified_step(gap.max(0.0), rate, curvature);
        if tau > max_tau {
            return None;
        }
        // Refresh the axis once the gap along it has shrunk to a quarter of its value at
        // the last refresh.
        if gap < 0.25 * reference {
            axis = None;
        }
        fresh = false;
    }
    count_failure();
    Some(tau)
}

/// The paper's final approach: probes at `τ + 2^k·δ` (`δ` the linear time to contact) until
/// the pair is no longer separate, then Brent's method on `η1` in the last bracket. Returns
/// `None` to fall back to certified stepping (no bracket found), `Some(None)` if the pair
/// stays apart in the window, `Some(Some(τ))` for a contact.
fn characteristic_contact(
    motion: &PairMotion,
    tau: f64,
    gap: f64,
    rate: f64,
    max_tau: f64,
) -> Option<Option<f64>> {
    if rate >= 0.0 {
        return None;
    }
    let (eta_lo, config) = motion.characteristic(tau);
    if config != Configuration::Separate || eta_lo <= 0.0 {
        return None;
    }
    let base = gap / -rate;
    let mut lo = tau;
    for k in 0..40 {
        let hi = tau + base * f64::powi(2.0, k - 2);
        if hi > max_tau {
            let (_, c) = motion.characteristic(max_tau);
            return (c == Configuration::Separate).then_some(None);
        }
        let (eta_hi, c) = motion.characteristic(hi);
        if c == Configuration::Separate {
            lo = hi;
            continue;
        }
        if eta_hi >= 0.0 {
            return None;
        }
        let mut tol = 1e-14 * (hi.abs() + 1e-300);
        let root = roots::find_root_brent(lo, hi, |x| motion.characteristic(x).0, &mut tol).ok()?;
        // Externally tangent at the root: separate just before it (Table 1, cases 3–4).
        let before = (root - 2.0 * tol).max(lo);
        return (motion.characteristic(before).1 == Configuration::Separate)
            .then_some(Some(before));
    }
    None
}

/// Resolves a contact of `a` and `b` (separation `dr = c_a − c_b`, relative velocity
/// `dv = v_a − v_b`) at time `t`: the linear impulse on `a`; angular velocities updated.
#[allow(clippy::too_many_arguments)]
pub fn ellipsoid_pair_impulse(
    a: &Ellipsoid,
    b: &Ellipsoid,
    sa: &mut Spin,
    sb: &mut Spin,
    dr: &Vec3,
    dv: &Vec3,
    t: f64,
    ma: f64,
    mb: f64,
) -> Vec3 {
    let (ra, rb) = (sa.rotation(), sb.rotation());
    let (ma3, mb3) = (a.shape_matrix(&ra, t), b.shape_matrix(&rb, t));
    let r = -dr;
    let Some(contact) = contact_geometry(&ma3, &mb3, &r) else {
        count_failure();
        return Vec3::zeros();
    };
    let scale = a.min_semi_axis(t).min(b.min_semi_axis(t));
    if contact.gap > resolved_gap(a.contact_tolerance.max(b.contact_tolerance)) * scale {
        // An early event (failed prediction): not in contact, nothing to resolve.
        return Vec3::zeros();
    }
    // Normal from b to a, lever arms from the centres to the contact point.
    let n = -contact.normal;
    let pa = contact.point;
    let pb = contact.point - r;
    let contact_velocity = dv + sa.omega.cross(&pa) - sb.omega.cross(&pb);
    let u = contact_velocity.dot(&n);
    // The surfaces grow towards each other at `S` (Eq. 32's growth term, exact for
    // proportional growth where the paper bounds it by the largest rates); reflect the gap
    // velocity `u − S` and never leave it closing.
    let growth = contact.ha * a.relative_growth(t) + contact.hb * b.relative_growth(t);
    let u_after = (2.0 * growth - u).max(growth);
    let (arm_a, arm_b) = (pa.cross(&n), pb.cross(&n));
    let ia_arm = a.inverse_inertia_times(&ra, ma, t, &arm_a);
    let ib_arm = b.inverse_inertia_times(&rb, mb, t, &arm_b);
    let k = 1.0 / ma + 1.0 / mb + arm_a.dot(&ia_arm) + arm_b.dot(&ib_arm);
    let j = (u_after - u) / k;
    sa.omega += ia_arm * j;
    sb.omega -= ib_arm * j;
    n * j
}

/// Resolves a contact at time `t` of an ellipsoid with its own periodic image displaced by
/// `−dr` (a lattice vector): the impulse at the first contact (on the body, from the image at
/// `−dr`); the angular velocity is updated.
///
/// The body touches the image at `−dr` at lever arm `p` (normal `n`, from that image towards
/// the body) and, translated by the period, the image at `+dr` at lever arm `q = p + dr`.
/// Every copy moves alike, so the body receives `+J n` at `p` and `−J n` at `q`: its linear
/// momentum is unchanged and `Δω = J I⁻¹ w`, `w = (p − q) × n`. The contact points separate
/// at `u = ω·w` along `n` (their centre velocities are equal), and `Δu = J wᵀI⁻¹w`;
/// reflecting `u` against the growth of the two surfaces as for a pair gives
/// `J = (u' − u)/(wᵀI⁻¹w)`, which without growth (`u' = −u`) leaves `½ωᵀIω` unchanged:
/// `ΔE = J(u + ½J wᵀI⁻¹w) = 0`.
pub fn ellipsoid_self_image_impulse(
    shape: &Ellipsoid,
    spin: &mut Spin,
    dr: &Vec3,
    t: f64,
    mass: f64,
) -> Vec3 {
    let rot = spin.rotation();
    let m = shape.shape_matrix(&rot, t);
    let r = -dr;
    let Some(contact) = contact_geometry(&m, &m, &r) else {
        count_failure();
        return Vec3::zeros();
    };
    if contact.gap > resolved_gap(shape.contact_tolerance) * shape.min_semi_axis(t) {
        return Vec3::zeros(); // an early event: not in contact
    }
    let n = -contact.normal;
    let (p, q) = (contact.point, contact.point - r);
    let w = (p - q).cross(&n);
    let u = spin.omega.dot(&w);
    let growth = (contact.ha + contact.hb) * shape.relative_growth(t);
    let u_after = (2.0 * growth - u).max(growth);
    let i_w = shape.inverse_inertia_times(&rot, mass, t, &w);
    let k = w.dot(&i_w);
    if k.is_nan() || k <= 0.0 {
        // No lever (a needle exactly along the shift, tip on tip): rotation cannot part the
        // contact. Counted; the pair is re-predicted (and stalls if it stays jammed).
        count_failure();
        return Vec3::zeros();
    }
    let j = (u_after - u) / k;
    spin.omega += i_w * j;
    n * j
}

impl Collidable for Ellipsoid {
    type Spin = Spin;
    type Envelope = Envelope;
    type Screened = ();
    type Images = SelfImages;
    type PlaneContact = SupportPlanes;

    fn numerical_failures() -> u64 {
        prediction_failures()
    }

    #[inline]
    fn bounding_radius(&self, t: f64) -> f64 {
        self.scale_at(t)
    }

    /// `√(a_max·a_min)`: the lists of needles grow with the thickness of the envelope and
    /// their updates with the rotation of the tips (`∝ a_max`), so the best skin width
    /// scales like the geometric mean of the two.
    #[inline]
    fn skin_length(&self, t: f64) -> f64 {
        self.scale_at(t) * self.axes.min().sqrt()
    }

    #[inline]
    fn bounding_growth_rate(&self) -> f64 {
        self.g
    }

    #[inline]
    fn volume(&self, t: f64) -> f64 {
        let s = self.scale_at(t);
        4.0 / 3.0 * PI * s * s * s * self.axes.x * self.axes.y * self.axes.z
    }

    fn rebase(&mut self, t0: f64) {
        self.s0 = self.scale_at(t0);
    }

    /// Relative growth scales all semi-axes by `1 + rate·t`; absolute growth makes the
    /// largest semi-axis grow at `rate` and the others in proportion (the shape is kept).
    fn set_growth(&mut self, t: f64, growth: Growth) {
        let s = self.scale_at(t);
        self.g = match growth {
            Growth::None => 0.0,
            Growth::Relative(rate) => rate * s,
            Growth::Absolute(rate) => rate,
        };
        self.s0 = s - self.g * t;
    }

    fn scale(&mut self, factor: f64) {
        self.s0 *= factor;
        self.g *= factor;
    }

    #[inline]
    fn collision_time(
        a: &Self,
        b: &Self,
        sa: &Spin,
        sb: &Spin,
        dr: &Vec3,
        dv: &Vec3,
        t: f64,
        max_tau: f64,
    ) -> f64 {
        predict_ellipsoid_pair(a, b, sa, sb, dr, dv, t, max_tau).unwrap_or(f64::INFINITY)
    }

    #[inline]
    fn collision_impulse(
        a: &Self,
        b: &Self,
        sa: &mut Spin,
        sb: &mut Spin,
        dr: &Vec3,
        dv: &Vec3,
        t: f64,
        ma: f64,
        mb: f64,
    ) -> Vec3 {
        ellipsoid_pair_impulse(a, b, sa, sb, dr, dv, t, ma, mb)
    }
}

/// Three rotational freedoms; free flight turns the orientation at the constant `ω`.
impl Rotation<Ellipsoid> for Spin {
    const FREEDOMS: u32 = 3;

    #[inline]
    fn after(&self, dt: f64) -> Spin {
        let spin = self;
        if dt == 0.0 || spin.omega == Vec3::zeros() {
            return *spin;
        }
        // Eq. 10–11: compose with the rotation by |ω|·Δt about ω/|ω| (applied in the world
        // frame, after the current orientation).
        // Renormalised so that rounding cannot accumulate over millions of compositions.
        let q = UnitQuaternion::from_scaled_axis(spin.omega * dt) * spin.orientation;
        Spin {
            orientation: UnitQuaternion::new_normalize(q.into_inner()),
            omega: spin.omega,
        }
    }

    fn thermal<R: Rng>(&self, shape: &Ellipsoid, mass: f64, kt: f64, t: f64, rng: &mut R) -> Spin {
        let spin = self;
        let inertia = shape.principal_inertia(mass, t);
        let body = Vec3::new(
            rng.sample::<f64, _>(StandardNormal) * (kt / inertia.x).sqrt(),
            rng.sample::<f64, _>(StandardNormal) * (kt / inertia.y).sqrt(),
            rng.sample::<f64, _>(StandardNormal) * (kt / inertia.z).sqrt(),
        );
        Spin {
            orientation: spin.orientation,
            omega: spin.orientation * body,
        }
    }

    #[inline]
    fn kinetic_twice(&self, shape: &Ellipsoid, mass: f64, t: f64) -> f64 {
        let body = self.orientation.inverse() * self.omega;
        body.component_mul(&body)
            .dot(&shape.principal_inertia(mass, t))
    }

    #[inline]
    fn scale_angular_velocity(&mut self, factor: f64) {
        self.omega *= factor;
    }
}

/// Neighbour lists filtered by envelopes (see [`Envelope`]); a particle's list update is its
/// certified envelope exit, and pair predictions look no further than the earlier exit.
impl EnvelopeModel<Ellipsoid> for Envelope {
    #[inline]
    fn kept(n: usize) -> usize {
        n
    }

    #[inline]
    fn build(envelopes: &mut [Self], i: usize, shape: &Ellipsoid, spin: &Spin, t: f64, skin: f64) {
        envelopes[i] = shape.envelope(spin, t, skin);
    }

    #[inline]
    fn may_overlap(envelopes: &[Self], i: usize, j: usize, d: &Vec3) -> bool {
        envelopes_may_overlap(&envelopes[i], &envelopes[j], d)
    }

    #[inline]
    fn record_exit<'a>(
        envelopes: &[Self],
        exits: &mut [f64],
        i: usize,
        t: f64,
        at: impl FnOnce() -> (&'a Ellipsoid, Spin, Vec3, Vec3),
    ) {
        let (shape, spin, q, vel) = at();
        exits[i] = envelope_exit(shape, &spin, &envelopes[i], &q, &vel, t)
            .map_or(f64::INFINITY, |tau| t + tau);
    }

    #[inline]
    fn pair_horizon(exits: &[f64], i: usize, j: usize, t: f64, max_tau: f64) -> f64 {
        max_tau.min((exits[i].min(exits[j]) - t).max(0.0))
    }

    #[inline]
    fn list_update(
        exits: &[f64],
        i: usize,
        t: f64,
        _list_sphere_exit: impl FnOnce() -> Option<f64>,
    ) -> Option<f64> {
        Some(exits[i] - t).filter(|tau| tau.is_finite())
    }
}

/// The ellipsoid's licence to track periodic images: a needle may reach more than half a
/// periodic box edge ([`ellipsoid_self_image_impulse`] resolves contacts with its own images).
#[derive(Clone, Copy, Debug)]
pub struct SelfImages;

impl PeriodicImages<Ellipsoid> for SelfImages {
    #[inline]
    fn tracking() -> Option<Self> {
        Some(SelfImages)
    }

    fn self_image_impulse(
        self,
        shape: &Ellipsoid,
        spin: &mut Spin,
        dr: &Vec3,
        t: f64,
        mass: f64,
    ) -> Vec3 {
        ellipsoid_self_image_impulse(shape, spin, dr, t, mass)
    }
}

/// The ellipsoid's own plane contacts, by its support function `h(n) = √(nᵀMn)`.
#[derive(Clone, Copy, Debug)]
pub struct SupportPlanes;

impl PlaneContact<Ellipsoid> for SupportPlanes {
    #[inline]
    fn own() -> Option<Self> {
        Some(SupportPlanes)
    }

    /// Plane gap `d + (n·v)τ − h(n, τ)` with the support function `h = √(nᵀMn)` (the closed
    /// form of the ellipsoid–plane distance), stepped like the pair prediction; `n` is fixed,
    /// so the steps are exact up to the rotation and growth bound.
    fn predict(
        self,
        shape: &Ellipsoid,
        spin: &Spin,
        n: &Vec3,
        distance: f64,
        normal_velocity: f64,
        t: f64,
        max_tau: f64,
    ) -> Option<f64> {
        // Bounding sphere first (most particles are far from every wall).
        let sphere_rate = shape.g - normal_velocity;
        let s = shape.scale_at(t);
        let start = if distance <= s {
            0.0
        } else {
            first_falling_root(0.0, -0.5 * sphere_rate, distance - s)?
        };
        if start > max_tau {
            return None;
        }
        let curvature = support_curvature_bound(shape, spin, shape.scale_at(t + max_tau));
        let tolerance = shape.contact_tolerance * shape.min_semi_axis(t);
        let mut tau = start;
        for _ in 0..MAX_STEPS {
            let pose = Pose::of(shape, spin, tau, t + tau);
            let (h, h_rate) =
                support_and_rate(&pose.m, n, &spin.omega, shape.relative_growth(t + tau));
            let gap = distance + normal_velocity * tau - h;
            let rate = normal_velocity - h_rate;
            if gap <= tolerance && rate < 0.0 {
                return Some(tau);
            }
            let step = certified_step(gap.max(0.0), rate, curvature);
            if step <= 0.0 {
                return Some(tau);
            }
            tau += step;
            if tau > max_tau {
                return None;
            }
        }
        count_failure();
        Some(tau)
    }

    /// Impulse at the support point `−Mn/h` facing the wall, reflecting its normal velocity
    /// against the growth of the surface there; virial `J·h`.
    fn impulse(
        self,
        shape: &Ellipsoid,
        spin: &mut Spin,
        n: &Vec3,
        vel: &Vec3,
        t: f64,
        mass: f64,
    ) -> (Vec3, f64) {
        let rot = spin.rotation();
        let m = shape.shape_matrix(&rot, t);
        let mn = m * n;
        let h = n.dot(&mn).sqrt();
        let arm = -mn / h;
        let u = (vel + spin.omega.cross(&arm)).dot(n);
        let growth = h * shape.relative_growth(t);
        let u_after = (2.0 * growth - u).max(growth);
        let lever = arm.cross(n);
        let i_lever = shape.inverse_inertia_times(&rot, mass, t, &lever);
        let j = (u_after - u) / (1.0 / mass + lever.dot(&i_lever));
        spin.omega += i_lever * j;
        (n * (j / mass), j * h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    fn sample() -> (Ellipsoid, Ellipsoid, Spin, Spin, Vec3, Vec3) {
        let a = Ellipsoid {
            g: 0.03,
            ..Ellipsoid::new(Vec3::new(0.63, 0.31, 0.31))
        };
        let sa = Spin {
            orientation: UnitQuaternion::from_scaled_axis(Vec3::new(0.3, -1.1, 0.4)),
            omega: Vec3::new(-1.7, 10.3, -4.1),
        };
        let sb = Spin {
            orientation: UnitQuaternion::from_scaled_axis(Vec3::new(-0.8, 0.2, 1.4)),
            omega: Vec3::new(4.7, 2.6, -1.3),
        };
        (
            a,
            a,
            sa,
            sb,
            Vec3::new(-0.29, -0.35, -1.14),
            Vec3::new(0.13, 2.18, 0.51),
        )
    }

    /// Random prolate needles and triaxial ellipsoids with random orientations, spins (fast
    /// about the long axis, as thermal needles are), velocities and growth.
    fn random_body(rng: &mut impl Rng) -> (Ellipsoid, Spin, Vec3) {
        let axes = if rng.gen_bool(0.5) {
            let r = rng.gen_range(1.5..40.0);
            Vec3::new(1.0, 1.0 / r, 1.0 / r)
        } else {
            Vec3::new(1.0, rng.gen_range(0.2..1.0), rng.gen_range(0.1..0.5))
        };
        let shape = Ellipsoid {
            g: rng.gen_range(0.0..2.0),
            ..Ellipsoid::new(axes * rng.gen_range(0.5..3.0))
        };
        let orientation =
            UnitQuaternion::from_scaled_axis(Vec3::from_fn(|_, _| rng.gen_range(-3.0..3.0)));
        let body = Vec3::new(
            rng.gen_range(-50.0..50.0),
            rng.gen_range(-3.0..3.0),
            rng.gen_range(-3.0..3.0),
        );
        let spin = Spin {
            orientation,
            omega: orientation * body,
        };
        (shape, spin, Vec3::from_fn(|_, _| rng.gen_range(-2.0..2.0)))
    }

    fn random_unit(rng: &mut impl Rng) -> Vec3 {
        loop {
            let v = Vec3::from_fn(|_, _| rng.gen_range(-1.0..1.0));
            if let Some(n) = v.try_normalize(1e-3) {
                return n;
            }
        }
    }

    #[test]
    fn the_spectral_norm_matches_an_eigen_decomposition_and_bounds_it() {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(15);
        for k in 0..2000 {
            let mut a = Matrix3::from_fn(|_, _| rng.gen_range(-1.0..1.0));
            a = a + a.transpose();
            match k % 4 {
                // Repeated eigenvalues (a needle's commutator has ±x and 0), and a multiple
                // of the identity.
                1 => a = Matrix3::from_diagonal(&Vec3::new(a[(0, 0)], a[(0, 0)], a[(1, 1)])),
                2 => a = Matrix3::identity() * a[(0, 1)],
                _ => {}
            }
            let exact = a.symmetric_eigenvalues().amax();
            let found = symmetric_spectral_norm(&a);
            assert!(found >= exact, "{found} < {exact} for {a}");
            assert!(found <= exact * (1.0 + 1e-5) + 1e-15, "{found} vs {exact}");
        }
        assert_eq!(symmetric_spectral_norm(&Matrix3::zeros()), 0.0);
    }

    #[test]
    fn a_prolate_commutator_is_the_spin_across_the_axis() {
        // Axis along body x, relative thickness 0.1: ‖[Ω, S]‖₂ / s = ω⊥·(1 − 0.1), whatever
        // the spin about the axis and the orientation.
        let shape = Ellipsoid::new(Vec3::new(1.0, 0.1, 0.1));
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(16);
        for _ in 0..100 {
            let orientation = UnitQuaternion::from_scaled_axis(random_unit(&mut rng) * 2.0);
            let body = Vec3::new(rng.gen_range(-30.0..30.0), 1.5, -2.0);
            let spin = Spin {
                orientation,
                omega: orientation * body,
            };
            let expected = 2.5 * 0.9;
            let found = commutator_bound(&shape, &spin);
            assert!(
                found >= expected && found < expected * (1.0 + 2e-6),
                "{found}"
            );
        }
    }

    #[test]
    fn an_ellipsoid_stays_in_its_envelope_until_the_exit_time() {
        // The body at τ lies in E₀ ⊕ B(δ) iff its support function exceeds E₀'s by at most δ
        // in every direction: checked along random directions at random times before the exit.
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(11);
        for _ in 0..300 {
            let (shape, spin, vel) = random_body(&mut rng);
            let t0 = rng.gen_range(0.0..1.0);
            let skin = rng.gen_range(0.01..0.5) * shape.scale_at(t0);
            let envelope = shape.envelope(&spin, t0, skin);
            // Later, after free flight from the build (the exit is asked again after every
            // event), but before the first exit time, when the kernel updates the list.
            let first = envelope_exit(&shape, &spin, &envelope, &Vec3::zeros(), &vel, t0)
                .expect("a moving body leaves its envelope");
            let later = rng.gen_range(0.0..1.0) * first;
            let q = vel * later;
            let spin_now = spin.after(later);
            let Some(tau) = envelope_exit(&shape, &spin_now, &envelope, &q, &vel, t0 + later)
            else {
                panic!("a moving body leaves its envelope");
            };
            for k in 0..=20 {
                let dt = later + tau * f64::from(k) / 20.0;
                let rot = spin.after(dt).rotation();
                let m = shape.shape_matrix(&rot, t0 + dt);
                for _ in 0..50 {
                    let n = random_unit(&mut rng);
                    let h = n.dot(&(vel * dt)) + n.dot(&(m * n)).sqrt();
                    let h0 = (envelope.root * n).norm();
                    assert!(h <= h0 + skin * (1.0 + 1e-9), "{h} > {h0} + {skin} at {dt}");
                }
            }
        }
    }

    #[test]
    fn envelopes_said_apart_are_apart_and_far_ones_are_told_apart() {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(12);
        let mut apart = 0;
        for _ in 0..400 {
            let (a, sa, _) = random_body(&mut rng);
            let (b, sb, _) = random_body(&mut rng);
            let (ea, eb) = (
                a.envelope(&sa, 0.0, rng.gen_range(0.0..0.3)),
                b.envelope(&sb, 0.0, rng.gen_range(0.0..0.3)),
            );
            let reach = a.scale_at(0.0) + b.scale_at(0.0) + ea.skin + eb.skin;
            let d = random_unit(&mut rng) * rng.gen_range(0.0..1.0) * reach;
            if envelopes_may_overlap(&ea, &eb, &d) {
                continue;
            }
            apart += 1;
            // Sampled surface points are at least as far apart as the ellipsoids.
            let mut nearest = f64::INFINITY;
            for _ in 0..4000 {
                let (u, w) = (random_unit(&mut rng), random_unit(&mut rng));
                let gap = (d + ea.root * u - eb.root * w).norm();
                nearest = nearest.min(gap);
            }
            assert!(
                nearest > ea.skin + eb.skin,
                "{nearest} {} {}",
                ea.skin,
                eb.skin
            );
        }
        assert!(apart > 50, "only {apart} of 400 pairs told apart");
    }

    #[test]
    fn closest_points_of_segments_match_a_scan() {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(13);
        for _ in 0..500 {
            let u = Vec3::from_fn(|_, _| rng.gen_range(-1.0..1.0));
            let w = if rng.gen_bool(0.2) {
                u * rng.gen_range(-1.0..1.0) // parallel
            } else {
                Vec3::from_fn(|_, _| rng.gen_range(-1.0..1.0))
            };
            let d = Vec3::from_fn(|_, _| rng.gen_range(-2.0..2.0));
            let (s, t) = closest_on_segments(&u, &w, &d);
            let found = (d + u * s - w * t).norm();
            let mut best = f64::INFINITY;
            for i in 0..=200 {
                for j in 0..=200 {
                    let (s, t) = (f64::from(i) / 100.0 - 1.0, f64::from(j) / 100.0 - 1.0);
                    best = best.min((d + u * s - w * t).norm());
                }
            }
            assert!(found <= best + 1e-12, "{found} > {best}");
        }
    }

    #[test]
    fn the_support_curvature_bound_holds_for_needles_spinning_about_their_axis() {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(14);
        for _ in 0..300 {
            let (shape, spin, _) = random_body(&mut rng);
            let n = random_unit(&mut rng);
            let h = |tau: f64| {
                let rot = spin.after(tau).rotation();
                n.dot(&(shape.shape_matrix(&rot, tau) * n)).sqrt()
            };
            let bound = support_curvature_bound(&shape, &spin, shape.scale_at(0.1));
            let step = 1e-4;
            for k in 1..1000 {
                let tau = f64::from(k) * 1e-4;
                let second = (h(tau + step) - 2.0 * h(tau) + h(tau - step)) / (step * step);
                assert!(second.abs() <= bound * 1.01 + 1e-3, "{second} > {bound}");
            }
        }
    }

    #[test]
    fn perram_wertheim_derivatives_match_finite_differences() {
        let (a, b, sa, sb, dr, _) = sample();
        let ma = a.shape_matrix(&sa.rotation(), 0.0);
        let mb = b.shape_matrix(&sb.rotation(), 0.0);
        let r = -dr;
        let f = |l: f64| {
            let g = ma * (1.0 - l) + mb * l;
            l * (1.0 - l) * r.dot(&g.try_inverse().unwrap().mul(&r))
        };
        use std::ops::Mul;
        for &l in &[0.2, 0.5, 0.7] {
            let (_, f1, f2) = pw_newton(&ma, &mb, &r, l).unwrap();
            let h = 1e-5;
            let n1 = (f(l + h) - f(l - h)) / (2.0 * h);
            let n2 = (f(l + h) - 2.0 * f(l) + f(l - h)) / (h * h);
            assert!((f1 - n1).abs() < 1e-6 * (1.0 + n1.abs()), "{f1} {n1}");
            assert!((f2 - n2).abs() < 1e-3 * (1.0 + n2.abs()), "{f2} {n2}");
        }
    }

    #[test]
    fn gap_rate_along_fixed_axis_matches_finite_differences() {
        let (a, b, sa, sb, dr, dv) = sample();
        let motion = PairMotion {
            a: &a,
            b: &b,
            sa: &sa,
            sb: &sb,
            r0: -dr,
            w: -dv,
            t: 0.0,
        };
        let tau = 0.05;
        let (pa, pb, r) = motion.at(tau);
        let (_, x) = pw_maximise(&pa.m, &pb.m, &r, 0.5, 60, 1e-15).unwrap();
        let n = x.normalize();
        let gap_n = |tau: f64| {
            let (pa, pb, r) = motion.at(tau);
            n.dot(&r) - n.dot(&(pa.m * n)).sqrt() - n.dot(&(pb.m * n)).sqrt()
        };
        let (_, rate, _) = motion.gap_and_rate(tau, 0.5, 60).unwrap();
        let h = 1e-6;
        let numeric = (gap_n(tau + h) - gap_n(tau - h)) / (2.0 * h);
        assert!((rate - numeric).abs() < 1e-6, "{rate} {numeric}");
    }

    #[test]
    fn a_contact_with_its_own_image_keeps_the_rotational_energy_and_reverses_the_gap_velocity() {
        let e = Ellipsoid::new(Vec3::new(1.0, 0.05, 0.07));
        let mut spin = Spin {
            orientation: UnitQuaternion::from_scaled_axis(Vec3::new(0.1, -0.2, 0.3)),
            omega: Vec3::new(0.7, -1.3, 2.1),
        };
        // A translate `r` of a centrally symmetric body touches it when `rᵀM⁻¹r = 4`: the
        // image at `r = L·x` with `L = 2/√(xᵀM⁻¹x)`.
        let m = e.shape_matrix(&spin.rotation(), 0.0);
        let edge = 2.0 / m.try_inverse().unwrap()[(0, 0)].sqrt();
        let dr = -Vec3::x() * edge;
        let mass = 1.3;
        let energy = |s: &Spin| s.kinetic_twice(&e, mass, 0.0);
        let (pa, n) = contact_point_and_normal(&e, &e, &spin, &spin, &dr, 0.0).unwrap();
        let w = (-dr).cross(&n);
        if spin.omega.dot(&w) > 0.0 {
            spin.omega = -spin.omega; // approaching, as at a predicted contact
        }
        let u_before = spin.omega.dot(&w);
        assert!(u_before < 0.0);
        let e_before = energy(&spin);
        let impulse = ellipsoid_self_image_impulse(&e, &mut spin, &dr, 0.0, mass);
        assert!(impulse.norm() > 0.0 && (pa - (-dr) * 0.5).norm() < 1e-9);
        let u_after = spin.omega.dot(&w);
        assert!(
            (u_after + u_before).abs() < 1e-12 * u_before.abs(),
            "{u_before} → {u_after}"
        );
        assert!(((energy(&spin) - e_before) / e_before).abs() < 1e-12);
    }

    #[test]
    fn plane_contact_of_a_translating_ellipsoid_is_exact() {
        let e = Ellipsoid::new(Vec3::new(2.0, 1.0, 1.0));
        let spin = Spin::default();
        // Long axis along the wall normal: the tip touches when the centre is 2 away.
        let tau = SupportPlanes
            .predict(&e, &spin, &Vec3::x(), 5.0, -1.5, 0.0, 10.0)
            .unwrap();
        assert!((tau - 2.0).abs() < 1e-12, "{tau}");
        // Moving away: never.
        assert_eq!(
            SupportPlanes.predict(&e, &spin, &Vec3::x(), 5.0, 0.5, 0.0, 10.0),
            None
        );
    }

    #[test]
    fn plane_contact_of_a_rotating_growing_ellipsoid_matches_a_scan() {
        let e = Ellipsoid {
            g: 0.1,
            ..Ellipsoid::new(Vec3::new(1.0, 0.3, 0.2))
        };
        let spin = Spin {
            orientation: UnitQuaternion::from_scaled_axis(Vec3::new(0.4, 1.2, -0.3)),
            omega: Vec3::new(0.3, 2.0, -1.1),
        };
        let n = Vec3::z();
        let (distance, u) = (2.5, -0.4);
        // Independent gap: half-width along z of the posed ellipsoid, √(Σ (R_zk a_k)²).
        let gap = |tau: f64| {
            let q = UnitQuaternion::from_scaled_axis(spin.omega * tau) * spin.orientation;
            let r = q.to_rotation_matrix();
            let a = e.semi_axes(tau);
            let half = (0..3)
                .map(|k| (r[(2, k)] * a[k]).powi(2))
                .sum::<f64>()
                .sqrt();
            distance + u * tau - half
        };
        let predicted = SupportPlanes
            .predict(&e, &spin, &n, distance, u, 0.0, 20.0)
            .unwrap();
        let first = (1..=200_000)
            .map(|i| i as f64 * 1e-4)
            .find(|&tau| gap(tau) < 0.0)
            .unwrap();
        assert!(
            predicted <= first && first - predicted < 2e-4,
            "{predicted} vs {first}"
        );
        assert!(gap(predicted).abs() < 1e-9, "{}", gap(predicted));
    }
}
