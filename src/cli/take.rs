//! `densepack take CURVE_OR_FILE`: dry run of the take phase (grading curve → sizes).

use clap::Args;
use densepack::io::packing::write_atomically;
use densepack::protocol::take_phase::{
    GradingCurve, GradingSpec, TakeParams, TakePhase, BYTES_PER_PARTICLE,
};
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// Arguments of `take`.
#[derive(Args, Debug)]
pub struct TakeArgs {
    /// Grading curve: a DIN 1045-2 name (A8, B8, C8, A16, B16, C16), `fuller:Q:D_MAX`
    /// (e.g. fuller:0.5:16), or a TOML file with a `grading` table (at the top or under
    /// `[particles]`), e.g. `grading = { kind = "table", sizes = [2, 4, 8], passing = [0, 40, 100] }`.
    curve: String,
    /// Aggregate volume fraction of the mix design φ_M, in (0, 1).
    #[arg(long)]
    phi_m: f64,
    /// Cut-off diameter d_min (mm): smaller grains belong to the mortar.
    #[arg(long)]
    d_min: f64,
    /// Specimen volume (mm³); or give --box or --cylinder.
    #[arg(long, conflicts_with_all = ["r#box", "cylinder"])]
    volume: Option<f64>,
    /// Box specimen edges (mm): X,Y,Z.
    #[arg(long, value_delimiter = ',', conflicts_with = "cylinder")]
    r#box: Option<Vec<f64>>,
    /// Cylinder specimen (mm): RADIUS,HEIGHT.
    #[arg(long, value_delimiter = ',')]
    cylinder: Option<Vec<f64>>,
    /// Seed for drawing the diameters (--sizes, --scene).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Write the drawn diameters (mm) to this file.
    #[arg(long)]
    sizes: Option<PathBuf>,
    /// Write a runnable scene with the drawn diameters (walled box from --box, or cylinder
    /// from --cylinder): seeded at a lower fraction, then grown back exactly to the drawn
    /// sizes.
    #[arg(long)]
    scene: Option<PathBuf>,
    /// Print the summary as JSON.
    #[arg(long)]
    json: bool,
}

/// Text of a runnable scene that draws the same grains (same curve, φ_M, d_min, specimen and
/// seed: the run's take phase repeats this draw), seeds them by random sequential addition
/// at δ = 0.9 of their size and grows them back to their true sizes (`full_size`). The
/// drawn `diameters` and their fraction `phi` are quoted in its header.
pub fn scene_text(
    args: &TakeArgs,
    name: &str,
    spec: &GradingSpec,
    diameters: &[f64],
    phi: f64,
) -> Result<String, String> {
    use std::fmt::Write as _;
    let container = match (&args.r#box, &args.cylinder) {
        (Some(b), None) if b.len() == 3 => format!(
            "type = \"box\"\nsize = [{:?}, {:?}, {:?}]\nperiodic = [false, false, false]   # concrete specimen: rigid walls",
            b[0], b[1], b[2]
        ),
        (None, Some(c)) if c.len() == 2 => format!(
            "type = \"cylinder\"\nradius = {:?}\nheight = {:?}",
            c[0], c[1]
        ),
        _ => return Err("--scene needs the specimen as --box X,Y,Z or --cylinder R,H".into()),
    };
    let grading = toml::Value::try_from(spec).map_err(|e| e.to_string())?;
    let mut t = String::new();
    let _ = writeln!(
        t,
        "# densepack scene written by `densepack take {} --phi-m {} --d-min {} --seed {}`.\n\
         # Grading curve: {name}. The take phase (Algorithm 1) draws {} aggregates, φ = {phi:.6},\n\
         # the same for this seed on every run. Lengths in mm. Seeded by RSA at 0.9 of the\n\
         # true diameters, then grown at a relative rate until all reach their true size.\n",
        args.curve,
        args.phi_m,
        args.d_min,
        args.seed,
        diameters.len()
    );
    let _ = writeln!(
        t,
        "seed = {}\nmass = \"volume\"\n\n[container]\n{container}\n",
        args.seed
    );
    let _ = writeln!(
        t,
        "[particles]\ngrading = {grading}\nmixture_fraction = {:?}\nd_min = {:?}\n",
        args.phi_m, args.d_min
    );
    let _ = writeln!(
        t,
        "[[stage]]\ngrowth = \"relative\"\nrate = 0.05\nuntil = {{ full_size = true }}\n\
         max_wall_seconds = 3600"
    );
    densepack::io::scene::Scene::from_toml(&t)
        .map_err(|e| format!("the scene for these sizes is not runnable: {e}"))?;
    Ok(t)
}

/// Parses a grading curve given as a DIN name, `fuller:Q:D_MAX` or a TOML file with a
/// `grading` table; returns it with a description.
pub fn curve_of(text: &str) -> Result<(GradingCurve, String), String> {
    let (spec, name) = spec_of(text)?;
    let curve = spec.build().map_err(|e| format!("{text}: grading: {e}"))?;
    Ok((curve, name))
}

/// The grading-curve description (as a scene's `particles.grading` holds it) of a DIN name,
/// `fuller:Q:D_MAX` or a TOML file with a `grading` table, with a description.
fn spec_of(text: &str) -> Result<(GradingSpec, String), String> {
    if let Some(spec) = GradingSpec::parse_short(text) {
        let spec = spec?;
        let name = spec.describe();
        return Ok((spec, name));
    }
    let path = Path::new(text);
    if !path.exists() {
        return Err(format!(
            "{text}: not a DIN curve name (A8, B8, C8, A16, B16, C16), not fuller:Q:D_MAX, \
             and no such file"
        ));
    }
    let source = std::fs::read_to_string(path).map_err(|e| format!("{text}: {e}"))?;
    let value: toml::Value = toml::from_str(&source).map_err(|e| format!("{text}: {e}"))?;
    let grading = value
        .get("grading")
        .or_else(|| value.get("particles").and_then(|p| p.get("grading")))
        .ok_or_else(|| format!("{text}: no `grading` table at the top or under [particles]"))?;
    let spec: GradingSpec = grading
        .clone()
        .try_into()
        .map_err(|e| format!("{text}: grading: {e}"))?;
    let name = format!("{text} ({})", spec.describe());
    Ok((spec, name))
}

fn volume_of(args: &TakeArgs) -> Result<f64, String> {
    match (&args.volume, &args.r#box, &args.cylinder) {
        (Some(v), None, None) => Ok(*v),
        (None, Some(b), None) if b.len() == 3 => Ok(b.iter().product()),
        (None, None, Some(c)) if c.len() == 2 => Ok(std::f64::consts::PI * c[0] * c[0] * c[1]),
        _ => Err("give the specimen as --volume V, --box X,Y,Z or --cylinder R,H (mm)".into()),
    }
}

/// Runs `take`.
pub fn run(args: &TakeArgs) -> ExitCode {
    let prepared = spec_of(&args.curve).and_then(|(spec, name)| {
        let curve = spec
            .build()
            .map_err(|e| format!("{}: grading: {e}", args.curve))?;
        let params = TakeParams {
            volume: volume_of(args)?,
            phi_m: args.phi_m,
            d_min: args.d_min,
        };
        let take = TakePhase::new(&curve, params).map_err(|e| e.to_string())?;
        Ok((take, name, spec))
    });
    let (take, name, spec) = match prepared {
        Ok(t) => t,
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let s = take.summary();
    let mut outputs: Vec<super::paths::Named> = Vec::new();
    outputs.extend(args.sizes.as_deref().map(|p| ("--sizes", p)));
    outputs.extend(args.scene.as_deref().map(|p| ("--scene", p)));
    let curve_file = Path::new(&args.curve);
    let inputs: Vec<super::paths::Named> = if curve_file.is_file() {
        vec![("curve file", curve_file)]
    } else {
        Vec::new()
    };
    if let Err(e) = super::paths::check_outputs(&outputs, &inputs) {
        errln!("error: {e}");
        return ExitCode::from(2);
    }
    if !outputs.is_empty() && !densepack::memory::overridden() {
        // The draw holds every diameter (8 B) and, for --sizes, its line of text (≤ 25 B).
        let count = s.expected_count + 4.0 * s.count_std_dev;
        let each = if args.sizes.is_some() { 33 } else { 8 };
        let hint = format!("{}=1", densepack::memory::OVERRIDE_ENV);
        let what = format!("{count:.4e} diameters × {each} B");
        if let Err(e) =
            densepack::memory::check(densepack::memory::estimate(count, each), what, &hint)
        {
            errln!("error: drawing the diameters {e}");
            return ExitCode::from(2);
        }
    }
    let mut drawn = None;
    if args.sizes.is_some() || args.scene.is_some() {
        let diameters = take.sample(&mut Xoshiro256PlusPlus::seed_from_u64(args.seed));
        let volume: f64 = diameters
            .iter()
            .map(|d| std::f64::consts::PI / 6.0 * d.powi(3))
            .sum();
        let phi = volume / s.container_volume;
        drawn = Some((diameters.len(), phi));
        let mut files: Vec<(&PathBuf, String)> = Vec::new();
        if let Some(path) = &args.sizes {
            let text: String = diameters.iter().map(|d| format!("{d}\n")).collect();
            files.push((path, text));
        }
        if let Some(path) = &args.scene {
            match scene_text(args, &name, &spec, &diameters, phi) {
                Ok(text) => files.push((path, text)),
                Err(e) => {
                    errln!("error: {e}");
                    return ExitCode::from(2);
                }
            }
        }
        for (path, text) in files {
            if let Err(e) = write_atomically(path, |w| w.write_all(text.as_bytes())) {
                errln!("error: {}: {e}", path.display());
                return ExitCode::from(1);
            }
        }
    }
    if args.json {
        let json = serde_json::json!({
            "curve": name,
            "container_volume": s.container_volume,
            "phi_m": s.phi_m,
            "d_min": args.d_min,
            "cutoff_fraction": s.cutoff_fraction,
            "phi_eff": s.phi_eff,
            "aggregate_volume": s.aggregate_volume,
            "expected_count": s.expected_count,
            "count_std_dev": s.count_std_dev,
            "smallest_diameter": s.smallest_diameter,
            "largest_diameter": s.largest_diameter,
            "estimated_memory_bytes": s.estimated_memory_bytes,
            "reference_reachable_phi_eff": {"rsa": s.rsa_reachable_phi_eff, "edmd": s.edmd_reachable_phi_eff},
            "drawn": drawn.map(|(n, phi)| serde_json::json!({"seed": args.seed, "count": n, "phi": phi})),
        });
        outln!(
            "{}",
            serde_json::to_string_pretty(&json).expect("serialisable")
        );
    } else {
        outln!("grading curve       {name}");
        outln!(
            "specimen            V = {:.1} mm³, φ_M = {}, d_min = {} mm",
            s.container_volume,
            s.phi_m,
            args.d_min
        );
        outln!(
            "cut-off             F(d_min) = {:.4} of the aggregate mass is mortar",
            s.cutoff_fraction
        );
        outln!(
            "effective fraction  φ_eff = φ_M (1 − F(d_min)) = {:.4} ({:.1} mm³ of aggregate)",
            s.phi_eff,
            s.aggregate_volume
        );
        outln!(
            "particles           N ≈ {:.0} ± {:.0}, diameters {} – {} mm",
            s.expected_count,
            s.count_std_dev,
            s.smallest_diameter,
            s.largest_diameter
        );
        outln!(
            "memory estimate     ≈ {:.1} MB ({BYTES_PER_PARTICLE} bytes per particle)",
            s.estimated_memory_bytes as f64 / 1e6
        );
        outln!(
            "reachable φ_eff     RSA ≈ {}, EDMD ≈ {} (Titscher & Unger, Fuller q = 0.5, 2–16 mm, \
             80 mm walled cube; a reference, not a promise for other curves)",
            s.rsa_reachable_phi_eff,
            s.edmd_reachable_phi_eff
        );
        if s.phi_eff > s.edmd_reachable_phi_eff {
            outln!("warning             φ_eff is above what EDMD reached in that reference");
        }
        if let Some((n, phi)) = drawn {
            outln!(
                "drawn               {n} diameters (seed {}), φ = {phi:.4}",
                args.seed
            );
        }
        for path in [&args.sizes, &args.scene].into_iter().flatten() {
            outln!("wrote               {}", path.display());
        }
    }
    ExitCode::SUCCESS
}
