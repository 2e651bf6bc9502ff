//! The fuzz targets' properties (`fuzz/fuzz_targets/{scene,packing}.rs`) on stable Rust, run
//! by every `cargo test`: the scene parser and validation, and the packing reader with the
//! independent verification, take arbitrary bytes and mutations of valid files (numbers
//! replaced by extreme values, lines dropped or doubled, text cut, bytes inserted) without a
//! panic, an abort or a hang, and return `Ok` or `Err`; what they accept satisfies what the
//! run and the report rely on. Bounded to a few thousand cases per property (a few seconds);
//! the libFuzzer targets remain for long coverage-guided runs.

use densepack::io::packing::{ContainerRecord, Packing, ParticleRecord};
use densepack::io::record::{CylinderRecord, EllipsoidRecord, SphereRecord};
use densepack::io::scene::{AnyScene, Method, Scene, MAX_PARTICLES};
use densepack::verify::{verify, TOLERANCE};
use proptest::prelude::*;
use rand::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// Valid scenes to mutate: the small shipped examples of each kind.
const SCENES: [&str; 7] = [
    include_str!("../examples/scenes/walls_8_spheres.toml"),
    include_str!("../examples/scenes/sample_spheres.toml"),
    include_str!("../examples/scenes/concrete_b16_50mm.toml"),
    include_str!("../examples/scenes/sample_ellipsoids.toml"),
    include_str!("../examples/scenes/sample_mixture.toml"),
    include_str!("../examples/scenes/hs_fluid_0.45.toml"),
    include_str!("scenes/export_cylinder.toml"),
];

/// Valid packings to mutate, one per kind of container and particle: spheres in a walled box
/// with gap claims, spheres in a cylinder, ellipsoids in a partly periodic box, a sphere +
/// cylinder mixture in a periodic box.
fn packings() -> Vec<String> {
    let walled = Packing {
        min_gap: 0.1,
        wall_gap: Some(0.05),
        ..Packing::new(
            ContainerRecord::Box {
                min: [0.0; 3],
                max: [4.0, 4.0, 3.0],
                periodic: [false, true, false],
            },
            vec![
                ParticleRecord::Sphere(SphereRecord {
                    center: [1.0, 1.0, 1.0],
                    radius: 0.5,
                }),
                ParticleRecord::Sphere(SphereRecord {
                    center: [2.5, 1.2, 1.5],
                    radius: 0.75,
                }),
            ],
        )
    };
    let cylinder = Packing::new(
        ContainerRecord::Cylinder {
            base_center: [0.0, 0.0, -1.0],
            radius: 3.0,
            height: 5.0,
        },
        vec![ParticleRecord::Sphere(SphereRecord {
            center: [0.5, -0.5, 1.0],
            radius: 1.0,
        })],
    );
    let ellipsoids = Packing::new(
        ContainerRecord::Box {
            min: [-2.0; 3],
            max: [2.0; 3],
            periodic: [true, true, false],
        },
        vec![
            ParticleRecord::Ellipsoid(EllipsoidRecord {
                center: [0.0, 0.0, 0.0],
                semi_axes: [1.2, 0.4, 0.3],
                orientation: [0.8, 0.6, 0.0, 0.0],
            }),
            ParticleRecord::Ellipsoid(EllipsoidRecord {
                center: [-1.5, 1.5, 1.0],
                semi_axes: [0.5, 0.5, 0.25],
                orientation: [1.0, 0.0, 0.0, 0.0],
            }),
        ],
    );
    let mixture = Packing::new(
        ContainerRecord::Box {
            min: [0.0; 3],
            max: [1.0; 3],
            periodic: [true; 3],
        },
        vec![
            ParticleRecord::Cylinder(CylinderRecord {
                center: [0.5, 0.5, 0.5],
                radius: 0.1,
                half_axis: [0.0, 0.2, 0.1],
            }),
            ParticleRecord::Sphere(SphereRecord {
                center: [0.1, 0.9, 0.2],
                radius: 0.15,
            }),
        ],
    );
    [walled, cylinder, ellipsoids, mixture]
        .iter()
        .map(|p| serde_json::to_string_pretty(p).unwrap())
        .collect()
}

/// Values a mutation writes in place of a number: the edges of every allowed range and
/// beyond, in both syntaxes (TOML's `nan`/`inf` are not JSON).
const EXTREMES: [&str; 20] = [
    "0",
    "-0.0",
    "-1",
    "1",
    "0.5",
    "3",
    "1e-300",
    "-1e-300",
    "5e-324",
    "1e300",
    "1e308",
    "-1e308",
    "1e999",
    "nan",
    "inf",
    "-inf",
    "4294967295",
    "18446744073709551615",
    "99999999999999999999",
    "1e9",
];

/// One edit of a text; positions are taken modulo what the text holds.
#[derive(Clone, Debug)]
enum Mutation {
    /// Replace the `n`-th number with an extreme value.
    Number(usize, usize),
    /// Drop the `n`-th line.
    DropLine(usize),
    /// Write the `n`-th line twice.
    DoubleLine(usize),
    /// Cut the text at a byte.
    Truncate(usize),
    /// Insert a byte.
    Insert(usize, u8),
    /// Turn the `n`-th `true` into `false` or back.
    Flip(usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        6 => (any::<usize>(), 0..EXTREMES.len()).prop_map(|(n, v)| Mutation::Number(n, v)),
        2 => any::<usize>().prop_map(Mutation::DropLine),
        1 => any::<usize>().prop_map(Mutation::DoubleLine),
        1 => any::<usize>().prop_map(Mutation::Truncate),
        1 => (any::<usize>(), any::<u8>()).prop_map(|(n, b)| Mutation::Insert(n, b)),
        1 => any::<usize>().prop_map(Mutation::Flip),
    ]
}

/// Byte ranges of the numbers in `text` (a digit run with its sign, point and exponent).
fn numbers(text: &[u8]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < text.len() {
        if text[i].is_ascii_digit() {
            let mut start = i;
            if start > 0 && text[start - 1] == b'-' {
                start -= 1;
            }
            while i < text.len() && (text[i].is_ascii_alphanumeric() || b".+-_".contains(&text[i]))
            {
                i += 1;
            }
            out.push((start, i));
        } else {
            i += 1;
        }
    }
    out
}

fn apply(text: &str, mutations: &[Mutation]) -> Vec<u8> {
    let mut bytes = text.as_bytes().to_vec();
    for m in mutations {
        let lines: Vec<(usize, usize)> = {
            let mut v = Vec::new();
            let mut start = 0;
            for (i, &b) in bytes.iter().enumerate() {
                if b == b'\n' {
                    v.push((start, i + 1));
                    start = i + 1;
                }
            }
            v.push((start, bytes.len()));
            v
        };
        match *m {
            Mutation::Number(n, v) => {
                let found = numbers(&bytes);
                if !found.is_empty() {
                    let (a, b) = found[n % found.len()];
                    bytes.splice(a..b, EXTREMES[v].bytes());
                }
            }
            Mutation::DropLine(n) => {
                let (a, b) = lines[n % lines.len()];
                bytes.drain(a..b);
            }
            Mutation::DoubleLine(n) => {
                let (a, b) = lines[n % lines.len()];
                let line = bytes[a..b].to_vec();
                bytes.splice(b..b, line);
            }
            Mutation::Truncate(n) => bytes.truncate(n % (bytes.len() + 1)),
            Mutation::Insert(n, b) => bytes.insert(n % (bytes.len() + 1), b),
            Mutation::Flip(n) => {
                let text = String::from_utf8_lossy(&bytes).into_owned();
                let spots: Vec<usize> = text.match_indices("true").map(|(i, _)| i).collect();
                if !spots.is_empty() {
                    let at = spots[n % spots.len()];
                    bytes.splice(at..at + 4, b"false".iter().copied());
                }
            }
        }
    }
    bytes
}

/// The scene target: no panic; an accepted scene keeps the promises of validation.
fn check_scene(data: &[u8]) -> Result<(), TestCaseError> {
    let Ok(text) = std::str::from_utf8(data) else {
        return Ok(());
    };
    // The mixture-or-spheres entry point of `densepack run` must not panic either.
    let _ = AnyScene::from_toml(text);
    let Ok(scene) = Scene::from_toml(text) else {
        return Ok(());
    };
    prop_assert!(scene.method == Method::Rsa || !scene.stages.is_empty());
    let volume = scene.container_volume();
    prop_assert!(volume.is_finite() && volume > 0.0, "volume {}", volume);
    for stage in &scene.stages {
        let _ = densepack::run::kernel_stage(stage, 1.0);
    }
    if let Some(count) = scene.particle_count() {
        prop_assert!(count <= MAX_PARTICLES);
        if count <= 100_000 {
            let diameters =
                scene.true_diameters(&mut Xoshiro256PlusPlus::seed_from_u64(scene.seed));
            prop_assert_eq!(diameters.len(), count);
            let scale = scene.seed_scale(&diameters);
            prop_assert!(diameters
                .iter()
                .all(|d| (d * scale).is_finite() && d * scale > 0.0));
        }
    }
    Ok(())
}

/// The packing target: no panic; an accepted packing has a valid container and claims, and
/// its report is consistent.
fn check_packing(data: &[u8]) -> Result<(), TestCaseError> {
    let Ok(text) = std::str::from_utf8(data) else {
        return Ok(());
    };
    let Ok(packing) = Packing::from_json(text, "arbitrary") else {
        return Ok(());
    };
    prop_assert!(packing.check().is_ok());
    let report = verify(&packing);
    prop_assert_eq!(report.particles, packing.particles.len());
    prop_assert_eq!(report.tolerance, TOLERANCE);
    prop_assert!(report.violations.len() <= report.violation_count);
    prop_assert!(report.overlap_count + report.gap_claim_count <= report.violation_count);
    prop_assert_eq!(report.ok(), report.violation_count == 0);
    Ok(())
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn arbitrary_bytes_never_panic_the_readers(
        data in proptest::collection::vec(any::<u8>(), 0..600),
    ) {
        check_scene(&data)?;
        check_packing(&data)?;
    }

    #[test]
    fn mutated_scenes_are_accepted_whole_or_refused(
        which in 0..SCENES.len(),
        edits in proptest::collection::vec(mutation(), 1..4),
    ) {
        check_scene(&apply(SCENES[which], &edits))?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(3000))]

    #[test]
    fn mutated_packings_are_accepted_whole_or_refused(
        which in 0..4usize,
        edits in proptest::collection::vec(mutation(), 1..4),
    ) {
        let texts = packings();
        check_packing(&apply(&texts[which], &edits))?;
    }
}

/// The mutations reach past the parsers: some mutated scenes and packings are accepted (the
/// properties above are not only ever run on refused input).
#[test]
fn mutations_leave_some_files_valid() {
    let texts = packings();
    let one = [Mutation::Number(3, 4)];
    assert!(Scene::from_toml(std::str::from_utf8(&apply(SCENES[0], &[])).unwrap()).is_ok());
    for text in &texts {
        assert!(Packing::from_json(text, "valid").is_ok());
        let edited = String::from_utf8(apply(text, &one)).unwrap();
        assert_ne!(&edited, text);
        assert!(Packing::from_json(&edited, "edited").is_ok(), "{edited}");
    }
}
