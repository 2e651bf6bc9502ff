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

use crate::protocol::take_phase::{GradingSpec, TakeError, TakeParams, TakePhase};
use crate::queue::QueueKind;
use crate::shape::{MassRule, Predictor, CONTACT_TOLERANCE, MAX_CONTACT_TOLERANCE};
use crate::tuning::{
    DEFAULT_EVENTS_PER_INTERVAL, DEFAULT_NEIGHBOUR_SKIN, DEFAULT_TEMPERATURE, MAX_SKIN,
};
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
}

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
    /// Parses a scene from TOML text and validates it.
    pub fn from_toml(text: &str) -> Result<Self, SceneError> {
        let scene: Scene =
            toml::from_str(text).map_err(|e| SceneError::Parse(locate_unknown_key(text, e)))?;
        scene.validate()?;
        Ok(scene)
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
    /// [`MAX_PARTICLES`]), or `None` for a grading curve, whose count is drawn.
    pub fn particle_count(&self) -> Option<usize> {
        let p = &self.particles;
        if p.grading.is_some() {
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
            None => self.take_phase().and_then(Result::ok).map_or(0.0, |t| {
                let s = t.summary();
                s.expected_count + 4.0 * s.count_std_dev
            }),
        };
        let (each, kind) = if self.particles.ellipsoid.is_some() {
            (crate::memory::ELLIPSOID_BYTES, "ellipsoids")
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

    /// Checks every field against its allowed range.
    pub fn validate(&self) -> Result<(), SceneError> {
        within(
            "temperature",
            self.temperature,
            TEMPERATURE_RANGE,
            ": kT only sets the thermal speed against the growth rates (time is in units of \
             ℓ·√(m/kT)); a run at kT = 10⁸ needs 10⁴ times the events of kT = 1. Keep kT = 1 \
             and scale the rates instead",
        )?;
        within(
            "events_per_particle_per_interval",
            self.events_per_particle_per_interval,
            EVENTS_PER_INTERVAL_RANGE,
            ": goals are checked at time barriers, and an interval of more events reaches \
             them too late (default 4)",
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
        let (smallest_extent, periodic_extent) = self.validate_container()?;
        let sizes = self.validate_particles()?;
        if sizes.count > MAX_PARTICLES as f64 {
            return Err(invalid(
                "particles",
                format!(
                    "{:.4e} particles in all: more than {MAX_PARTICLES} (the kernel's index range)",
                    sizes.count
                ),
            ));
        }
        let container = self.container_volume();
        let p = &self.particles;
        if p.packing_fraction.is_some() && p.seed_scale.is_some() {
            return Err(invalid(
                "particles.seed_scale",
                "give either `seed_scale` or `packing_fraction`, not both",
            ));
        }
        if let Some(phi) = p.packing_fraction {
            fraction("particles.packing_fraction", phi)?;
        } else if sizes.volume / container >= 1.0 {
            return Err(invalid(
                "particles",
                format!(
                    "the spheres fill {:.3} of the container; the packing fraction must be < 1",
                    sizes.volume / container
                ),
            ));
        }
        if let Some(x) = p.seed_scale {
            if !(x.is_finite() && x > 0.0 && x <= 1.0) {
                return Err(invalid(
                    "particles.seed_scale",
                    format!("= {x} is outside the allowed range (0, 1]"),
                ));
            }
        }
        let scale = match p.packing_fraction {
            Some(phi) => (phi * container / sizes.volume).cbrt(),
            None => p.seed_scale.unwrap_or(1.0),
        };
        let seeded_phi = sizes.volume * scale.powi(3) / container;
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
        let rsa_gap = p.gap.unwrap_or(0.0);
        if let Some(g) = p.gap {
            if self.method != Method::Rsa {
                return Err(invalid(
                    "particles.gap",
                    "applies to method = \"rsa\"; with EDMD open a gap with a stage \
                     `until = { gap = .. }`",
                ));
            }
            if !(g.is_finite() && g >= 0.0) {
                return Err(invalid("particles.gap", format!("= {g} must be ≥ 0")));
            }
        }
        if let Some(w) = p.wall_gap {
            let Some(g) = p.gap else {
                return Err(invalid(
                    "particles.wall_gap",
                    "applies only with `particles.gap`",
                ));
            };
            if !(w.is_finite() && (0.0..=0.5 * g).contains(&w)) {
                return Err(invalid(
                    "particles.wall_gap",
                    format!(
                        "= {w} is outside the allowed range [0, gap/2 = {}]",
                        0.5 * g
                    ),
                ));
            }
        }
        let d_seed = sizes.d_max * scale;
        if d_seed + rsa_gap >= smallest_extent {
            return Err(invalid(
                "particles",
                format!(
                    "the largest sphere (diameter {d_seed}{}) does not fit the container \
                     (smallest extent {smallest_extent})",
                    if rsa_gap > 0.0 {
                        format!(" plus the gap {rsa_gap}")
                    } else {
                        String::new()
                    }
                ),
            ));
        }
        if rsa_gap > 0.0 {
            let inflated =
                sizes.count * std::f64::consts::PI / 6.0 * (sizes.d_min + rsa_gap).powi(3);
            if inflated >= container {
                return Err(invalid(
                    "particles.gap",
                    format!(
                        "= {rsa_gap}: {:.0} spheres of at least {} plus the gap cannot fit the \
                         container; lower the gap",
                        sizes.count, sizes.d_min
                    ),
                ));
            }
        }
        let final_diameter = self.validate_stages(&sizes, scale, container)?;
        if let Some(e) = &self.particles.ellipsoid {
            let grows = self.stages.iter().any(|s| s.growth != GrowthKind::None);
            self.validate_ellipsoids(
                e,
                d_seed,
                smallest_extent,
                periodic_extent,
                seeded_phi,
                grows,
            )?;
        }
        // Minimum image needs every contact distance below half the periodic box length.
        if periodic_extent.is_finite()
            && 2.0 * final_diameter.max(d_seed + rsa_gap) >= periodic_extent
        {
            let d = final_diameter.max(d_seed + rsa_gap);
            return Err(invalid(
                "container.size",
                format!(
                    "a periodic box edge must exceed twice the largest diameter the run can \
                     reach ({d:.4}); give at least {:.4} or use more, smaller particles",
                    2.0 * d
                ),
            ));
        }
        Ok(())
    }

    /// Checks the container; returns its smallest extent and smallest periodic edge.
    fn validate_container(&self) -> Result<(f64, f64), SceneError> {
        let extents = match &self.container {
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
                Ok((smallest, periodic_min))
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
                Ok(((2.0 * radius).min(*height), f64::INFINITY))
            }
        }?;
        let volume = self.container_volume();
        if !(volume.is_finite() && volume > 0.0) {
            return Err(invalid(
                "container",
                format!("its volume ({volume}) must be a finite number > 0"),
            ));
        }
        Ok(extents)
    }

    /// Checks the particle description; returns its nominal sizes (expected ones for a
    /// grading curve).
    fn validate_particles(&self) -> Result<NominalSizes, SceneError> {
        let p = &self.particles;
        if p.rsa_max_failures == 0 {
            return Err(invalid("particles.rsa_max_failures", "= 0 must be ≥ 1"));
        }
        let graded = p.grading.is_some();
        if !graded
            && (p.mixture_fraction.is_some() || p.effective_fraction.is_some() || p.d_min.is_some())
        {
            let field = if p.d_min.is_some() {
                "particles.d_min"
            } else if p.effective_fraction.is_some() {
                "particles.effective_fraction"
            } else {
                "particles.mixture_fraction"
            };
            return Err(invalid(field, "applies only with `grading`"));
        }
        match (&p.components, p.count, p.diameter, graded) {
            (None, None, None, true) => {
                let take = self.take_phase().expect("graded")?;
                let summary = take.summary();
                Ok(NominalSizes {
                    count: summary.expected_count,
                    d_min: summary.smallest_diameter,
                    d_max: summary.largest_diameter,
                    volume: summary.aggregate_volume,
                })
            }
            (Some(cs), None, None, false) => {
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
                let diameters: Vec<f64> = cs.iter().map(|c| c.diameter).collect();
                Ok(NominalSizes {
                    count: cs.iter().map(|c| c.count as f64).sum(),
                    d_min: diameters.iter().copied().fold(f64::INFINITY, f64::min),
                    d_max: diameters.iter().copied().fold(0.0, f64::max),
                    volume: cs
                        .iter()
                        .map(|c| c.count as f64 * sphere_volume(&[c.diameter]))
                        .sum(),
                })
            }
            (None, Some(count), Some(d), false) => {
                if count == 0 {
                    return Err(invalid("particles.count", "= 0 must be ≥ 1"));
                }
                positive("particles.diameter", d)?;
                Ok(NominalSizes {
                    count: count as f64,
                    d_min: d,
                    d_max: d,
                    volume: count as f64 * sphere_volume(&[d]),
                })
            }
            _ => Err(invalid(
                "particles",
                "give exactly one of: `count` and `diameter`; `components`; or `grading` \
                 with `mixture_fraction` and `d_min`",
            )),
        }
    }

    /// Checks the stages; returns the largest diameter the run can reach (for the
    /// minimum-image bound of periodic boxes).
    fn validate_stages(
        &self,
        sizes: &NominalSizes,
        scale: f64,
        container: f64,
    ) -> Result<f64, SceneError> {
        if self.method == Method::Rsa {
            if !self.stages.is_empty() {
                return Err(invalid(
                    "stage",
                    "method = \"rsa\" takes no stages (the seeding is the packing)",
                ));
            }
            return Ok(sizes.d_max * scale);
        }
        if self.stages.is_empty() {
            return Err(invalid("stage", "at least one [[stage]] is required"));
        }
        // Upper bound on any gap: N spheres of at least d_min + Δd must fit the volume.
        let gap_bound =
            (6.0 * container / (std::f64::consts::PI * sizes.count)).cbrt() - sizes.d_min;
        let seeded_phi = sizes.volume * scale.powi(3) / container;
        let equal_spheres = sizes.d_min == sizes.d_max && self.particles.ellipsoid.is_none();
        let mut final_diameter = sizes.d_max * scale;
        let mut at_true_size = scale == 1.0;
        let last = self.stages.len() - 1;
        for (k, s) in self.stages.iter().enumerate() {
            let f = |name: &str| format!("stage[{k}].{name}");
            match (s.growth, s.rate) {
                (GrowthKind::None, Some(_)) => {
                    return Err(invalid(f("rate"), "is not allowed with growth = \"none\""))
                }
                (GrowthKind::None, None) => {}
                (_, None) => return Err(invalid(f("rate"), "is required when the particles grow")),
                (GrowthKind::Relative, Some(r)) => within(
                    &f("rate"),
                    r,
                    RATE_RANGE,
                    " per unit time (relative growth): faster growth leaves the packing \
                     unchanged and overflows the speeds, slower growth cannot finish",
                )?,
                (GrowthKind::Absolute, Some(r)) => {
                    // In smallest diameters per unit time, so that a scene in other units
                    // (every length ×10^k) has the same range.
                    let [lo, hi] = RATE_RANGE.map(|x| x * sizes.d_min);
                    if !(r.is_finite() && r >= lo && r <= hi) {
                        return Err(invalid(
                            f("rate"),
                            format!(
                                "= {} is outside the allowed range [{lo:e}, {hi:e}] lengths \
                                 per unit time (absolute growth: {:e} to {:e} times the \
                                 smallest diameter {}): faster growth leaves the packing \
                                 unchanged and overflows the speeds, slower growth cannot finish",
                                show(r),
                                RATE_RANGE[0],
                                RATE_RANGE[1],
                                sizes.d_min
                            ),
                        ));
                    }
                }
            }
            if let Some(a) = &s.adaptive {
                let rate = s
                    .rate
                    .filter(|_| s.growth != GrowthKind::None)
                    .ok_or_else(|| {
                        invalid(f("adaptive"), "needs a growing stage (growth and rate)")
                    })?;
                within(
                    &f("adaptive.onset_pressure"),
                    a.onset_pressure,
                    [1.0, 1e12],
                    "",
                )?;
                if !(a.exponent > 0.0 && a.exponent <= 4.0) {
                    return Err(invalid(
                        f("adaptive.exponent"),
                        format!("= {} is outside the allowed range (0, 4]", show(a.exponent)),
                    ));
                }
                if !(a.min_rate > 0.0 && a.min_rate <= rate) {
                    return Err(invalid(
                        f("adaptive.min_rate"),
                        format!(
                            "= {} is outside the allowed range (0, rate = {}]",
                            show(a.min_rate),
                            show(rate)
                        ),
                    ));
                }
                let u = &s.until;
                if u.packing_fraction.is_some()
                    || u.time.is_some()
                    || u.full_size.is_some()
                    || u.gap.is_some()
                {
                    return Err(invalid(
                        f("adaptive"),
                        "applies to goals reduced_pressure, max_gap and \
                         collisions_per_particle: a packing fraction, time or gap goal is \
                         placed with a fixed rate",
                    ));
                }
            }
            let u = &s.until;
            if u.packing_fraction.is_none()
                && u.reduced_pressure.is_none()
                && u.time.is_none()
                && u.collisions_per_particle.is_none()
                && u.full_size.is_none()
                && u.gap.is_none()
                && u.max_gap.is_none()
            {
                return Err(invalid(
                    f("until"),
                    "needs a goal: packing_fraction, reduced_pressure, time, \
                     collisions_per_particle, full_size, gap or max_gap",
                ));
            }
            for (name, flag) in [("full_size", u.full_size), ("max_gap", u.max_gap)] {
                if flag == Some(false) {
                    return Err(invalid(
                        f(&format!("until.{name}")),
                        "= false is not a goal; remove it or set it to true",
                    ));
                }
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
                wall_seconds(&f("max_wall_seconds"), x)?;
            }
            if s.max_events == Some(0) {
                return Err(invalid(f("max_events"), "= 0 must be ≥ 1"));
            }
            if let Some(x) = s.stall_epsilon {
                if !(x.is_finite() && x >= 0.0) {
                    return Err(invalid(f("stall_epsilon"), format!("= {x} must be ≥ 0")));
                }
            }
            if !s.opens_gap() {
                for (key, given) in [
                    ("wall_gap", s.wall_gap.is_some()),
                    ("wall_gap_fraction", s.wall_gap_fraction.is_some()),
                ] {
                    if given {
                        return Err(invalid(
                            f(key),
                            "applies only to a gap stage (`until.gap` or `until.max_gap`)",
                        ));
                    }
                }
            }
            if u.full_size.is_some() {
                if s.growth != GrowthKind::Relative {
                    return Err(invalid(
                        f("until.full_size"),
                        "needs growth = \"relative\" (all sizes reach their target together, \
                         Eq. 30)",
                    ));
                }
                if u.packing_fraction.is_some() {
                    return Err(invalid(
                        f("until.full_size"),
                        "give either `full_size` or `packing_fraction`",
                    ));
                }
                at_true_size = true;
                final_diameter = final_diameter.max(sizes.d_max);
            }
            if s.opens_gap() {
                let field = f(if u.gap.is_some() {
                    "until.gap"
                } else {
                    "until.max_gap"
                });
                if u.gap.is_some() && u.max_gap.is_some() {
                    return Err(invalid(field, "give either `gap` or `max_gap`"));
                }
                if s.growth != GrowthKind::Absolute {
                    return Err(invalid(
                        field,
                        "needs growth = \"absolute\" (every radius gains the same, Eq. 31)",
                    ));
                }
                if k != last {
                    return Err(invalid(field, "must be the goal of the last stage"));
                }
                if !at_true_size {
                    return Err(invalid(
                        field,
                        "needs the spheres at their true sizes: put a stage with \
                         `until = { full_size = true }` before it, or seed at true size \
                         (seed_scale = 1, no packing_fraction)",
                    ));
                }
                if u.packing_fraction.is_some() || u.full_size.is_some() {
                    return Err(invalid(
                        field,
                        "cannot be combined with packing_fraction or full_size",
                    ));
                }
                if let Some(x) = s.wall_gap_fraction {
                    if s.wall_gap.is_some() {
                        return Err(invalid(
                            f("wall_gap_fraction"),
                            "give either `wall_gap` or `wall_gap_fraction`",
                        ));
                    }
                    if !(x.is_finite() && (0.0..=0.5).contains(&x)) {
                        return Err(invalid(
                            f("wall_gap_fraction"),
                            format!("= {x} is outside the allowed range [0, 0.5]"),
                        ));
                    }
                }
                if let Some(w) = s.wall_gap {
                    let Some(g) = u.gap else {
                        return Err(invalid(
                            f("wall_gap"),
                            "is a length and applies with `until.gap`; with `max_gap` the \
                             gap is not known in advance: give `wall_gap_fraction` in \
                             [0, 0.5] (wall gap / Δd) instead",
                        ));
                    };
                    if !(w.is_finite() && (0.0..=0.5 * g).contains(&w)) {
                        return Err(invalid(
                            f("wall_gap"),
                            format!(
                                "= {w} is outside the allowed range [0, gap/2 = {}]",
                                0.5 * g
                            ),
                        ));
                    }
                }
                let gap = match u.gap {
                    Some(g) => {
                        positive(&field, g)?;
                        if g >= gap_bound {
                            return Err(invalid(
                                field,
                                format!(
                                    "= {g} cannot be reached: {:.0} spheres of at least {:.4} \
                                     plus the gap would overfill the container (gap < {:.4}); \
                                     lower the gap or the mixture fraction",
                                    sizes.count,
                                    sizes.d_min,
                                    gap_bound.max(0.0)
                                ),
                            ));
                        }
                        g
                    }
                    None => gap_bound.max(0.0),
                };
                final_diameter = final_diameter.max(sizes.d_max + gap);
            } else if s.growth != GrowthKind::None && u.full_size.is_none() {
                // Growth to a fraction, or to jamming (bounded by the Kepler fraction for
                // equal spheres; polydisperse scenes by the same scale, an estimate).
                let phi = u.packing_fraction.unwrap_or(KEPLER_FRACTION);
                at_true_size = false;
                final_diameter = final_diameter
                    .max(sizes.d_max * scale * (phi.max(seeded_phi) / seeded_phi).cbrt());
            }
        }
        Ok(final_diameter)
    }
}

/// Seeding scale `δ` of paper 001, §6.2: spheres are seeded at 90 % of their diameter and
/// grown back.
pub const DEFAULT_SEED_SCALE: f64 = 0.9;

/// Count, extreme diameters and total volume of a scene's spheres at their true sizes
/// (expected values for a grading curve).
struct NominalSizes {
    count: f64,
    d_min: f64,
    d_max: f64,
    volume: f64,
}

impl Scene {
    /// Ellipsoid-specific checks: a box container, and bounding spheres (the largest
    /// semi-axis) that fit the box and stay below a periodic edge up to the densest fraction
    /// the stages can reach.
    fn validate_ellipsoids(
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

// ------------------------------------------------------------------ sphere + cylinder mixtures

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
        let table: toml::Table =
            toml::from_str(text).map_err(|e| SceneError::Parse(e.to_string()))?;
        if table.contains_key("mixture") {
            Ok(AnyScene::Mixture(Box::new(MixtureScene::from_toml(text)?)))
        } else {
            Ok(AnyScene::Spheres(Box::new(Scene::from_toml(text)?)))
        }
    }
}
