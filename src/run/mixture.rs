//! Sphere + cylinder mixtures (no EDMD kernel, see `protocol::mixture`): RSA or a random
//! start and the relaxer, the packing record, the independent check.

use super::stages::provenance;
use super::{RunError, RunOutcome, SceneContainer};
use crate::boundary::Boundary;
use crate::geometry::cylinder::Shape;
use crate::io::packing::{Packing, PackingStats, ParticleRecord, Timings};
use crate::io::record::{CylinderRecord, SphereRecord};
use crate::protocol::mixture::Rve;
use crate::verify::verify;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use std::sync::atomic::AtomicBool;

/// The packing record of a mixture configuration (periodic box, wrapped centres).
/// `reduced_pressure` is 0 (no pressure is measured without event-driven dynamics),
/// `events` counts RSA candidates or relaxer steps.
pub fn mixture_packing(
    rve: &Rve,
    seed: u64,
    wall_seconds: f64,
    method: &str,
    mut extra: serde_json::Map<String, serde_json::Value>,
) -> Packing {
    let (fs, fc) = rve.fractions();
    extra.insert("method".into(), serde_json::json!(method));
    extra.insert("sphere_fraction".into(), serde_json::json!(fs));
    extra.insert("cylinder_fraction".into(), serde_json::json!(fc));
    let events = extra
        .get("candidates")
        .or_else(|| extra.get("steps"))
        .and_then(|v| v.as_u64())
        .unwrap_or(0);
    Packing {
        seed,
        stats: PackingStats {
            packing_fraction: fs + fc,
            events,
            wall_seconds,
            stop_reason: "intersection_free".into(),
            extra,
            ..PackingStats::default()
        },
        ..Packing::new(rve.boundary.record(), records(rve))
    }
}

/// The packing-file records of the bodies of `rve` (centres wrapped into the box): the
/// protocol makes bodies, the runner composes the file.
fn records(rve: &Rve) -> Vec<ParticleRecord> {
    rve.bodies
        .iter()
        .map(|b| {
            let mut c = b.center();
            rve.boundary.wrap(&mut c);
            match b {
                Shape::Sphere(s) => ParticleRecord::Sphere(SphereRecord {
                    center: c.into(),
                    radius: s.radius,
                }),
                Shape::Cylinder(cy) => ParticleRecord::Cylinder(CylinderRecord {
                    center: c.into(),
                    radius: cy.radius,
                    half_axis: cy.half_axis.into(),
                }),
            }
        })
        .collect()
}

/// Runs a validated mixture scene: RSA or random start + relaxer, then the independent
/// check; deterministic for the scene's seed (Xoshiro256++) unless a time limit strikes.
/// `cancel` is checked at every RSA candidate and relaxer step. No stages: the outcome's
/// `stages` is empty.
pub(super) fn run_mixture(
    scene: &crate::io::scene::MixtureScene,
    cancel: Option<&AtomicBool>,
) -> Result<RunOutcome, RunError> {
    use crate::io::scene::MixtureMethod;
    use crate::protocol::mixture::{relax, rsa};
    let spec = scene.spec();
    let boundary = spec.boundary();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(scene.seed);
    let start = std::time::Instant::now();
    let mut extra = serde_json::Map::new();
    let method = scene.mixture.method.as_str();
    let rve = match scene.mixture.method {
        MixtureMethod::Rsa => {
            let sizes = spec.sizes(scene.mixture.order);
            let out = rsa::rsa_mixture(&boundary, &sizes, &scene.rsa_limits(), cancel, &mut rng)
                .map_err(|e| match e {
                    rsa::RsaError::Cancelled => RunError::Cancelled,
                    e => RunError::Adsorption(e),
                })?;
            extra.insert("candidates".into(), serde_json::json!(out.candidates));
            extra.insert("restarts".into(), serde_json::json!(out.restarts));
            out.rve
        }
        MixtureMethod::Md => {
            let sizes = spec.sizes(crate::protocol::mixture::GenerationOrder::CylindersFirst);
            let mut rve = relax::random_rve(&boundary, &sizes, &mut rng);
            let report =
                relax::relax(&mut rve, &scene.relax_settings(), cancel).map_err(|e| match e {
                    relax::RelaxError::Cancelled => RunError::Cancelled,
                    relax::RelaxError::GaveUp(f) => RunError::Relaxation(f),
                })?;
            extra.insert("steps".into(), serde_json::json!(report.steps));
            extra.insert("relax".into(), serde_json::json!(report));
            rve
        }
    };
    let seconds = start.elapsed().as_secs_f64();
    let mut packing = mixture_packing(&rve, scene.seed, seconds, method, extra);
    let verify_started = std::time::Instant::now();
    let verification = verify(&packing);
    if !verification.ok() {
        return Err(RunError::Verification(verification.violations.join("; ")));
    }
    packing.provenance = Some(provenance(
        scene,
        scene.seed,
        Timings {
            seeding_seconds: 0.0,
            stages_seconds: seconds,
            verification_seconds: verify_started.elapsed().as_secs_f64(),
        },
    ));
    Ok(RunOutcome {
        packing,
        stages: Vec::new(),
        verification,
    })
}
