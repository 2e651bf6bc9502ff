//! VTK XML unstructured grids (`.vtu`): the particles, one vertex cell per particle at its
//! centre with the point data ParaView's glyph filters need, and the container's surface in
//! a second file beside it.
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
//!
//! **Encoding.** Every array is binary in `<AppendedData encoding="raw">`, compressed as in
//! the `.vti` export (`vtkZLibDataCompressor`, `UInt64` headers; see [`super::vti`]): values
//! keep every bit (a `Float64` is its 8 bytes). 10⁴ equal spheres take 264 KB, 26 B per
//! sphere: the centres' 24 B, the equal radii and constant orientations compress away.
//!
//! **Container** ([`container_path`]: `NAME.container.vtu` beside `NAME.vtu`): the
//! container's surface as polygons, a box as its 6 quadrilaterals (`VTK_QUAD`), a cylinder
//! as [`CYLINDER_SEGMENTS`] side quadrilaterals and as many triangles (`VTK_TRIANGLE`) in
//! each cap, a polygon inscribed in the circle. A periodic box is drawn the same: its faces
//! are where the images begin.

use super::ExportError;
use crate::io::packing::{ContainerRecord, Packing, ParticleRecord};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Segments of the polygon a cylinder container's circles are drawn with.
pub const CYLINDER_SEGMENTS: usize = 64;

/// Per-particle attributes of the point data (see the table above), one per particle
/// ([`crate::io::record::RecordShape::vtk_attributes`]).
pub struct VtkAttributes {
    /// Centre.
    pub center: [f64; 3],
    /// Radius of the bounding sphere (the radius, for a sphere).
    pub radius: f64,
    /// Semi-axes in the body frame.
    pub semi_axes: [f64; 3],
    /// Unit quaternion `[w, x, y, z]`, body → world.
    pub orientation: [f64; 4],
    /// `R diag(semi_axes) Rᵀ`, row-major.
    pub shape_tensor: [f64; 9],
    /// A cylinder's half-axis vector; `0, 0, 0` for other shapes.
    pub half_axis: [f64; 3],
    /// Shape id: the kind's voxel phase id ([`crate::io::record::RecordShape::PHASE`]).
    pub shape: u8,
}

/// The arrays of one `.vtu` document: the XML elements that name them and the appended
/// block their compressed bytes go to (offsets count from the block's start, after `_`).
#[derive(Default)]
struct Appended {
    payload: Vec<u8>,
}

impl Appended {
    /// The `<DataArray>` element of `values` (`kind` names their VTK type, each value
    /// `bytes` long), whose compressed bytes are appended.
    fn array(
        &mut self,
        kind: &str,
        name: &str,
        components: usize,
        values: Vec<u8>,
    ) -> std::io::Result<String> {
        let offset = self.payload.len();
        self.payload.extend(super::vti::compressed(&values)?);
        Ok(format!(
            "<DataArray type=\"{kind}\" Name=\"{name}\" NumberOfComponents=\"{components}\" \
             format=\"appended\" offset=\"{offset}\"/>"
        ))
    }
}

fn f64_bytes(values: impl Iterator<Item = f64>) -> Vec<u8> {
    values.flat_map(f64::to_le_bytes).collect()
}

fn i64_bytes(values: impl Iterator<Item = usize>) -> Vec<u8> {
    values.flat_map(|v| (v as i64).to_le_bytes()).collect()
}

/// The unstructured-grid document: `points`, cells given by `connectivity` and `offsets`
/// (each cell's end) and `types`, and the point data elements `point_data` already added to
/// `appended` (with the `PointData` attribute text).
fn write_grid(
    w: &mut impl Write,
    packing: &Packing,
    mut appended: Appended,
    point_data: (&str, Vec<String>),
    points: Vec<u8>,
    cells: (Vec<usize>, Vec<usize>, Vec<u8>),
) -> std::io::Result<()> {
    let n_points = points.len() / 24;
    let n_cells = cells.2.len();
    let points = appended.array("Float64", "Points", 3, points)?;
    let connectivity =
        appended.array("Int64", "connectivity", 1, i64_bytes(cells.0.into_iter()))?;
    let offsets = appended.array("Int64", "offsets", 1, i64_bytes(cells.1.into_iter()))?;
    let types = appended.array("UInt8", "types", 1, cells.2)?;
    super::vti::write_head(w, packing, "UnstructuredGrid")?;
    writeln!(w, "  <UnstructuredGrid>")?;
    writeln!(
        w,
        "    <Piece NumberOfPoints=\"{n_points}\" NumberOfCells=\"{n_cells}\">"
    )?;
    if !point_data.1.is_empty() {
        writeln!(w, "      <PointData{}>", point_data.0)?;
        for element in &point_data.1 {
            writeln!(w, "        {element}")?;
        }
        writeln!(w, "      </PointData>")?;
    }
    writeln!(w, "      <Points>\n        {points}\n      </Points>")?;
    writeln!(
        w,
        "      <Cells>\n        {connectivity}\n        {offsets}\n        {types}\n      </Cells>"
    )?;
    writeln!(w, "    </Piece>")?;
    writeln!(w, "  </UnstructuredGrid>")?;
    super::vti::write_tail(w, &appended.payload)
}

/// Writes the particles' `.vtu` document to `w`.
pub fn write_vtu_to(packing: &Packing, w: &mut impl Write) -> std::io::Result<()> {
    let a: Vec<VtkAttributes> = packing
        .particles
        .iter()
        .map(ParticleRecord::vtk_attributes)
        .collect();
    let n = a.len();
    let mut appended = Appended::default();
    let point_data = vec![
        appended.array(
            "Float64",
            "radius",
            1,
            f64_bytes(a.iter().map(|x| x.radius)),
        )?,
        appended.array(
            "Float64",
            "semi_axes",
            3,
            f64_bytes(a.iter().flat_map(|x| x.semi_axes)),
        )?,
        appended.array(
            "Float64",
            "orientation",
            4,
            f64_bytes(a.iter().flat_map(|x| x.orientation)),
        )?,
        appended.array(
            "Float64",
            "shape_tensor",
            9,
            f64_bytes(a.iter().flat_map(|x| x.shape_tensor)),
        )?,
        appended.array(
            "Float64",
            "half_axis",
            3,
            f64_bytes(a.iter().flat_map(|x| x.half_axis)),
        )?,
        appended.array("UInt8", "shape", 1, a.iter().map(|x| x.shape).collect())?,
    ];
    // VTK_VERTEX = 1: one single-point cell per particle.
    write_grid(
        w,
        packing,
        appended,
        (" Scalars=\"radius\" Tensors=\"shape_tensor\"", point_data),
        f64_bytes(a.iter().flat_map(|x| x.center)),
        ((0..n).collect(), (1..=n).collect(), vec![1u8; n]),
    )
}

/// The container's surface (see the module docs): points and polygons.
fn container_surface(container: &ContainerRecord) -> (Vec<[f64; 3]>, Vec<Vec<usize>>) {
    match container {
        ContainerRecord::Box { min, max, .. } => {
            // Corner k has coordinate axis a at max when bit a of k is set.
            let points = (0..8)
                .map(|k| std::array::from_fn(|a| if k >> a & 1 == 1 { max[a] } else { min[a] }))
                .collect();
            let faces = vec![
                vec![0, 4, 6, 2], // x min
                vec![1, 3, 7, 5], // x max
                vec![0, 1, 5, 4], // y min
                vec![2, 6, 7, 3], // y max
                vec![0, 2, 3, 1], // z min
                vec![4, 5, 7, 6], // z max
            ];
            (points, faces)
        }
        ContainerRecord::Cylinder {
            base_center: b,
            radius,
            height,
        } => {
            let k = CYLINDER_SEGMENTS;
            let ring = |z: f64| {
                (0..k).map(move |s| {
                    let phi = std::f64::consts::TAU * s as f64 / k as f64;
                    [b[0] + radius * phi.cos(), b[1] + radius * phi.sin(), z]
                })
            };
            // Bottom ring 0..k, top ring k..2k, then the two cap centres.
            let mut points: Vec<[f64; 3]> = ring(b[2]).chain(ring(b[2] + height)).collect();
            points.push(*b);
            points.push([b[0], b[1], b[2] + height]);
            let (bottom, top) = (2 * k, 2 * k + 1);
            let mut faces: Vec<Vec<usize>> = (0..k)
                .map(|s| vec![s, (s + 1) % k, k + (s + 1) % k, k + s])
                .collect();
            faces.extend((0..k).map(|s| vec![bottom, (s + 1) % k, s]));
            faces.extend((0..k).map(|s| vec![top, k + s, k + (s + 1) % k]));
            (points, faces)
        }
    }
}

/// Writes the container's `.vtu` document to `w`.
pub fn write_container_vtu_to(packing: &Packing, w: &mut impl Write) -> std::io::Result<()> {
    let (points, faces) = container_surface(&packing.container);
    let mut offsets = Vec::with_capacity(faces.len());
    let mut end = 0;
    for f in &faces {
        end += f.len();
        offsets.push(end);
    }
    // VTK_TRIANGLE = 5, VTK_QUAD = 9.
    let types = faces
        .iter()
        .map(|f| if f.len() == 3 { 5 } else { 9 })
        .collect();
    write_grid(
        w,
        packing,
        Appended::default(),
        ("", Vec::new()),
        f64_bytes(points.into_iter().flatten()),
        (faces.into_iter().flatten().collect(), offsets, types),
    )
}

/// Where the container's surface goes beside the particles' file `path`:
/// `NAME.container.vtu` for `NAME.vtu`.
pub fn container_path(path: &Path) -> PathBuf {
    let stem = path
        .file_stem()
        .and_then(|s| s.to_str())
        .unwrap_or("packing");
    path.with_file_name(format!("{stem}.container.vtu"))
}

/// Writes the particles to `path` and the container's surface to [`container_path`] (each
/// atomically); returns the container's file.
pub fn write_vtu(packing: &Packing, path: &Path) -> Result<PathBuf, ExportError> {
    let container = container_path(path);
    super::write_file(path, |w| write_vtu_to(packing, w))?;
    super::write_file(&container, |w| write_container_vtu_to(packing, w))?;
    Ok(container)
}
