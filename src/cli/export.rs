//! `densepack export PACKING.json --format F --out FILE`.

use clap::{Args, ValueEnum};
use densepack::io::export::{
    csv, gmsh,
    voxel::{self, Labels, VoxelOptions},
    vtk, ExportError,
};
use densepack::io::packing::Packing;
use std::path::PathBuf;
use std::process::ExitCode;

/// File formats on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum FormatArg {
    /// Gmsh `.geo` script (OpenCASCADE): physical volumes matrix, aggregates[, interface].
    Gmsh,
    /// VTK `.vtu` points with radius, semi_axes, orientation (ParaView glyphs).
    Vtk,
    /// Voxel label image as `.npy`, with a `FILE.json` sidecar.
    Npy,
    /// Voxel label image as raw bytes, with a `FILE.json` sidecar.
    Raw,
    /// CSV table `x,y,z,r`.
    Csv,
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
    #[arg(long, value_enum)]
    format: FormatArg,
    /// Output file (written atomically).
    #[arg(long)]
    out: PathBuf,
    /// Voxel formats: voxels along the longest container edge.
    #[arg(long, default_value_t = 128)]
    voxels: usize,
    /// Voxel formats: what a label means.
    #[arg(long, value_enum, default_value_t = LabelsArg::Phase)]
    labels: LabelsArg,
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
    /// near-touching particles leave gaps a mesher can resolve.
    #[arg(long, default_value_t = 0.0)]
    shrink: f64,
}

fn reject_unused(args: &ExportArgs) -> Result<(), ExportError> {
    let voxel = matches!(args.format, FormatArg::Npy | FormatArg::Raw);
    let gmsh = matches!(args.format, FormatArg::Gmsh);
    let invalid = |option: &'static str, only: &str| ExportError::Invalid {
        option,
        message: format!("only applies to --format {only}"),
    };
    if !gmsh && args.interface.is_some() {
        return Err(invalid("--interface", "gmsh"));
    }
    if !gmsh && args.mesh_size.is_some() {
        return Err(invalid("--mesh-size", "gmsh"));
    }
    if !gmsh && args.shrink != 0.0 {
        return Err(invalid("--shrink", "gmsh"));
    }
    if matches!(args.format, FormatArg::Vtk)
        && args.out.extension().and_then(|e| e.to_str()) != Some("vtu")
    {
        return Err(ExportError::Invalid {
            option: "--out",
            message: "a VTK XML unstructured grid needs the extension .vtu (readers go by it)"
                .into(),
        });
    }
    if !voxel
        && (args.voxels != 128
            || !matches!(args.labels, LabelsArg::Phase)
            || args.partial_volume.is_some())
    {
        return Err(invalid("--voxels/--labels/--partial-volume", "npy or raw"));
    }
    Ok(())
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
    if let Err(e) = reject_unused(args) {
        errln!("error: {e}");
        return ExitCode::from(2);
    }
    let out = &args.out;
    let voxel = matches!(args.format, FormatArg::Npy | FormatArg::Raw);
    let sidecar = voxel::sidecar_path(out);
    let mut outputs: Vec<super::paths::Named> = vec![("--out", out)];
    if voxel {
        outputs.push(("the sidecar (--out + .json)", &sidecar));
    }
    if let Err(e) = super::paths::check_outputs(&outputs, &[("packing", &args.packing)]) {
        errln!("error: {e}");
        return ExitCode::from(2);
    }
    if voxel && !densepack::memory::overridden() {
        // The image is built whole in memory before it is written.
        if let Ok(grid) = voxel::Grid::new(&packing.container, args.voxels) {
            let each = match (args.partial_volume, args.labels) {
                (None, LabelsArg::Phase) => 1,
                _ => 4,
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
                errln!("error: --voxels {}: the image {e}", args.voxels);
                return ExitCode::from(2);
            }
        }
    }
    let result = match args.format {
        FormatArg::Gmsh => gmsh::write_geo(
            &packing,
            &gmsh::GmshOptions {
                interface_thickness: args.interface,
                mesh_size: args.mesh_size,
                shrink: args.shrink,
            },
            &|surfaces| {
                // The exporter builds the surfaces; the independent checker judges them.
                let v = densepack::verify::verify(surfaces);
                gmsh::SurfaceCheck {
                    violation_count: v.violation_count,
                    first_violation: v.violations.into_iter().next(),
                    min_pair_gap: v.min_pair_gap,
                    min_wall_gap: v.min_wall_gap,
                }
            },
            out,
        )
        .map(|report| {
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
        }),
        FormatArg::Vtk => vtk::write_vtu(&packing, out).map(|()| format!("wrote {}", out.display())),
        FormatArg::Csv => csv::write_csv(&packing, out).map(|()| format!("wrote {}", out.display())),
        FormatArg::Npy | FormatArg::Raw => voxel::write_voxels(
            &packing,
            &VoxelOptions {
                voxels: args.voxels,
                labels: match (args.partial_volume, args.labels) {
                    (Some(samples), _) => Labels::PartialVolume(samples),
                    (None, LabelsArg::Phase) => Labels::Phase,
                    (None, LabelsArg::Particle) => Labels::Particle,
                },
                npy: matches!(args.format, FormatArg::Npy),
            },
            out,
        )
        .map(|s| {
            format!(
                "wrote {} and {}: {}x{}x{} voxels of {:.4e} x {:.4e} x {:.4e}; packing fraction exact {:.6}, \
                 voxels {:.6} (difference {:+.2e}, first-order bound {:.2e})",
                out.display(),
                s.sidecar.display(),
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
            )
        }),
    };
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
