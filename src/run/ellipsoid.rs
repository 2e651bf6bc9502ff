//! Running an ellipsoid scene (paper 004): seeding by random sequential addition of the
//! bounding spheres with uniformly random orientations, the scene's stages (with checkpoints
//! and resume as for spheres: the snapshot holds every orientation and angular velocity), the
//! orientation tensor, and the independent verification.

use super::stages::{kernel_config, Placed, StagesDone};
use super::{dispatch_box, Job, RunError, RunOutcome, SceneContainer, Seeded, ShapeRun};
use crate::boundary::Boundary;
use crate::io::packing::ParticleRecord;
use crate::io::record::EllipsoidRecord;
use crate::io::scene::{ContainerSpec, EllipsoidSpec, Scene, StartPacking};
use crate::kernel::{Edmd, Progress, StageReport};
use crate::protocol::rsa::rsa_spheres;
use crate::queue::EventQueue;
use crate::shape::ellipsoid::Spin;
use crate::shape::{Ellipsoid, Vec3};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion};
use rand::Rng;
use rand_distr::StandardNormal;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Runs a validated scene whose `[particles.ellipsoid]` is set.
pub(super) fn run_ellipsoid_scene(
    scene: &Scene,
    job: &Job,
    on_stage: &mut dyn FnMut(usize, &StageReport),
    on_progress: &mut dyn FnMut(usize, &Progress),
) -> Result<RunOutcome, RunError> {
    let ContainerSpec::Box { size, periodic, .. } = &scene.container else {
        return Err(RunError::Unsupported(
            "ellipsoids need a box container (container.type = \"box\")".into(),
        ));
    };
    // Relative to the box's corner, as every kernel (`super::container_origin`).
    dispatch_box::<Ellipsoids>(scene, job, size, periodic, on_stage, on_progress)
}

/// Ellipsoids ([`Ellipsoid`]): the scenes with `[particles.ellipsoid]`.
struct Ellipsoids;

/// Semi-axes of every particle at seeding: volume-equivalent `diameters`, aspect ratios
/// fixed or drawn uniformly from their ranges.
fn semi_axes_of<R: Rng>(diameters: &[f64], spec: &EllipsoidSpec, rng: &mut R) -> Vec<Vec3> {
    diameters
        .iter()
        .map(|&d| {
            let [r1, r2] = match (spec.aspect_ratios, spec.aspect_ratio_ranges) {
                (Some(r), _) => r,
                (None, Some([[a0, a1], [b0, b1]])) => [
                    a0 + (a1 - a0) * rng.gen::<f64>(),
                    b0 + (b1 - b0) * rng.gen::<f64>(),
                ],
                (None, None) => [1.0, 1.0],
            };
            Vec3::from(EllipsoidSpec::semi_axes(d, r1, r2))
        })
        .collect()
}

/// A uniformly distributed rotation (normalised 4-vector of standard normals).
fn random_orientation<R: Rng>(rng: &mut R) -> UnitQuaternion<f64> {
    loop {
        let q = Quaternion::new(
            rng.sample::<f64, _>(StandardNormal),
            rng.sample::<f64, _>(StandardNormal),
            rng.sample::<f64, _>(StandardNormal),
            rng.sample::<f64, _>(StandardNormal),
        );
        if q.norm() > 1e-6 {
            return UnitQuaternion::from_quaternion(q);
        }
    }
}

impl ShapeRun for Ellipsoids {
    type Shape = Ellipsoid;

    /// Bounding spheres of the seeding sizes placed by RSA, uniformly random orientations,
    /// thermal velocities (all drawn from `rng` after the true diameters).
    fn seed<B: Boundary + SceneContainer, Q: EventQueue>(
        scene: &Scene,
        job: &Job,
        true_diameters: Vec<f64>,
        // Validation refuses `particles.from` with ellipsoids.
        _start: Option<&StartPacking>,
        boundary: B,
        rng: &mut Xoshiro256PlusPlus,
        started: std::time::Instant,
    ) -> Result<Seeded<Ellipsoid, B, Q>, RunError> {
        let spec = scene
            .particles
            .ellipsoid
            .as_ref()
            .expect("an ellipsoid scene");
        let scale = scene.seed_scale(&true_diameters);
        let seeding: Vec<f64> = true_diameters.iter().map(|d| scale * d).collect();
        drop(true_diameters);
        let axes = semi_axes_of(&seeding, spec, rng);
        drop(seeding);
        let bounding: Vec<f64> = axes.iter().map(|a| a.max()).collect();
        let centres = rsa_spheres(
            &boundary,
            &bounding,
            0.0,
            0.0,
            scene.particles.rsa_max_failures,
            job.cancel.as_deref(),
            rng,
        )?;
        drop(bounding);
        let seeding_seconds = started.elapsed().as_secs_f64();
        let spins: Vec<Spin> = (0..axes.len())
            .map(|_| Spin {
                orientation: random_orientation(rng),
                omega: Vec3::zeros(),
            })
            .collect();
        let shapes = axes
            .iter()
            .map(|a| Ellipsoid {
                predictor: spec.predictor,
                contact_tolerance: spec.contact_tolerance,
                ..Ellipsoid::new(*a)
            })
            .collect();
        let kernel = Edmd::with_spins(centres, shapes, spins, boundary, kernel_config(scene), rng);
        Ok(Seeded::Kernel(kernel, seeding_seconds))
    }

    fn packing<B: Boundary, Q: EventQueue>(
        kernel: Edmd<Ellipsoid, B, Q>,
        original: &B,
        _true_diameters: &dyn Fn() -> Vec<f64>,
        done: &StagesDone,
    ) -> (Placed, Vec<(String, serde_json::Value)>) {
        // Back to the order of the seeding, which the kernel permutes for cache locality.
        let mut order: Vec<u32> = vec![0; kernel.particles().len()];
        for (k, &id) in kernel.original_indices().iter().enumerate() {
            order[id as usize] = k as u32;
        }
        let particles: Vec<ParticleRecord> = order
            .iter()
            .map(|&k| {
                let p = &kernel.particles()[k as usize];
                let q = p.spin.orientation;
                ParticleRecord::Ellipsoid(EllipsoidRecord {
                    center: p.pos.into(),
                    semi_axes: p.shape.semi_axes(0.0).into(),
                    orientation: [q.w, q.i, q.j, q.k],
                })
            })
            .collect();
        let volume = kernel.packing_fraction_at(0.0) * original.volume();
        drop(kernel);
        let (tensor, ratio) = orientation_tensor(&particles);
        // Over the whole run, a resumed one included (the counters are in the checkpoint).
        let failures: u64 = done
            .reports
            .iter()
            .map(|r| r.counts.prediction_failures)
            .sum();
        let extra = vec![
            ("orientation_tensor".into(), serde_json::json!(tensor)),
            (
                "orientation_eigenvalue_ratio".into(),
                serde_json::json!(ratio),
            ),
            (
                "ellipsoid_prediction_failures".into(),
                serde_json::json!(failures),
            ),
        ];
        let placed = Placed {
            particles,
            volume,
            min_gap: 0.0,
            wall_gap: None,
        };
        (placed, extra)
    }
}

/// The second-order orientation tensor `T = ⟨w wᵀ⟩` of the ellipsoids' `a` axes (body x,
/// paper 004 Eq. 1; `w` is the direction of Eq. 1b/33 up to sign, which `T` ignores) and the
/// ratio `ρ = λ_max/λ_min` of its eigenvalues (1 for perfect isotropy, `T = I/3`).
pub fn orientation_tensor(particles: &[ParticleRecord]) -> ([[f64; 3]; 3], f64) {
    axis_tensor(particles.iter().filter_map(|p| match p {
        ParticleRecord::Ellipsoid(EllipsoidRecord { orientation, .. }) => {
            let [w, x, y, z] = *orientation;
            Some(UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z)) * Vec3::x())
        }
        _ => None,
    }))
}

/// `T = ⟨w wᵀ⟩` of unit vectors `w` and its eigenvalue ratio `ρ = λ_max/λ_min` (zeros and
/// NaN for no vectors): [`orientation_tensor`] of given axes, e.g. of independent uniform
/// directions, the reference `ρ̄` of a perfectly isotropic set of the same size.
pub fn axis_tensor(axes: impl Iterator<Item = Vec3>) -> ([[f64; 3]; 3], f64) {
    let mut t = Matrix3::<f64>::zeros();
    let mut n = 0usize;
    for axis in axes {
        t += axis * axis.transpose();
        n += 1;
    }
    if n == 0 {
        return ([[0.0; 3]; 3], f64::NAN);
    }
    t /= n as f64;
    let eig = t.symmetric_eigenvalues();
    let ratio = eig.max() / eig.min();
    (
        std::array::from_fn(|i| std::array::from_fn(|j| t[(i, j)])),
        ratio,
    )
}
