//! The jamming report against lattices whose contacts and jamming are known exactly
//! (Donev, Torquato, Stillinger & Connelly, J. Comput. Phys. 197, 139, 2004: the FCC
//! crystal is collectively jammed in a periodic box, the simple cubic lattice is not, since
//! its planes slide over each other).

mod common;

use densepack::analysis::jamming::{jamming_report, JammingError, Q6_FCC};
use densepack::io::packing::{ContainerRecord, Packing, ParticleRecord};
use densepack::io::record::{CylinderRecord, EllipsoidRecord, SphereRecord};

fn periodic_box(edge: f64) -> ContainerRecord {
    ContainerRecord::Box {
        min: [0.0; 3],
        max: [edge; 3],
        periodic: [true; 3],
    }
}

/// `cells³` cubic cells of edge `a` with the given basis (fractions of `a`), spheres of
/// radius `r`.
fn lattice(cells: usize, a: f64, basis: &[[f64; 3]], r: f64) -> Vec<ParticleRecord> {
    let mut out = Vec::new();
    for x in 0..cells {
        for y in 0..cells {
            for z in 0..cells {
                for b in basis {
                    let center = [
                        (x as f64 + b[0] + 0.25) * a,
                        (y as f64 + b[1] + 0.25) * a,
                        (z as f64 + b[2] + 0.25) * a,
                    ];
                    out.push(ParticleRecord::Sphere(SphereRecord { center, radius: r }));
                }
            }
        }
    }
    out
}

const FCC: [[f64; 3]; 4] = [
    [0.0, 0.0, 0.0],
    [0.5, 0.5, 0.0],
    [0.5, 0.0, 0.5],
    [0.0, 0.5, 0.5],
];

#[test]
fn fcc_crystal_is_jammed_with_twelve_contacts_and_fcc_q6() {
    let a = 2.0_f64.sqrt(); // unit diameter: nearest neighbours at a/√2 = 1
    let packing = Packing::new(periodic_box(4.0 * a), lattice(4, a, &FCC, 0.5));
    let r = jamming_report(&packing, 1e-9, true, 7, 60.0).unwrap();
    assert_eq!(r.particles, 256);
    let row = &r.at_cutoff;
    assert_eq!(row.rattler_fraction, 0.0);
    assert!((row.backbone_mean_contacts.unwrap() - 12.0).abs() < 1e-12);
    // 6N contacts for 3N − 3 freedoms.
    let expected = 6.0 * 256.0 / (3.0 * 256.0 - 3.0);
    assert!((row.constraints_per_freedom.unwrap() - expected).abs() < 1e-12);
    // Second neighbours sit at √2 diameters: no bond, no contact at any cut-off.
    assert_eq!(r.bonds, 6 * 256);
    assert!((r.q6 - Q6_FCC).abs() < 1e-4, "Q6 = {}", r.q6);
    let lp = r.lp.expect("asked for");
    assert!(lp.jammed, "{lp:?}");
}

#[test]
fn simple_cubic_lattice_is_not_collectively_jammed() {
    let packing = Packing::new(periodic_box(6.0), lattice(6, 1.0, &[[0.0; 3]], 0.5));
    let r = jamming_report(&packing, 1e-9, true, 7, 60.0).unwrap();
    let row = &r.at_cutoff;
    // Six contacts each: enough by count (3N contacts ≥ 3N − 3 + 1), but planes slide.
    assert_eq!(row.rattler_fraction, 0.0);
    assert!((row.backbone_mean_contacts.unwrap() - 6.0).abs() < 1e-12);
    let lp = r.lp.expect("asked for");
    assert!(!lp.jammed, "{lp:?}");
    // A sliding plane does work under one of the two random loads: that load is not
    // carried (the solver proves the program infeasible), the other may be.
    assert!(lp.loads_carried.contains(&Some(false)), "{lp:?}");
    assert!(!lp.loads_carried.contains(&None), "{lp:?}");
    // Q6 of the six bond directions ±x, ±y, ±z: P6 averages to (2·1 + 4·P6(0))/6 per pair
    // of bonds, so Q6² = (1 + 2·P6(0))/3 with P6(0) = −5/16.
    let expected = ((1.0 - 2.0 * 5.0 / 16.0) / 3.0_f64).sqrt();
    assert!(
        (r.q6 - expected).abs() < 1e-9,
        "Q6 = {} vs {expected}",
        r.q6
    );
}

#[test]
fn walled_cube_of_eight_spheres_is_jammed_by_its_walls() {
    let container = ContainerRecord::Box {
        min: [0.0; 3],
        max: [2.0; 3],
        periodic: [false; 3],
    };
    let particles = lattice(2, 1.0, &[[0.25; 3]], 0.5);
    let r = jamming_report(&Packing::new(container, particles), 1e-9, true, 3, 60.0).unwrap();
    // Three neighbours and three walls each: 36 contacts for 24 freedoms.
    assert!((r.at_cutoff.backbone_mean_contacts.unwrap() - 6.0).abs() < 1e-12);
    assert!((r.at_cutoff.constraints_per_freedom.unwrap() - 1.5).abs() < 1e-12);
    assert_eq!(r.trivial_motions, 0);
    assert!(r.lp.expect("asked for").jammed);
}

#[test]
fn a_loose_sphere_is_a_rattler_and_the_plateau_sees_each_gap() {
    // FCC, nearest-neighbour distance 1 + 1e-7 diameters: pairs at relative gap 1e-7.
    let s = 1.0 + 1e-7;
    let a = 2.0_f64.sqrt() * s;
    let mut particles = lattice(4, a, &FCC, 0.5);
    // One sphere shrunk by 1 %: no contact left, a rattler; its twelve neighbours keep
    // eleven, spread over every hemisphere.
    if let ParticleRecord::Sphere(SphereRecord { radius, .. }) = &mut particles[0] {
        *radius = 0.495;
    }
    let packing = Packing::new(periodic_box(4.0 * a), particles);
    let r = jamming_report(&packing, 1e-6, false, 1, 1.0).unwrap();
    assert!(r.lp.is_none());
    assert_eq!(r.at_cutoff.rattler_fraction, 1.0 / 256.0);
    let at = |h: f64| r.plateau.iter().find(|row| row.cutoff == h).unwrap();
    // Below the gap nothing touches (all rattlers); above it 6·256 − 12 pairs do.
    assert_eq!(at(1e-8).mean_contacts, 0.0);
    assert_eq!(at(1e-8).rattler_fraction, 1.0);
    assert!((at(1e-6).mean_contacts - 2.0 * (6.0 * 256.0 - 12.0) / 256.0).abs() < 1e-12);
}

#[test]
fn a_vacancy_in_simple_cubic_frees_every_sphere_to_first_order() {
    // Beside a vacancy a sphere keeps five contacts, all with no component towards the
    // vacancy: it can slide into it (its contact directions lie in a closed hemisphere), then
    // its neighbour along the row can follow, and so on: no sphere is locally jammed.
    let mut particles = lattice(4, 1.0, &[[0.0; 3]], 0.5);
    particles.remove(0);
    let packing = Packing::new(periodic_box(4.0), particles);
    let r = jamming_report(&packing, 1e-9, false, 1, 1.0).unwrap();
    assert_eq!(r.at_cutoff.rattler_fraction, 1.0);
}

#[test]
fn bad_cut_offs_cylinders_and_ellipsoid_gap_claims_are_refused() {
    let packing = Packing::new(periodic_box(6.0), lattice(2, 1.0, &[[0.0; 3]], 0.5));
    for bad in [0.0, -1e-9, 0.5, f64::NAN] {
        assert!(jamming_report(&packing, bad, false, 1, 1.0).is_err());
    }
    let cylinder = ParticleRecord::Cylinder(CylinderRecord {
        center: [1.0; 3],
        radius: 0.2,
        half_axis: [0.0, 0.0, 0.5],
    });
    let packing = Packing::new(periodic_box(6.0), vec![cylinder]);
    let e = jamming_report(&packing, 1e-9, false, 1, 1.0).unwrap_err();
    assert_eq!(e, JammingError::Unsupported(0, "cylinder"));
    // A claimed gap would make the grown grains parallel bodies, not ellipsoids.
    let mut packing = Packing::new(periodic_box(6.0), vec![spheroid([1.0; 3], 1.5, 0.0)]);
    packing.min_gap = 0.01;
    let e = jamming_report(&packing, 1e-9, false, 1, 1.0).unwrap_err();
    assert!(e.to_string().contains("min_gap = 0.01"), "{e}");
    let cylinder_container = ContainerRecord::Cylinder {
        base_center: [0.0; 3],
        radius: 3.0,
        height: 6.0,
    };
    let packing = Packing::new(
        cylinder_container,
        vec![spheroid([0.0, 0.0, 3.0], 1.5, 0.0)],
    );
    let e = jamming_report(&packing, 1e-9, false, 1, 1.0).unwrap_err();
    assert!(e.to_string().contains("box"), "{e}");
}

/// A prolate spheroid of semi-axes `(0.5·alpha, 0.5, 0.5)` at `center`, its long (body z)
/// axis turned from world z towards world x by `degrees` about y.
fn spheroid(center: [f64; 3], alpha: f64, degrees: f64) -> ParticleRecord {
    let half = 0.5 * degrees.to_radians();
    ParticleRecord::Ellipsoid(EllipsoidRecord {
        center,
        semi_axes: [0.5, 0.5, 0.5 * alpha],
        orientation: [half.cos(), 0.0, half.sin(), 0.0],
    })
}

/// The FCC lattice of unit spheres with lattice spacing scaled by `1 + gap`, stretched by
/// `alpha` along x, as spheroids whose long axis is world x (body z turned by 90°). The
/// affine map `x ↦ diag(alpha, 1, 1)·x` takes the touching spheres to touching spheroids,
/// and the Perram–Wertheim scale factor is affine invariant: every pair of nearest
/// neighbours touches when scaled by exactly `1 + gap`.
fn stretched_fcc(alpha: f64, gap: f64) -> Packing {
    let a = 2.0_f64.sqrt() * (1.0 + gap);
    let particles = lattice(4, a, &FCC, 0.5)
        .into_iter()
        .map(|p| match p {
            ParticleRecord::Sphere(SphereRecord { center, .. }) => {
                spheroid([alpha * center[0], center[1], center[2]], alpha, 90.0)
            }
            other => other,
        })
        .collect();
    let container = ContainerRecord::Box {
        min: [0.0; 3],
        max: [alpha * 4.0 * a, 4.0 * a, 4.0 * a],
        periodic: [true; 3],
    };
    Packing::new(container, particles)
}

#[test]
fn a_stretched_fcc_crystal_of_spheroids_keeps_its_twelve_contacts() {
    for alpha in [1.5, 2.0] {
        let r = jamming_report(&stretched_fcc(alpha, 0.0), 1e-9, true, 7, 60.0).unwrap();
        assert_eq!((r.particles, r.ellipsoids), (256, 256));
        assert_eq!(r.freedoms_per_particle, 5.0);
        assert_eq!(r.isostatic_contacts, 10.0);
        // Skipped, not run: the LP test is for spheres.
        assert!(r.lp.is_none() && r.lp_skipped);
        // 12 contacts at every cut-off down to rounding; second neighbours (scale √2 in
        // the sphere lattice, so at least √2 here) at none.
        for row in r.plateau.iter().filter(|row| row.cutoff >= 1e-12) {
            assert_eq!(row.mean_contacts, 12.0, "alpha {alpha}: {row:?}");
            assert_eq!(row.rattler_fraction, 0.0);
            assert_eq!(row.backbone_mean_contacts, Some(12.0));
            // 6N contacts for 5N − 3 freedoms.
            let expected = 6.0 * 256.0 / (5.0 * 256.0 - 3.0);
            assert!((row.constraints_per_freedom.unwrap() - expected).abs() < 1e-12);
        }
    }
}

#[test]
fn the_report_counts_spheroid_contacts_against_the_cut_off() {
    // Every nearest-neighbour pair at scale factor 1 + 1e-7 exactly (affine invariance).
    let r = jamming_report(&stretched_fcc(1.5, 1e-7), 1e-6, false, 1, 1.0).unwrap();
    let at = |h: f64| r.plateau.iter().find(|row| row.cutoff == h).unwrap();
    for h in [1e-10, 1e-8] {
        assert_eq!(at(h).mean_contacts, 0.0, "cut-off {h}");
        assert_eq!(at(h).rattler_fraction, 1.0);
        assert_eq!(at(h).backbone_mean_contacts, None);
    }
    for h in [1e-6, 1e-4] {
        assert_eq!(at(h).mean_contacts, 12.0, "cut-off {h}");
        assert_eq!(at(h).rattler_fraction, 0.0);
    }
    assert_eq!(r.at_cutoff.mean_contacts, 12.0);
}

/// The report's pair gap of `a` and `b` in a large periodic box: the smallest cut-off at
/// which the pair counts as a contact, found by bisection (geometric) on the cut-off.
fn pair_gap(a: ParticleRecord, b: ParticleRecord) -> f64 {
    let packing = Packing::new(periodic_box(20.0), vec![a, b]);
    let touches = |h: f64| {
        jamming_report(&packing, h, false, 1, 1.0)
            .unwrap()
            .at_cutoff
            .mean_contacts
            > 0.0
    };
    let (mut lo, mut hi) = (1e-16, 0.1);
    assert!(touches(hi) && !touches(lo));
    for _ in 0..200 {
        let mid = (lo * hi).sqrt();
        if touches(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    hi
}

#[test]
fn pair_gaps_are_the_perram_wertheim_scale_factor_minus_one() {
    let g = 3e-3;
    // Tip to tip along the common long axis x: touching at distance 2·0.5·α.
    let alpha = 2.0;
    let found = pair_gap(
        spheroid([5.0, 5.0, 5.0], alpha, 90.0),
        spheroid([5.0 + alpha * (1.0 + g), 5.0, 5.0], alpha, 90.0),
    );
    assert!((found / g - 1.0).abs() < 1e-9, "{found}");
    // Tip of one (long axis x) against the side of the other (long axis z): both normals
    // are along x at the touching point, which lies 0.5·α + 0.5 from the first centre.
    let found = pair_gap(
        spheroid([5.0, 5.0, 5.0], alpha, 90.0),
        spheroid(
            [5.0 + (0.5 * alpha + 0.5) * (1.0 + g), 5.0, 5.0],
            alpha,
            0.0,
        ),
    );
    assert!((found / g - 1.0).abs() < 1e-9, "{found}");
    // A sphere of radius 0.5 beside a spheroid's side, across the periodic face.
    let found = pair_gap(
        ParticleRecord::Sphere(SphereRecord {
            center: [19.9, 5.0, 5.0],
            radius: 0.5,
        }),
        spheroid([-0.1 + 1.0 * (1.0 + g), 5.0, 5.0], alpha, 0.0),
    );
    assert!((found / g - 1.0).abs() < 1e-9, "{found}");
}

#[test]
fn a_tilted_spheroid_touches_the_floor_at_its_half_width() {
    // Long semi-axis 0.75 at 30° from z: half-width along z √(0.75²·cos² + 0.5²·sin²).
    let (alpha, degrees, g) = (1.5_f64, 30.0_f64, 1e-5);
    let t = degrees.to_radians();
    let w = ((0.75 * t.cos()).powi(2) + (0.5 * t.sin()).powi(2)).sqrt();
    let container = ContainerRecord::Box {
        min: [0.0; 3],
        max: [4.0, 4.0, 4.0],
        periodic: [true, true, false],
    };
    let packing = Packing::new(
        container,
        vec![spheroid([2.0, 2.0, w * (1.0 + g)], alpha, degrees)],
    );
    let r = jamming_report(&packing, 1e-9, false, 1, 1.0).unwrap();
    let at = |h: f64| r.plateau.iter().find(|row| row.cutoff == h).unwrap();
    assert_eq!(at(1e-6).mean_contacts, 0.0);
    assert_eq!(at(1e-4).mean_contacts, 1.0);
    // Two periodic axes: two rigid translations.
    assert_eq!(r.trivial_motions, 2);
}

#[test]
fn general_ellipsoids_have_six_freedoms_and_spheres_beside_them_three() {
    let ellipsoid = ParticleRecord::Ellipsoid(EllipsoidRecord {
        center: [1.0; 3],
        semi_axes: [0.5, 0.4, 0.3],
        orientation: [1.0, 0.0, 0.0, 0.0],
    });
    let sphere = ParticleRecord::Sphere(SphereRecord {
        center: [4.0; 3],
        radius: 0.5,
    });
    let r = jamming_report(
        &Packing::new(periodic_box(6.0), vec![ellipsoid.clone()]),
        1e-9,
        true,
        1,
        1.0,
    )
    .unwrap();
    assert_eq!((r.freedoms_per_particle, r.isostatic_contacts), (6.0, 12.0));
    assert!(r.lp_skipped);
    let r = jamming_report(
        &Packing::new(periodic_box(6.0), vec![ellipsoid, sphere]),
        1e-9,
        false,
        1,
        1.0,
    )
    .unwrap();
    assert_eq!(r.ellipsoids, 1);
    assert_eq!(r.freedoms_per_particle, 4.5);
    assert!(!r.lp_skipped, "not asked for");
}

#[test]
fn analyse_reports_spheroids_and_flags_a_cut_off_below_the_plateau() {
    let dir = common::temp_dir("analyse_spheroids");
    let path = dir.join("stretched.json");
    // Every contact at gap 1e-8: the default cut-off 1e-9 sees none, 1e-7 all twelve.
    stretched_fcc(1.5, 1e-8).write(&path).unwrap();
    let out = common::densepack(&["analyse", path.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    for expected in [
        "ellipsoids 256 (5 degrees of freedom each)",
        "isostatic: 10 for a periodic packing",
        "note: the cut-off is below the plateau (12.0000 contacts per particle at 1e-7)",
        "LP test: skipped",
    ] {
        assert!(text.contains(expected), "{expected:?} missing from\n{text}");
    }
    // On the plateau: no note.
    let out = common::densepack(&["analyse", "--cutoff", "1e-6", path.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("backbone Z 12.0000"), "{text}");
    assert!(!text.contains("note:"), "{text}");
}

#[test]
fn analyse_refuses_cylinders_with_exit_code_2() {
    let dir = common::temp_dir("analyse_cylinder");
    let path = dir.join("cylinder.json");
    let cylinder = ParticleRecord::Cylinder(CylinderRecord {
        center: [3.0; 3],
        radius: 0.2,
        half_axis: [0.0, 0.0, 0.5],
    });
    Packing::new(periodic_box(6.0), vec![cylinder])
        .write(&path)
        .unwrap();
    let out = common::densepack(&["analyse", path.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("particle 0 is a cylinder"), "{err}");
}

#[test]
fn a_sphere_whose_four_contacts_lie_in_one_hemisphere_is_a_rattler() {
    // FCC with nearest-neighbour distance 1. Sphere 0 moves by t along +x and shrinks until it
    // touches its four neighbours at (1, ±1, 0)/√2 and (1, 0, ±1)/√2: contact distance
    // |n − t·x̂| = √(1 − √2·t + t²). Four contacts (enough by count) all with x > 0: it can
    // move along −x freely, so it is not locally jammed.
    let a = 2.0_f64.sqrt();
    let t = 0.1;
    let reach = (1.0 - 2.0_f64.sqrt() * t + t * t).sqrt();
    let mut particles = lattice(4, a, &FCC, 0.5);
    if let ParticleRecord::Sphere(SphereRecord { center, radius }) = &mut particles[0] {
        center[0] += t;
        *radius = reach - 0.5;
    }
    let packing = Packing::new(periodic_box(4.0 * a), particles);
    let r = jamming_report(&packing, 1e-9, false, 1, 1.0).unwrap();
    assert_eq!(r.at_cutoff.rattler_fraction, 1.0 / 256.0);
    // The backbone is the other 255 spheres with the crystal's 12·256/2 pairs less sphere 0's
    // twelve.
    let pairs = (12 * 256 / 2 - 12) as f64;
    let expected = 2.0 * pairs / 255.0;
    let z = r.at_cutoff.backbone_mean_contacts.unwrap();
    assert!((z - expected).abs() < 1e-12, "{z} vs {expected}");
}
