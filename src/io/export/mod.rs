//! Exports of a packing for meshing, visualisation and FFT homogenisation.
//!
//! | format | file | reader it is checked with (CI) |
//! |---|---|---|
//! | `gmsh` | `.geo` script, OpenCASCADE kernel ([`gmsh`]) | Gmsh meshes it in 3D |
//! | `vtk` | `.vtu` XML unstructured grid of points with per-particle attributes, binary and zlib-compressed, and the container's surface in `NAME.container.vtu` ([`vtk`]) | meshio |
//! | `vti` | `.vti` VTK XML image data of the voxel image, binary, zlib-compressed ([`vti`]) | the VTK Python package |
//! | `abaqus` | `.inp` Abaqus voxel model: C3D8R elements, element sets per phase (and particle), face node sets ([`abaqus`]) | meshio |
//! | `npy` | `.npy` voxel label image + `FILE.json` sidecar ([`voxel`]) | numpy |
//! | `raw` | raw voxel label image + `FILE.json` sidecar ([`voxel`]) | numpy |
//! | `csv` | `.csv`, one row per particle ([`csv`]) | numpy |
//! | `xyzd` | PackingGeneration's binary `x y z d` doubles, spheres ([`xyzd`]) | numpy |
//! | `lammps` | LAMMPS data file, atom style sphere ([`lammps`]) | numpy |
//!
//! Exporters never match on a particle's kind: what a format needs of a particle (its
//! bounding sphere, containment, CSV row, Gmsh solid, VTK point data) is a method of
//! [`ParticleRecord`], implemented once per kind in [`crate::io::record`]. Only the formats
//! defined for spheres (xyzd, LAMMPS) ask for the sphere variant.
//! All files are written through [`write_atomically`]: an existing file is never left
//! half-written. Lengths keep the packing's unit.

pub mod abaqus;
pub mod csv;
pub mod gmsh;
pub mod lammps;
pub mod voxel;
pub mod vti;
pub mod vtk;
pub mod xyzd;

use crate::io::packing::{write_atomically, ContainerRecord, Packing, ParticleRecord};
use std::path::Path;

/// Why an export failed.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// An option is out of range for this packing (names the option).
    #[error("{option}: {message}")]
    Invalid {
        /// The option, as spelled on the command line.
        option: &'static str,
        /// What is wrong and what is allowed.
        message: String,
    },
    /// Writing failed.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The cause.
        source: std::io::Error,
    },
}

/// An export format (the `--format` of `densepack export`, the `format` of the Python
/// `Packing.export`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// Gmsh `.geo` script ([`gmsh`]).
    Gmsh,
    /// VTK `.vtu` points with per-particle attributes ([`vtk`]).
    Vtk,
    /// VTK `.vti` image data of the voxel image ([`vti`]).
    Vti,
    /// Abaqus `.inp` voxel model ([`abaqus`]).
    Abaqus,
    /// Voxel image `.npy` with a `FILE.json` sidecar ([`voxel`]).
    Npy,
    /// Voxel image as raw bytes with a `FILE.json` sidecar ([`voxel`]).
    Raw,
    /// CSV table, one row per particle ([`csv`]).
    Csv,
    /// PackingGeneration's binary `.xyzd`, spheres ([`xyzd`]).
    Xyzd,
    /// LAMMPS data file, atom style sphere ([`lammps`]).
    Lammps,
}

impl Format {
    /// Every format, in the order the help lists them.
    pub const ALL: [Format; 9] = [
        Format::Gmsh,
        Format::Vtk,
        Format::Vti,
        Format::Abaqus,
        Format::Npy,
        Format::Raw,
        Format::Csv,
        Format::Xyzd,
        Format::Lammps,
    ];

    /// The format's name (lower case, as on the command line).
    pub fn name(self) -> &'static str {
        match self {
            Format::Gmsh => "gmsh",
            Format::Vtk => "vtk",
            Format::Vti => "vti",
            Format::Abaqus => "abaqus",
            Format::Npy => "npy",
            Format::Raw => "raw",
            Format::Csv => "csv",
            Format::Xyzd => "xyzd",
            Format::Lammps => "lammps",
        }
    }

    /// One line for people: what the format writes (the CLI's `--help` lists it).
    pub fn describe(self) -> &'static str {
        match self {
            Format::Gmsh => {
                "Gmsh `.geo` script (OpenCASCADE): physical volumes matrix, aggregates (per kind, or \
                 per particle with --labels particle)[, interface], surfaces xmin … zmax"
            }
            Format::Vtk => "VTK `.vtu` points with radius, semi_axes, orientation (ParaView glyphs)",
            Format::Vti => {
                "VTK `.vti` image data of the voxel image (binary, zlib), for FFT solvers and ParaView"
            }
            Format::Abaqus => {
                "Abaqus `.inp` voxel model: C3D8R elements, an element set per phase (per particle \
                 with --labels particle), node sets XMIN … ZMAX"
            }
            Format::Npy => "Voxel label image as `.npy`, with a `FILE.json` sidecar",
            Format::Raw => "Voxel label image as raw bytes, with a `FILE.json` sidecar",
            Format::Csv => "CSV table: `x,y,z,r` for spheres, 15 columns with other shapes",
            Format::Xyzd => {
                "PackingGeneration's binary `.xyzd` (little-endian doubles x y z d), spheres"
            }
            Format::Lammps => {
                "LAMMPS data file, atom style sphere (id type diameter density x y z), spheres"
            }
        }
    }

    /// The format called `name`; the error lists the formats.
    pub fn parse(name: &str) -> Result<Self, ExportError> {
        Self::ALL
            .into_iter()
            .find(|f| f.name() == name)
            .ok_or_else(|| ExportError::Invalid {
                option: "--format",
                message: format!(
                    "= {name:?} is not a format; the formats are {}",
                    Self::ALL.map(Format::name).join(", ")
                ),
            })
    }

    /// Whether the format writes the voxel image (and takes the voxel options).
    pub fn uses_voxels(self) -> bool {
        matches!(
            self,
            Format::Npy | Format::Raw | Format::Vti | Format::Abaqus
        )
    }

    /// Whether the format writes a `FILE.json` sidecar beside the file.
    pub fn has_sidecar(self) -> bool {
        matches!(self, Format::Npy | Format::Raw)
    }

    /// The extension the file must have, for formats whose readers go by it.
    fn required_extension(self) -> Option<&'static str> {
        match self {
            Format::Vtk => Some("vtu"),
            Format::Vti => Some("vti"),
            Format::Abaqus => Some("inp"),
            _ => None,
        }
    }
}

/// Options of [`export`]. Each applies to some formats only; `None` (or the default) means
/// not given, and a given option the format does not use is an error naming it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExportOptions {
    /// Voxel formats (`npy`, `raw`, `vti`, `abaqus`): voxels along the longest container
    /// edge (default 128).
    pub voxels: Option<usize>,
    /// Voxel formats: what a voxel holds (default [`voxel::Labels::Phase`]). Gmsh: the
    /// physical volumes of the particles, per kind ([`voxel::Labels::Phase`], the default)
    /// or per particle ([`voxel::Labels::Particle`]).
    pub labels: Option<voxel::Labels>,
    /// Gmsh: thickness of interface shells around the particles.
    pub interface: Option<f64>,
    /// Gmsh: largest element size (default half the mean radius).
    pub mesh_size: Option<f64>,
    /// Gmsh: relative radius reduction in `[0, 1)` before export (default 0).
    pub shrink: Option<f64>,
}

/// Voxels along the longest edge when [`ExportOptions::voxels`] is not given.
pub const DEFAULT_VOXELS: usize = 128;

/// What [`export`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub enum Exported {
    /// A Gmsh script.
    Gmsh(gmsh::GmshReport),
    /// A voxel image (`npy` and `raw` with a sidecar, `vti`, `abaqus`).
    Voxels(voxel::VoxelSummary),
    /// The particles' `.vtu` and the container's beside it ([`vtk::container_path`]).
    Vtk {
        /// The container's file.
        container: std::path::PathBuf,
    },
    /// A file with nothing further to report (CSV, xyzd, LAMMPS).
    File,
}

/// Writes `packing` to `path` in `format` (atomically). `check_surfaces` is the independent
/// overlap check a Gmsh export runs on the surfaces it writes (see [`gmsh::write_geo`]; the
/// callers pass `crate::verify::surface_check`); the other formats do not call it.
pub fn export(
    packing: &Packing,
    format: Format,
    options: &ExportOptions,
    check_surfaces: &dyn Fn(&Packing) -> gmsh::SurfaceCheck,
    path: &Path,
) -> Result<Exported, ExportError> {
    let only = |option: &'static str, formats: &str| ExportError::Invalid {
        option,
        message: format!("only applies to --format {formats}"),
    };
    if format != Format::Gmsh {
        for (given, option) in [
            (options.interface.is_some(), "--interface"),
            (options.mesh_size.is_some(), "--mesh-size"),
            (options.shrink.is_some(), "--shrink"),
        ] {
            if given {
                return Err(only(option, "gmsh"));
            }
        }
    }
    if !format.uses_voxels() {
        if options.voxels.is_some() {
            return Err(only("--voxels", "npy, raw, vti or abaqus"));
        }
        match (format, options.labels) {
            (_, None) | (Format::Gmsh, Some(voxel::Labels::Phase | voxel::Labels::Particle)) => {}
            (Format::Gmsh, Some(voxel::Labels::PartialVolume(_))) => {
                return Err(only("--partial-volume", "npy, raw, vti or abaqus"))
            }
            (_, Some(_)) => {
                return Err(only(
                    "--labels/--partial-volume",
                    "npy, raw, vti, abaqus or gmsh (--labels only)",
                ))
            }
        }
    }
    if let Some(extension) = format.required_extension() {
        if path.extension().and_then(|e| e.to_str()) != Some(extension) {
            return Err(ExportError::Invalid {
                option: "--out",
                message: format!(
                    "--format {} needs the extension .{extension} (readers go by it)",
                    format.name()
                ),
            });
        }
    }
    let voxels = options.voxels.unwrap_or(DEFAULT_VOXELS);
    let labels = options.labels.unwrap_or(voxel::Labels::Phase);
    match format {
        Format::Gmsh => gmsh::write_geo(
            packing,
            &gmsh::GmshOptions {
                interface_thickness: options.interface,
                mesh_size: options.mesh_size,
                shrink: options.shrink.unwrap_or(0.0),
                groups: match options.labels {
                    Some(voxel::Labels::Particle) => gmsh::GmshGroups::ByParticle,
                    _ => gmsh::GmshGroups::ByKind,
                },
            },
            check_surfaces,
            path,
        )
        .map(Exported::Gmsh),
        Format::Vtk => vtk::write_vtu(packing, path).map(|container| Exported::Vtk { container }),
        Format::Csv => csv::write_csv(packing, path).map(|()| Exported::File),
        Format::Xyzd => xyzd::write_xyzd(packing, path).map(|()| Exported::File),
        Format::Lammps => lammps::write_data(packing, path).map(|()| Exported::File),
        Format::Vti => vti::write_vti(packing, voxels, labels, path).map(Exported::Voxels),
        Format::Abaqus => abaqus::write_inp(packing, voxels, labels, path).map(Exported::Voxels),
        Format::Npy | Format::Raw => voxel::write_voxels(
            packing,
            &voxel::VoxelOptions {
                voxels,
                labels,
                npy: format == Format::Npy,
            },
            path,
        )
        .map(Exported::Voxels),
    }
}

/// The centres and radii of a packing of spheres; any other particle is an error naming
/// the first one and the format (`name`) that takes spheres only.
pub(crate) fn spheres(packing: &Packing, name: &str) -> Result<Vec<([f64; 3], f64)>, ExportError> {
    packing
        .particles
        .iter()
        .enumerate()
        .map(|(i, p)| match p {
            ParticleRecord::Sphere(s) => Ok((s.center, s.radius)),
            _ => Err(ExportError::Invalid {
                option: "--format",
                message: format!(
                    "{name} takes spheres only, and particle {i} is of kind {}",
                    p.kind()
                ),
            }),
        })
        .collect()
}

/// Writes `path` atomically with `fill`, mapping I/O errors to [`ExportError::Io`].
pub(crate) fn write_file(
    path: &Path,
    fill: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> std::io::Result<()>,
) -> Result<(), ExportError> {
    write_atomically(path, fill).map_err(|source| ExportError::Io {
        path: path.display().to_string(),
        source,
    })
}

/// Axis-aligned bounding box `(lower, upper)` of a container.
pub fn container_bounds(c: &ContainerRecord) -> ([f64; 3], [f64; 3]) {
    match c {
        ContainerRecord::Box { min, max, .. } => (*min, *max),
        ContainerRecord::Cylinder {
            base_center: b,
            radius,
            height,
        } => (
            [b[0] - radius, b[1] - radius, b[2]],
            [b[0] + radius, b[1] + radius, b[2] + height],
        ),
    }
}

/// Volume of a container.
pub fn container_volume(c: &ContainerRecord) -> f64 {
    match c {
        ContainerRecord::Box { min, max, .. } => (0..3).map(|k| max[k] - min[k]).product(),
        ContainerRecord::Cylinder { radius, height, .. } => {
            std::f64::consts::PI * radius * radius * height
        }
    }
}

/// Periodic axes of a container (none for a cylinder).
pub fn periodic_axes(c: &ContainerRecord) -> [bool; 3] {
    match c {
        ContainerRecord::Box { periodic, .. } => *periodic,
        ContainerRecord::Cylinder { .. } => [false; 3],
    }
}

/// Exact packing fraction of the written particles: Σ particle volume / container volume.
pub fn packing_fraction(packing: &Packing) -> f64 {
    packing
        .particles
        .iter()
        .map(ParticleRecord::volume)
        .sum::<f64>()
        / container_volume(&packing.container)
}

/// One line naming the producer, for the header of every export.
pub fn provenance_line(packing: &Packing) -> String {
    format!(
        "densepack {} export of a packing of {} particles (seed {}, packing fraction {:.6})",
        env!("CARGO_PKG_VERSION"),
        packing.particles.len(),
        packing.seed,
        packing_fraction(packing)
    )
}
