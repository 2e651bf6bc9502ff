//! VTK XML image data (`.vti`) of the voxel image, for FFT solvers (AMITEX, DAMASK) and
//! ParaView: the voxels of [`voxel`](super::voxel) as one cell array on a uniform grid.
//!
//! - `WholeExtent="0 nx 0 ny 0 nz"` counts points, so the `nx·ny·nz` cells are the voxels;
//!   `Origin` is the lower corner of the first voxel and `Spacing` the voxel edges, in the
//!   packing's length unit;
//! - the cell array is `phase` (`UInt8`), `particle` (`UInt32`) or `solid_fraction`
//!   (`Float32`), with the label meanings of [`voxel::Labels`](super::voxel::Labels);
//! - VTK orders cells with x fastest (`index = i + nx (j + ny k)`), the transpose of the
//!   `.npy` export's C order: `array.reshape(nz, ny, nx).transpose(2, 1, 0)` equals the
//!   `.npy` image;
//! - binary, in `<AppendedData encoding="raw">`, compressed by `vtkZLibDataCompressor`: a
//!   `UInt64` header `[blocks, block size, size of the last partial block (0 when full),
//!   compressed size of each block]` then the zlib streams of the blocks (1 MiB of
//!   uncompressed data each; zlib by the `flate2` crate).
//!
//! The provenance line is an XML comment at the top of the file.

use super::voxel::{image_and_summary, Labels, VoxelImage, VoxelSummary};
use super::{provenance_line, ExportError};
use crate::io::packing::Packing;
use std::io::Write;
use std::path::Path;

/// Uncompressed bytes per compressed block (VTK's readers accept any size; ParaView's
/// writer uses 32 KiB, larger blocks compress a little better and cost no memory here).
const BLOCK: usize = 1 << 20;

/// The image in VTK's cell order (x fastest) as little-endian bytes, with the VTK type and
/// array name.
fn vtk_bytes(image: &VoxelImage, shape: [usize; 3]) -> (Vec<u8>, &'static str, &'static str) {
    let [nx, ny, nz] = shape;
    // C order index of VTK cell (i, j, k).
    let c_index = (0..nz)
        .flat_map(move |k| (0..ny).flat_map(move |j| (0..nx).map(move |i| (i * ny + j) * nz + k)));
    match image {
        VoxelImage::Phase(v) => (c_index.map(|c| v[c]).collect(), "UInt8", "phase"),
        VoxelImage::Particle(v) => (
            c_index.flat_map(|c| v[c].to_le_bytes()).collect(),
            "UInt32",
            "particle",
        ),
        VoxelImage::PartialVolume { fractions, .. } => (
            c_index.flat_map(|c| fractions[c].to_le_bytes()).collect(),
            "Float32",
            "solid_fraction",
        ),
    }
}

/// `data` in VTK's zlib-compressed block layout (header then blocks; see the module docs),
/// shared with the `.vtu` writer ([`super::vtk`]).
pub(super) fn compressed(data: &[u8]) -> std::io::Result<Vec<u8>> {
    let blocks: Vec<Vec<u8>> = data
        .chunks(BLOCK)
        .map(|chunk| {
            let mut z = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
            z.write_all(chunk)?;
            z.finish()
        })
        .collect::<std::io::Result<_>>()?;
    let mut header = vec![
        blocks.len() as u64,
        BLOCK as u64,
        (data.len() % BLOCK) as u64,
    ];
    header.extend(blocks.iter().map(|b| b.len() as u64));
    let mut out: Vec<u8> = header.iter().flat_map(|h| h.to_le_bytes()).collect();
    for b in blocks {
        out.extend(b);
    }
    Ok(out)
}

/// The start of a VTK XML file of dataset `kind` whose arrays are appended and compressed
/// (shared with [`super::vtk`]): declaration, provenance comment, `<VTKFile>`.
pub(super) fn write_head(w: &mut impl Write, packing: &Packing, kind: &str) -> std::io::Result<()> {
    writeln!(w, "<?xml version=\"1.0\"?>")?;
    writeln!(
        w,
        "<!-- {} -->",
        provenance_line(packing).replace("--", "-")
    )?;
    writeln!(
        w,
        "<VTKFile type=\"{kind}\" version=\"1.0\" byte_order=\"LittleEndian\" \
         header_type=\"UInt64\" compressor=\"vtkZLibDataCompressor\">"
    )
}

/// The end of a file begun by [`write_head`]: the appended block `payload` (raw bytes after
/// the `_` marker) and `</VTKFile>`.
pub(super) fn write_tail(w: &mut impl Write, payload: &[u8]) -> std::io::Result<()> {
    write!(w, "  <AppendedData encoding=\"raw\">\n   _")?;
    w.write_all(payload)?;
    writeln!(w, "\n  </AppendedData>")?;
    writeln!(w, "</VTKFile>")
}

/// Voxelises `packing` (`voxels` along the longest edge, `labels`) and writes the `.vti`.
pub fn write_vti(
    packing: &Packing,
    voxels: usize,
    labels: Labels,
    path: &Path,
) -> Result<VoxelSummary, ExportError> {
    let (image, summary) = image_and_summary(packing, voxels, labels)?;
    let grid = summary.grid;
    let [nx, ny, nz] = grid.shape;
    let (bytes, vtk_type, name) = vtk_bytes(&image, grid.shape);
    let io = |source| ExportError::Io {
        path: path.display().to_string(),
        source,
    };
    let payload = compressed(&bytes).map_err(io)?;
    let [ox, oy, oz] = grid.origin;
    let [hx, hy, hz] = grid.spacing;
    super::write_file(path, |w| {
        write_head(w, packing, "ImageData")?;
        writeln!(
            w,
            "  <ImageData WholeExtent=\"0 {nx} 0 {ny} 0 {nz}\" Origin=\"{ox} {oy} {oz}\" \
             Spacing=\"{hx} {hy} {hz}\">"
        )?;
        writeln!(w, "    <Piece Extent=\"0 {nx} 0 {ny} 0 {nz}\">")?;
        writeln!(w, "      <CellData Scalars=\"{name}\">")?;
        writeln!(
            w,
            "        <DataArray type=\"{vtk_type}\" Name=\"{name}\" NumberOfComponents=\"1\" \
             format=\"appended\" offset=\"0\"/>"
        )?;
        writeln!(w, "      </CellData>")?;
        writeln!(w, "    </Piece>")?;
        writeln!(w, "  </ImageData>")?;
        write_tail(w, &payload)
    })?;
    Ok(summary)
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Read;

    #[test]
    fn compressed_blocks_inflate_back_to_the_data_and_the_header_counts_them() {
        let data: Vec<u8> = (0..BLOCK * 2 + 123).map(|i| (i % 7) as u8).collect();
        let out = compressed(&data).unwrap();
        let word = |k: usize| u64::from_le_bytes(out[8 * k..8 * k + 8].try_into().unwrap());
        assert_eq!((word(0), word(1), word(2)), (3, BLOCK as u64, 123));
        let mut at = 8 * 6;
        let mut back = Vec::new();
        for b in 0..3 {
            let size = word(3 + b) as usize;
            flate2::read::ZlibDecoder::new(&out[at..at + size])
                .read_to_end(&mut back)
                .unwrap();
            at += size;
        }
        assert_eq!(at, out.len());
        assert_eq!(back, data);
    }

    #[test]
    fn cells_are_written_x_fastest() {
        // C order [2, 3, 4] with value = C index: VTK cell (i, j, k) holds (i·3 + j)·4 + k.
        let image = VoxelImage::Phase((0..24).collect());
        let (bytes, _, _) = vtk_bytes(&image, [2, 3, 4]);
        for k in 0..4 {
            for j in 0..3 {
                for i in 0..2 {
                    assert_eq!(bytes[i + 2 * (j + 3 * k)] as usize, (i * 3 + j) * 4 + k);
                }
            }
        }
    }
}
