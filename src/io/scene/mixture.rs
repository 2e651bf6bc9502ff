//! The schema of sphere + cylinder scenes (recognised by their `[mixture]` table).

use super::{invalid, wall_seconds, SceneError};
use serde::{Deserialize, Serialize};

/// A scene for a sphere + cylinder RVE (Salnikov et al. 2014), recognised by its `[mixture]`
/// table:
///
/// ```toml
/// seed = 7
/// [mixture]
/// method = "rsa"               # "rsa" (Algorithm 5) or "md" (random start + relaxer, §IV)
/// sphere_fraction = 0.05       # f_s
/// cylinder_fraction = 0.30     # f_c
/// spheres = 50                 # n_s
/// cylinders = 50               # n_c (needs n_c > 4 f_c a²/π)
/// aspect_ratio = 5.0           # a = half-length / radius
/// box_size = 1.0               # edge of the periodic cube (default 1)
/// order = "cylinders_first"    # RSA: "spheres_first" | "interleaved"
/// max_attempts_per_body = 100000
/// max_restarts = 20
/// time_limit_seconds = 60.0    # optional, both methods
/// [mixture.relax]              # md only; every key optional (defaults: RelaxSettings)
/// damping = 0.5
/// ```
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MixtureScene {
    /// Seed of the random generator (Xoshiro256++).
    pub seed: u64,
    /// The mixture.
    pub mixture: MixtureSection,
}

/// Generation method of a mixture.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum MixtureMethod {
    /// Random sequential adsorption (Algorithm 5).
    #[default]
    Rsa,
    /// Random intersecting start relaxed by time-driven molecular dynamics (§IV).
    Md,
}

impl MixtureMethod {
    /// The scene name of the method.
    pub fn as_str(self) -> &'static str {
        match self {
            MixtureMethod::Rsa => "rsa",
            MixtureMethod::Md => "md",
        }
    }
}

/// The `[mixture]` table.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct MixtureSection {
    /// Method.
    #[serde(default)]
    pub method: MixtureMethod,
    /// `f_s`.
    pub sphere_fraction: f64,
    /// `f_c`.
    pub cylinder_fraction: f64,
    /// `n_s`.
    pub spheres: usize,
    /// `n_c`.
    pub cylinders: usize,
    /// `a = ‖l‖/r` (required when there are cylinders).
    pub aspect_ratio: Option<f64>,
    /// Edge of the periodic cube.
    #[serde(default = "default_box_size")]
    pub box_size: f64,
    /// RSA generation order.
    #[serde(default)]
    pub order: crate::protocol::mixture::GenerationOrder,
    /// RSA: consecutive rejections of one body before a fresh start.
    #[serde(default = "default_mixture_attempts")]
    pub max_attempts_per_body: u64,
    /// RSA: fresh starts before failing.
    #[serde(default = "default_mixture_restarts")]
    pub max_restarts: u32,
    /// Wall-clock limit of the generation, seconds.
    pub time_limit_seconds: Option<f64>,
    /// Relaxer settings (method `md`).
    #[serde(default)]
    pub relax: RelaxSection,
}

fn default_box_size() -> f64 {
    1.0
}

fn default_mixture_attempts() -> u64 {
    crate::protocol::mixture::rsa::RsaLimits::default().max_attempts_per_body
}

fn default_mixture_restarts() -> u32 {
    crate::protocol::mixture::rsa::RsaLimits::default().max_restarts
}

/// The `[mixture.relax]` table: each key overrides one field of
/// [`crate::protocol::mixture::relax::RelaxSettings`].
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct RelaxSection {
    /// Time step.
    pub time_step: Option<f64>,
    /// Viscous damping β.
    pub damping: Option<f64>,
    /// Berendsen coupling α_Ber.
    pub berendsen_rate: Option<f64>,
    /// Berendsen temperature.
    pub berendsen_temperature: Option<f64>,
    /// Nosé–Hoover coupling α_NH.
    pub nose_hoover_rate: Option<f64>,
    /// Nosé–Hoover temperature.
    pub nose_hoover_temperature: Option<f64>,
    /// Steps without progress before Nosé–Hoover is switched on.
    pub stagnation_steps: Option<u64>,
    /// Initial force prefactor.
    pub initial_prefactor: Option<f64>,
    /// Largest force prefactor.
    pub max_prefactor: Option<f64>,
    /// Largest displacement per step (smallest radii).
    pub max_displacement: Option<f64>,
    /// Relative inflation kept as a gap.
    pub margin: Option<f64>,
    /// Steps before giving up.
    pub max_steps: Option<u64>,
}

impl MixtureScene {
    /// Parses and validates a mixture scene.
    pub fn from_toml(text: &str) -> Result<Self, SceneError> {
        let scene: MixtureScene =
            toml::from_str(text).map_err(|e| SceneError::Parse(e.to_string()))?;
        scene.validate()?;
        Ok(scene)
    }

    /// Algorithm 5 inputs.
    pub fn spec(&self) -> crate::protocol::mixture::MixtureSpec {
        let m = &self.mixture;
        crate::protocol::mixture::MixtureSpec {
            sphere_fraction: m.sphere_fraction,
            cylinder_fraction: m.cylinder_fraction,
            spheres: m.spheres,
            cylinders: m.cylinders,
            aspect_ratio: m.aspect_ratio.unwrap_or(f64::NAN),
            box_size: m.box_size,
        }
    }

    /// Time limit, if any.
    pub fn time_limit(&self) -> Option<std::time::Duration> {
        self.mixture
            .time_limit_seconds
            .map(std::time::Duration::from_secs_f64)
    }

    /// RSA limits.
    pub fn rsa_limits(&self) -> crate::protocol::mixture::rsa::RsaLimits {
        crate::protocol::mixture::rsa::RsaLimits {
            max_attempts_per_body: self.mixture.max_attempts_per_body,
            max_restarts: self.mixture.max_restarts,
            time_limit: self.time_limit(),
        }
    }

    /// Relaxer settings: defaults overridden by `[mixture.relax]`.
    pub fn relax_settings(&self) -> crate::protocol::mixture::relax::RelaxSettings {
        let r = &self.mixture.relax;
        let d = crate::protocol::mixture::relax::RelaxSettings::default();
        crate::protocol::mixture::relax::RelaxSettings {
            time_step: r.time_step.unwrap_or(d.time_step),
            damping: r.damping.unwrap_or(d.damping),
            berendsen_rate: r.berendsen_rate.unwrap_or(d.berendsen_rate),
            berendsen_temperature: r.berendsen_temperature.unwrap_or(d.berendsen_temperature),
            nose_hoover_rate: r.nose_hoover_rate.unwrap_or(d.nose_hoover_rate),
            nose_hoover_temperature: r
                .nose_hoover_temperature
                .unwrap_or(d.nose_hoover_temperature),
            stagnation_steps: r.stagnation_steps.unwrap_or(d.stagnation_steps),
            initial_prefactor: r.initial_prefactor.unwrap_or(d.initial_prefactor),
            max_prefactor: r.max_prefactor.unwrap_or(d.max_prefactor),
            max_displacement: r.max_displacement.unwrap_or(d.max_displacement),
            margin: r.margin.unwrap_or(d.margin),
            max_steps: r.max_steps.unwrap_or(d.max_steps),
            time_limit: self.time_limit(),
        }
    }

    /// Estimated peak memory of the generation in bytes ([`crate::memory`]), and how it was
    /// formed.
    pub fn memory_estimate(&self) -> (u64, String) {
        let bodies = self.mixture.spheres as f64 + self.mixture.cylinders as f64;
        let each = crate::memory::MIXTURE_BODY_BYTES;
        (
            crate::memory::estimate(bodies, each),
            format!(
                "{bodies:.4e} bodies × {each} B + {} for the process",
                crate::memory::human(crate::memory::BASE_BYTES)
            ),
        )
    }

    /// Checks every field, naming it (`mixture.cylinders`, `mixture.relax.damping`, …).
    pub fn validate(&self) -> Result<(), SceneError> {
        let to_scene = |e: crate::protocol::mixture::MixtureError| match e {
            crate::protocol::mixture::MixtureError::Invalid { field, message } => {
                invalid(&field, message)
            }
            bound => invalid("mixture.cylinders", bound.to_string()),
        };
        if self.mixture.cylinders > 0 && self.mixture.aspect_ratio.is_none() {
            return Err(invalid(
                "mixture.aspect_ratio",
                "is required when cylinders > 0 (a = half-length / radius, > 0)",
            ));
        }
        self.spec().validate().map_err(to_scene)?;
        if let Some(t) = self.mixture.time_limit_seconds {
            wall_seconds("mixture.time_limit_seconds", t)?;
        }
        if self.mixture.max_attempts_per_body == 0 {
            return Err(invalid(
                "mixture.max_attempts_per_body",
                "= 0 must be ≥ 1".to_string(),
            ));
        }
        self.relax_settings().validate().map_err(to_scene)
    }
}
