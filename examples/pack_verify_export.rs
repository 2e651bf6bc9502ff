//! Packs, verifies and exports through the library API: what `densepack run` followed by
//! `densepack verify` and `densepack export` do, in a few lines of Rust.
//!
//! ```sh
//! cargo run --release --example pack_verify_export -- [SCENE.toml] [OUT_DIR]
//! ```
//!
//! Without a scene it packs 2000 equal spheres in a periodic cube (seeded at φ = 0.3, grown
//! to φ = 0.6). It writes `OUT_DIR/packing.json` (the packing format of `densepack run`),
//! `packing.csv`, `packing.vtu` and `packing.container.vtu` (default `OUT_DIR`:
//! `densepack-example` in the system's temporary directory, so that a run leaves the
//! checkout clean). Exit 2 for a
//! scene that cannot be read or is invalid, 1 when the run fails or the packing does not pass
//! the check (nothing is written then).

use densepack::io::export::{csv, vtk};
use densepack::io::scene::Scene;
use std::path::PathBuf;
use std::process::ExitCode;

/// The scene used without an argument.
const DEFAULT_SCENE: &str = r#"
seed = 1
[container]
type = "box"
size = [16.2, 16.2, 16.2]
periodic = [true, true, true]
[particles]
count = 2000
diameter = 1.0
packing_fraction = 0.3
[[stage]]
growth = "relative"
rate = 0.1
until = { packing_fraction = 0.6 }
"#;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let text = match args.first() {
        Some(path) => match std::fs::read_to_string(path) {
            Ok(text) => text,
            Err(e) => {
                eprintln!("error: cannot read scene {path}: {e}");
                return ExitCode::from(2);
            }
        },
        None => DEFAULT_SCENE.to_string(),
    };
    let out_dir = args.get(1).map_or_else(
        || std::env::temp_dir().join("densepack-example"),
        PathBuf::from,
    );

    // 1. Parse and validate: every field is checked before anything runs.
    let scene = match Scene::from_toml(&text) {
        Ok(scene) => scene,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(2);
        }
    };

    // 2. Pack: seeding, the stages, and the run's own final check.
    let outcome = match densepack::run::run_scene(&scene, &mut |stage, report| {
        eprintln!("stage {stage}: {}", report.summary());
    }) {
        Ok(outcome) => outcome,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };

    // 3. Verify: the independent check any packing can be given (here the same as the run's
    //    final check, recomputed from the records alone).
    let check = densepack::verify::verify(&outcome.packing);
    println!(
        "particles {}  packing fraction {:.6}  smallest gap {} of contact  violations {}",
        check.particles,
        check.packing_fraction,
        check
            .min_pair_gap_relative
            .map_or("n/a".to_string(), |g| format!("{g:.3e}")),
        check.violation_count
    );
    if !check.ok() {
        for v in &check.violations {
            eprintln!("violation: {v}");
        }
        return ExitCode::from(1);
    }

    // 4. Export: the packing record, a CSV table and a VTK file for ParaView (each written
    //    atomically).
    if let Err(e) = std::fs::create_dir_all(&out_dir) {
        eprintln!("error: cannot create {}: {e}", out_dir.display());
        return ExitCode::from(2);
    }
    let json = out_dir.join("packing.json");
    let table = out_dir.join("packing.csv");
    let glyphs = out_dir.join("packing.vtu");
    if let Err(e) = outcome.packing.write(&json) {
        eprintln!("error: {e}");
        return ExitCode::from(1);
    }
    let written = csv::write_csv(&outcome.packing, &table)
        .and_then(|()| vtk::write_vtu(&outcome.packing, &glyphs));
    let container = match written {
        Ok(container) => container,
        Err(e) => {
            eprintln!("error: {e}");
            return ExitCode::from(1);
        }
    };
    println!(
        "wrote {}, {}, {} and {}",
        json.display(),
        table.display(),
        glyphs.display(),
        container.display()
    );
    ExitCode::SUCCESS
}
