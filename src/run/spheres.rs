//! Sphere scenes (those without `[particles.ellipsoid]`): seeding by random sequential
//! addition (a `method = "rsa"` scene ends there), and the written spheres of a finished
//! kernel (at their true sizes with the gap a gap stage opened).

use super::stages::{finish, gap_opened, kernel_config, Placed, StagesDone};
use super::{Job, RunError, SceneContainer, Seeded, ShapeRun};
use crate::boundary::Boundary;
use crate::io::packing::Packing;
use crate::io::packing::PackingStats;
use crate::io::scene::{Method, Scene, StartPacking};
use crate::kernel::Edmd;
use crate::protocol::rsa::rsa_spheres;
use crate::queue::EventQueue;
use crate::shape::{Collidable, Sphere, Vec3};
use rand_xoshiro::Xoshiro256PlusPlus;

/// Spheres ([`Sphere`]): the kinds of scene without `[particles.ellipsoid]`.
pub(super) struct Spheres;

impl ShapeRun for Spheres {
    type Shape = Sphere;

    fn seed<B: Boundary + SceneContainer, Q: EventQueue>(
        scene: &Scene,
        job: &Job,
        true_diameters: Vec<f64>,
        start: Option<&StartPacking>,
        boundary: B,
        rng: &mut Xoshiro256PlusPlus,
        started: std::time::Instant,
    ) -> Result<Seeded<Sphere, B, Q>, RunError> {
        if let Some(start) = start {
            let centres = start_centres(scene, start, &boundary)?;
            let shapes = start.radii.iter().map(|&r| Sphere::new(r)).collect();
            let kernel = Edmd::new(centres, shapes, boundary, kernel_config(scene), rng);
            return Ok(Seeded::Kernel(kernel, started.elapsed().as_secs_f64()));
        }
        let scale = scene.seed_scale(&true_diameters);
        let radii: Vec<f64> = true_diameters.iter().map(|d| 0.5 * scale * d).collect();
        drop(true_diameters);
        let (rsa_gap, rsa_wall_gap) = match scene.method {
            Method::Rsa => {
                let gap = scene.particles.gap.unwrap_or(0.0);
                (gap, scene.particles.wall_gap.unwrap_or(0.5 * gap))
            }
            Method::Edmd => (0.0, 0.0),
        };
        let centres = rsa_spheres(
            &boundary,
            &radii,
            rsa_gap,
            rsa_wall_gap,
            scene.particles.rsa_max_failures,
            job.cancel.as_deref(),
            rng,
        )?;
        let seeding_seconds = started.elapsed().as_secs_f64();
        if scene.method == Method::Rsa {
            let placed = Placed::spheres(
                &boundary,
                centres,
                &radii,
                rsa_gap,
                scene.particles.wall_gap,
            );
            let stats = PackingStats {
                wall_seconds: started.elapsed().as_secs_f64(),
                stop_reason: "rsa_complete".into(),
                ..PackingStats::default()
            };
            let container = boundary.record();
            return finish(
                job.scene,
                container,
                &boundary,
                placed,
                stats,
                Vec::new(),
                seeding_seconds,
            )
            .map(Seeded::Finished);
        }
        // `radii` is freed before the kernel allocates its arrays.
        let shapes = radii.into_iter().map(Sphere::new).collect();
        let kernel = Edmd::new(centres, shapes, boundary, kernel_config(scene), rng);
        Ok(Seeded::Kernel(kernel, seeding_seconds))
    }

    fn packing<B: Boundary, Q: EventQueue>(
        kernel: Edmd<Sphere, B, Q>,
        original: &B,
        true_diameters: &dyn Fn() -> Vec<f64>,
        done: &StagesDone,
    ) -> (Placed, Vec<(String, serde_json::Value)>) {
        // The kernel's other arrays are freed before the output is built, so that the output
        // and the verification's own index do not add to the kernel's peak memory.
        let particles = kernel.into_particles();
        let centres: Vec<Vec3> = particles.iter().map(|p| p.pos).collect();
        let grown_radii: Vec<f64> = particles
            .iter()
            .map(|p| p.shape.bounding_radius(0.0))
            .collect();
        drop(particles);
        let (radii, min_gap, wall_gap) = match done.wall_gap_fraction {
            // The gap stage starts at the true sizes (validation requires it) and every radius
            // grows by the same at the absolute rate; the guaranteed gap is the gap opened by
            // the smallest growth (they differ only by rounding), and the walls kept the
            // fraction λ of it (`Stage::wall_growth`). The true radii come from the seed, so a
            // resumed run writes the same.
            Some(fraction) => {
                let true_radii: Vec<f64> = true_diameters().iter().map(|d| 0.5 * d).collect();
                let grown = grown_radii
                    .iter()
                    .zip(&true_radii)
                    .map(|(g, t)| g - t)
                    .fold(f64::INFINITY, f64::min)
                    .max(0.0);
                // A gap stage overshoots its Δd by a hair (`GAP_TIME_MARGIN`), so every
                // grain grew by at least Δd/2 and the packing keeps the requested Δd: that is
                // the claim written (a script testing `min_gap >= 0.5` after `gap = 0.5`
                // holds). Should rounding ever leave a grain short, the measured gap is
                // written instead; the verification checks either claim.
                let opened = gap_opened(grown);
                let min_gap = match done.requested_gap {
                    Some(requested) if opened >= requested => requested,
                    _ => opened,
                };
                let wall_gap = (fraction != 0.5).then_some(fraction * min_gap);
                (true_radii, min_gap, wall_gap)
            }
            None => (grown_radii, 0.0, None),
        };
        let placed = Placed::spheres(original, centres, &radii, min_gap, wall_gap);
        let extra = if done.gap_history.is_empty() {
            Vec::new()
        } else {
            vec![("gap_history".into(), serde_json::json!(done.gap_history))]
        };
        (placed, extra)
    }
}

/// The centres of the packing a scene starts from, once the independent check
/// ([`crate::verify`]) has found its spheres apart and inside the container: the kernel
/// predicts from non-overlapping pairs only, so an overlap within the check's rounding
/// tolerance is refused as well. The message names the file and the first violation.
fn start_centres<B: Boundary + SceneContainer>(
    scene: &Scene,
    start: &StartPacking,
    boundary: &B,
) -> Result<Vec<Vec3>, RunError> {
    let from = scene.particles.from.as_deref().unwrap_or("");
    let particles = start
        .centres
        .iter()
        .zip(&start.radii)
        .map(|(c, &radius)| crate::io::packing::ParticleRecord::sphere(*c, radius))
        .collect();
    let check = crate::verify::verify(&Packing::new(boundary.record(), particles));
    let refuse = |what: String| {
        RunError::Start(format!(
            "particles.from: {from}: {what}; a run starts from spheres that neither overlap \
             nor cross a wall (`densepack verify` lists them; shrink the radii to start)"
        ))
    };
    if check.violation_count > 0 {
        return Err(refuse(format!(
            "{} violations, the first: {}",
            check.violation_count,
            check.violations.first().map_or("", String::as_str)
        )));
    }
    if let Some(g) = check.min_pair_gap.filter(|&g| g < 0.0) {
        return Err(refuse(format!("two spheres overlap by {:.3e}", -g)));
    }
    if let Some(g) = check.min_wall_gap.filter(|&g| g < 0.0) {
        return Err(refuse(format!("a sphere crosses a wall by {:.3e}", -g)));
    }
    Ok(start.centres.iter().map(|&c| Vec3::from(c)).collect())
}
