//! Running an ellipsoid scene (paper 004): seeding by random sequential addition of the
//! bounding spheres with uniformly random orientations, the scene's stages, the orientation
//! tensor, and the independent verification.

use super::{
    kernel_config, packing_of, run_stages, verified, ContainerRecordOf, RunError, RunOutcome,
};
use crate::boundary::{Boundary, PeriodicBox, WalledBox};
use crate::io::packing::ParticleRecord;
use crate::io::scene::{ContainerSpec, EllipsoidSpec, Scene};
use crate::kernel::{Edmd, StageReport};
use crate::protocol::rsa::rsa_spheres;
use crate::queue::{CalendarQueue, EventQueue, HeapQueue, QueueKind};
use crate::shape::{prediction_failures, Ellipsoid, Spin, Vec3};
use nalgebra::{Matrix3, Quaternion, UnitQuaternion};
use rand::{Rng, SeedableRng};
use rand_distr::StandardNormal;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Runs a validated scene whose `[particles.ellipsoid]` is set.
pub(super) fn run_ellipsoid_scene(
    scene: &Scene,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<RunOutcome, RunError> {
    let ContainerSpec::Box {
        min,
        size,
        periodic,
    } = &scene.container
    else {
        return Err(RunError::Unsupported(
            "ellipsoids need a box container (container.type = \"box\")".into(),
        ));
    };
    let min = Vec3::from(*min);
    let len = Vec3::from(*size);
    if periodic.iter().all(|&p| p) {
        dispatch_queue(scene, PeriodicBox { min, len }, on_stage)
    } else {
        let walled = WalledBox {
            min,
            max: min + len,
            periodic: *periodic,
        };
        dispatch_queue(scene, walled, on_stage)
    }
}

fn dispatch_queue<B: Boundary + ContainerRecordOf>(
    scene: &Scene,
    boundary: B,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<RunOutcome, RunError> {
    match scene.queue {
        QueueKind::Heap => run_with::<B, HeapQueue>(scene, boundary, on_stage),
        QueueKind::Calendar => run_with::<B, CalendarQueue>(scene, boundary, on_stage),
    }
}

/// Semi-axes of every particle: volume-equivalent diameters from the scene, aspect ratios
/// fixed or drawn uniformly from their ranges.
fn semi_axes_of<R: Rng>(scene: &Scene, spec: &EllipsoidSpec, rng: &mut R) -> Vec<Vec3> {
    scene
        .seeding_diameters()
        .into_iter()
        .map(|d| {
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

fn run_with<B: Boundary + ContainerRecordOf, Q: EventQueue>(
    scene: &Scene,
    boundary: B,
    on_stage: &mut dyn FnMut(usize, &StageReport),
) -> Result<RunOutcome, RunError> {
    let spec = scene
        .particles
        .ellipsoid
        .as_ref()
        .expect("an ellipsoid scene");
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(scene.seed);
    let axes = semi_axes_of(scene, spec, &mut rng);
    let bounding: Vec<f64> = axes.iter().map(|a| a.max()).collect();
    let centres = rsa_spheres(
        &boundary,
        &bounding,
        0.0,
        scene.particles.rsa_max_failures,
        &mut rng,
    )?;
    let spins: Vec<Spin> = (0..axes.len())
        .map(|_| Spin {
            orientation: random_orientation(&mut rng),
            omega: Vec3::zeros(),
        })
        .collect();
    let shapes = axes
        .iter()
        .map(|a| Ellipsoid {
            predictor: spec.predictor,
            ..Ellipsoid::new(*a)
        })
        .collect();
    let failures_before = prediction_failures();
    let mut kernel: Edmd<Ellipsoid, B, Q> = Edmd::with_spins(
        centres,
        shapes,
        spins,
        boundary,
        kernel_config(scene),
        &mut rng,
    );
    let reports = run_stages(scene, &mut kernel, on_stage)?;
    let mut packing = packing_of(scene, &kernel, &reports, |p| {
        let q = p.spin.orientation;
        ParticleRecord::Ellipsoid {
            center: p.pos.into(),
            semi_axes: p.shape.semi_axes(0.0).into(),
            orientation: [q.w, q.i, q.j, q.k],
        }
    });
    drop(kernel);
    let (tensor, ratio) = orientation_tensor(&packing.particles);
    let extra = &mut packing.stats.extra;
    extra.insert("orientation_tensor".into(), serde_json::json!(tensor));
    extra.insert(
        "orientation_eigenvalue_ratio".into(),
        serde_json::json!(ratio),
    );
    extra.insert(
        "ellipsoid_prediction_failures".into(),
        serde_json::json!(prediction_failures() - failures_before),
    );
    verified(packing, reports)
}

/// The second-order orientation tensor `T = ⟨w wᵀ⟩` of the ellipsoids' `a` axes (body x,
/// paper 004 Eq. 1; `w` is the direction of Eq. 1b/33 up to sign, which `T` ignores) and the
/// ratio `ρ = λ_max/λ_min` of its eigenvalues (1 for perfect isotropy, `T = I/3`).
pub fn orientation_tensor(particles: &[ParticleRecord]) -> ([[f64; 3]; 3], f64) {
    let mut t = Matrix3::<f64>::zeros();
    let mut n = 0usize;
    for p in particles {
        if let ParticleRecord::Ellipsoid { orientation, .. } = p {
            let [w, x, y, z] = *orientation;
            let q = UnitQuaternion::from_quaternion(Quaternion::new(w, x, y, z));
            let axis = q * Vec3::x();
            t += axis * axis.transpose();
            n += 1;
        }
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
