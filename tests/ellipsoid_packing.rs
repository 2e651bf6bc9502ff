//! Ellipsoid packings through the kernel: conservation laws, the hard-sphere equation of state
//! for spheres treated as ellipsoids, jamming density against the literature, walls, the
//! orientation tensor and scene errors. Every packing is checked by the independent
//! Perram–Wertheim overlap test (`densepack::verify`, run by `run_scene`) and again here.

mod common;

use common::{carnahan_starling, kolafa, recomputed_phi, run_toml};
use densepack::boundary::PeriodicBox;
use densepack::io::packing::{Packing, ParticleRecord};
use densepack::io::record::EllipsoidRecord;
use densepack::io::scene::{Scene, SceneError};
use densepack::kernel::{Edmd, KernelConfig, Limits, RateSchedule, Stage, StopReason, Until};
use densepack::protocol::rsa::rsa_spheres;
use densepack::queue::CalendarQueue;
use densepack::shape::ellipsoid::Spin;
use densepack::shape::{Ellipsoid, Growth, Vec3};
use densepack::verify::verify;
use nalgebra::UnitQuaternion;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

fn scene(body: &str, ellipsoid: &str, stages: &str) -> String {
    format!("{body}\n[particles.ellipsoid]\n{ellipsoid}\n{stages}")
}

/// Zero overlaps by the independent check, and every ellipsoid record well formed.
fn assert_valid(packing: &Packing) {
    let v = verify(packing);
    assert!(v.ok(), "{:?}", v.violations);
    for p in &packing.particles {
        let ParticleRecord::Ellipsoid(EllipsoidRecord { orientation, .. }) = p else {
            panic!("an ellipsoid scene writes ellipsoids");
        };
        let norm: f64 = orientation.iter().map(|x| x * x).sum();
        assert!((norm - 1.0).abs() < 1e-12);
    }
}

#[test]
fn spheres_as_ellipsoids_reproduce_the_hard_sphere_pressure() {
    let text = scene(
        "seed = 21\n[container]\ntype = \"box\"\nsize = [8.0, 8.0, 8.0]\n\
         periodic = [true, true, true]\n[particles]\ncount = 400\ndiameter = 1.0\n\
         packing_fraction = 0.3",
        "aspect_ratios = [1.0, 1.0]",
        "[[stage]]\ngrowth = \"none\"\nuntil = { collisions_per_particle = 50 }\n\
         [[stage]]\ngrowth = \"none\"\nuntil = { collisions_per_particle = 600 }",
    );
    let out = run_toml(&text);
    let phi = 0.3;
    assert!((recomputed_phi(&out.packing) - phi).abs() < 1e-9);
    let z = out.packing.stats.reduced_pressure.expect("dynamics ran");
    let cs = carnahan_starling(phi);
    let k = kolafa(phi);
    eprintln!("φ = {phi:.4}: Z = {z:.4}, Carnahan–Starling {cs:.4}, Kolafa {k:.4}");
    assert!(((z - cs) / cs).abs() < 0.015, "Z = {z} vs CS {cs}");
    assert!(((z - k) / k).abs() < 0.01, "Z = {z} vs Kolafa {k}");
    assert_valid(&out.packing);
}

#[test]
fn collisions_conserve_momentum_and_energy() {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let len = 6.0;
    let boundary = PeriodicBox {
        min: Vec3::zeros(),
        len: Vec3::new(len, len, len),
    };
    // 60 scalene ellipsoids 1 : 0.6 : 0.4 (largest semi-axis 0.5), seeded by their bounding
    // spheres with random orientations, then grown to φ ≈ 0.3.
    let n = 60;
    let shape = Ellipsoid::new(Vec3::new(0.5, 0.3, 0.2));
    let centres = rsa_spheres(
        &boundary,
        &vec![0.5; n],
        0.0,
        0.0,
        1_000_000,
        None,
        &mut rng,
    )
    .unwrap();
    let spins: Vec<Spin> = (0..n)
        .map(|k| Spin {
            orientation: UnitQuaternion::from_scaled_axis(Vec3::new(
                0.3 * k as f64,
                1.1 * k as f64,
                -0.7 * k as f64,
            )),
            omega: Vec3::zeros(),
        })
        .collect();
    let config = KernelConfig {
        mass: densepack::shape::MassRule::Volume,
        ..KernelConfig::default()
    };
    let mut kernel: Edmd<Ellipsoid, PeriodicBox, CalendarQueue> =
        Edmd::with_spins(centres, vec![shape; n], spins, boundary, config, &mut rng);
    let grow = Stage {
        growth: Growth::Relative(0.05),
        schedule: RateSchedule::Fixed,
        until: Until {
            packing_fraction: Some(0.3),
            ..Until::default()
        },
        limits: Limits::default(),
        thermostat: true,
        wall_growth: 1.0,
    };
    assert_eq!(
        kernel.run_stage(&grow).stop_reason,
        StopReason::PackingFractionReached
    );
    let p0 = kernel.momentum();
    let e0 = kernel.kinetic_twice() + kernel.rotational_kinetic_twice();
    let rot0 = kernel.rotational_kinetic_twice();
    let equilibrate = Stage {
        growth: Growth::None,
        schedule: RateSchedule::Fixed,
        until: Until {
            collisions_per_particle: Some(200.0),
            ..Until::default()
        },
        limits: Limits::default(),
        thermostat: false,
        wall_growth: 1.0,
    };
    let report = kernel.run_stage(&equilibrate);
    assert_eq!(report.stop_reason, StopReason::CollisionsReached);
    assert!(report.counts.collisions >= 200 * n as u64);
    let p1 = kernel.momentum();
    let e1 = kernel.kinetic_twice() + kernel.rotational_kinetic_twice();
    let scale = (e0 / n as f64).sqrt();
    assert!((p1 - p0).norm() < 1e-10 * scale * n as f64, "{p0} → {p1}");
    assert!(((e1 - e0) / e0).abs() < 1e-10, "energy {e0} → {e1}");
    // Collisions exchange energy between translation and rotation (equipartition: both
    // hold half of it on average), so the rotational part must have moved.
    let rot1 = kernel.rotational_kinetic_twice();
    assert!(
        rot1 > 0.2 * e1 && rot1 < 0.8 * e1,
        "{rot0} → {rot1} of {e1}"
    );
}

/// Prolate spheroids of aspect ratio 1.5 compressed to jamming land near φ ≈ 0.70–0.72
/// (Donev et al., Science 303, 990 (2004), Fig. 1: maximal jamming density about 0.716 at
/// α = 1.5 for slow compression, lower for fast).
#[test]
fn prolate_spheroids_jam_in_the_literature_range() {
    let text = scene(
        "seed = 3\nqueue = \"calendar\"\n[container]\ntype = \"box\"\nsize = [5.0, 5.0, 5.0]\n\
         periodic = [true, true, true]\n[particles]\ncount = 60\ndiameter = 1.0\n\
         packing_fraction = 0.1",
        "aspect_ratios = [1.5, 1.5]",
        "[[stage]]\ngrowth = \"relative\"\nrate = 0.02\nuntil = { reduced_pressure = 1e7 }",
    );
    let out = run_toml(&text);
    let phi = recomputed_phi(&out.packing);
    eprintln!(
        "jammed at φ = {phi:.4}, Z = {:.3e}",
        out.packing.stats.reduced_pressure.unwrap_or(f64::NAN)
    );
    assert!((0.68..=0.73).contains(&phi), "φ_J = {phi}");
    assert_valid(&out.packing);
}

#[test]
fn ellipsoids_touch_flat_walls_with_their_own_surface() {
    // Oblate ellipsoids (R1 = 3, R2 = 1) grown in a box walled along z: at high pressure
    // some touch the walls, closer than their bounding spheres could.
    let text = scene(
        "seed = 4\n[container]\ntype = \"box\"\nsize = [6.0, 6.0, 3.0]\n\
         periodic = [true, true, false]\n[particles]\ncount = 30\ndiameter = 1.0\n\
         packing_fraction = 0.03",
        "aspect_ratios = [3.0, 1.0]",
        "[[stage]]\ngrowth = \"relative\"\nrate = 0.05\nuntil = { reduced_pressure = 1e4 }",
    );
    let out = run_toml(&text);
    assert_valid(&out.packing);
    let mut closest = f64::INFINITY;
    for p in &out.packing.particles {
        let ParticleRecord::Ellipsoid(EllipsoidRecord {
            center,
            semi_axes,
            orientation,
        }) = p
        else {
            unreachable!()
        };
        let [w, x, y, z] = *orientation;
        let q = UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(w, x, y, z));
        // Half-height along z: √(Σ_k R_zk² a_k²).
        let body_z = q.inverse_transform_vector(&Vec3::z());
        let half = (0..3)
            .map(|k| (body_z[k] * semi_axes[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        let gap = center[2].min(3.0 - center[2]) - half;
        assert!(gap > -1e-9, "pokes through a wall by {gap}");
        let bounding = semi_axes.iter().copied().fold(0.0, f64::max);
        if center[2].min(3.0 - center[2]) < bounding {
            closest = closest.min(gap);
        }
    }
    assert!(
        closest < 1e-3,
        "no ellipsoid reached a wall inside its bounding sphere"
    );
}

#[test]
fn orientations_stay_isotropic_and_aspect_ranges_are_honoured() {
    let text = scene(
        "seed = 9\n[container]\ntype = \"box\"\nsize = [11.0, 11.0, 11.0]\n\
         periodic = [true, true, true]\n[particles]\ncount = 500\ndiameter = 1.0\n\
         packing_fraction = 0.05",
        "aspect_ratio_ranges = [[1.0, 3.0], [1.0, 3.0]]",
        "[[stage]]\ngrowth = \"relative\"\nrate = 0.1\nuntil = { packing_fraction = 0.3 }",
    );
    let out = run_toml(&text);
    assert_valid(&out.packing);
    // The orientation tensor ⟨w wᵀ⟩ of the long (body x) axes, recomputed from the written
    // quaternions, and its eigenvalues in closed form: the statistics must match both.
    let (tensor, eigenvalues) = long_axis_tensor(&out.packing.particles);
    let written = &out.packing.stats.extra["orientation_tensor"];
    for i in 0..3 {
        for j in 0..3 {
            let w = written[i][j].as_f64().unwrap();
            assert!(
                (w - tensor[i][j]).abs() < 1e-12,
                "T[{i}][{j}]: {w} vs {}",
                tensor[i][j]
            );
        }
    }
    let ratio = eigenvalues[2] / eigenvalues[0];
    let written_ratio = out.packing.stats.extra["orientation_eigenvalue_ratio"]
        .as_f64()
        .unwrap();
    assert!(
        (written_ratio - ratio).abs() < 1e-9 * ratio,
        "ρ = {written_ratio} vs {ratio}"
    );
    // 500 uniformly random axes: the eigenvalues of ⟨wwᵀ⟩ scatter by about 0.02 around 1/3
    // (standard deviation √(4/45/500) ≈ 0.013 each), so ρ stays well below 1.35 and every
    // eigenvalue within 0.07 of 1/3 for an isotropic packing; aligned axes would break both.
    assert!(ratio < 1.35, "ρ = {ratio}");
    for l in eigenvalues {
        assert!((l - 1.0 / 3.0).abs() < 0.07, "eigenvalues {eigenvalues:?}");
    }
    for p in &out.packing.particles {
        let ParticleRecord::Ellipsoid(EllipsoidRecord { semi_axes, .. }) = p else {
            unreachable!()
        };
        let [a, b, c] = *semi_axes;
        for r in [a / b, a / c] {
            assert!((1.0 - 1e-9..=3.0 + 1e-9).contains(&r), "aspect ratio {r}");
        }
    }
}

/// `T = ⟨w wᵀ⟩` over the ellipsoids' body x axes `w` (the first column of each quaternion's
/// rotation matrix, written out here) and its eigenvalues in ascending order, by the
/// closed-form trigonometric solution of the characteristic cubic of a symmetric 3×3 matrix.
fn long_axis_tensor(particles: &[ParticleRecord]) -> ([[f64; 3]; 3], [f64; 3]) {
    let mut t = [[0.0; 3]; 3];
    for p in particles {
        let ParticleRecord::Ellipsoid(EllipsoidRecord { orientation, .. }) = p else {
            unreachable!()
        };
        let n = orientation.iter().map(|q| q * q).sum::<f64>().sqrt();
        let [w, x, y, z] = orientation.map(|q| q / n);
        let axis = [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y + w * z),
            2.0 * (x * z - w * y),
        ];
        for i in 0..3 {
            for j in 0..3 {
                t[i][j] += axis[i] * axis[j] / particles.len() as f64;
            }
        }
    }
    // Eigenvalues q + 2p cos(θ + 2πk/3) of B = (T − qI)/p, q = tr T / 3.
    let q = (t[0][0] + t[1][1] + t[2][2]) / 3.0;
    let off = t[0][1].powi(2) + t[0][2].powi(2) + t[1][2].powi(2);
    let p = (((0..3).map(|k| (t[k][k] - q).powi(2)).sum::<f64>() + 2.0 * off) / 6.0).sqrt();
    let b: Vec<Vec<f64>> = (0..3)
        .map(|i| {
            (0..3)
                .map(|j| (t[i][j] - if i == j { q } else { 0.0 }) / p)
                .collect()
        })
        .collect();
    let det = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1])
        - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0])
        + b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
    let theta = (det / 2.0).clamp(-1.0, 1.0).acos() / 3.0;
    let third = 2.0 * std::f64::consts::PI / 3.0;
    let mut eig = [0.0, 1.0, 2.0].map(|k| q + 2.0 * p * (theta + k * third).cos());
    eig.sort_by(f64::total_cmp);
    (t, eig)
}

#[test]
fn bad_ellipsoid_scenes_name_the_field() {
    let base = "seed = 1\n[container]\ntype = \"box\"\nsize = [10.0, 10.0, 10.0]\n\
                periodic = [true, true, true]\n[particles]\ncount = 10\ndiameter = 1.0\n\
                packing_fraction = 0.01";
    let stage = "[[stage]]\ngrowth = \"relative\"\nrate = 0.1\nuntil = { packing_fraction = 0.2 }";
    let field = |ellipsoid: &str, body: &str| match Scene::from_toml(&scene(body, ellipsoid, stage))
    {
        Err(SceneError::Invalid { field, .. }) => field,
        other => panic!("expected an invalid field, got {other:?}"),
    };
    assert_eq!(
        field("aspect_ratios = [0.0, 2.0]", base),
        "particles.ellipsoid.aspect_ratios[0]"
    );
    assert_eq!(
        field("aspect_ratio_ranges = [[2.0, 1.0], [1.0, 1.0]]", base),
        "particles.ellipsoid.aspect_ratio_ranges[0]"
    );
    assert_eq!(
        field(
            "aspect_ratios = [2.0, 2.0]\naspect_ratio_ranges = [[1.0, 2.0], [1.0, 2.0]]",
            base
        ),
        "particles.ellipsoid"
    );
    // Needles of aspect ratio 10 grown to φ = 0.2 in this box would be longer than its edge.
    assert_eq!(
        field("aspect_ratios = [10.0, 10.0]", base),
        "container.size"
    );
    assert_eq!(
        field("aspect_ratios = [2.0, 2.0]\ncontact_tolerance = 0.1", base),
        "particles.ellipsoid.contact_tolerance"
    );
    let cylinder = "seed = 1\n[container]\ntype = \"cylinder\"\nradius = 5.0\nheight = 10.0\n\
                    [particles]\ncount = 10\ndiameter = 1.0\npacking_fraction = 0.01";
    assert_eq!(
        field("aspect_ratios = [2.0, 2.0]", cylinder),
        "container.type"
    );
    // Unknown keys are refused.
    assert!(matches!(
        Scene::from_toml(&scene(base, "aspect_ratio = [2.0, 2.0]", stage)),
        Err(SceneError::Parse(_))
    ));
}

/// Paper 004, Table 2, prolate R1 = R2 = 10 at the paper's N = 90 to φ = 0.30: the needles grow
/// longer than half the box edge (the kernel tracks periodic images), and the packing has no
/// overlap by the independent check, which tests every image and self-image.
#[test]
fn needles_longer_than_half_the_box_pack_without_overlap() {
    let out = run_toml(include_str!(
        "../examples/scenes/ellipsoids_prolate_r10_n90.toml"
    ));
    assert_eq!(out.packing.particles.len(), 90);
    assert!((recomputed_phi(&out.packing) - 0.30).abs() < 1e-9);
    let densepack::io::packing::ContainerRecord::Box { min, max, .. } = &out.packing.container
    else {
        panic!("a box scene");
    };
    let edge = max[0] - min[0];
    let longest = out
        .packing
        .particles
        .iter()
        .map(|p| match p {
            ParticleRecord::Ellipsoid(EllipsoidRecord { semi_axes, .. }) => 2.0 * semi_axes[0],
            _ => unreachable!(),
        })
        .fold(0.0, f64::max);
    assert!(
        longest > 0.5 * edge && longest < edge,
        "bounding diameter {longest} of edge {edge}"
    );
    assert_valid(&out.packing);
}
