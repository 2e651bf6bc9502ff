//! CSV table of particles: a header line, then one row per particle in packing order,
//! floats in shortest round-trip form.
//!
//! Columns for sphere packings: `x,y,z,r` (centre and radius). Packings with other shapes
//! get `type,x,y,z,r,lx,ly,lz,a,b,c,qw,qx,qy,qz`: the radius and half-axis vector `l` of
//! cylinders (`r` alone for spheres), the semi-axes and orientation quaternion of
//! ellipsoids; unused columns are empty.

use super::ExportError;
use crate::io::packing::{Packing, ParticleRecord};
use std::io::Write;

/// The header of a sphere packing's table.
const SPHERE_HEADER: &str = "x,y,z,r";
/// The header of a table with other shapes.
const MIXED_HEADER: &str = "type,x,y,z,r,lx,ly,lz,a,b,c,qw,qx,qy,qz";

/// One row for a particle: the sphere columns, or the mixed ones when `mixed`
/// ([`ParticleRecord::csv_row`]).
fn row(p: &ParticleRecord, mixed: bool) -> String {
    match p {
        ParticleRecord::Sphere(s) if !mixed => {
            let c = s.center;
            format!("{},{},{},{}", c[0], c[1], c[2], s.radius)
        }
        _ => p.csv_row(),
    }
}

/// Writes the table to `w`.
pub fn write_csv_to(packing: &Packing, w: &mut impl Write) -> std::io::Result<()> {
    let mixed = packing
        .particles
        .iter()
        .any(|p| !matches!(p, ParticleRecord::Sphere(_)));
    writeln!(w, "{}", if mixed { MIXED_HEADER } else { SPHERE_HEADER })?;
    for p in &packing.particles {
        writeln!(w, "{}", row(p, mixed))?;
    }
    Ok(())
}

/// Writes the table to `path` (atomically).
pub fn write_csv(packing: &Packing, path: &std::path::Path) -> Result<(), ExportError> {
    super::write_file(path, |w| write_csv_to(packing, w))
}
