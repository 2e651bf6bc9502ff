//! PackingGeneration's `.xyzd` (V. Baranau's PackingGeneration, `packing.xyzd`): binary, no
//! header, per sphere four little-endian `f64` — centre `x, y, z` and **diameter** `d` — in
//! packing order; 32 bytes per sphere. Source: `PackingSerializer::WritePacking` in
//! PackingGeneration (`WriteLittleEndian<FLOAT_TYPE>(data, 4, file)`, `FLOAT_TYPE` =
//! `double`), which its readers (`numpy.fromfile(f, "<f8").reshape(-1, 4)`) expect.
//!
//! The file holds no container: PackingGeneration keeps the box in `generation.conf`
//! (`Packing size: X Y Z`, corner at the origin). Centres keep the packing's frame and
//! length unit. Spheres only.

use super::{spheres, ExportError};
use crate::io::packing::Packing;
use std::io::Write;
use std::path::Path;

/// Writes `path` (atomically).
pub fn write_xyzd(packing: &Packing, path: &Path) -> Result<(), ExportError> {
    let spheres = spheres(packing, "xyzd")?;
    super::write_file(path, |w| {
        for (c, r) in spheres {
            for v in [c[0], c[1], c[2], 2.0 * r] {
                w.write_all(&v.to_le_bytes())?;
            }
        }
        Ok(())
    })
}
