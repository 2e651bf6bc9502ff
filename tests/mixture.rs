//! Sphere + cylinder RVEs (Salnikov et al. 2014): random sequential adsorption, the
//! time-driven relaxer, periodic images, the independent check and input errors.
//! Every configuration is judged by `verify::verify` (GJK separating-plane certificates,
//! no code shared with `geometry::cylinder`) and by the exact typed tests.

mod common;

use common::recomputed_phi;
use densepack::geometry::cylinder::{overlaps, Cylinder, Shape, Sphere};
use densepack::io::record::CylinderRecord;
use densepack::io::scene::{AnyScene, MixtureScene, SceneError};
use densepack::protocol::mixture::relax::{random_rve, relax, RelaxError, RelaxSettings};
use densepack::protocol::mixture::rsa::{rsa_mixture, RsaError, RsaLimits};
use densepack::protocol::mixture::{
    first_intersection, GenerationOrder, MixtureError, MixtureSpec, Rve,
};
use densepack::run::mixture_packing;
use densepack::verify::verify;
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

type V = Vector3<f64>;

fn spec(fs: f64, fc: f64, n: usize, a: f64) -> MixtureSpec {
    MixtureSpec {
        sphere_fraction: fs,
        cylinder_fraction: fc,
        spheres: n,
        cylinders: n,
        aspect_ratio: a,
        box_size: 1.0,
    }
}

fn assert_verified(rve: &Rve) {
    assert!(
        first_intersection(rve).is_none(),
        "exact tests find an intersection"
    );
    let v = verify(&mixture_packing(
        rve,
        0,
        0.0,
        "test",
        serde_json::Map::new(),
    ));
    assert!(v.ok(), "independent check: {:?}", v.violations);
}

#[test]
fn rsa_reaches_the_requested_fractions_in_every_order() {
    for order in [
        GenerationOrder::CylindersFirst,
        GenerationOrder::SpheresFirst,
        GenerationOrder::Interleaved,
    ] {
        let s = spec(0.1, 0.15, 30, 5.0);
        s.validate().unwrap();
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(7);
        let out = rsa_mixture(
            &s.boundary(),
            &s.sizes(order),
            &RsaLimits::default(),
            None,
            &mut rng,
        )
        .unwrap_or_else(|e| panic!("{order:?}: {e}"));
        let (fs, fc) = out.rve.fractions();
        // Algorithm 5 steps 1–2 give the fractions exactly (up to rounding).
        assert!(
            (fs - 0.1).abs() < 1e-12 && (fc - 0.15).abs() < 1e-12,
            "{fs} {fc}"
        );
        let cylinders: Vec<_> = out
            .rve
            .bodies
            .iter()
            .filter_map(|b| match b {
                Shape::Cylinder(c) => Some(c),
                _ => None,
            })
            .collect();
        assert_eq!(cylinders.len(), 30);
        for c in cylinders {
            assert!((c.aspect_ratio() - 5.0).abs() < 1e-12);
        }
        if order == GenerationOrder::Interleaved {
            // Kinds alternate (equal counts).
            assert!(out
                .rve
                .bodies
                .windows(2)
                .all(|w| std::mem::discriminant(&w[0]) != std::mem::discriminant(&w[1])));
        }
        assert_verified(&out.rve);
    }
}

#[test]
fn images_across_faces_edges_and_corners_are_seen() {
    let boundary = spec(0.1, 0.1, 10, 3.0).boundary();
    // A sphere at a corner meets a sphere at the opposite corner only through the corner
    // image; a long cylinder near an edge meets a sphere only across that edge.
    let corner = Rve {
        boundary: boundary.clone(),
        bodies: vec![
            Shape::Sphere(Sphere::new(V::new(0.02, 0.02, 0.02), 0.05)),
            Shape::Sphere(Sphere::new(V::new(0.97, 0.98, 0.99), 0.05)),
        ],
    };
    let edge = Rve {
        boundary: boundary.clone(),
        bodies: vec![
            Shape::Cylinder(Cylinder::new(
                V::new(0.5, 0.03, 0.98),
                V::new(0.3, 0.0, 0.0),
                0.05,
            )),
            Shape::Sphere(Sphere::new(V::new(0.6, 0.97, 0.02), 0.05)),
        ],
    };
    for rve in [corner, edge] {
        assert!(first_intersection(&rve).is_some());
        let v = verify(&mixture_packing(
            &rve,
            0,
            0.0,
            "test",
            serde_json::Map::new(),
        ));
        assert!(
            !v.ok(),
            "the independent check must reject the image overlap"
        );
        // Moved to the middle of the box they are far apart: both accept.
        let mut apart = rve.clone();
        apart.bodies[1] = apart.bodies[1].translated(V::new(-0.45, -0.45, 0.45));
        assert_verified(&apart);
    }
    // A cylinder long enough to touch its own image through a face diagonal.
    let own = Rve {
        boundary,
        bodies: vec![Shape::Cylinder(Cylinder::new(
            V::new(0.5, 0.5, 0.5),
            V::new(0.3, 0.3, 0.0),
            0.4,
        ))],
    };
    assert!(first_intersection(&own).is_some());
    assert!(!verify(&mixture_packing(
        &own,
        0,
        0.0,
        "test",
        serde_json::Map::new()
    ))
    .ok());
}

#[test]
fn relaxer_makes_a_fraction_rsa_cannot_reach_intersection_free() {
    // 55 % (30 % spheres + 25 % cylinders of a = 5): far beyond the paper's RSA (~35 %).
    let s = spec(0.30, 0.25, 30, 5.0);
    s.validate().unwrap();
    let sizes = s.sizes(GenerationOrder::CylindersFirst);
    let limits = RsaLimits {
        max_attempts_per_body: 20_000,
        max_restarts: 1,
        time_limit: None,
    };
    let rsa = rsa_mixture(
        &s.boundary(),
        &sizes,
        &limits,
        None,
        &mut Xoshiro256PlusPlus::seed_from_u64(3),
    );
    match rsa {
        Err(RsaError::Failed(f)) => {
            assert!(f.placed < f.total);
            assert!(f.to_string().contains("placed"), "{f}");
        }
        other => panic!("RSA was expected to fail: {other:?}"),
    }
    let mut rve = random_rve(
        &s.boundary(),
        &sizes,
        &mut Xoshiro256PlusPlus::seed_from_u64(3),
    );
    assert!(
        first_intersection(&rve).is_some(),
        "the start must intersect"
    );
    let report = relax(&mut rve, &RelaxSettings::default(), None).unwrap();
    assert!(report.initial_contacts > 50, "{report:?}");
    let (fs, fc) = rve.fractions();
    assert!((fs - 0.30).abs() < 1e-12 && (fc - 0.25).abs() < 1e-12);
    for b in &rve.bodies {
        if let Shape::Cylinder(c) = b {
            assert!(
                (c.aspect_ratio() - 5.0).abs() < 1e-9,
                "rotation kept the length"
            );
        }
    }
    assert_verified(&rve);
}

/// The two-body cases of Fig. 15–29, each relaxed apart in a box large enough not to matter.
#[test]
fn relaxer_separates_each_two_body_case() {
    let cyl = |c: [f64; 3], l: [f64; 3], r: f64| {
        Shape::Cylinder(Cylinder::new(V::from(c) + V::repeat(5.0), V::from(l), r))
    };
    let sph = |c: [f64; 3], r: f64| Shape::Sphere(Sphere::new(V::from(c) + V::repeat(5.0), r));
    let z = [0.0, 0.0, 2.0];
    let cases: Vec<(&str, Shape, Shape)> = vec![
        (
            "fig15 two spheres",
            sph([0.0; 3], 1.0),
            sph([1.5, 0.0, 0.0], 0.6),
        ),
        (
            "fig16 sc2",
            cyl([0.0; 3], z, 0.5),
            sph([0.9, 0.0, 0.0], 0.5),
        ),
        (
            "fig17 sc2 off-centre",
            cyl([0.0; 3], z, 0.5),
            sph([0.6, 0.6, 1.9], 0.5),
        ),
        (
            "fig18/19 sc3",
            cyl([0.0; 3], z, 0.5),
            sph([0.0, 0.1, 2.3], 0.5),
        ),
        (
            "fig20 sc4",
            cyl([0.0; 3], z, 0.5),
            sph([0.8, 0.0, 2.2], 0.5),
        ),
        (
            "sc1",
            cyl([0.0; 3], [0.0, 0.0, 0.3], 0.2),
            sph([0.0, 0.0, 0.1], 1.0),
        ),
        (
            "fig21 cc1",
            cyl([0.0; 3], [2.0, 0.0, 0.0], 0.5),
            cyl([0.0, 0.0, 0.9], [0.0, 2.0, 0.0], 0.5),
        ),
        (
            "fig22/23 cc1",
            cyl([0.0; 3], [2.0, 0.3, 0.1], 0.5),
            cyl([0.2, -0.1, 0.8], [0.4, 2.0, -0.3], 0.4),
        ),
        (
            "fig24 cd1",
            cyl([0.0; 3], z, 0.5),
            cyl([0.0, 0.0, 2.4], [2.0, 0.0, 0.0], 0.5),
        ),
        (
            "fig25 parallel",
            cyl([0.0; 3], z, 0.5),
            cyl([0.9, 0.0, 0.3], [0.0, 0.0, -2.0], 0.5),
        ),
        (
            "fig26/27 cd1",
            cyl([0.0; 3], z, 0.5),
            cyl([0.3, 0.7, 2.5], [2.0, 0.2, 0.6], 0.5),
        ),
        (
            "fig28 d1",
            cyl([0.0; 3], [0.0, 0.0, 1.0], 1.0),
            cyl([1.5, 0.0, 1.2], [1.0, 0.0, 0.0], 0.3),
        ),
        (
            "fig29 crossing axes",
            cyl([0.0; 3], z, 0.5),
            cyl([0.0; 3], [2.0, 0.0, 0.0], 0.5),
        ),
    ];
    for (name, a, b) in cases {
        assert!(overlaps(&a, &b), "{name}: must start intersecting");
        let mut rve = Rve {
            boundary: densepack::boundary::PeriodicBox {
                min: V::zeros(),
                len: V::repeat(10.0),
            },
            bodies: vec![a, b],
        };
        relax(&mut rve, &RelaxSettings::default(), None).unwrap_or_else(|e| panic!("{name}: {e}"));
        assert!(!overlaps(&rve.bodies[0], &rve.bodies[1]), "{name}");
        assert_verified(&rve);
    }
}

#[test]
fn same_seed_same_configuration() {
    let s = spec(0.15, 0.2, 20, 3.0);
    let sizes = s.sizes(GenerationOrder::Interleaved);
    let run_rsa = |seed| {
        rsa_mixture(
            &s.boundary(),
            &sizes,
            &RsaLimits::default(),
            None,
            &mut Xoshiro256PlusPlus::seed_from_u64(seed),
        )
        .unwrap()
        .rve
    };
    assert_eq!(run_rsa(11), run_rsa(11));
    assert_ne!(run_rsa(11), run_rsa(12));
    let run_md = |seed| {
        let mut rve = random_rve(
            &s.boundary(),
            &sizes,
            &mut Xoshiro256PlusPlus::seed_from_u64(seed),
        );
        let report = relax(&mut rve, &RelaxSettings::default(), None).unwrap();
        (rve, report.steps)
    };
    assert_eq!(run_md(5), run_md(5));
}

#[test]
fn cylinder_count_bound_and_bad_inputs_are_clear_errors() {
    // 10 cylinders of a = 5 at f_c = 0.45 would be 1.13 box edges long (Table VII's last
    // a = 5 column): 4 f_c a²/π = 14.3.
    let err = spec(0.05, 0.45, 10, 5.0).validate().unwrap_err();
    match &err {
        MixtureError::CylinderCountBound { bound, length, .. } => {
            assert!((bound - 4.0 * 0.45 * 25.0 / std::f64::consts::PI).abs() < 1e-12);
            assert!(*length > 1.0);
        }
        other => panic!("{other:?}"),
    }
    assert!(err.to_string().contains("mixture.cylinders = 10"), "{err}");
    assert!(spec(0.05, 0.30, 10, 5.0).validate().is_ok());

    let scene = |body: &str| format!("seed = 1\n[mixture]\n{body}\n");
    let base = "sphere_fraction = 0.1\ncylinder_fraction = 0.1\nspheres = 10\ncylinders = 10\naspect_ratio = 3.0";
    assert!(matches!(
        AnyScene::from_toml(&scene(base)),
        Ok(AnyScene::Mixture(_))
    ));
    let field_of = |text: String| match MixtureScene::from_toml(&text) {
        Err(SceneError::Invalid { field, message }) => (field, message),
        other => panic!("expected an invalid field, got {other:?}"),
    };
    let cases = [
        (
            "sphere_fraction = 0.1",
            "sphere_fraction = -0.1",
            "mixture.sphere_fraction",
        ),
        (
            "cylinder_fraction = 0.1",
            "cylinder_fraction = 1.5",
            "mixture.cylinder_fraction",
        ),
        (
            "aspect_ratio = 3.0",
            "aspect_ratio = 0.0",
            "mixture.aspect_ratio",
        ),
        ("cylinders = 10", "cylinders = 0", "mixture.cylinders"),
        (
            "aspect_ratio = 3.0",
            "aspect_ratio = 10.0",
            "mixture.cylinders",
        ),
    ];
    for (from, to, field) in cases {
        let (got, message) = field_of(scene(&base.replace(from, to)));
        assert_eq!(got, field, "{to}: {message}");
    }
    // A limit no `Duration` holds (found by tests/arbitrary_input.rs: it panicked).
    let (got, message) = field_of(scene(&format!("{base}\ntime_limit_seconds = 1e300")));
    assert_eq!(got, "mixture.time_limit_seconds");
    assert!(message.contains("(0, 1e9]"), "{message}");
    let (got, _) = field_of(scene(&base.replace("aspect_ratio = 3.0", "")));
    assert_eq!(got, "mixture.aspect_ratio");
    let (got, _) = field_of(scene(&format!(
        "{base}\nmethod = \"md\"\n[mixture.relax]\ndamping = -1.0"
    )));
    assert_eq!(got, "mixture.relax.damping");
    // Unknown keys are parse errors naming the key.
    match MixtureScene::from_toml(&scene(&format!("{base}\nfraction = 0.3"))) {
        Err(SceneError::Parse(m)) => assert!(m.contains("fraction"), "{m}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn relaxer_gives_up_with_a_clear_message() {
    let s = spec(0.30, 0.25, 30, 5.0);
    let mut rve = random_rve(
        &s.boundary(),
        &s.sizes(GenerationOrder::CylindersFirst),
        &mut Xoshiro256PlusPlus::seed_from_u64(1),
    );
    let settings = RelaxSettings {
        max_steps: 5,
        ..RelaxSettings::default()
    };
    let Err(RelaxError::GaveUp(e)) = relax(&mut rve, &settings, None) else {
        panic!("five steps cannot relax the start");
    };
    assert!(e.contacts > 0 && e.steps == 5);
    let text = e.to_string();
    assert!(
        text.contains("gave up after 5 steps") && text.contains("intersections remain"),
        "{text}"
    );
}

#[test]
fn cli_runs_the_55_percent_scene_and_rejects_bad_ones() {
    use densepack::io::packing::{Packing, ParticleRecord};
    let dir = common::temp_dir("cli");
    let bin = env!("CARGO_BIN_EXE_densepack");
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/examples/scenes/mixture_55.toml"
    );
    let out = dir.join("m55.json");
    let run = std::process::Command::new(bin)
        .args(["run", scene, "--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let mut packing = Packing::read(&out).unwrap();
    assert!((recomputed_phi(&packing) - 0.55).abs() < 1e-12);
    let cylinders = packing
        .particles
        .iter()
        .filter(|p| matches!(p, ParticleRecord::Cylinder(_)))
        .count();
    assert_eq!((cylinders, packing.particles.len()), (50, 100));
    let check = std::process::Command::new(bin)
        .args(["verify", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(check.status.success());
    // Put the first cylinder onto the second: `verify` must fail.
    let second_center = match &packing.particles[1] {
        ParticleRecord::Cylinder(CylinderRecord { center, .. }) => *center,
        other => panic!("cylinders come first: {other:?}"),
    };
    if let ParticleRecord::Cylinder(CylinderRecord { center, .. }) = &mut packing.particles[0] {
        *center = second_center;
    }
    let bad = dir.join("bad.json");
    packing.write(&bad).unwrap();
    let check = std::process::Command::new(bin)
        .args(["verify", bad.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(check.status.code(), Some(1));
    // The cylinder count bound: exit code 2, the field named, nothing written.
    let scene = dir.join("bound.toml");
    std::fs::write(
        &scene,
        "seed = 1\n[mixture]\nsphere_fraction = 0.05\ncylinder_fraction = 0.45\n\
         spheres = 10\ncylinders = 10\naspect_ratio = 5.0\n",
    )
    .unwrap();
    let out = dir.join("never.json");
    let run = std::process::Command::new(bin)
        .args([
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&run.stderr).contains("mixture.cylinders"));
    assert!(!out.exists());
}
