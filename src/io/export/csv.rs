//! CSV table of particles: a header line, then one row per particle in packing order,
//! floats in shortest round-trip form.
//!
//! Columns for spheres: `x,y,z,r` (centre and radius).

use super::ExportError;
use crate::io::packing::{Packing, ParticleRecord};
use std::io::Write;

/// The header of a packing's table.
const SPHERE_HEADER: &str = "x,y,z,r";

/// One row for a particle.
fn row(p: &ParticleRecord) -> String {
    match p {
        ParticleRecord::Sphere { center, radius } => {
            format!("{},{},{},{}", center[0], center[1], center[2], radius)
        }
    }
}

/// Writes the table to `w`.
pub fn write_csv_to(packing: &Packing, w: &mut impl Write) -> std::io::Result<()> {
    writeln!(w, "{SPHERE_HEADER}")?;
    for p in &packing.particles {
        writeln!(w, "{}", row(p))?;
    }
    Ok(())
}

/// Writes the table to `path` (atomically).
pub fn write_csv(packing: &Packing, path: &std::path::Path) -> Result<(), ExportError> {
    super::write_file(path, |w| write_csv_to(packing, w))
}
