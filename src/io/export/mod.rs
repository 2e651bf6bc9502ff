//! Exports of a packing for meshing, visualisation and FFT homogenisation.
//!
//! | format | file | reader it is checked with (CI) |
//! |---|---|---|
//! | `gmsh` | `.geo` script, OpenCASCADE kernel ([`gmsh`]) | Gmsh meshes it in 3D |
//! | `vtk` | `.vtu` XML unstructured grid of points with per-particle attributes ([`vtk`]) | meshio |
//! | `npy` | `.npy` voxel label image + `FILE.json` sidecar ([`voxel`]) | numpy |
//! | `raw` | raw voxel label image + `FILE.json` sidecar ([`voxel`]) | numpy |
//! | `csv` | `.csv`, one row per particle ([`csv`]) | numpy |
//!
//! Every exporter is a dispatch over [`ParticleRecord`]: a new particle shape is one match
//! arm in [`bounding_sphere`], [`contains`], and in each writer's per-particle function.
//! All files are written through [`write_atomically`]: an existing file is never left
//! half-written. Lengths keep the packing's unit.

pub mod csv;
pub mod gmsh;
pub mod voxel;
pub mod vtk;

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

/// Centre and radius of the smallest sphere around a particle that all exporters use for
/// bounding boxes (periodic images, voxel ranges).
pub fn bounding_sphere(p: &ParticleRecord) -> ([f64; 3], f64) {
    match p {
        ParticleRecord::Sphere { center, radius } => (*center, *radius),
        ParticleRecord::Cylinder {
            center,
            radius,
            half_axis,
        } => (*center, (radius * radius + norm2(half_axis)).sqrt()),
        ParticleRecord::Ellipsoid {
            center, semi_axes, ..
        } => (*center, semi_axes.iter().copied().fold(0.0, f64::max)),
    }
}

/// The rotation of an ellipsoid record (body frame to world frame).
pub(crate) fn rotation_of(orientation: &[f64; 4]) -> nalgebra::UnitQuaternion<f64> {
    let [w, x, y, z] = *orientation;
    nalgebra::UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z))
}

fn norm2(v: &[f64; 3]) -> f64 {
    v.iter().map(|x| x * x).sum()
}

/// Whether point `x` lies inside (or on) particle `p`, with the particle at its written pose
/// (no periodic wrap: the caller passes the unwrapped point).
pub fn contains(p: &ParticleRecord, x: [f64; 3]) -> bool {
    match p {
        ParticleRecord::Sphere { center, radius } => {
            let d2: f64 = (0..3).map(|k| (x[k] - center[k]).powi(2)).sum();
            d2 <= radius * radius
        }
        ParticleRecord::Cylinder {
            center,
            radius,
            half_axis,
        } => {
            // Axial coordinate t along the unit axis, radial distance² = |x − c|² − t².
            let length = norm2(half_axis).sqrt();
            let d: Vec<f64> = (0..3).map(|k| x[k] - center[k]).collect();
            let t = (0..3).map(|k| d[k] * half_axis[k]).sum::<f64>() / length;
            let radial2 = d.iter().map(|v| v * v).sum::<f64>() - t * t;
            t.abs() <= length && radial2 <= radius * radius
        }
        ParticleRecord::Ellipsoid {
            center,
            semi_axes,
            orientation,
        } => {
            // In the body frame: Σ (x_k / a_k)² ≤ 1.
            let d = nalgebra::Vector3::new(x[0] - center[0], x[1] - center[1], x[2] - center[2]);
            let body = rotation_of(orientation).inverse_transform_vector(&d);
            (0..3)
                .map(|k| (body[k] / semi_axes[k]).powi(2))
                .sum::<f64>()
                <= 1.0
        }
    }
}

/// Volume of a particle.
pub fn particle_volume(p: &ParticleRecord) -> f64 {
    match p {
        ParticleRecord::Sphere { radius, .. } => 4.0 / 3.0 * std::f64::consts::PI * radius.powi(3),
        ParticleRecord::Cylinder {
            radius, half_axis, ..
        } => std::f64::consts::PI * radius * radius * 2.0 * norm2(half_axis).sqrt(),
        ParticleRecord::Ellipsoid { semi_axes: a, .. } => {
            4.0 / 3.0 * std::f64::consts::PI * a[0] * a[1] * a[2]
        }
    }
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
    packing.particles.iter().map(particle_volume).sum::<f64>()
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
