//! The `[particles.ellipsoid]` table of a scene (paper 004) and the checks an ellipsoid
//! scene adds to a sphere scene's.

use super::{invalid, positive, ContainerSpec, GrowthKind, Method, Scene, SceneError};
use crate::shape::ellipsoid::{Predictor, CONTACT_TOLERANCE, MAX_CONTACT_TOLERANCE};
use serde::{Deserialize, Serialize};

/// Ellipsoid shapes of a scene (paper 004): semi-axes `a`, `b = a/R1`, `c = a/R2` along the
/// body x, y, z axes, scaled so that `a·b·c = (d/2)³` for the particle's diameter `d`.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EllipsoidSpec {
    /// `[R1, R2]` for every particle.
    pub aspect_ratios: Option<[f64; 2]>,
    /// `[[R1_min, R1_max], [R2_min, R2_max]]`: each particle draws R1 and R2 uniformly
    /// (paper 004, Fig. 5).
    pub aspect_ratio_ranges: Option<[[f64; 2]; 2]>,
    /// Collision predictor (default `"separating_axis"`).
    #[serde(default)]
    pub predictor: Predictor,
    /// Gap relative to the smallest semi-axis below which an approach counts as a contact
    /// (default [`CONTACT_TOLERANCE`], 10⁻¹²; allowed `[1e-15, MAX_CONTACT_TOLERANCE]`).
    #[serde(default = "default_contact_tolerance")]
    pub contact_tolerance: f64,
}

fn default_contact_tolerance() -> f64 {
    CONTACT_TOLERANCE
}

/// Smallest contact tolerance a scene may set (rounding of the gap itself is ~10⁻¹⁶).
pub const MIN_CONTACT_TOLERANCE: f64 = 1e-15;

/// Largest ellipsoid packing fraction known (Donev et al. 2004, crystal of ellipsoids,
/// 0.7707): no ellipsoid scene can grow past it.
pub const ELLIPSOID_MAX_FRACTION: f64 = 0.7707;

impl EllipsoidSpec {
    /// Peak resident memory of an ellipsoid run per particle, for the memory estimate
    /// ([`crate::memory`]): 709 B measured at 4·10⁴ prolate ellipsoids (φ = 0.1, periodic
    /// box, `/usr/bin/time -v`, over the empty process), rounded up.
    pub const BYTES_PER_PARTICLE: u64 = 750;

    /// Semi-axes `[a, b, c]` for volume-equivalent diameter `d` and aspect ratios `R1`, `R2`.
    pub fn semi_axes(d: f64, r1: f64, r2: f64) -> [f64; 3] {
        let a = 0.5 * d * (r1 * r2).cbrt();
        [a, a / r1, a / r2]
    }

    /// The largest ratio of bounding radius to volume-equivalent radius over the allowed
    /// aspect ratios (the function is monotone between the corners and the lines R = 1).
    pub fn max_bounding_ratio(&self) -> f64 {
        let ranges = match (self.aspect_ratios, self.aspect_ratio_ranges) {
            (Some([r1, r2]), _) => [[r1, r1], [r2, r2]],
            (None, Some(r)) => r,
            (None, None) => return 1.0,
        };
        let candidates = |[lo, hi]: [f64; 2]| {
            let mut v = vec![lo, hi];
            if lo < 1.0 && hi > 1.0 {
                v.push(1.0);
            }
            v
        };
        let mut best = 0.0_f64;
        for &r1 in &candidates(ranges[0]) {
            for &r2 in &candidates(ranges[1]) {
                let [a, b, c] = Self::semi_axes(2.0, r1, r2);
                best = best.max(a.max(b).max(c));
            }
        }
        best
    }

    pub(super) fn validate(&self) -> Result<(), SceneError> {
        let field = "particles.ellipsoid";
        let tol = self.contact_tolerance;
        if !(MIN_CONTACT_TOLERANCE..=MAX_CONTACT_TOLERANCE).contains(&tol) {
            return Err(invalid(
                format!("{field}.contact_tolerance"),
                format!(
                    "= {tol} is outside the allowed range [{MIN_CONTACT_TOLERANCE:e}, \
                     {MAX_CONTACT_TOLERANCE:e}]"
                ),
            ));
        }
        match (self.aspect_ratios, self.aspect_ratio_ranges) {
            (Some(r), None) => {
                for (k, x) in r.iter().enumerate() {
                    positive(&format!("{field}.aspect_ratios[{k}]"), *x)?;
                }
            }
            (None, Some(ranges)) => {
                for (k, [lo, hi]) in ranges.iter().enumerate() {
                    positive(&format!("{field}.aspect_ratio_ranges[{k}][0]"), *lo)?;
                    positive(&format!("{field}.aspect_ratio_ranges[{k}][1]"), *hi)?;
                    if hi < lo {
                        return Err(invalid(
                            format!("{field}.aspect_ratio_ranges[{k}]"),
                            format!("[{lo}, {hi}]: the upper bound must be ≥ the lower"),
                        ));
                    }
                }
            }
            _ => {
                return Err(invalid(
                    field,
                    "give exactly one of `aspect_ratios` and `aspect_ratio_ranges`",
                ))
            }
        }
        Ok(())
    }
}

impl Scene {
    /// Ellipsoid-specific checks: a box container, and bounding spheres (the largest
    /// semi-axis) that fit the box and stay below a periodic edge up to the densest fraction
    /// the stages can reach.
    pub(super) fn validate_ellipsoids(
        &self,
        e: &EllipsoidSpec,
        d_max: f64,
        smallest_extent: f64,
        periodic_extent: f64,
        seeded_phi: f64,
        grows: bool,
    ) -> Result<(), SceneError> {
        e.validate()?;
        if self.method == Method::Rsa {
            return Err(invalid(
                "method",
                "ellipsoids are packed by EDMD only (\"edmd\")",
            ));
        }
        if self.particles.grading.is_some() {
            return Err(invalid(
                "particles.grading",
                "grading curves are for spheres; give ellipsoids `count`/`diameter` or `components`",
            ));
        }
        if let Some(k) = self.gap_stage() {
            return Err(invalid(
                format!("stage[{k}].until"),
                "gap and max_gap goals are for spheres, not ellipsoids",
            ));
        }
        if !matches!(self.container, ContainerSpec::Box { .. }) {
            return Err(invalid(
                "container.type",
                "ellipsoids need a \"box\" container (periodic or walled)",
            ));
        }
        let bounding = d_max * e.max_bounding_ratio();
        if bounding >= smallest_extent {
            return Err(invalid(
                "particles",
                format!(
                    "the largest ellipsoid (bounding diameter {bounding:.4}) does not fit the \
                     container (smallest extent {smallest_extent})"
                ),
            ));
        }
        let mut final_phi = seeded_phi;
        if grows {
            for s in &self.stages {
                if s.growth != GrowthKind::None {
                    final_phi =
                        final_phi.max(s.until.packing_fraction.unwrap_or(ELLIPSOID_MAX_FRACTION));
                }
            }
        }
        let bounding_final = bounding * (final_phi / seeded_phi).cbrt();
        // The kernel tracks periodic images (several images of a partner, and a particle's own
        // images) for ellipsoids longer than half the box, up to a bounding diameter of one
        // periodic edge.
        if periodic_extent.is_finite() && bounding_final >= periodic_extent {
            return Err(invalid(
                "container.size",
                format!(
                    "a periodic box edge must exceed the largest bounding diameter (longest \
                     axis) the ellipsoids can reach ({bounding_final:.4}); give at least \
                     {bounding_final:.4} or use more, smaller particles"
                ),
            ));
        }
        Ok(())
    }
}
