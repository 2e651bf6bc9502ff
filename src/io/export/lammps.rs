//! LAMMPS data file (`read_data`), atom style `sphere`, for DEM and MD codes:
//!
//! ```text
//! LAMMPS data file: densepack … export … (boundary p p p)
//!
//! 3 atoms
//! 1 atom types
//!
//! 0 10 xlo xhi
//! 0 10 ylo yhi
//! 0 10 zlo zhi
//!
//! Atoms # sphere
//!
//! 1 1 1.2 1 0.5 0.5 0.5
//! ```
//!
//! Atom lines are `id type diameter density x y z` (the `sphere` style's columns): ids
//! `1…N` in packing order, one atom type (type 1: spheres, the only kind this format takes),
//! density 1 (mass units are the user's; LAMMPS derives each mass from it), floats in
//! shortest round-trip form, lengths in the packing's unit. The box bounds are the
//! container's: a box as it is; a cylinder as its **bounding box** (the mantle is not a
//! LAMMPS box: add a `wall/region` cylinder in the input script). A data file does not say
//! which axes are periodic; the header line says the `boundary` command that matches the
//! container (`p` periodic, `f` fixed walls).

use super::{container_bounds, periodic_axes, provenance_line, spheres, ExportError};
use crate::io::packing::Packing;
use std::io::Write;
use std::path::Path;

/// The `boundary` command's letters for the container: `p` periodic, `f` fixed.
fn boundary(packing: &Packing) -> String {
    periodic_axes(&packing.container)
        .map(|p| if p { "p" } else { "f" })
        .join(" ")
}

/// Writes `path` (atomically).
pub fn write_data(packing: &Packing, path: &Path) -> Result<(), ExportError> {
    let spheres = spheres(packing, "lammps")?;
    let (lo, hi) = container_bounds(&packing.container);
    super::write_file(path, |w| {
        writeln!(
            w,
            "LAMMPS data file: {} (boundary {})",
            provenance_line(packing),
            boundary(packing)
        )?;
        writeln!(w)?;
        writeln!(w, "{} atoms", spheres.len())?;
        writeln!(w, "1 atom types")?;
        writeln!(w)?;
        for (k, axis) in ["x", "y", "z"].iter().enumerate() {
            writeln!(w, "{} {} {axis}lo {axis}hi", lo[k], hi[k])?;
        }
        writeln!(w)?;
        writeln!(w, "Atoms # sphere")?;
        writeln!(w)?;
        for (id, (c, r)) in spheres.iter().enumerate() {
            writeln!(w, "{} 1 {} 1 {} {} {}", id + 1, 2.0 * r, c[0], c[1], c[2])?;
        }
        Ok(())
    })
}
