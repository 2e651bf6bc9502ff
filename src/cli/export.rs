//! `densepack export PACKING.json --format F --out FILE`.

use clap::{Args, ValueEnum};
use densepack::io::export::{
    export,
    voxel::{self, Labels},
    ExportError, ExportOptions, Exported, Format, DEFAULT_VOXELS,
};
use densepack::io::packing::Packing;
use std::path::PathBuf;
use std::process::ExitCode;

/// `--format`: the library's formats ([`Format::ALL`]), each listed in `--help` with its
/// description.
fn format_parser() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(
        Format::ALL.map(|f| clap::builder::PossibleValue::new(f.name()).help(f.describe())),
    )
}

/// Voxel label kinds on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum LabelsArg {
    /// uint8: 0 matrix, 1 sphere, 255 outside the container.
    Phase,
    /// uint32: 0 matrix, particle index + 1.
    Particle,
}

/// Arguments of `export`.
#[derive(Args, Debug)]
pub struct ExportArgs {
    /// Packing file (JSON).
    packing: PathBuf,
    /// Output format.
    #[arg(long, value_parser = format_parser())]
    format: String,
    /// Output file (written atomically).
    #[arg(long)]
    out: PathBuf,
    /// Voxel formats (npy, raw, vti, abaqus): voxels along the longest container edge [default: 128].
    #[arg(long)]
    voxels: Option<usize>,
    /// Voxel formats: what a label means [default: phase]. Gmsh: physical volumes per kind
    /// (phase) or one per particle (particle).
    #[arg(long, value_enum)]
    labels: Option<LabelsArg>,
    /// Voxel formats: write float32 solid fractions per voxel from S³ sample points (composite
    /// voxels, 1..=16) instead of labels.
    #[arg(long, conflicts_with = "labels")]
    partial_volume: Option<usize>,
    /// Gmsh: thickness of interface shells around the particles (physical volume "interface").
    #[arg(long)]
    interface: Option<f64>,
    /// Gmsh: largest element size (default: half the mean radius).
    #[arg(long)]
    mesh_size: Option<f64>,
    /// Gmsh: shrink every particle radius by this relative amount first, in [0, 1), so that
    /// near-touching particles leave gaps a mesher can resolve [default: 0].
    #[arg(long)]
    shrink: Option<f64>,
}

/// Runs `export`.
pub fn run(args: &ExportArgs) -> ExitCode {
    let packing = match Packing::read(&args.packing) {
        Ok(p) => p,
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let format = Format::parse(&args.format).expect("clap accepts the formats' names only");
    let options = ExportOptions {
        voxels: args.voxels,
        labels: match (args.partial_volume, args.labels) {
            (Some(samples), _) => Some(Labels::PartialVolume(samples)),
            (None, Some(LabelsArg::Phase)) => Some(Labels::Phase),
            (None, Some(LabelsArg::Particle)) => Some(Labels::Particle),
            (None, None) => None,
        },
        interface: args.interface,
        mesh_size: args.mesh_size,
        shrink: args.shrink,
    };
    let out = &args.out;
    let sidecar = voxel::sidecar_path(out);
    let mut outputs: Vec<super::paths::Named> = vec![("--out", out)];
    if format.has_sidecar() {
        outputs.push(("the sidecar (--out + .json)", &sidecar));
    }
    if let Err(e) = super::paths::check_outputs(&outputs, &[("packing", &args.packing)]) {
        errln!("error: {e}");
        return ExitCode::from(2);
    }
    if format.uses_voxels() && !densepack::memory::overridden() {
        // The image is built whole in memory before it is written.
        let voxels = args.voxels.unwrap_or(DEFAULT_VOXELS);
        if let Ok(grid) = voxel::Grid::new(&packing.container, voxels) {
            let each = match options.labels {
                None | Some(Labels::Phase) => 1,
                Some(_) => 4,
            };
            let what = format!(
                "{} voxels × {each} B + the packing's {} particles",
                grid.len(),
                packing.particles.len()
            );
            let needed = densepack::memory::estimate(grid.len() as f64, each).saturating_add(
                densepack::memory::estimate(
                    packing.particles.len() as f64,
                    densepack::memory::SPHERE_BYTES,
                ),
            );
            let hint = format!("{}=1", densepack::memory::OVERRIDE_ENV);
            if let Err(e) = densepack::memory::check(needed, what, &hint) {
                errln!("error: --voxels {voxels}: the image {e}");
                return ExitCode::from(2);
            }
        }
    }
    let result = export(
        &packing,
        format,
        &options,
        &densepack::verify::surface_check,
        out,
    )
    .map(|exported| match exported {
        Exported::Gmsh(report) => {
            let mut msg = format!(
                "wrote {} (mesh it with: gmsh -3 -order 2 {0} -o MESH.msh); element size {:.4e}",
                out.display(),
                report.mesh_size
            );
            if let Some(gap) = report.narrowest_gap {
                msg += &format!(", narrowest gap {gap:.3e}");
                // Measured: gaps of 1.3 % of the element size mesh in seconds (the CI
                // scenes); jammed packings (gaps ~1e-15) do not mesh at all.
                if gap < 1e-3 * report.mesh_size {
                    msg += " — far below the element size: expect slow or failed meshing; \
                            widen the gaps with --shrink (e.g. 0.02)";
                }
            }
            msg
        }
        Exported::File => format!("wrote {}", out.display()),
        Exported::Vtk { container } => format!(
            "wrote {} and the container's surface {}",
            out.display(),
            container.display()
        ),
        Exported::Voxels(s) => format!(
            "wrote {}{}: {}x{}x{} voxels of {:.4e} x {:.4e} x {:.4e}; packing fraction exact {:.6}, \
             voxels {:.6} (difference {:+.2e}, first-order bound {:.2e})",
            out.display(),
            s.sidecar
                .as_ref()
                .map_or(String::new(), |p| format!(" and {}", p.display())),
            s.grid.shape[0],
            s.grid.shape[1],
            s.grid.shape[2],
            s.grid.spacing[0],
            s.grid.spacing[1],
            s.grid.spacing[2],
            s.packing_fraction_exact,
            s.packing_fraction_voxels,
            s.packing_fraction_voxels - s.packing_fraction_exact,
            s.resolution_bound
        ),
    });
    match result {
        Ok(msg) => {
            outln!("{msg}");
            ExitCode::SUCCESS
        }
        Err(e @ ExportError::Invalid { .. }) => {
            errln!("error: {e}");
            ExitCode::from(2)
        }
        Err(e) => {
            errln!("error: {e}");
            ExitCode::from(1)
        }
    }
}
