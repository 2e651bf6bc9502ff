//! The jamming report against lattices whose contacts and jamming are known exactly
//! (Donev, Torquato, Stillinger & Connelly, J. Comput. Phys. 197, 139, 2004: the FCC
//! crystal is collectively jammed in a periodic box, the simple cubic lattice is not, since
//! its planes slide over each other).

use densepack::analysis::jamming::{jamming_report, Q6_FCC};
use densepack::io::packing::{ContainerRecord, Packing, ParticleRecord};

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
                    out.push(ParticleRecord::Sphere { center, radius: r });
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
    assert!(
        lp.load_work > 1e-3,
        "a sliding plane does work under a random load: {lp:?}"
    );
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
    // Simple cubic, spacing 1 + 1e-7 diameters: pairs at relative gap 1e-7.
    let s = 1.0 + 1e-7;
    let mut particles = lattice(4, s, &[[0.0; 3]], 0.5);
    // One sphere shrunk by 1 %: no contact left, a rattler; its six neighbours keep five.
    if let ParticleRecord::Sphere { radius, .. } = &mut particles[0] {
        *radius = 0.495;
    }
    let packing = Packing::new(periodic_box(4.0 * s), particles);
    let r = jamming_report(&packing, 1e-6, false, 1, 1.0).unwrap();
    assert!(r.lp.is_none());
    assert_eq!(r.at_cutoff.rattler_fraction, 1.0 / 64.0);
    let at = |h: f64| r.plateau.iter().find(|row| row.cutoff == h).unwrap();
    // Below the gap nothing touches (all rattlers); above it 3·64 − 6 pairs do.
    assert_eq!(at(1e-8).mean_contacts, 0.0);
    assert_eq!(at(1e-8).rattler_fraction, 1.0);
    assert!((at(1e-6).mean_contacts - 2.0 * (3.0 * 64.0 - 6.0) / 64.0).abs() < 1e-12);
}

#[test]
fn bad_cut_offs_and_ellipsoids_are_refused() {
    let packing = Packing::new(periodic_box(6.0), lattice(2, 1.0, &[[0.0; 3]], 0.5));
    for bad in [0.0, -1e-9, 0.5, f64::NAN] {
        assert!(jamming_report(&packing, bad, false, 1, 1.0).is_err());
    }
    let ellipsoid = ParticleRecord::Ellipsoid {
        center: [1.0; 3],
        semi_axes: [0.5, 0.4, 0.3],
        orientation: [1.0, 0.0, 0.0, 0.0],
    };
    let packing = Packing::new(periodic_box(6.0), vec![ellipsoid]);
    assert!(jamming_report(&packing, 1e-9, false, 1, 1.0).is_err());
}
