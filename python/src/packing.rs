//! `Packing` (a packing file in memory, its arrays, verification, exports, voxels) and the
//! take phase (`take`).

use crate::{os_error, value_error};
use densepack::io::export::{self, voxel, ExportError, ExportOptions, Exported, Format};
use densepack::io::packing::{Packing as Record, ParticleRecord};
use densepack::io::record::{CylinderRecord, EllipsoidRecord, SphereRecord};
use densepack::protocol::take_phase::{GradingSpec, TakeParams, TakePhase};
use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use rand::SeedableRng;
use std::path::PathBuf;

/// A packing: the container, the particles and how they were made (the CLI's packing JSON).
/// Arrays are new numpy copies on every access. Immutable and picklable.
#[pyclass(module = "densepack._densepack", frozen)]
pub struct Packing {
    pub(crate) packing: Record,
}

/// NaN, for array entries a particle kind does not have.
const NAN: f64 = f64::NAN;

impl Packing {
    /// One row of three per particle, from `row`.
    fn rows<'py>(
        &self,
        py: Python<'py>,
        width: usize,
        row: impl Fn(&ParticleRecord) -> Vec<f64>,
    ) -> Bound<'py, PyArray2<f64>> {
        let n = self.packing.particles.len();
        let data: Vec<f64> = self.packing.particles.iter().flat_map(row).collect();
        Array2::from_shape_vec((n, width), data)
            .expect("every row has `width` entries")
            .into_pyarray(py)
    }
}

#[pymethods]
impl Packing {
    /// Reads a packing JSON (as `densepack run` writes it). `OSError` when the file cannot
    /// be read, `ValueError` when it is not a densepack packing.
    #[staticmethod]
    fn load(path: PathBuf) -> PyResult<Self> {
        let text = std::fs::read_to_string(&path)
            .map_err(|e| os_error(format!("{}: {e}", path.display())))?;
        Self::from_json(&text, &path.display().to_string())
    }

    /// A packing read from another tool's file: `source` is `"csv"`, `"xyzd"`,
    /// `"lammps-data"`, `"lammps-dump"` or `"json"` (as `densepack import --from`). Give the
    /// container where the file has none: `box=(x, y, z)` (lower corner at the origin,
    /// `periodic=(bool, bool, bool)`) or `cylinder=(radius, height)`. The packing promises no
    /// gap (`min_gap` 0): `verify()` checks overlaps and containment. `ValueError` names the
    /// line and field of a malformed file, `OSError` when it cannot be read.
    #[staticmethod]
    #[pyo3(signature = (path, source, *, r#box=None, cylinder=None, periodic=None))]
    fn import_file(
        py: Python<'_>,
        path: PathBuf,
        source: &str,
        r#box: Option<Vec<f64>>,
        cylinder: Option<Vec<f64>>,
        periodic: Option<Vec<bool>>,
    ) -> PyResult<Self> {
        use densepack::io::import::{import, ImportError, ImportOptions, Source};
        let python_names = |e: ImportError| match e {
            ImportError::Io { .. } => os_error(e),
            ImportError::Invalid { option, message } => value_error(format!(
                "{}: {message}",
                match option {
                    "--from" => "source",
                    other => other.trim_start_matches("--"),
                }
            )),
            other => value_error(other),
        };
        let source = Source::parse(source).map_err(python_names)?;
        let options =
            ImportOptions::of_specimen(r#box.as_deref(), cylinder.as_deref(), periodic.as_deref())
                .map_err(python_names)?;
        py.detach(|| import(&path, source, &options))
            .map(|packing| Self { packing })
            .map_err(python_names)
    }

    /// Writes the packing JSON atomically (the same bytes the CLI writes: floats round-trip
    /// exactly).
    fn save(&self, path: PathBuf) -> PyResult<()> {
        self.packing.write(&path).map_err(os_error)
    }

    /// A packing from its JSON text (`name` labels errors).
    #[staticmethod]
    #[pyo3(signature = (text, name = "<json>"))]
    fn from_json(text: &str, name: &str) -> PyResult<Self> {
        Record::from_json(text, name)
            .map(|packing| Self { packing })
            .map_err(value_error)
    }

    /// The packing JSON text.
    fn to_json(&self) -> PyResult<String> {
        serde_json::to_string_pretty(&self.packing).map_err(value_error)
    }

    fn __len__(&self) -> usize {
        self.packing.particles.len()
    }

    fn __repr__(&self) -> String {
        format!(
            "<densepack.Packing {} particles, packing fraction {:.6}, min gap {:.4e}, seed {}>",
            self.packing.particles.len(),
            self.packing_fraction(),
            self.packing.min_gap,
            self.packing.seed
        )
    }

    /// Pickles as its JSON text.
    fn __reduce__<'py>(slf: &Bound<'py, Self>) -> PyResult<(Bound<'py, PyAny>, (String,))> {
        let from_json = slf.get_type().getattr("from_json")?;
        Ok((from_json, (slf.get().to_json()?,)))
    }

    /// Centres, shape (N, 3).
    #[getter]
    fn centers<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        self.rows(py, 3, |p| p.center().to_vec())
    }

    /// Radii, shape (N,): of a sphere; of a cylinder's cross-section; of the sphere of equal
    /// volume for an ellipsoid, (a·b·c)^(1/3).
    #[getter]
    fn radii<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        let r: Vec<f64> = self
            .packing
            .particles
            .iter()
            .map(|p| match p {
                ParticleRecord::Sphere(SphereRecord { radius, .. })
                | ParticleRecord::Cylinder(CylinderRecord { radius, .. }) => *radius,
                ParticleRecord::Ellipsoid(EllipsoidRecord { semi_axes: a, .. }) => {
                    (a[0] * a[1] * a[2]).cbrt()
                }
            })
            .collect();
        PyArray1::from_vec(py, r)
    }

    /// Semi-axes along the body axes, shape (N, 3): (r, r, r) for a sphere, NaN for a
    /// cylinder (and other kinds).
    #[getter]
    fn semi_axes<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        self.rows(py, 3, |p| match p {
            ParticleRecord::Sphere(SphereRecord { radius, .. }) => vec![*radius; 3],
            ParticleRecord::Ellipsoid(EllipsoidRecord { semi_axes, .. }) => semi_axes.to_vec(),
            _ => vec![NAN; 3],
        })
    }

    /// Orientations as unit quaternions [w, x, y, z] rotating the body frame into the
    /// world frame, shape (N, 4): the identity for spheres, NaN for cylinders (their axis
    /// is `half_axes`) and other kinds.
    #[getter]
    fn orientations<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        self.rows(py, 4, |p| match p {
            ParticleRecord::Sphere(_) => vec![1.0, 0.0, 0.0, 0.0],
            ParticleRecord::Ellipsoid(EllipsoidRecord { orientation, .. }) => orientation.to_vec(),
            _ => vec![NAN; 4],
        })
    }

    /// Half axes of cylinders (centre to the centre of an end disk), shape (N, 3); NaN for
    /// the other kinds.
    #[getter]
    fn half_axes<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        self.rows(py, 3, |p| match p {
            ParticleRecord::Cylinder(CylinderRecord { half_axis, .. }) => half_axis.to_vec(),
            _ => vec![NAN; 3],
        })
    }

    /// Particle kinds, shape (N,), strings `"sphere"`, `"ellipsoid"`, `"cylinder"`.
    #[getter]
    fn kinds<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let names: Vec<&str> = self
            .packing
            .particles
            .iter()
            .map(ParticleRecord::kind)
            .collect();
        py.import("numpy")?.call_method1("asarray", (names,))
    }

    /// The container as a dict (`type` "box" with `min`, `max`, `periodic`, or "cylinder"
    /// with `base_center`, `radius`, `height`).
    #[getter]
    fn container<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(pythonize::pythonize(py, &self.packing.container)?)
    }

    /// Run statistics (packing fraction, reduced pressure, events, stage reports, ...).
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(pythonize::pythonize(py, &self.packing.stats)?)
    }

    /// Where the packing came from (version, git commit, the full scene, timings), or None.
    #[getter]
    fn provenance<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        Ok(pythonize::pythonize(py, &self.packing.provenance)?)
    }

    /// Guaranteed smallest surface-to-surface gap between particles (scene length unit).
    #[getter]
    fn min_gap(&self) -> f64 {
        self.packing.min_gap
    }

    /// Seed of the run.
    #[getter]
    fn seed(&self) -> u64 {
        self.packing.seed
    }

    /// Packing fraction recomputed from the particles: Σ volume / container volume.
    #[getter]
    fn packing_fraction(&self) -> f64 {
        export::packing_fraction(&self.packing)
    }

    /// The independent overlap, gap and containment check (`densepack verify --json`):
    /// a dict with `ok` and the report.
    fn verify<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let packing = &self.packing;
        let v = py.detach(|| densepack::verify::verify(packing));
        let report = pythonize::pythonize(py, &v)?;
        report.set_item("ok", v.ok())?;
        Ok(report)
    }

    /// Writes the packing as `format` (`gmsh`, `vtk`, `vti`, `abaqus`, `npy`, `raw`, `csv`,
    /// `xyzd`, `lammps`: the formats of `densepack export`, with its options as keywords:
    /// `voxels`, `labels` ("phase" or "particle"; voxel formats, and gmsh: physical volumes
    /// per kind or per particle), `partial_volume` (samples per axis; voxel formats),
    /// `interface`, `mesh_size`, `shrink` (gmsh)). An option the format does not use raises
    /// `ValueError` naming it. Returns a dict of what was written.
    #[pyo3(signature = (path, format, *, voxels=None, labels=None, partial_volume=None,
                        interface=None, mesh_size=None, shrink=None))]
    #[expect(
        clippy::too_many_arguments,
        reason = "the keywords of one Python method"
    )]
    fn export<'py>(
        &self,
        py: Python<'py>,
        path: PathBuf,
        format: &str,
        voxels: Option<usize>,
        labels: Option<&str>,
        partial_volume: Option<usize>,
        interface: Option<f64>,
        mesh_size: Option<f64>,
        shrink: Option<f64>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let format = Format::parse(format).map_err(export_error)?;
        let labels = match (labels, partial_volume) {
            (Some(_), Some(_)) => {
                return Err(value_error(
                    "labels, partial_volume: give one (partial volumes replace labels)",
                ))
            }
            (Some(l), None) => Some(labels_of(l)?),
            (None, Some(samples)) => Some(voxel::Labels::PartialVolume(samples)),
            (None, None) => None,
        };
        let options = ExportOptions {
            voxels,
            labels,
            interface,
            mesh_size,
            shrink,
        };
        let packing = &self.packing;
        let exported = py
            .detach(|| {
                export::export(
                    packing,
                    format,
                    &options,
                    &densepack::verify::surface_check,
                    &path,
                )
            })
            .map_err(export_error)?;
        let report = PyDict::new(py);
        report.set_item("path", &path)?;
        report.set_item("format", format.name())?;
        match exported {
            Exported::Gmsh(r) => {
                report.set_item("mesh_size", r.mesh_size)?;
                report.set_item("narrowest_gap", r.narrowest_gap)?;
            }
            Exported::Voxels(s) => {
                for (key, value) in pythonize::pythonize(py, &s)?.cast::<PyDict>()?.iter() {
                    report.set_item(key, value)?;
                }
            }
            Exported::Vtk { container } => {
                report.set_item("container_path", container)?;
            }
            Exported::File => {}
        }
        Ok(report.into_any())
    }

    /// The voxel image in memory, shape (nx, ny, nz) with `n` voxels along the longest
    /// container edge: `labels="phase"` (uint8: 0 matrix, 1 sphere, 2 ellipsoid,
    /// 3 cylinder, 255 outside a cylinder container), `"particle"` (uint32: particle index
    /// + 1), or `partial_volume=S` (float32 solid fraction from S³ sample points). The grid
    /// is `voxel_grid(n)`.
    #[pyo3(signature = (n, labels = "phase", *, partial_volume = None))]
    fn voxels<'py>(
        &self,
        py: Python<'py>,
        n: usize,
        labels: &str,
        partial_volume: Option<usize>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let grid = voxel::Grid::new(&self.packing.container, n).map_err(export_error)?;
        let labels = match partial_volume {
            Some(samples) => voxel::Labels::PartialVolume(samples),
            None => labels_of(labels)?,
        };
        let packing = &self.packing;
        let image = py
            .detach(|| voxel::VoxelImage::of(packing, &grid, labels))
            .map_err(export_error)?;
        let shape = grid.shape;
        Ok(match image {
            voxel::VoxelImage::Phase(v) => image_array(py, v, shape)?.into_any(),
            voxel::VoxelImage::Particle(v) => image_array(py, v, shape)?.into_any(),
            voxel::VoxelImage::PartialVolume { fractions, .. } => {
                image_array(py, fractions, shape)?.into_any()
            }
        })
    }

    /// The voxel grid of `voxels(n)`: `shape`, `spacing` and `origin` (lower corner of the
    /// first voxel; voxel centres at origin + (index + 0.5)·spacing).
    fn voxel_grid<'py>(&self, py: Python<'py>, n: usize) -> PyResult<Bound<'py, PyAny>> {
        let grid = voxel::Grid::new(&self.packing.container, n).map_err(export_error)?;
        Ok(pythonize::pythonize(py, &grid)?)
    }
}

fn image_array<'py, T: numpy::Element>(
    py: Python<'py>,
    data: Vec<T>,
    shape: [usize; 3],
) -> PyResult<Bound<'py, PyArray3<T>>> {
    numpy::ndarray::Array3::from_shape_vec(shape, data)
        .map(|a| a.into_pyarray(py))
        .map_err(value_error)
}

fn labels_of(name: &str) -> PyResult<voxel::Labels> {
    match name {
        "phase" => Ok(voxel::Labels::Phase),
        "particle" => Ok(voxel::Labels::Particle),
        other => Err(value_error(format!(
            "labels = {other:?}: allowed are \"phase\" and \"particle\" (or partial_volume=S)"
        ))),
    }
}

/// An export error as a Python exception; option names lose the CLI's dashes.
fn export_error(e: ExportError) -> PyErr {
    match e {
        ExportError::Invalid { option, message } => value_error(format!(
            "{}: {message}",
            option.trim_start_matches("--").replace(['-', '/'], "_")
        )),
        ExportError::Io { .. } => os_error(e),
    }
}

/// Dry run of the concrete take phase (paper 001, Algorithm 1): the diameters drawn for
/// `seed` (numpy float64, largest classes first, mm) and the summary (expected count, φ_eff,
/// memory, ...). `grading` is a DIN 1045-2 name ("B16"), "fuller:Q:D_MAX", or a dict of the
/// scene's `particles.grading` table. Give the specimen as `box=(x, y, z)`,
/// `cylinder=(radius, height)` or `volume`.
#[pyfunction]
#[pyo3(signature = (grading, *, phi_m, d_min, r#box=None, cylinder=None, volume=None, seed=0))]
#[expect(
    clippy::too_many_arguments,
    reason = "the keywords of one Python function"
)]
pub fn take<'py>(
    py: Python<'py>,
    grading: &Bound<'py, PyAny>,
    phi_m: f64,
    d_min: f64,
    r#box: Option<[f64; 3]>,
    cylinder: Option<[f64; 2]>,
    volume: Option<f64>,
    seed: u64,
) -> PyResult<(Bound<'py, PyArray1<f64>>, Bound<'py, PyAny>)> {
    let spec = if let Ok(s) = grading.cast::<PyString>() {
        let text = s.to_cow()?;
        let text = text.as_ref();
        GradingSpec::parse_short(text)
            .ok_or_else(|| {
                value_error(format!(
                    "grading = {text:?}: not a DIN curve name (A8, B8, C8, A16, B16, C16) nor \
                     fuller:Q:D_MAX; give a table as a dict"
                ))
            })?
            .map_err(value_error)?
    } else {
        pythonize::depythonize::<GradingSpec>(grading)
            .map_err(|e| value_error(format!("grading: {e}")))?
    };
    let volume = match (r#box, cylinder, volume) {
        (Some(b), None, None) => b.iter().product(),
        (None, Some([r, h]), None) => std::f64::consts::PI * r * r * h,
        (None, None, Some(v)) => v,
        _ => {
            return Err(value_error(
                "give the specimen as exactly one of box=(x, y, z), cylinder=(radius, height) \
                 or volume (mm)",
            ))
        }
    };
    let curve = spec
        .build()
        .map_err(|e| value_error(format!("grading: {e}")))?;
    let take = TakePhase::new(
        &curve,
        TakeParams {
            volume,
            phi_m,
            d_min,
        },
    )
    .map_err(value_error)?;
    let diameters =
        py.detach(|| take.sample(&mut rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed)));
    let summary = pythonize::pythonize(py, &take.summary())?;
    summary.set_item("curve", spec.describe())?;
    Ok((PyArray1::from_vec(py, diameters), summary))
}
