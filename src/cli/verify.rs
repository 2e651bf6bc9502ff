//! `densepack verify PACKING.json`: the independent check and a description of the packing.

use densepack::analysis::{gap_histogram, sieve_curve, SievePoint};
use densepack::io::packing::{Packing, ParticleRecord};
use densepack::protocol::take_phase::GradingCurve;
use densepack::verify::VerifyOptions;
use std::path::Path;
use std::process::ExitCode;

/// The sieve curve of `packing` against the grading curve `grading` (a DIN name,
/// `fuller:Q:D_MAX` or a TOML file with a `grading` table) cut off at `d_min` (default: the
/// smallest particle): the curve's name, `d_min`, the points and the largest deviation.
pub fn sieve_against(
    packing: &Packing,
    grading: &str,
    d_min: Option<f64>,
) -> Result<(String, f64, Vec<SievePoint>, f64), String> {
    let (curve, name) = super::take::curve_of(grading)?;
    sieve_against_curve(packing, &curve, name, d_min)
}

/// [`sieve_against`] for a curve already built.
pub fn sieve_against_curve(
    packing: &Packing,
    curve: &GradingCurve,
    name: String,
    d_min: Option<f64>,
) -> Result<(String, f64, Vec<SievePoint>, f64), String> {
    let smallest = packing
        .particles
        .iter()
        .map(ParticleRecord::sieve_diameter)
        .fold(f64::INFINITY, f64::min);
    let d_min = d_min.unwrap_or(smallest);
    if !(d_min > 0.0 && d_min < curve.d_max()) {
        return Err(format!(
            "--d-min = {d_min} must be > 0 and below the curve's d_max = {}",
            curve.d_max()
        ));
    }
    let (points, worst) = sieve_curve(packing, curve, d_min);
    Ok((name, d_min, points, worst))
}

/// How a smallest gap relative to the radii reads against the tolerance: an overlap beyond
/// it, a contact within it, or nothing to add.
fn verdict(relative: Option<f64>, tolerance: f64) -> &'static str {
    match relative {
        Some(g) if g < -tolerance => ": overlap",
        Some(g) if g < 0.0 => ": within the tolerance",
        _ => "",
    }
}

/// Runs `verify` with relative tolerance `tolerance`; exit 1 on a violated constraint, 2 on
/// an unreadable or malformed packing or curve.
pub fn run(
    path: &Path,
    json: bool,
    grading: Option<&str>,
    d_min: Option<f64>,
    tolerance: f64,
) -> ExitCode {
    let packing = match Packing::read(path) {
        Ok(p) => p,
        Err(e) => {
            errln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let sieve = match grading.map(|text| sieve_against(&packing, text, d_min)) {
        None => None,
        Some(Ok(s)) => Some(s),
        Some(Err(e)) => {
            errln!("error: {e}");
            return ExitCode::from(2);
        }
    };
    let v = densepack::verify::verify_with(&packing, &VerifyOptions { tolerance });
    let histogram = gap_histogram(&v.nearest_gap_relative);
    if json {
        let mut value = serde_json::to_value(&v).expect("serialisable");
        value["gap_histogram"] = serde_json::json!(histogram);
        if let Some((name, d_min, points, worst)) = &sieve {
            value["sieve"] = serde_json::json!({
                "curve": name, "d_min": d_min, "points": points, "max_deviation": worst,
            });
        }
        outln!(
            "{}",
            serde_json::to_string_pretty(&value).expect("serialisable")
        );
    } else {
        outln!(
            "particles {}  packing_fraction {:.6}  tolerance {:e} (relative)",
            v.particles,
            v.packing_fraction,
            v.tolerance
        );
        outln!(
            "min pair gap {:.3e} (relative {:.3e}{})  min wall gap {}",
            v.min_pair_gap.unwrap_or(f64::NAN),
            v.min_pair_gap_relative.unwrap_or(f64::NAN),
            verdict(v.min_pair_gap_relative, v.tolerance),
            match (v.min_wall_gap, v.min_wall_gap_relative) {
                (Some(g), Some(r)) => format!(
                    "{g:.3e} (relative {r:.3e}{})",
                    verdict(Some(r), v.tolerance)
                ),
                _ => "none".into(),
            }
        );
        outln!(
            "violations {} (overlaps {}, gap claims {})",
            v.violation_count,
            v.overlap_count,
            v.gap_claim_count
        );
        for msg in &v.violations {
            outln!("  {msg}");
        }
        outln!("nearest relative gap per particle (|c_i − c_j|/(r_i + r_j) − 1):");
        for b in histogram.iter().filter(|b| b.count > 0) {
            outln!("  [{:>8.0e}, {:>8.0e})  {}", b.lo, b.hi, b.count);
        }
        if let Some((name, d_min, points, worst)) = &sieve {
            outln!("sieve curve against {name}, cut off at d_min = {d_min}:");
            outln!("  {:>10}  {:>9}  {:>9}", "sieve", "passing", "target");
            for p in points {
                outln!("  {:>10.4}  {:>9.4}  {:>9.4}", p.size, p.passing, p.target);
            }
            outln!("  largest deviation {worst:.4}");
        }
    }
    if v.ok() {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(1)
    }
}
