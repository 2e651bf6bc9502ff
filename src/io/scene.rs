//! Scene files (TOML): what to pack and how.
//!
//! Lengths are in the scene's own unit (millimetres for concrete scenes; any unit for
//! dimensionless studies): every length in a packing is in the same unit. Time is in units
//! where `kT = temperature` and a particle of the mean initial volume has mass 1.
//!
//! ```toml
//! seed = 42
//! queue = "calendar"            # or "heap"
//! mass = "equal"                # or "volume" (mass ∝ d³)
//!
//! [container]
//! type = "box"                  # or "cylinder" (base_center, radius, height; axis along z)
//! size = [20.0, 20.0, 20.0]
//! periodic = [true, true, true] # walls on the axes that are not periodic
//!
//! [particles]
//! count = 1000
//! diameter = 1.0                # or components = [{ count = 500, diameter = 1.0 }, ...]
//! packing_fraction = 0.3        # seeding fraction: diameters scaled to give it, placed by RSA
//!
//! [[stage]]
//! growth = "relative"           # "none" | "relative" (1/time) | "absolute" (length/time)
//! rate = 0.02
//! until = { reduced_pressure = 1e12 }
//! ```
//!
//! Ellipsoids (paper 004) replace the spheres when `[particles.ellipsoid]` is present; the
//! diameters are then volume-equivalent sphere diameters:
//!
//! ```toml
//! [particles]
//! count = 100
//! diameter = 1.0                # volume-equivalent: a·b·c = (d/2)³
//! packing_fraction = 0.05       # seeding fraction (RSA on bounding spheres)
//! [particles.ellipsoid]
//! aspect_ratios = [2.0, 2.0]    # R1 = a/b, R2 = a/c: prolate R1 = R2, oblate R2 = 1
//! # aspect_ratio_ranges = [[1.0, 5.0], [1.0, 5.0]]   # or drawn uniformly per particle
//! predictor = "separating_axis" # or "characteristic" (paper's η1 roots, Brent)
//! ```
//!
//! Every table rejects unknown keys; [`Scene::validate`] names the offending field and its
//! allowed range.

use crate::kernel::{KernelConfig, Limits, Stage, Until};
use crate::queue::QueueKind;
use crate::shape::{Growth, MassRule, Predictor};
use serde::Deserialize;

/// A scene file.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Seed of the random generator (Xoshiro256++).
    pub seed: u64,
    /// Event queue.
    #[serde(default)]
    pub queue: QueueKind,
    /// Mass rule.
    #[serde(default)]
    pub mass: MassRule,
    /// Temperature `kT` of the velocities (default 1).
    #[serde(default = "default_temperature")]
    pub temperature: f64,
    /// Target events per particle between time barriers (default 4; see BENCHMARKS.md).
    #[serde(default = "default_events_per_interval")]
    pub events_per_particle_per_interval: f64,
    /// Neighbour-list skin relative to each particle's radius (default 0.1; see
    /// BENCHMARKS.md).
    #[serde(default = "default_neighbour_skin")]
    pub neighbour_skin: f64,
    /// The container.
    pub container: ContainerSpec,
    /// The particles.
    pub particles: ParticlesSpec,
    /// The stages, run in order.
    #[serde(rename = "stage")]
    pub stages: Vec<StageSpec>,
}

fn default_temperature() -> f64 {
    KernelConfig::default().temperature
}

fn default_events_per_interval() -> f64 {
    KernelConfig::default().events_per_particle_per_interval
}

fn default_neighbour_skin() -> f64 {
    KernelConfig::default().neighbour_skin
}

/// The container of a scene.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum ContainerSpec {
    /// An axis-aligned box.
    Box {
        /// Lower corner (default origin).
        #[serde(default)]
        min: [f64; 3],
        /// Edge lengths.
        size: [f64; 3],
        /// Periodic axes; the others have rigid walls.
        periodic: [bool; 3],
    },
    /// A cylinder with its axis along z.
    Cylinder {
        /// Centre of the bottom cap (default origin).
        #[serde(default)]
        base_center: [f64; 3],
        /// Radius.
        radius: f64,
        /// Height.
        height: f64,
    },
}

/// One size class of particles.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Component {
    /// Number of spheres.
    pub count: usize,
    /// Diameter.
    pub diameter: f64,
}

/// The particles of a scene.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ParticlesSpec {
    /// Number of equal spheres (with `diameter`).
    pub count: Option<usize>,
    /// Diameter of the equal spheres.
    pub diameter: Option<f64>,
    /// Size classes (instead of `count` and `diameter`).
    pub components: Option<Vec<Component>>,
    /// Packing fraction at seeding: all diameters are scaled by one factor to give it.
    /// Without it the diameters are used as given.
    pub packing_fraction: Option<f64>,
    /// Consecutive RSA rejections of one sphere before seeding fails (default 10⁶).
    #[serde(default = "default_rsa_failures")]
    pub rsa_max_failures: u64,
    /// Ellipsoids instead of spheres (the diameters are volume-equivalent).
    #[serde(default)]
    pub ellipsoid: Option<EllipsoidSpec>,
}

/// Ellipsoid shapes of a scene (paper 004): semi-axes `a`, `b = a/R1`, `c = a/R2` along the
/// body x, y, z axes, scaled so that `a·b·c = (d/2)³` for the particle's diameter `d`.
#[derive(Clone, Debug, Deserialize, PartialEq)]
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
}

/// Largest ellipsoid packing fraction known (Donev et al. 2004, crystal of ellipsoids,
/// 0.7707): no ellipsoid scene can grow past it.
pub const ELLIPSOID_MAX_FRACTION: f64 = 0.7707;

impl EllipsoidSpec {
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

    fn validate(&self) -> Result<(), SceneError> {
        let field = "particles.ellipsoid";
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

fn default_rsa_failures() -> u64 {
    1_000_000
}

/// Goal of a stage.
#[derive(Clone, Debug, Default, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct UntilSpec {
    /// Packing fraction to reach.
    pub packing_fraction: Option<f64>,
    /// Reduced pressure to reach (jamming).
    pub reduced_pressure: Option<f64>,
    /// Simulated time to run.
    pub time: Option<f64>,
    /// Pair collisions per particle to run.
    pub collisions_per_particle: Option<f64>,
}

/// Growth protocol names.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum GrowthKind {
    /// No growth.
    None,
    /// Rate relative to each particle's size (1/time).
    Relative,
    /// Absolute radius rate (length/time).
    Absolute,
}

/// A stage of a scene.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct StageSpec {
    /// Growth protocol.
    pub growth: GrowthKind,
    /// Growth rate (required unless `growth = "none"`).
    pub rate: Option<f64>,
    /// Goal.
    pub until: UntilSpec,
    /// Most events (failure when hit).
    pub max_events: Option<u64>,
    /// Most wall-clock seconds (failure when hit).
    pub max_wall_seconds: Option<f64>,
    /// Stall criterion ε: failure when simulated time advances less than ε over 1000 events.
    pub stall_epsilon: Option<f64>,
    /// Rescale velocities to the temperature at barriers (default: on when growing).
    pub thermostat: Option<bool>,
}

/// A scene that cannot be run, naming the field.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SceneError {
    /// The file is not valid TOML or does not match the schema (unknown key, wrong type).
    #[error("{0}")]
    Parse(String),
    /// A field is out of its allowed range.
    #[error("{field}: {message}")]
    Invalid {
        /// The offending field, dotted (`particles.packing_fraction`).
        field: String,
        /// What is wrong and what is allowed.
        message: String,
    },
}

/// Total volume of spheres of the given diameters.
fn sphere_volume(diameters: &[f64]) -> f64 {
    diameters
        .iter()
        .map(|d| std::f64::consts::PI / 6.0 * d.powi(3))
        .sum()
}

fn invalid(field: impl Into<String>, message: impl Into<String>) -> SceneError {
    SceneError::Invalid {
        field: field.into(),
        message: message.into(),
    }
}

fn positive(field: &str, x: f64) -> Result<(), SceneError> {
    if x.is_finite() && x > 0.0 {
        Ok(())
    } else {
        Err(invalid(field, format!("= {x} must be a finite number > 0")))
    }
}

fn fraction(field: &str, x: f64) -> Result<(), SceneError> {
    if x.is_finite() && x > 0.0 && x < 1.0 {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("= {x} is outside the allowed range (0, 1)"),
        ))
    }
}

/// Densest possible packing fraction of equal spheres (Kepler, fcc/hcp): no monodisperse
/// scene can grow past it, which bounds the largest diameter a growth run can reach.
pub const KEPLER_FRACTION: f64 = 0.740_480_489_693_061;

impl Scene {
    /// Parses a scene from TOML text and validates it.
    pub fn from_toml(text: &str) -> Result<Self, SceneError> {
        let scene: Scene = toml::from_str(text).map_err(|e| SceneError::Parse(e.to_string()))?;
        scene.validate()?;
        Ok(scene)
    }

    /// The diameters the spheres are seeded with: as written, or all scaled by one factor so
    /// that they fill `particles.packing_fraction` of the container.
    pub fn seeding_diameters(&self) -> Vec<f64> {
        let mut diameters = self.diameters();
        if let Some(phi) = self.particles.packing_fraction {
            let scale = (phi * self.container_volume() / sphere_volume(&diameters)).cbrt();
            for d in &mut diameters {
                *d *= scale;
            }
        }
        diameters
    }

    /// The diameters of all spheres as written in the scene (before seeding scale).
    fn diameters(&self) -> Vec<f64> {
        let p = &self.particles;
        match &p.components {
            Some(cs) => cs
                .iter()
                .flat_map(|c| std::iter::repeat_n(c.diameter, c.count))
                .collect(),
            None => vec![p.diameter.unwrap_or(0.0); p.count.unwrap_or(0)],
        }
    }

    /// Volume of the container.
    pub fn container_volume(&self) -> f64 {
        match &self.container {
            ContainerSpec::Box { size, .. } => size[0] * size[1] * size[2],
            ContainerSpec::Cylinder { radius, height, .. } => {
                std::f64::consts::PI * radius * radius * height
            }
        }
    }

    /// Checks every field against its allowed range.
    pub fn validate(&self) -> Result<(), SceneError> {
        positive("temperature", self.temperature)?;
        positive(
            "events_per_particle_per_interval",
            self.events_per_particle_per_interval,
        )?;
        positive("neighbour_skin", self.neighbour_skin)?;
        // Container.
        let (smallest_extent, periodic_extent) = match &self.container {
            ContainerSpec::Box {
                min,
                size,
                periodic,
            } => {
                for k in 0..3 {
                    positive(&format!("container.size[{k}]"), size[k])?;
                    if !min[k].is_finite() {
                        return Err(invalid(format!("container.min[{k}]"), "must be finite"));
                    }
                }
                let smallest = size.iter().copied().fold(f64::INFINITY, f64::min);
                let periodic_min = (0..3)
                    .filter(|&k| periodic[k])
                    .map(|k| size[k])
                    .fold(f64::INFINITY, f64::min);
                (smallest, periodic_min)
            }
            ContainerSpec::Cylinder {
                base_center,
                radius,
                height,
            } => {
                positive("container.radius", *radius)?;
                positive("container.height", *height)?;
                if base_center.iter().any(|x| !x.is_finite()) {
                    return Err(invalid("container.base_center", "must be finite"));
                }
                ((2.0 * radius).min(*height), f64::INFINITY)
            }
        };
        // Particles.
        let p = &self.particles;
        match (&p.components, p.count, p.diameter) {
            (Some(cs), None, None) => {
                if cs.is_empty() {
                    return Err(invalid(
                        "particles.components",
                        "needs at least one component",
                    ));
                }
                for (k, c) in cs.iter().enumerate() {
                    if c.count == 0 {
                        return Err(invalid(
                            format!("particles.components[{k}].count"),
                            "= 0 must be ≥ 1",
                        ));
                    }
                    positive(&format!("particles.components[{k}].diameter"), c.diameter)?;
                }
            }
            (None, Some(count), Some(d)) => {
                if count == 0 {
                    return Err(invalid("particles.count", "= 0 must be ≥ 1"));
                }
                positive("particles.diameter", d)?;
            }
            _ => {
                return Err(invalid(
                    "particles",
                    "give either `count` and `diameter`, or `components`",
                ))
            }
        }
        if p.rsa_max_failures == 0 {
            return Err(invalid("particles.rsa_max_failures", "= 0 must be ≥ 1"));
        }
        let container = self.container_volume();
        if let Some(phi) = p.packing_fraction {
            fraction("particles.packing_fraction", phi)?;
        } else {
            let filled = sphere_volume(&self.diameters()) / container;
            if filled >= 1.0 {
                return Err(invalid(
                    "particles",
                    format!(
                        "the spheres fill {filled:.3} of the container; the packing fraction \
                         must be < 1"
                    ),
                ));
            }
        }
        let diameters = self.seeding_diameters();
        let seeded_phi = sphere_volume(&diameters) / container;
        let d_max = diameters.iter().copied().fold(0.0, f64::max);
        if d_max >= smallest_extent {
            return Err(invalid(
                "particles",
                format!(
                    "the largest sphere (diameter {d_max}) does not fit the container \
                     (smallest extent {smallest_extent})"
                ),
            ));
        }
        // Stages.
        if self.stages.is_empty() {
            return Err(invalid("stage", "at least one [[stage]] is required"));
        }
        let mut grows = false;
        for (k, s) in self.stages.iter().enumerate() {
            let f = |name: &str| format!("stage[{k}].{name}");
            match (s.growth, s.rate) {
                (GrowthKind::None, Some(_)) => {
                    return Err(invalid(f("rate"), "is not allowed with growth = \"none\""))
                }
                (GrowthKind::None, None) => {}
                (_, None) => return Err(invalid(f("rate"), "is required when the particles grow")),
                (_, Some(r)) => {
                    positive(&f("rate"), r)?;
                    grows = true;
                }
            }
            let u = &s.until;
            if u.packing_fraction.is_none()
                && u.reduced_pressure.is_none()
                && u.time.is_none()
                && u.collisions_per_particle.is_none()
            {
                return Err(invalid(
                    f("until"),
                    "needs a goal: packing_fraction, reduced_pressure, time or collisions_per_particle",
                ));
            }
            if let Some(x) = u.packing_fraction {
                fraction(&f("until.packing_fraction"), x)?;
                if s.growth == GrowthKind::None {
                    return Err(invalid(
                        f("until.packing_fraction"),
                        "cannot be reached without growth",
                    ));
                }
            }
            if let Some(x) = u.reduced_pressure {
                if !(x.is_finite() && x > 1.0) {
                    return Err(invalid(
                        f("until.reduced_pressure"),
                        format!("= {x} must be a finite number > 1"),
                    ));
                }
            }
            if let Some(x) = u.time {
                positive(&f("until.time"), x)?;
            }
            if let Some(x) = u.collisions_per_particle {
                positive(&f("until.collisions_per_particle"), x)?;
            }
            if let Some(x) = s.max_wall_seconds {
                positive(&f("max_wall_seconds"), x)?;
            }
            if s.max_events == Some(0) {
                return Err(invalid(f("max_events"), "= 0 must be ≥ 1"));
            }
            if let Some(x) = s.stall_epsilon {
                if !(x.is_finite() && x >= 0.0) {
                    return Err(invalid(f("stall_epsilon"), format!("= {x} must be ≥ 0")));
                }
            }
        }
        if let Some(e) = &self.particles.ellipsoid {
            self.validate_ellipsoids(e, smallest_extent, periodic_extent, seeded_phi, grows)?;
        }
        // Minimum image needs every contact distance below half the periodic box length.
        // Growth can at most reach the Kepler fraction for equal spheres; bound the final
        // diameter by it (polydisperse scenes by the same scale, a conservative estimate).
        if periodic_extent.is_finite() {
            let mut final_phi = seeded_phi;
            if grows {
                final_phi = self
                    .stages
                    .iter()
                    .filter_map(|s| s.until.packing_fraction)
                    .fold(final_phi, f64::max);
                if self
                    .stages
                    .iter()
                    .any(|s| s.growth != GrowthKind::None && s.until.packing_fraction.is_none())
                {
                    final_phi = final_phi.max(KEPLER_FRACTION);
                }
            }
            let d_final = d_max * (final_phi / seeded_phi).cbrt();
            if 2.0 * d_final >= periodic_extent {
                return Err(invalid(
                    "container.size",
                    format!(
                        "a periodic box edge must exceed twice the largest diameter the run can \
                         reach ({:.4}); give at least {:.4} or use more, smaller particles",
                        d_final,
                        2.0 * d_final
                    ),
                ));
            }
        }
        Ok(())
    }
}

impl Scene {
    /// Ellipsoid-specific checks: a box container, and bounding spheres (the largest
    /// semi-axis) that fit the box and stay below half a periodic edge up to the densest
    /// fraction the stages can reach (minimum image).
    fn validate_ellipsoids(
        &self,
        e: &EllipsoidSpec,
        smallest_extent: f64,
        periodic_extent: f64,
        seeded_phi: f64,
        grows: bool,
    ) -> Result<(), SceneError> {
        e.validate()?;
        if !matches!(self.container, ContainerSpec::Box { .. }) {
            return Err(invalid(
                "container.type",
                "ellipsoids need a \"box\" container (periodic or walled)",
            ));
        }
        let d_max = self.seeding_diameters().into_iter().fold(0.0, f64::max);
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
        if periodic_extent.is_finite() && 2.0 * bounding_final >= periodic_extent {
            return Err(invalid(
                "container.size",
                format!(
                    "a periodic box edge must exceed twice the largest bounding diameter the \
                     ellipsoids can reach ({bounding_final:.4}) for the minimum-image \
                     convention; give at least {:.4} or use more, smaller particles",
                    2.0 * bounding_final
                ),
            ));
        }
        Ok(())
    }
}

impl StageSpec {
    /// The kernel stage this spec describes.
    pub fn to_stage(&self) -> Stage {
        let growth = match (self.growth, self.rate) {
            (GrowthKind::Relative, Some(r)) => Growth::Relative(r),
            (GrowthKind::Absolute, Some(r)) => Growth::Absolute(r),
            _ => Growth::None,
        };
        Stage {
            growth,
            until: Until {
                packing_fraction: self.until.packing_fraction,
                reduced_pressure: self.until.reduced_pressure,
                time: self.until.time,
                collisions_per_particle: self.until.collisions_per_particle,
            },
            limits: Limits {
                events: self.max_events.unwrap_or(u64::MAX),
                wall_seconds: self.max_wall_seconds,
                stall_epsilon: self.stall_epsilon.unwrap_or(0.0),
            },
            thermostat: self.thermostat.unwrap_or(growth != Growth::None),
        }
    }
}
