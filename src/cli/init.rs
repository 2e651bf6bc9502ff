//! `densepack init KIND`: a commented sample scene.

use clap::{Args, ValueEnum};
use densepack::io::packing::write_atomically;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

/// Kinds of sample scenes.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Kind {
    /// Equal spheres in a periodic box, grown to jamming (runnable).
    Spheres,
    /// DIN B16 aggregates (4–16 mm) in a 50 mm walled cube, from `densepack take` (runnable).
    Concrete,
    /// 200 prolate spheroids (aspect ratio 1.5) in a periodic box, grown close to jamming.
    Ellipsoids,
    /// 30 spheres and 30 cylinders (aspect ratio 3) in the periodic unit cube, relaxed apart.
    Mixture,
}

/// Arguments of `init`.
#[derive(Args, Debug)]
pub struct InitArgs {
    /// Which sample scene.
    #[arg(value_enum, default_value_t = Kind::Spheres)]
    kind: Kind,
    /// Write the scene to this file (refuses to overwrite) instead of stdout.
    #[arg(long)]
    out: Option<PathBuf>,
}

const SPHERES: &str = include_str!("../../examples/scenes/sample_spheres.toml");
/// Written by `densepack take B16 --phi-m 0.7 --d-min 4 --box 50,50,50 --seed 1 --scene ..`
/// (a test checks that the command still writes exactly this file).
const CONCRETE: &str = include_str!("../../examples/scenes/concrete_b16_50mm.toml");
const ELLIPSOIDS: &str = include_str!("../../examples/scenes/sample_ellipsoids.toml");
const MIXTURE: &str = include_str!("../../examples/scenes/sample_mixture.toml");

/// Runs `init`.
pub fn run(args: &InitArgs) -> ExitCode {
    let text = match args.kind {
        Kind::Spheres => SPHERES,
        Kind::Concrete => CONCRETE,
        Kind::Ellipsoids => ELLIPSOIDS,
        Kind::Mixture => MIXTURE,
    };
    match &args.out {
        None => {
            out!("{text}");
            ExitCode::SUCCESS
        }
        Some(path) if path.exists() => {
            errln!("error: {} exists; not overwritten", path.display());
            ExitCode::from(2)
        }
        Some(path) => match super::paths::check_outputs(&[("--out", path)], &[])
            .map_err(|e| (e, 2))
            .and_then(|()| {
                write_atomically(path, |w| w.write_all(text.as_bytes()))
                    .map_err(|e| (format!("{}: {e}", path.display()), 1))
            }) {
            Ok(()) => {
                outln!(
                    "wrote {} (run it with: densepack run {0} --out packing.json)",
                    path.display()
                );
                ExitCode::SUCCESS
            }
            Err((e, code)) => {
                errln!("error: {e}");
                ExitCode::from(code)
            }
        },
    }
}
