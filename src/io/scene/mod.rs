//! Scene files (TOML): what to pack and how.
//!
//! Lengths are in the scene's own unit (millimetres for concrete scenes; any unit for
//! dimensionless studies): every length in a packing is in the same unit. Time is in units
//! of `ℓ·√(m/kT)`, where `kT = temperature`, a particle of the mean initial volume has mass 1
//! and `ℓ` is the power of ten at or below the smallest diameter (1 for diameters in
//! `[1, 10)`): the run works in lengths divided by `ℓ` ([`crate::io::units`]), so a scene
//! rewritten in another decimal unit (every length literal ×10^k) runs identically.
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
//! Concrete scenes draw the diameters from a grading curve (lengths in millimetres):
//!
//! ```toml
//! [particles]
//! grading = { kind = "din", name = "A16" }   # or fuller / table (see GradingSpec)
//! mixture_fraction = 0.535                    # φ_M of the mix design
//! d_min = 2.0                                 # cut-off: smaller grains belong to the mortar
//! # seed_scale = 0.9                          # δ: seeded at δ·d (default 0.9 before a full_size stage)
//!
//! [[stage]]                                   # grow to the true sizes (paper 001, Eq. 30)
//! growth = "relative"
//! rate = 0.05
//! until = { full_size = true }
//!
//! [[stage]]                                   # then open a gap Δd between all particles (Eq. 31)
//! growth = "absolute"
//! rate = 0.01
//! until = { gap = 1.0 }                       # or { max_gap = true }: Δd maximisation
//! ```
//!
//! `method = "rsa"` packs by random sequential addition alone (no stages), keeping
//! `particles.gap` between spheres and half of it to walls.
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
//!
//! The schema's rooms: this module holds the types, their defaults and what they describe
//! (seeding sizes, memory estimates, stage descriptions); `validate` checks a sphere or
//! ellipsoid scene field by field; `mixture` is the schema of sphere + cylinder scenes. The
//! schema does not name kernel types: `crate::run` turns a scene into kernel settings and
//! stages.

mod ellipsoid;
mod mixture;
mod overrides;
mod validate;

pub use ellipsoid::{EllipsoidSpec, ELLIPSOID_MAX_FRACTION, MIN_CONTACT_TOLERANCE};
pub use mixture::{MixtureMethod, MixtureScene, MixtureSection, RelaxSection};
pub use overrides::parse_assignment;

use crate::protocol::take_phase::{GradingSpec, TakeError, TakeParams, TakePhase};
use crate::queue::QueueKind;
use crate::shape::MassRule;
use crate::tuning::{DEFAULT_EVENTS_PER_INTERVAL, DEFAULT_NEIGHBOUR_SKIN, DEFAULT_TEMPERATURE};
use rand::Rng;
use serde::{Deserialize, Serialize};

/// A scene file.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// Seed of the random generator (Xoshiro256++).
    pub seed: u64,
    /// Packing algorithm (default EDMD).
    #[serde(default)]
    pub method: Method,
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
    #[serde(
        deserialize_with = "deserialize_container",
        serialize_with = "serialize_container"
    )]
    pub container: ContainerSpec,
    /// The particles.
    pub particles: ParticlesSpec,
    /// The stages, run in order (EDMD only).
    #[serde(rename = "stage", default)]
    pub stages: Vec<StageSpec>,
    /// A last step after the stages that makes the packing collectively jammed (spheres in
    /// a box).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub jam: Option<JamSpec>,
}

/// The `[jam]` table: after the stages, sequential linear programming
/// ([`crate::protocol::slp`]) moves and grows the spheres until no first-order motion lets
/// them grow: a collectively jammed packing with an isostatic backbone.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct JamSpec {
    /// How: `"linear_programming"` (the only method).
    pub method: JamMethod,
    /// Most steps (default 200), in `[1, 10000]`; the run fails when they are not enough.
    pub max_steps: Option<usize>,
    /// Most wall-clock seconds (default none); the run fails when they run out.
    pub max_wall_seconds: Option<f64>,
}

/// The methods of `[jam]`.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum JamMethod {
    /// Sequential linear programming ([`crate::protocol::slp`]).
    LinearProgramming,
}

/// The packing algorithm of a scene.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "lowercase")]
pub enum Method {
    /// Seed by RSA, then run the stages with event-driven molecular dynamics.
    #[default]
    Edmd,
    /// Random sequential addition only: the seeding is the packing.
    Rsa,
}

fn default_temperature() -> f64 {
    DEFAULT_TEMPERATURE
}

fn default_events_per_interval() -> f64 {
    DEFAULT_EVENTS_PER_INTERVAL
}

fn default_neighbour_skin() -> f64 {
    DEFAULT_NEIGHBOUR_SKIN
}

/// The container of a scene, written as a table with a `type` key (`type = "box"`).
///
/// The derived serde impls use the externally tagged form (`{ box = { size = … } }`);
/// `deserialize_container` and `serialize_container` turn the scene's `type` key into
/// that form and back, so that errors inside the table name their field
/// (`container.size[1]: invalid type …`), which serde's internally tagged enums cannot do.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
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

/// Writes the container as the scene has it: one table with a `type` key (the inverse of
/// [`deserialize_container`]; the resolved scene of a packing's provenance).
fn serialize_container<S: serde::Serializer>(
    container: &ContainerSpec,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    use serde::ser::Error;
    use serde_json::Value;
    let tagged = serde_json::to_value(container).map_err(S::Error::custom)?;
    let Value::Object(variants) = tagged else {
        return Err(S::Error::custom(
            "a container serialises to a variant table",
        ));
    };
    let Some((kind, Value::Object(mut table))) = variants.into_iter().next() else {
        return Err(S::Error::custom(
            "a container serialises to a variant table",
        ));
    };
    table.insert("type".into(), Value::String(kind));
    table.serialize(serializer)
}

/// One size class of particles.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct Component {
    /// Number of spheres.
    pub count: usize,
    /// Diameter.
    pub diameter: f64,
}

/// The particles of a scene: equal spheres (`count`, `diameter`), size classes
/// (`components`) or a grading curve (`grading`, `mixture_fraction`, `d_min`).
///
/// The diameters given (or drawn) are the particles' *true* sizes. They are seeded smaller,
/// by `seed_scale` or to `packing_fraction`, and a `full_size` stage grows them back.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct ParticlesSpec {
    /// Number of equal spheres (with `diameter`).
    pub count: Option<usize>,
    /// Diameter of the equal spheres.
    pub diameter: Option<f64>,
    /// Size classes (instead of `count` and `diameter`).
    pub components: Option<Vec<Component>>,
    /// Grading curve the diameters are drawn from (take phase, paper 001 §2–3; mm).
    pub grading: Option<GradingSpec>,
    /// Aggregate volume fraction `φ_M` of the mix design, in (0, 1) (with `grading`).
    pub mixture_fraction: Option<f64>,
    /// Effective fraction `φ_eff` in (0, 1) filled by the grains above `d_min` (with
    /// `grading`, instead of `mixture_fraction`; paper 001 §6.2 prescribes it directly).
    pub effective_fraction: Option<f64>,
    /// Cut-off diameter `d_min` (mm): grains below it belong to the mortar (with `grading`).
    pub d_min: Option<f64>,
    /// Packing fraction at seeding: all diameters are scaled by one factor to give it.
    pub packing_fraction: Option<f64>,
    /// Seeding scale `δ` in (0, 1]: spheres are seeded at `δ·d` (paper 001 §6.2). Default
    /// 0.9 when the first stage grows to `full_size`, else 1 (the true sizes).
    pub seed_scale: Option<f64>,
    /// Minimum gap `Δd` kept by `method = "rsa"` between spheres.
    pub gap: Option<f64>,
    /// Gap kept by `method = "rsa"` between spheres and walls, in `[0, gap/2]` (default
    /// `gap/2`: each grain keeps its half of the gap everywhere).
    pub wall_gap: Option<f64>,
    /// Consecutive RSA rejections of one sphere before seeding fails (default 10⁶).
    #[serde(default = "default_rsa_failures")]
    pub rsa_max_failures: u64,
    /// Ellipsoids instead of spheres (the diameters are volume-equivalent).
    #[serde(default)]
    pub ellipsoid: Option<EllipsoidSpec>,
    /// A packing JSON file (`densepack run`, `densepack import`) whose spheres the stages
    /// start from, at their sizes and places as written, instead of seeding ([`StartPacking`]).
    /// A relative path is relative to the scene file ([`Scene::from_toml_at`]).
    pub from: Option<String>,
}

/// The spheres a scene starts from (`particles.from`), placed relative to the scene
/// container's origin (a box's lower corner, a cylinder's base centre).
#[derive(Clone, Debug, PartialEq)]
pub struct StartPacking {
    /// Centres relative to the container's origin.
    pub centres: Vec<[f64; 3]>,
    /// Radii as written: the true sizes.
    pub radii: Vec<f64>,
}

/// Relative tolerance of the container match between a scene and the packing it starts from.
const START_CONTAINER_TOLERANCE: f64 = 1e-9;

fn default_rsa_failures() -> u64 {
    1_000_000
}

/// Goal of a stage.
#[derive(Clone, Debug, Default, Deserialize, Serialize, PartialEq)]
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
    /// Grow (relative growth) until the spheres reach their true sizes (Eq. 30).
    pub full_size: Option<bool>,
    /// Grow (absolute growth) from the true sizes until every radius has gained `gap/2`:
    /// the packing is written at the true sizes with this minimum gap (Eq. 31).
    pub gap: Option<f64>,
    /// Grow (absolute growth) from the true sizes until jammed (reduced pressure, default
    /// 10¹²): the largest minimum gap Δd_max.
    pub max_gap: Option<bool>,
}

impl UntilSpec {
    /// The goal as the scene states it, for messages: `packing_fraction = 0.74`, …
    pub fn describe(&self) -> String {
        let mut parts = Vec::new();
        let mut number = |name: &str, v: Option<f64>| {
            if let Some(v) = v {
                parts.push(format!("{name} = {v}"));
            }
        };
        number("packing_fraction", self.packing_fraction);
        number("reduced_pressure", self.reduced_pressure);
        number("time", self.time);
        number("collisions_per_particle", self.collisions_per_particle);
        number("gap", self.gap);
        for (name, flag) in [("full_size", self.full_size), ("max_gap", self.max_gap)] {
            if flag == Some(true) {
                parts.push(format!("{name} = true"));
            }
        }
        parts.join(", ")
    }
}

/// Growth protocol names.
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq, Eq)]
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
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
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
    /// With `until.gap`: the gap kept between the grains and the walls (mm), in `[0, gap/2]`
    /// (default `gap/2`); the same as `wall_gap_fraction = wall_gap / gap`.
    pub wall_gap: Option<f64>,
    /// In a gap stage (`until.gap` or `until.max_gap`): the gap kept to the walls as a
    /// fraction `λ` of the gap Δd between grains, in `[0, 1/2]` (default 1/2: each grain
    /// keeps its half of the gap to the walls too; 0: grains may touch the walls). The walls
    /// see every grain grow at `2λ` times the pair rate, so the wall gap is `λ·Δd(t)` at
    /// every time, and `λ·Δd_max` for `max_gap`.
    pub wall_gap_fraction: Option<f64>,
    /// A rate that falls as the reduced pressure rises (jamming and Δd maximisation):
    /// `rate·(onset_pressure/Z)^exponent` above `onset_pressure`, never below `min_rate`;
    /// set at every time barrier. Goals: `reduced_pressure`, `max_gap` or
    /// `collisions_per_particle` (a fraction, time or gap goal needs a known rate).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub adaptive: Option<AdaptiveSpec>,
}

/// The pressure-adaptive rate of a stage (the runner, `crate::run`, makes it the kernel's
/// `PressureAdaptive` rate schedule).
#[derive(Clone, Copy, Debug, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct AdaptiveSpec {
    /// Reduced pressure above which the rate falls, in `[1, 1e12]`.
    pub onset_pressure: f64,
    /// Exponent of the fall, in `(0, 4]`.
    pub exponent: f64,
    /// Smallest rate, in `(0, rate]` and within the allowed range of rates.
    pub min_rate: f64,
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

/// Most particles a scene may hold: the kernel indexes particles with `u32` and reserves
/// `u32::MAX` as "no particle".
pub const MAX_PARTICLES: usize = u32::MAX as usize - 1;

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

/// Allowed temperature `kT`. Time runs in units of `ℓ·√(m/kT)`: `kT` sets only the thermal
/// speed `√(kT/m)` against the growth rates, so a stage needs about `√kT` times the events it
/// needs at `kT = 1` to grow as far (measured: 100 spheres jammed at rate 0.1 in 43 000
/// events at `kT = 1` had reached φ = 0.51 only after 14 M events at `kT = 10⁸`). Within
/// `[10⁻⁶, 10⁶]` a run stays within 10³ of that effort, and every speed, energy and virial
/// far inside `f64`; beyond it, the same run is a lower or higher rate at `kT = 1`.
pub const TEMPERATURE_RANGE: [f64; 2] = [1e-6, 1e6];

/// Allowed growth rate per unit time, relative (`growth = "relative"`, 1/time) or in smallest
/// diameters (`growth = "absolute"`, length/time divided by the smallest diameter).
/// Above 10⁶ the growth outruns the thermal motion by so much that the packing no longer
/// changes (measured: 100 spheres jam at φ 0.612–0.621 for every rate from 10⁴ to 10¹⁵⁰);
/// near 10¹⁵⁴ the squares of the speeds overflow `f64` and the run stalls or hangs (10³⁰⁸).
/// Below 10⁻⁶ a radius gains less than a millionth per unit time: the run needs more than
/// 10⁴ times the events of the usual rates (10⁻²) to grow as far.
pub const RATE_RANGE: [f64; 2] = [1e-6, 1e6];

/// Allowed `events_per_particle_per_interval`. A stage checks its goals and limits only at
/// time barriers, and an interval ends early only after 16 times its planned events: at
/// 10³⁰⁰ a jamming run never reached a barrier (measured: 11 M events for 100 spheres until
/// its wall-clock limit stopped it). 1–16 were measured (BENCHMARKS.md, "Defaults"); the range
/// leaves two to three orders of magnitude either side.
pub const EVENTS_PER_INTERVAL_RANGE: [f64; 2] = [1e-2, 1e3];

/// Longest wall-clock limit (seconds) a scene or option may give: about 31 years. Durations
/// are converted to the platform's clock, which panics beyond ~5.8·10¹¹ years (`Duration`)
/// and overflows far earlier when added to the current instant.
pub const MAX_WALL_SECONDS: f64 = 1e9;

/// A number as a message shows it: plainly between 10⁻⁴ and 10⁶, else in exponent form
/// (`1e308`, not 309 digits).
fn show(x: f64) -> String {
    if x == 0.0 || !x.is_finite() || (1e-4..1e6).contains(&x.abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A wall-clock limit in `(0, MAX_WALL_SECONDS]`.
pub fn wall_seconds(field: &str, x: f64) -> Result<(), SceneError> {
    if x.is_finite() && x > 0.0 && x <= MAX_WALL_SECONDS {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!(
                "= {} is outside the allowed range (0, {MAX_WALL_SECONDS:e}] seconds",
                show(x)
            ),
        ))
    }
}

/// A value in `[lo, hi]`, naming the field and the range with `reason` when it is not.
fn within(field: &str, x: f64, [lo, hi]: [f64; 2], reason: &str) -> Result<(), SceneError> {
    if x.is_finite() && x >= lo && x <= hi {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!(
                "= {} is outside the allowed range [{lo:e}, {hi:e}]{reason}",
                show(x)
            ),
        ))
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

/// The parser's message, plus the lines of an unknown key: inside a tagged table (such as
/// `[container]`) the parser can only point at the table's header.
fn locate_unknown_key(text: &str, error: toml::de::Error) -> String {
    let message = error.to_string();
    let Some(key) = message
        .split("unknown field `")
        .nth(1)
        .and_then(|rest| rest.split('`').next())
    else {
        return message;
    };
    let lines: Vec<String> = text
        .lines()
        .enumerate()
        .filter(|(_, line)| {
            line.trim_start()
                .strip_prefix(key)
                .is_some_and(|rest| rest.trim_start().starts_with('='))
        })
        .map(|(k, _)| (k + 1).to_string())
        .collect();
    if lines.is_empty() {
        message
    } else {
        format!("{message}(`{key}` is on line {})\n", lines.join(", "))
    }
}

/// Densest possible packing fraction of equal spheres (Kepler, fcc/hcp): no monodisperse
/// scene can grow past it, which bounds the largest diameter a growth run can reach.
pub const KEPLER_FRACTION: f64 = 0.740_480_489_693_061;

impl Scene {
    /// Parses a scene from TOML text and validates it; a relative `particles.from` is
    /// relative to the working directory.
    pub fn from_toml(text: &str) -> Result<Self, SceneError> {
        Self::from_toml_at(text, None)
    }

    /// Parses a scene from the TOML text of a file in directory `base` and validates it:
    /// a relative `particles.from` is made relative to `base` (written into the scene, so
    /// that provenance and checkpoints name the file read).
    pub fn from_toml_at(text: &str, base: Option<&std::path::Path>) -> Result<Self, SceneError> {
        let mut scene: Scene =
            toml::from_str(text).map_err(|e| SceneError::Parse(locate_unknown_key(text, e)))?;
        if let (Some(base), Some(from)) = (base, &scene.particles.from) {
            if std::path::Path::new(from).is_relative() {
                scene.particles.from = Some(base.join(from).to_string_lossy().into_owned());
            }
        }
        scene.validate()?;
        Ok(scene)
    }

    /// The spheres of `particles.from`, read and checked against the scene: a sphere
    /// packing in the scene's container (same kind, periodic axes and size to 10⁻⁹
    /// relative; its origin may differ), centres moved to the scene container's frame.
    /// `None` without `from`. Whether the spheres overlap is the run's check (the
    /// independent one of `crate::verify`), not the schema's.
    pub fn start_packing(&self) -> Result<Option<StartPacking>, SceneError> {
        use crate::io::packing::{ContainerRecord, Packing, ParticleRecord};
        let Some(from) = &self.particles.from else {
            return Ok(None);
        };
        let bad = |message: String| invalid("particles.from", format!("{from}: {message}"));
        let packing = Packing::read(std::path::Path::new(from)).map_err(|e| bad(e.to_string()))?;
        let close =
            |a: f64, b: f64| (a - b).abs() <= START_CONTAINER_TOLERANCE * a.abs().max(b.abs());
        let origin = match (&self.container, &packing.container) {
            (
                ContainerSpec::Box { size, periodic, .. },
                ContainerRecord::Box {
                    min,
                    max,
                    periodic: file_periodic,
                },
            ) => {
                if periodic != file_periodic {
                    return Err(bad(format!(
                        "its box has periodic = {file_periodic:?}, the scene's container \
                         {periodic:?}"
                    )));
                }
                for k in 0..3 {
                    if !close(size[k], max[k] - min[k]) {
                        return Err(bad(format!(
                            "its box is {:?} long, the scene's container.size is {size:?}",
                            [max[0] - min[0], max[1] - min[1], max[2] - min[2]]
                        )));
                    }
                }
                *min
            }
            (
                ContainerSpec::Cylinder { radius, height, .. },
                ContainerRecord::Cylinder {
                    base_center,
                    radius: r,
                    height: h,
                },
            ) => {
                if !close(*radius, *r) || !close(*height, *h) {
                    return Err(bad(format!(
                        "its cylinder has radius {r} and height {h}, the scene's {radius} and \
                         {height}"
                    )));
                }
                *base_center
            }
            _ => {
                return Err(bad(
                    "its container is not of the scene's kind (box or cylinder)".into(),
                ))
            }
        };
        let mut start = StartPacking {
            centres: Vec::with_capacity(packing.particles.len()),
            radii: Vec::with_capacity(packing.particles.len()),
        };
        for (i, p) in packing.particles.iter().enumerate() {
            let ParticleRecord::Sphere(sphere) = p else {
                return Err(bad(format!(
                    "particle {i} is not a sphere (a scene starts from spheres only)"
                )));
            };
            let (center, radius) = (&sphere.center, &sphere.radius);
            start
                .centres
                .push(std::array::from_fn(|k| center[k] - origin[k]));
            start.radii.push(*radius);
        }
        if start.radii.is_empty() {
            return Err(bad("it has no particles".into()));
        }
        Ok(Some(start))
    }

    /// The take phase of a graded scene (`None` for explicit diameters).
    pub fn take_phase(&self) -> Option<Result<TakePhase, SceneError>> {
        let p = &self.particles;
        let spec = p.grading.as_ref()?;
        Some((|| {
            let curve = spec
                .build()
                .map_err(|e| invalid("particles.grading", e.to_string()))?;
            let d_min = p
                .d_min
                .ok_or_else(|| invalid("particles.d_min", "is required with `grading`"))?;
            positive("particles.d_min", d_min)?;
            let volume = self.container_volume();
            let field = |e: &TakeError| match e {
                TakeError::CutOff { .. } | TakeError::CutOffBelowTable { .. } => "particles.d_min",
                TakeError::EffectiveFraction(_) => "particles.effective_fraction",
                TakeError::MixtureFraction(_) => "particles.mixture_fraction",
                _ => "particles.grading",
            };
            let take =
                match (p.mixture_fraction, p.effective_fraction) {
                    (Some(phi_m), None) => TakePhase::new(
                        &curve,
                        TakeParams {
                            volume,
                            phi_m,
                            d_min,
                        },
                    ),
                    (None, Some(phi_eff)) => {
                        TakePhase::for_effective_fraction(&curve, volume, phi_eff, d_min)
                    }
                    _ => return Err(invalid(
                        "particles.mixture_fraction",
                        "give exactly one of `mixture_fraction` (φ_M) and `effective_fraction` \
                         (φ_eff) with `grading`",
                    )),
                };
            take.map_err(|e| invalid(field(&e), e.to_string()))
        })())
    }

    /// The particles' true diameters: as written, or drawn from the grading curve with `rng`
    /// (largest first). The scene must be valid.
    pub fn true_diameters<R: Rng + ?Sized>(&self, rng: &mut R) -> Vec<f64> {
        let p = &self.particles;
        debug_assert!(
            p.from.is_none(),
            "the sizes of `from` are the start packing's"
        );
        if let Some(take) = self.take_phase() {
            return take.expect("a validated scene").sample(rng);
        }
        match &p.components {
            Some(cs) => cs
                .iter()
                .flat_map(|c| std::iter::repeat_n(c.diameter, c.count))
                .collect(),
            None => vec![p.diameter.unwrap_or(0.0); p.count.unwrap_or(0)],
        }
    }

    /// The factor from true to seeding diameters: `particles.seed_scale`, or the one that
    /// gives `particles.packing_fraction`, or the default (0.9 when the first stage grows to
    /// `full_size`, paper 001 §6.2; else 1).
    pub fn seed_scale(&self, true_diameters: &[f64]) -> f64 {
        let p = &self.particles;
        if let Some(phi) = p.packing_fraction {
            return (phi * self.container_volume() / sphere_volume(true_diameters)).cbrt();
        }
        p.seed_scale.unwrap_or(
            if self.method == Method::Edmd
                && self
                    .stages
                    .first()
                    .is_some_and(|s| s.until.full_size == Some(true))
            {
                DEFAULT_SEED_SCALE
            } else {
                1.0
            },
        )
    }

    /// Number of particles as written (saturating; validation bounds it by
    /// [`MAX_PARTICLES`]), or `None` for a grading curve, whose count is drawn, and for a
    /// scene that starts from a packing file (`particles.from`).
    pub fn particle_count(&self) -> Option<usize> {
        let p = &self.particles;
        if p.grading.is_some() || p.from.is_some() {
            return None;
        }
        Some(match &p.components {
            Some(cs) => cs.iter().fold(0usize, |sum, c| sum.saturating_add(c.count)),
            None => p.count.unwrap_or(0),
        })
    }

    /// Estimated peak memory of the run in bytes ([`crate::memory`]), and how it was formed.
    /// A grading curve counts its expected number of grains plus four standard deviations.
    /// The scene must be valid.
    pub fn memory_estimate(&self) -> (u64, String) {
        let count = match self.particle_count() {
            Some(n) => n as f64,
            // A scene that starts from a packing has the file's count (read again here).
            None if self.particles.from.is_some() => self
                .start_packing()
                .ok()
                .flatten()
                .map_or(0.0, |s| s.radii.len() as f64),
            None => self.take_phase().and_then(Result::ok).map_or(0.0, |t| {
                let s = t.summary();
                s.expected_count + 4.0 * s.count_std_dev
            }),
        };
        let (each, kind) = if self.particles.ellipsoid.is_some() {
            (EllipsoidSpec::BYTES_PER_PARTICLE, "ellipsoids")
        } else {
            (crate::memory::SPHERE_BYTES, "spheres")
        };
        (
            crate::memory::estimate(count, each),
            format!(
                "{count:.4e} {kind} × {each} B + {} for the process",
                crate::memory::human(crate::memory::BASE_BYTES)
            ),
        )
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

    /// Index of the stage that opens a gap (`until.gap` or `until.max_gap`), if any. It is
    /// always the last stage.
    pub fn gap_stage(&self) -> Option<usize> {
        self.stages.iter().position(StageSpec::opens_gap)
    }
}

/// Seeding scale `δ` of paper 001, §6.2: spheres are seeded at 90 % of their diameter and
/// grown back.
pub const DEFAULT_SEED_SCALE: f64 = 0.9;

impl StageSpec {
    /// Whether this stage opens a gap between the particles (`until.gap` or `max_gap`).
    pub fn opens_gap(&self) -> bool {
        self.until.gap.is_some() || self.until.max_gap.is_some()
    }

    /// The gap a gap stage keeps to the walls as a fraction `λ` of the gap between grains:
    /// `wall_gap_fraction`, or `wall_gap / gap`, or 1/2.
    pub fn wall_gap_fraction(&self) -> f64 {
        match (self.wall_gap_fraction, self.wall_gap, self.until.gap) {
            (Some(x), _, _) => x,
            (None, Some(w), Some(g)) => w / g,
            _ => 0.5,
        }
    }
}

/// Any scene file: a sphere scene or a mixture scene (it has a `[mixture]` table).
#[derive(Clone, Debug, PartialEq)]
pub enum AnyScene {
    /// Growing spheres (EDMD).
    Spheres(Box<Scene>),
    /// Spheres + cylinders.
    Mixture(Box<MixtureScene>),
}

impl AnyScene {
    /// Estimated peak memory of the run in bytes, and how it was formed.
    pub fn memory_estimate(&self) -> (u64, String) {
        match self {
            AnyScene::Spheres(s) => s.memory_estimate(),
            AnyScene::Mixture(m) => m.memory_estimate(),
        }
    }

    /// Parses and validates either kind of scene.
    pub fn from_toml(text: &str) -> Result<Self, SceneError> {
        Self::from_toml_at(text, None)
    }

    /// Parses and validates either kind of scene from the text of a file in directory
    /// `base` (see [`Scene::from_toml_at`]).
    pub fn from_toml_at(text: &str, base: Option<&std::path::Path>) -> Result<Self, SceneError> {
        let table: toml::Table =
            toml::from_str(text).map_err(|e| SceneError::Parse(e.to_string()))?;
        if table.contains_key("mixture") {
            Ok(AnyScene::Mixture(Box::new(MixtureScene::from_toml(text)?)))
        } else {
            Ok(AnyScene::Spheres(Box::new(Scene::from_toml_at(
                text, base,
            )?)))
        }
    }
}
