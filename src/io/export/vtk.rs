//! VTK XML unstructured grid (`.vtu`, ASCII): one vertex cell per particle at its centre,
//! with the point data ParaView's glyph filters need.
//!
//! | point array | components | meaning |
//! |---|---|---|
//! | `radius` | 1 | radius of the bounding sphere (the radius, for a sphere) |
//! | `semi_axes` | 3 | semi-axes in the body frame (`r, r, r` for a sphere) |
//! | `orientation` | 4 | unit quaternion `w, x, y, z` body → world (`1, 0, 0, 0` for a sphere) |
//! | `shape_tensor` | 9 | `R diag(semi_axes) Rᵀ`, row-major: scale and orient a sphere glyph with ParaView's *Tensor Glyph* |
//! | `half_axis` | 3 | a cylinder's half-axis vector (centre → end-disk centre), as in the packing; `0, 0, 0` for other shapes |
//! | `shape` | 1 | shape id: 1 sphere, 2 ellipsoid, 3 cylinder (body z axis along the half axis) |
//!
//! For spheres, ParaView's *Glyph* filter with a sphere source, *Scale Array* `radius` and
//! scale factor 2 (the source has radius 0.5) draws the packing. The provenance line is an
//! XML comment at the top of the file.

use super::{provenance_line, ExportError};
use crate::io::packing::{Packing, ParticleRecord};
use std::io::Write;

/// Per-particle attributes of the point data.
struct Attributes {
    center: [f64; 3],
    radius: f64,
    semi_axes: [f64; 3],
    orientation: [f64; 4],
    shape_tensor: [f64; 9],
    half_axis: [f64; 3],
    shape: u8,
}

fn attributes(p: &ParticleRecord) -> Attributes {
    match p {
        ParticleRecord::Sphere { center, radius } => Attributes {
            center: *center,
            radius: *radius,
            semi_axes: [*radius; 3],
            orientation: [1.0, 0.0, 0.0, 0.0],
            shape_tensor: [*radius, 0.0, 0.0, 0.0, *radius, 0.0, 0.0, 0.0, *radius],
            half_axis: [0.0; 3],
            shape: 1,
        },
        ParticleRecord::Cylinder {
            center,
            radius,
            half_axis,
        } => {
            // Body frame: z along the axis. The rotation taking z to the axis, as a unit
            // quaternion [w, x, y, z], and the tensor R·diag(r, r, |l|)·Rᵀ.
            let l = nalgebra::Vector3::from(*half_axis);
            let length = l.norm();
            let rotation = nalgebra::UnitQuaternion::rotation_between(&nalgebra::Vector3::z(), &l)
                .unwrap_or_else(|| {
                    nalgebra::UnitQuaternion::from_axis_angle(
                        &nalgebra::Vector3::x_axis(),
                        std::f64::consts::PI,
                    )
                });
            let r = rotation.to_rotation_matrix();
            let tensor = r.matrix()
                * nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(
                    *radius, *radius, length,
                ))
                * r.matrix().transpose();
            let q = rotation.quaternion();
            Attributes {
                center: *center,
                radius: *radius,
                semi_axes: [*radius, *radius, length],
                orientation: [q.w, q.i, q.j, q.k],
                shape_tensor: std::array::from_fn(|k| tensor[(k / 3, k % 3)]),
                half_axis: *half_axis,
                shape: 3,
            }
        }
        ParticleRecord::Ellipsoid {
            center,
            semi_axes: a,
            orientation,
        } => {
            let r = super::rotation_of(orientation).to_rotation_matrix();
            let tensor = r.matrix()
                * nalgebra::Matrix3::from_diagonal(&nalgebra::Vector3::new(a[0], a[1], a[2]))
                * r.matrix().transpose();
            Attributes {
                center: *center,
                radius: a.iter().copied().fold(0.0, f64::max),
                semi_axes: *a,
                orientation: *orientation,
                shape_tensor: std::array::from_fn(|k| tensor[(k / 3, k % 3)]),
                half_axis: [0.0; 3],
                shape: 2,
            }
        }
    }
}

fn data_array<T: std::fmt::Display>(
    w: &mut impl Write,
    kind: &str,
    name: &str,
    components: usize,
    values: impl Iterator<Item = T>,
) -> std::io::Result<()> {
    write!(
        w,
        "        <DataArray type=\"{kind}\" Name=\"{name}\" NumberOfComponents=\"{components}\" format=\"ascii\">\n         "
    )?;
    for v in values {
        write!(w, " {v}")?;
    }
    writeln!(w, "\n        </DataArray>")
}

/// Writes the `.vtu` document to `w`.
pub fn write_vtu_to(packing: &Packing, w: &mut impl Write) -> std::io::Result<()> {
    let a: Vec<Attributes> = packing.particles.iter().map(attributes).collect();
    let n = a.len();
    writeln!(w, "<?xml version=\"1.0\"?>")?;
    writeln!(w, "<!-- {} -->", provenance_line(packing))?;
    writeln!(
        w,
        "<VTKFile type=\"UnstructuredGrid\" version=\"1.0\" byte_order=\"LittleEndian\" header_type=\"UInt64\">"
    )?;
    writeln!(w, "  <UnstructuredGrid>")?;
    writeln!(
        w,
        "    <Piece NumberOfPoints=\"{n}\" NumberOfCells=\"{n}\">"
    )?;
    writeln!(
        w,
        "      <PointData Scalars=\"radius\" Tensors=\"shape_tensor\">"
    )?;
    data_array(w, "Float64", "radius", 1, a.iter().map(|x| x.radius))?;
    data_array(
        w,
        "Float64",
        "semi_axes",
        3,
        a.iter().flat_map(|x| x.semi_axes),
    )?;
    data_array(
        w,
        "Float64",
        "orientation",
        4,
        a.iter().flat_map(|x| x.orientation),
    )?;
    data_array(
        w,
        "Float64",
        "shape_tensor",
        9,
        a.iter().flat_map(|x| x.shape_tensor),
    )?;
    data_array(
        w,
        "Float64",
        "half_axis",
        3,
        a.iter().flat_map(|x| x.half_axis),
    )?;
    data_array(w, "UInt8", "shape", 1, a.iter().map(|x| x.shape))?;
    writeln!(w, "      </PointData>")?;
    writeln!(w, "      <Points>")?;
    data_array(w, "Float64", "Points", 3, a.iter().flat_map(|x| x.center))?;
    writeln!(w, "      </Points>")?;
    writeln!(w, "      <Cells>")?;
    data_array(w, "Int64", "connectivity", 1, 0..n)?;
    data_array(w, "Int64", "offsets", 1, 1..=n)?;
    // VTK_VERTEX = 1.
    data_array(w, "UInt8", "types", 1, std::iter::repeat_n(1u8, n))?;
    writeln!(w, "      </Cells>")?;
    writeln!(w, "    </Piece>")?;
    writeln!(w, "  </UnstructuredGrid>")?;
    writeln!(w, "</VTKFile>")
}

/// Writes the `.vtu` file to `path` (atomically).
pub fn write_vtu(packing: &Packing, path: &std::path::Path) -> Result<(), ExportError> {
    super::write_file(path, |w| write_vtu_to(packing, w))
}
