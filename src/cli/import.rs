//! `densepack import FILE --from F --out PACKING.json`.

use clap::{Args, ValueEnum};
use densepack::io::import::{import, ImportError, ImportOptions, Source};
use densepack::io::packing::ContainerRecord;
use std::path::PathBuf;
use std::process::ExitCode;

/// Foreign formats on the command line.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum SourceArg {
    /// Comma-separated table with a header naming x,y,z and r (radius) or d (diameter).
    Csv,
    /// PackingGeneration's binary .xyzd (little-endian doubles x y z d).
    Xyzd,
    /// LAMMPS data file, atom style sphere (id type diameter density x y z).
    LammpsData,
    /// LAMMPS text dump (last snapshot): x y z (or xu.., xs..) and radius or diameter.
    LammpsDump,
    /// A packing JSON (min_gap, seed and stats may be absent).
    Json,
}

impl SourceArg {
    fn source(self) -> Source {
        match self {
            SourceArg::Csv => Source::Csv,
            SourceArg::Xyzd => Source::Xyzd,
            SourceArg::LammpsData => Source::LammpsData,
            SourceArg::LammpsDump => Source::LammpsDump,
            SourceArg::Json => Source::Json,
        }
    }
}

/// Arguments of `import`.
#[derive(Args, Debug)]
pub struct ImportArgs {
    /// The foreign file.
    file: PathBuf,
    /// Its format.
    #[arg(long, value_enum)]
    from: SourceArg,
    /// Output packing file (JSON, written atomically).
    #[arg(long)]
    out: PathBuf,
    /// Box container X,Y,Z with its lower corner at the origin (required for csv and xyzd;
    /// replaces the file's container otherwise).
    #[arg(long = "box", value_delimiter = ',', conflicts_with = "cylinder")]
    r#box: Option<Vec<f64>>,
    /// Periodic axes of the box, e.g. true,true,false [default: the file's (lammps-dump
    /// bounds flags, the boundary note of a lammps-data title), else walls].
    #[arg(long, value_delimiter = ',', conflicts_with = "cylinder")]
    periodic: Option<Vec<bool>>,
    /// Cylinder container RADIUS,HEIGHT, axis along z, base centre at the origin (replaces
    /// the file's container).
    #[arg(long, value_delimiter = ',')]
    cylinder: Option<Vec<f64>>,
    /// Write the packing JSON on one line.
    #[arg(long)]
    compact: bool,
}

/// The container and periodic axes of the options.
fn options(args: &ImportArgs) -> Result<ImportOptions, String> {
    let periodic = match args.periodic.as_deref() {
        None => None,
        Some(&[a, b, c]) => Some([a, b, c]),
        Some(p) => return Err(format!("--periodic: {} values given, expected 3", p.len())),
    };
    let container = match (args.r#box.as_deref(), args.cylinder.as_deref()) {
        (Some(&[x, y, z]), None) => Some(ContainerRecord::Box {
            min: [0.0; 3],
            max: [x, y, z],
            periodic: periodic.unwrap_or([false; 3]),
        }),
        (Some(b), None) => return Err(format!("--box: {} values given, expected X,Y,Z", b.len())),
        (None, Some(&[radius, height])) => Some(ContainerRecord::Cylinder {
            base_center: [0.0; 3],
            radius,
            height,
        }),
        (None, Some(c)) => {
            return Err(format!(
                "--cylinder: {} values given, expected RADIUS,HEIGHT",
                c.len()
            ))
        }
        _ => None,
    };
    if let Some(c) = &container {
        c.check().map_err(|e| {
            let option = if args.r#box.is_some() {
                "--box"
            } else {
                "--cylinder"
            };
            format!("{option}: {e}")
        })?;
    }
    Ok(ImportOptions {
        // --periodic alone applies to the file's box; with --box it is in the box.
        periodic: periodic.filter(|_| container.is_none()),
        container,
    })
}

/// Runs `import`.
pub fn run(args: &ImportArgs) -> ExitCode {
    let options = match options(args).and_then(|o| {
        super::paths::check_outputs(&[("--out", &args.out)], &[("FILE", &args.file)]).map(|()| o)
    }) {
        Ok(o) => o,
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let packing = match import(&args.file, args.from.source(), &options) {
        Ok(p) => p,
        Err(e @ ImportError::Io { .. }) => {
            errln!("error: {e}");
            return ExitCode::from(1);
        }
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let written = if args.compact {
        packing.write_compact(&args.out)
    } else {
        packing.write(&args.out)
    };
    if let Err(e) = written {
        errln!("error: {e}");
        return ExitCode::from(1);
    }
    outln!(
        "wrote {}: {} particles from {} ({}), container {}, packing fraction {:.6}; \
         no gap promised: verify checks overlaps and containment",
        args.out.display(),
        packing.particles.len(),
        args.file.display(),
        args.from.source().name(),
        serde_json::to_string(&packing.container).unwrap_or_default(),
        densepack::io::export::packing_fraction(&packing)
    );
    ExitCode::SUCCESS
}
