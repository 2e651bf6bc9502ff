//! The packing JSON file (`"format": "densepack-packing"`, version 1), read by other tools.
//!
//! ```json
//! {"format": "densepack-packing", "version": 1,
//!  "container": {"type": "box", "min": [0,0,0], "max": [10,10,10], "periodic": [true,true,true]},
//!  "particles": [{"type": "sphere", "center": [1.0, 2.0, 3.0], "radius": 0.5},
//!                {"type": "cylinder", "center": [5.0, 5.0, 5.0], "radius": 0.3,
//!                 "half_axis": [0.0, 0.0, 1.5]}],
//!  "min_gap": 0.0, "seed": 42,   // optional "wall_gap" (default min_gap / 2)
//!  "stats": {"packing_fraction": 0.64, "reduced_pressure": 1e12, "events": 1, "collisions": 1,
//!            "wall_seconds": 0.1, "stop_reason": "pressure_reached"}}
//! ```
//! Floats are written with full round-trip precision (shortest representation that parses
//! back to the same `f64`); periodic centres are wrapped into the box.

use super::record::placed;
pub use super::record::ParticleRecord;
use serde::{Deserialize, Serialize};
use std::path::Path;

/// The container of a packing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "lowercase", deny_unknown_fields)]
pub enum ContainerRecord {
    /// Axis-aligned box, periodic or walled per axis.
    Box {
        /// Lower corner.
        min: [f64; 3],
        /// Upper corner.
        max: [f64; 3],
        /// Periodic axes.
        periodic: [bool; 3],
    },
    /// Cylinder with its axis along z.
    Cylinder {
        /// Centre of the bottom cap.
        base_center: [f64; 3],
        /// Radius.
        radius: f64,
        /// Height.
        height: f64,
    },
}

impl ContainerRecord {
    /// Whether the container is a body of positive, finite size: a box with finite corners and
    /// `max > min` on every axis, a cylinder with a finite base centre and a finite radius and
    /// height > 0. The error names the offending field (`container.max[1]`) and what it must
    /// be; every volume, wall distance and minimum image of the checks assumes this.
    pub fn check(&self) -> Result<(), String> {
        match self {
            Self::Box { min, max, .. } => {
                for k in 0..3 {
                    for (name, v) in [("min", min[k]), ("max", max[k])] {
                        if !v.is_finite() {
                            return Err(format!("container.{name}[{k}] = {v} must be finite"));
                        }
                    }
                    // Negated: a box of zero or negative extent is refused, and one whose
                    // extent overflows (every cell and image count would be infinite).
                    if !(max[k] > min[k] && (max[k] - min[k]).is_finite()) {
                        return Err(format!(
                            "container.max[{k}] = {} must be > container.min[{k}] = {} \
                             (a box of positive, finite extent)",
                            max[k], min[k]
                        ));
                    }
                }
                Ok(())
            }
            Self::Cylinder {
                base_center,
                radius,
                height,
            } => {
                if let Some(k) = (0..3).find(|&k| !base_center[k].is_finite()) {
                    return Err(format!(
                        "container.base_center[{k}] = {} must be finite",
                        base_center[k]
                    ));
                }
                // The diameter must be finite too (the bounding box's extent).
                for (name, v) in [("radius", 2.0 * radius), ("height", *height)] {
                    if !(v.is_finite() && v > 0.0) {
                        let v = if name == "radius" { *radius } else { v };
                        return Err(format!(
                            "container.{name} = {v} must be a finite number > 0 \
                             (a cylinder of finite size)"
                        ));
                    }
                }
                // Its bounding box must not reach past the largest finite number either
                // (every cell count of the checks would be infinite).
                let reach = [
                    base_center[0] - radius,
                    base_center[0] + radius,
                    base_center[1] - radius,
                    base_center[1] + radius,
                    base_center[2] + height,
                ];
                if reach.iter().any(|x| !x.is_finite()) {
                    return Err(format!(
                        "container.base_center = {base_center:?} with radius {radius:?} and height \
                         {height:?} reaches beyond ±{:e} (a cylinder of finite extent)",
                        f64::MAX
                    ));
                }
                Ok(())
            }
        }
    }

    /// The container in another frame: every length `x` becomes `scale(x)` and every point
    /// `p` becomes `origin + scale(p)` (`scale`: a change of unit, or the identity).
    pub fn in_frame(self, origin: [f64; 3], scale: impl Fn(f64) -> f64) -> Self {
        match self {
            Self::Box { min, max, periodic } => Self::Box {
                min: placed(min, origin, &scale),
                max: placed(max, origin, &scale),
                periodic,
            },
            Self::Cylinder {
                base_center,
                radius,
                height,
            } => Self::Cylinder {
                base_center: placed(base_center, origin, &scale),
                radius: scale(radius),
                height: scale(height),
            },
        }
    }
}

/// Run statistics stored with a packing (every field may be absent: packings of other tools
/// read with zeros, `null` and an empty stop reason).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct PackingStats {
    /// Packing fraction of the written particles.
    pub packing_fraction: f64,
    /// Reduced pressure `PV/NkT` (time average for equilibrium runs, last interval for
    /// growth); `null` when no dynamics ran (random sequential addition).
    pub reduced_pressure: Option<f64>,
    /// Processed events.
    pub events: u64,
    /// Pair collisions.
    pub collisions: u64,
    /// Wall-clock seconds of the simulation.
    pub wall_seconds: f64,
    /// Why the last stage stopped.
    pub stop_reason: String,
    /// Further observables (collisions per particle, events by kind, events per second,
    /// per-stage reports).
    #[serde(flatten)]
    pub extra: serde_json::Map<String, serde_json::Value>,
}

/// A packing file.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Packing {
    /// Always `"densepack-packing"`.
    pub format: String,
    /// Format version, 1.
    pub version: u32,
    /// The container.
    pub container: ContainerRecord,
    /// The particles.
    pub particles: Vec<ParticleRecord>,
    /// Guaranteed smallest surface-to-surface gap between particles (absent: 0, no gap
    /// promised beyond not overlapping).
    #[serde(default)]
    pub min_gap: f64,
    /// Guaranteed smallest gap between a particle's surface and a wall; absent means
    /// `min_gap / 2`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wall_gap: Option<f64>,
    /// Seed of the run (absent: 0).
    #[serde(default)]
    pub seed: u64,
    /// Statistics (absent: empty).
    #[serde(default)]
    pub stats: PackingStats,
    /// Where the packing came from (absent in files written by other tools).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<Provenance>,
}

/// Where a packing came from: the program, the resolved scene and seed (which reproduce the
/// particles exactly with the same version), and where the time went.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// Version of densepack that wrote the packing.
    pub densepack_version: String,
    /// Git commit densepack was built from, when it was built in a git checkout (absent
    /// otherwise, and in packings of versions before 0.2.0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub git_commit: Option<String>,
    /// Seed of the run.
    pub seed: u64,
    /// The scene with every default filled in (JSON form of the TOML schema).
    pub scene: serde_json::Value,
    /// Wall-clock timings.
    pub timings: Timings,
    /// When the run finished (or the import was made), seconds since the Unix epoch.
    pub finished_unix_seconds: u64,
    /// The foreign file the particles were imported from (`densepack import`); absent for
    /// packings densepack made.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub imported_from: Option<ImportedFrom>,
}

/// The file a packing was imported from ([`crate::io::import`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ImportedFrom {
    /// The file name (without its directory).
    pub file: String,
    /// The format it was read as (`csv`, `xyzd`, `lammps-data`, `lammps-dump`, `json`).
    pub format: String,
}

impl Provenance {
    /// The provenance of a packing made now by this build of densepack: `scene` (the
    /// resolved scene, `null` for an import), `seed` and `timings`; not imported.
    pub fn new(scene: serde_json::Value, seed: u64, timings: Timings) -> Self {
        Provenance {
            densepack_version: env!("CARGO_PKG_VERSION").into(),
            // Set by build.rs when built in a git checkout.
            git_commit: option_env!("DENSEPACK_GIT_COMMIT").map(Into::into),
            seed,
            scene,
            timings,
            finished_unix_seconds: std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_secs()),
            imported_from: None,
        }
    }
}

/// Wall-clock seconds of the phases of a run (all 0 for an import).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Timings {
    /// Seeding (random sequential addition).
    pub seeding_seconds: f64,
    /// All stages of the simulation.
    pub stages_seconds: f64,
    /// Independent verification.
    pub verification_seconds: f64,
}

/// Format name written into every packing.
pub const FORMAT: &str = "densepack-packing";

/// Errors reading or writing a packing file.
#[derive(Debug, thiserror::Error)]
pub enum PackingError {
    /// I/O failure.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
    /// Not a valid packing file.
    #[error("{path}: not a densepack packing: {message}")]
    Format {
        /// The file.
        path: String,
        /// What is wrong.
        message: String,
    },
}

impl Packing {
    /// A packing of `particles` in `container` with no gap promise, seed 0, empty statistics
    /// and no provenance; fill in the rest with struct update syntax.
    pub fn new(container: ContainerRecord, particles: Vec<ParticleRecord>) -> Self {
        Self {
            format: FORMAT.into(),
            version: 1,
            container,
            particles,
            min_gap: 0.0,
            wall_gap: None,
            seed: 0,
            stats: PackingStats::default(),
            provenance: None,
        }
    }

    /// The gap promised between particles and walls: `wall_gap`, or half of `min_gap`.
    pub fn wall_gap(&self) -> f64 {
        self.wall_gap.unwrap_or(0.5 * self.min_gap)
    }

    /// Whether the file is well formed enough to be checked: a valid container
    /// ([`ContainerRecord::check`]) and gap claims that are finite and ≥ 0 (`min_gap`,
    /// `wall_gap`). A negative claim is not a weaker promise but a malformed file: the
    /// overlap check never depends on it. The error names the field and its allowed range.
    pub fn check(&self) -> Result<(), String> {
        self.container.check()?;
        for (name, v) in [("min_gap", Some(self.min_gap)), ("wall_gap", self.wall_gap)] {
            if let Some(v) = v {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(format!(
                        "{name} = {v} must be a finite number ≥ 0 (a gap the particles keep)"
                    ));
                }
            }
        }
        Ok(())
    }

    /// Reads and checks a packing file.
    pub fn read(path: &Path) -> Result<Self, PackingError> {
        let text = std::fs::read_to_string(path).map_err(|source| PackingError::Io {
            path: path.display().to_string(),
            source,
        })?;
        Self::from_json(&text, &path.display().to_string())
    }

    /// Parses and checks the text of a packing file; `path` names it in errors.
    pub fn from_json(text: &str, path: &str) -> Result<Self, PackingError> {
        let format_err = |message: String| PackingError::Format {
            path: path.to_string(),
            message,
        };
        let packing: Packing = serde_json::from_str(text).map_err(|e| format_err(e.to_string()))?;
        if packing.format != FORMAT || packing.version != 1 {
            return Err(format_err(format!(
                "format {:?} version {} (expected {FORMAT:?} version 1)",
                packing.format, packing.version
            )));
        }
        packing.check().map_err(format_err)?;
        Ok(packing)
    }

    /// Writes the packing pretty-printed (one field per line, indented; measured 181 bytes per
    /// sphere (10 000 jammed spheres), 408 per ellipsoid (3000)), atomically: streamed to a temporary file beside `path`,
    /// then renamed, so an existing file is never left half-written and no copy of the whole
    /// text is held in memory.
    pub fn write(&self, path: &Path) -> Result<(), PackingError> {
        self.write_json(path, true)
    }

    /// Writes the packing like [`Packing::write`] but compact: one line, no indentation
    /// (113 bytes per sphere, 255 per ellipsoid, for the packings above; the same JSON
    /// value).
    pub fn write_compact(&self, path: &Path) -> Result<(), PackingError> {
        self.write_json(path, false)
    }

    fn write_json(&self, path: &Path, pretty: bool) -> Result<(), PackingError> {
        write_atomically(path, |w| {
            if pretty {
                serde_json::to_writer_pretty(&mut *w, self)
            } else {
                serde_json::to_writer(&mut *w, self)
            }
            .map_err(std::io::Error::other)
        })
        .map_err(|source| PackingError::Io {
            path: path.display().to_string(),
            source,
        })
    }
}

/// Writes to `path` through a temporary file in the same directory and a rename; `fill`
/// writes the content. On any error the temporary file is removed and `path` is untouched.
pub fn write_atomically(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> std::io::Result<()> {
    use std::io::Write;
    let dir = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| "packing".into());
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let result = (|| {
        let mut w = std::io::BufWriter::new(std::fs::File::create(&tmp)?);
        fill(&mut w)?;
        w.flush()?;
        w.get_ref().sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
