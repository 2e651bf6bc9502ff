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
//! Every table rejects unknown keys; [`Scene::validate`] names the offending field and its
//! allowed range.

use crate::kernel::{KernelConfig, Limits, Stage, Until, MAX_SKIN};
use crate::queue::QueueKind;
use crate::shape::{Growth, MassRule};
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
    #[serde(deserialize_with = "deserialize_container")]
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

/// The container of a scene, written as a table with a `type` key (`type = "box"`).
///
/// The derived deserializer reads the externally tagged form (`{ box = { size = … } }`);
/// [`deserialize_container`] turns the scene's `type` key into that form, so that errors
/// inside the table name their field (`container.size[1]: invalid type …`), which serde's
/// internally tagged enums cannot do.
#[derive(Clone, Debug, Deserialize, PartialEq)]
#[serde(rename_all = "lowercase", deny_unknown_fields)]
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

/// Reads the `[container]` table: its `type` key selects the variant, and errors name the
/// offending field with its path (`container.size[1]`).
fn deserialize_container<'de, D: serde::Deserializer<'de>>(
    deserializer: D,
) -> Result<ContainerSpec, D::Error> {
    use serde::de::Error;
    let mut table = toml::Table::deserialize(deserializer)?;
    let kind = match table.remove("type") {
        Some(toml::Value::String(kind)) => kind,
        Some(other) => {
            return Err(D::Error::custom(format!(
                "container.type: expected a string (\"box\" or \"cylinder\"), found {}",
                other.type_str()
            )))
        }
        None => {
            return Err(D::Error::custom(
                "container.type: missing; give type = \"box\" or type = \"cylinder\"",
            ))
        }
    };
    let mut tagged = toml::Table::new();
    tagged.insert(kind, toml::Value::Table(table));
    serde_path_to_error::deserialize(toml::Value::Table(tagged)).map_err(|e| {
        // The path starts with the variant (`box.size[1]`); name the scene's field instead.
        let path = e.path().to_string();
        let field = path.split_once('.').map_or("", |(_, rest)| rest);
        let inner = e.into_inner();
        if field.is_empty() {
            D::Error::custom(format!("container: {inner}"))
        } else {
            D::Error::custom(format!("container.{field}: {inner}"))
        }
    })
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

/// Total volume of the spheres of size classes `(count, diameter)`.
fn classes_volume(classes: &[(usize, f64)]) -> f64 {
    classes
        .iter()
        .map(|&(count, d)| count as f64 * std::f64::consts::PI / 6.0 * d.powi(3))
        .sum()
}

/// Most particles a scene may hold: the kernel indexes particles with `u32` and reserves
/// `u32::MAX` as "no particle".
pub const MAX_PARTICLES: usize = u32::MAX as usize - 1;

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
        let scale = self.seeding_scale();
        self.size_classes()
            .into_iter()
            .flat_map(|(count, d)| std::iter::repeat_n(d * scale, count))
            .collect()
    }

    /// The factor by which the written diameters are scaled at seeding (1 without
    /// `particles.packing_fraction`).
    fn seeding_scale(&self) -> f64 {
        match self.particles.packing_fraction {
            Some(phi) => {
                (phi * self.container_volume() / classes_volume(&self.size_classes())).cbrt()
            }
            None => 1.0,
        }
    }

    /// Number of particles (saturating; validation bounds it by [`MAX_PARTICLES`]).
    pub fn particle_count(&self) -> usize {
        self.size_classes()
            .iter()
            .fold(0usize, |sum, &(count, _)| sum.saturating_add(count))
    }

    /// The size classes as written, `(count, diameter)`: one class for equal spheres.
    fn size_classes(&self) -> Vec<(usize, f64)> {
        let p = &self.particles;
        match &p.components {
            Some(cs) => cs.iter().map(|c| (c.count, c.diameter)).collect(),
            None => vec![(p.count.unwrap_or(0), p.diameter.unwrap_or(0.0))],
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
        if !(self.neighbour_skin > 0.0 && self.neighbour_skin <= MAX_SKIN) {
            return Err(invalid(
                "neighbour_skin",
                format!(
                    "= {} is outside the allowed range (0, {MAX_SKIN}]",
                    self.neighbour_skin
                ),
            ));
        }
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
                        return Err(invalid(
                            format!("container.min[{k}]"),
                            format!("= {} must be a finite number", min[k]),
                        ));
                    }
                    if !(min[k] + size[k]).is_finite() {
                        return Err(invalid(
                            format!("container.size[{k}]"),
                            "the upper corner min + size overflows a finite number",
                        ));
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
                    return Err(invalid(
                        "container.base_center",
                        format!("= {base_center:?} must be finite numbers"),
                    ));
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
        let classes = self.size_classes();
        if self.particle_count() > MAX_PARTICLES {
            return Err(invalid(
                "particles",
                format!("more than {MAX_PARTICLES} particles in all (the kernel's index range)"),
            ));
        }
        if p.rsa_max_failures == 0 {
            return Err(invalid("particles.rsa_max_failures", "= 0 must be ≥ 1"));
        }
        let container = self.container_volume();
        if !(container.is_finite() && container > 0.0) {
            return Err(invalid(
                "container",
                format!("its volume ({container}) must be a finite number > 0"),
            ));
        }
        if let Some(phi) = p.packing_fraction {
            fraction("particles.packing_fraction", phi)?;
        } else {
            let filled = classes_volume(&classes) / container;
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
        let scale = self.seeding_scale();
        let seeded_phi = classes_volume(&classes) * scale.powi(3) / container;
        if !(seeded_phi > 0.0 && seeded_phi.is_finite() && scale.is_finite()) {
            return Err(invalid(
                "particles",
                format!(
                    "the spheres' volume relative to the container ({seeded_phi:e}) is not a \
                     positive finite number: the diameters are too small (or too large) for the \
                     container"
                ),
            ));
        }
        let d_max = classes.iter().map(|&(_, d)| d * scale).fold(0.0, f64::max);
        let equal_spheres = classes.iter().all(|&(_, d)| d == classes[0].1);
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
                if equal_spheres && x >= KEPLER_FRACTION {
                    return Err(invalid(
                        f("until.packing_fraction"),
                        format!(
                            "= {x} cannot be reached: equal spheres pack at most π/√18 ≈ \
                             {KEPLER_FRACTION:.6} (Kepler); allowed range (0, {KEPLER_FRACTION:.6})"
                        ),
                    ));
                }
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
