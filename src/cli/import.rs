//! `densepack import FILE --from F --out PACKING.json`.

use clap::Args;
use densepack::io::import::{import, ImportError, ImportOptions, Source};
use std::path::PathBuf;
use std::process::ExitCode;

/// `--from`: the library's sources ([`Source::ALL`]), each listed in `--help` with its
/// description.
fn source_parser() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(
        Source::ALL.map(|s| clap::builder::PossibleValue::new(s.name()).help(s.describe())),
    )
}

/// Arguments of `import`.
#[derive(Args, Debug)]
pub struct ImportArgs {
    /// The foreign file.
    file: PathBuf,
    /// Its format.
    #[arg(long, value_parser = source_parser())]
    from: String,
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
    ImportOptions::of_specimen(
        args.r#box.as_deref(),
        args.cylinder.as_deref(),
        args.periodic.as_deref(),
    )
    .map_err(|e| e.to_string())
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
    let source = Source::parse(&args.from).expect("clap accepts the sources' names only");
    let packing = match import(&args.file, source, &options) {
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
        source.name(),
        serde_json::to_string(&packing.container).unwrap_or_default(),
        densepack::io::export::packing_fraction(&packing)
    );
    ExitCode::SUCCESS
}
