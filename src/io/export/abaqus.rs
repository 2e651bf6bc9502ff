//! Abaqus input file (`.inp`) of the voxel model: one 8-node brick with reduced integration
//! (`C3D8R`) per voxel of [`voxel`](super::voxel), on the voxel grid's nodes.
//!
//! - `*Node`: node `(i, j, k)` of the grid (`0 ≤ i ≤ nx`, …) has the id
//!   `1 + i + (nx+1)(j + (ny+1) k)` and sits at `origin + (i, j, k) · spacing`, in the
//!   packing's length unit; only nodes of written elements are listed;
//! - `*Element, type=C3D8R`: voxel `(i, j, k)` has the id `1 + i + nx (j + ny k)` (the cell
//!   order of the `.vti` export) and its nodes in Abaqus order (bottom face counter-clockwise
//!   seen from +z, then the top face); voxels outside a cylinder container are not written;
//! - `*Elset`: one set per phase present (`MATRIX`, `SPHERE`, `ELLIPSOID`, `CYLINDER`), and
//!   with [`Labels::Particle`] one more per particle, `PARTICLE_<index + 1>`;
//! - `*Nset`: the nodes on each face of a box, `XMIN XMAX YMIN YMAX ZMIN ZMAX`, each listed
//!   in the same order of the two in-face indices, so that the n-th node of `XMIN` and the
//!   n-th of `XMAX` are partners of a periodic constraint (`*Equation`); a cylinder has only
//!   `ZMIN` and `ZMAX` (its mantle is a staircase of voxels);
//! - materials and sections are left to the user (a comment line in the file says so).
//!
//! Partial-volume images have no Abaqus form: [`Labels::PartialVolume`] is refused.

use super::voxel::{
    image_and_summary, Labels, VoxelImage, VoxelSummary, OUTSIDE_PARTICLE, OUTSIDE_PHASE,
};
use super::{provenance_line, ExportError};
use crate::io::packing::{ContainerRecord, Packing};
use crate::io::record::PHASE_NAMES;
use std::borrow::Cow;
use std::io::Write;
use std::path::Path;

/// Entries per data line of a set (Abaqus reads at most 16).
const PER_LINE: usize = 16;

/// Writes `ids` as Abaqus data lines of at most [`PER_LINE`] entries.
fn write_ids(w: &mut impl Write, ids: &[usize]) -> std::io::Result<()> {
    for line in ids.chunks(PER_LINE) {
        let text: Vec<String> = line.iter().map(usize::to_string).collect();
        writeln!(w, "{}", text.join(", "))?;
    }
    Ok(())
}

/// Voxelises `packing` (`voxels` along the longest edge, `labels` phase or particle) and
/// writes the `.inp`.
pub fn write_inp(
    packing: &Packing,
    voxels: usize,
    labels: Labels,
    path: &Path,
) -> Result<VoxelSummary, ExportError> {
    if let Labels::PartialVolume(_) = labels {
        return Err(ExportError::Invalid {
            option: "--partial-volume",
            message: "does not apply to --format abaqus (elements have one phase each; \
                      use --labels phase or particle)"
                .into(),
        });
    }
    let (image, summary) = image_and_summary(packing, voxels, labels)?;
    let [nx, ny, nz] = summary.grid.shape;
    // Phase per voxel in C order (u8::MAX outside), and the particle label when asked for.
    let (phase, particle): (Cow<[u8]>, Option<&[u32]>) = match &image {
        VoxelImage::Phase(v) => (Cow::Borrowed(v), None),
        VoxelImage::Particle(v) => (
            v.iter()
                .map(|&l| match l {
                    0 => 0,
                    OUTSIDE_PARTICLE => OUTSIDE_PHASE,
                    l => packing.particles[l as usize - 1].phase(),
                })
                .collect(),
            Some(v),
        ),
        VoxelImage::PartialVolume { .. } => unreachable!("refused above"),
    };
    let node = |i: usize, j: usize, k: usize| 1 + i + (nx + 1) * (j + (ny + 1) * k);
    let c_index = |i: usize, j: usize, k: usize| (i * ny + j) * nz + k;
    let inside = |i, j, k| phase[c_index(i, j, k)] != OUTSIDE_PHASE;
    let mut used = vec![false; (nx + 1) * (ny + 1) * (nz + 1)];
    let mut phase_sets: Vec<Vec<usize>> = vec![Vec::new(); PHASE_NAMES.len()];
    let mut particle_sets: Vec<Vec<usize>> =
        vec![Vec::new(); particle.map_or(0, |_| packing.particles.len())];
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                if !inside(i, j, k) {
                    continue;
                }
                let id = 1 + i + nx * (j + ny * k);
                phase_sets[phase[c_index(i, j, k)] as usize].push(id);
                if let Some(l) = particle.map(|v| v[c_index(i, j, k)]).filter(|&l| l > 0) {
                    particle_sets[l as usize - 1].push(id);
                }
                for (di, dj, dk) in (0..8).map(|m| (m & 1, m >> 1 & 1, m >> 2)) {
                    used[node(i + di, j + dj, k + dk) - 1] = true;
                }
            }
        }
    }
    let faces: Vec<(&str, Vec<usize>)> = {
        let is_box = matches!(packing.container, ContainerRecord::Box { .. });
        let face = |axis: usize, at: usize| -> Vec<usize> {
            // The two in-face indices, the slower one first.
            let (a, b) = match axis {
                0 => (ny, nz),
                1 => (nx, nz),
                _ => (nx, ny),
            };
            (0..=b)
                .flat_map(|q| (0..=a).map(move |p| (p, q)))
                .map(|(p, q)| match axis {
                    0 => node(at, p, q),
                    1 => node(p, at, q),
                    _ => node(p, q, at),
                })
                .filter(|&n| used[n - 1])
                .collect()
        };
        let mut faces = Vec::new();
        for (axis, n, names) in [
            (0, nx, ["XMIN", "XMAX"]),
            (1, ny, ["YMIN", "YMAX"]),
            (2, nz, ["ZMIN", "ZMAX"]),
        ] {
            if is_box || axis == 2 {
                faces.push((names[0], face(axis, 0)));
                faces.push((names[1], face(axis, n)));
            }
        }
        faces
    };
    let grid = summary.grid;
    super::write_file(path, |w| {
        writeln!(w, "*Heading")?;
        writeln!(w, "{}", provenance_line(packing))?;
        writeln!(
            w,
            "** Voxel model: {nx} x {ny} x {nz} C3D8R elements of {} x {} x {}, origin {} {} {}",
            grid.spacing[0],
            grid.spacing[1],
            grid.spacing[2],
            grid.origin[0],
            grid.origin[1],
            grid.origin[2]
        )?;
        writeln!(
            w,
            "** Materials are left to the user: add *Material and *Solid Section per element set."
        )?;
        writeln!(
            w,
            "** Face node sets list partner nodes in the same order (periodic *Equation)."
        )?;
        writeln!(w, "*Node")?;
        for k in 0..=nz {
            for j in 0..=ny {
                for i in 0..=nx {
                    let id = node(i, j, k);
                    if used[id - 1] {
                        let x = |axis: usize, n: usize| {
                            grid.origin[axis] + n as f64 * grid.spacing[axis]
                        };
                        writeln!(w, "{id}, {}, {}, {}", x(0, i), x(1, j), x(2, k))?;
                    }
                }
            }
        }
        writeln!(w, "*Element, type=C3D8R")?;
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    if inside(i, j, k) {
                        writeln!(
                            w,
                            "{}, {}, {}, {}, {}, {}, {}, {}, {}",
                            1 + i + nx * (j + ny * k),
                            node(i, j, k),
                            node(i + 1, j, k),
                            node(i + 1, j + 1, k),
                            node(i, j + 1, k),
                            node(i, j, k + 1),
                            node(i + 1, j, k + 1),
                            node(i + 1, j + 1, k + 1),
                            node(i, j + 1, k + 1),
                        )?;
                    }
                }
            }
        }
        for (id, name) in PHASE_NAMES {
            let set = &phase_sets[id as usize];
            if !set.is_empty() {
                writeln!(w, "*Elset, elset={}", name.to_uppercase())?;
                write_ids(w, set)?;
            }
        }
        for (index, set) in particle_sets.iter().enumerate() {
            if !set.is_empty() {
                writeln!(w, "*Elset, elset=PARTICLE_{}", index + 1)?;
                write_ids(w, set)?;
            }
        }
        for (name, set) in &faces {
            writeln!(w, "*Nset, nset={name}")?;
            write_ids(w, set)?;
        }
        Ok(())
    })?;
    Ok(summary)
}
