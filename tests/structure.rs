//! The structure report of `densepack analyse` against exact solutions and the literature:
//! g(r) of an ideal gas is 1 (within its counting statistics), g(r) of a perfect FCC crystal
//! is its coordination shells at √k diameters with their exact numbers, a jammed packing
//! has the split second peak at √3 and 2 diameters (Donev, Torquato & Stillinger, PRE 71,
//! 011105, 2005), slab volumes of spheres add up to the sphere and halve it through its
//! centre, the sphere–cylinder volume matches Viviani's solid, and size classes of the
//! rock-salt crystal have six contacts each.

mod common;

use densepack::analysis::jamming::jamming_report;
use densepack::analysis::structure::{
    radial_distribution, sphere_cylinder_volume, sphere_slab_volume, structure_report,
    StructureError,
};
use densepack::io::packing::{ContainerRecord, Packing, ParticleRecord};
use densepack::io::record::SphereRecord;
use rand::{Rng, SeedableRng};
use std::f64::consts::PI;

fn periodic_box(edge: f64) -> ContainerRecord {
    ContainerRecord::Box {
        min: [0.0; 3],
        max: [edge; 3],
        periodic: [true; 3],
    }
}

/// `n` centres uniform in the box `[0, edge)³` with radii uniform in `[r_lo, r_hi]`.
fn ideal_gas(n: usize, edge: f64, r_lo: f64, r_hi: f64, seed: u64) -> Vec<ParticleRecord> {
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            ParticleRecord::Sphere(SphereRecord {
                center: [0; 3].map(|_| rng.gen_range(0.0..edge)),
                radius: if r_hi > r_lo {
                    rng.gen_range(r_lo..r_hi)
                } else {
                    r_lo
                },
            })
        })
        .collect()
}

/// Asserts g = 1 in every bin within five standard deviations of its pair count: the count
/// of ordered pairs in a bin with ideal expectation `E` is twice a Poisson count of mean
/// `E/2`, so `g` has standard deviation `√(2/E)`. `E` is recovered as the count's
/// expectation, `(N_ref − 1)/V_ref · N_ref · ⟨σ³⟩ · (4π/3)(b³ − a³)`, with `⟨σ³⟩` the mean
/// of `(r_i + r_j)³` over all pairs, computed here by brute force.
fn assert_ideal(packing: &Packing, bins: usize, range: f64, volume: f64) {
    let g = radial_distribution(packing, bins, range).unwrap();
    let radii: Vec<f64> = packing
        .particles
        .iter()
        .map(|p| match p {
            ParticleRecord::Sphere(SphereRecord { radius, .. }) => *radius,
            _ => unreachable!(),
        })
        .collect();
    let n = radii.len();
    let mut cubes = 0.0;
    for i in 0..n {
        for j in 0..n {
            if i != j {
                cubes += (radii[i] + radii[j]).powi(3);
            }
        }
    }
    let mean_cube = cubes / (n * (n - 1)) as f64;
    let refs = g.references as f64;
    let w = g.bin_width;
    let mut worst: f64 = 0.0;
    for (k, &value) in g.g.iter().enumerate() {
        let (a, b) = (k as f64 * w, (k + 1) as f64 * w);
        let expected =
            (refs - 1.0) / volume * refs * mean_cube * 4.0 / 3.0 * PI * (b.powi(3) - a.powi(3));
        let sigma = (2.0 / expected).sqrt();
        worst = worst.max((value - 1.0).abs() / sigma);
        assert!(
            (value - 1.0).abs() < 5.0 * sigma,
            "bin {k} (s = {:.3}): g = {value}, ideal 1 ± {sigma:.4}",
            g.centres[k]
        );
    }
    assert!(worst > 0.0, "a random sample is not exactly ideal");
}

#[test]
fn g_of_an_ideal_gas_is_one_within_its_statistics() {
    // Equal radii, density 1 per unit diameter cubed.
    let edge = 20.0;
    let packing = Packing::new(periodic_box(edge), ideal_gas(8000, edge, 0.5, 0.5, 1));
    assert_ideal(&packing, 30, 3.0, edge.powi(3));
    // Polydisperse radii in [0.2, 0.8]: the scaled distance needs the mean of (r_i + r_j)³.
    let packing = Packing::new(periodic_box(edge), ideal_gas(6000, edge, 0.2, 0.8, 2));
    assert_ideal(&packing, 30, 3.0, edge.powi(3));
}

#[test]
fn g_of_an_ideal_gas_in_a_walled_box_uses_the_inner_references() {
    let edge = 24.0;
    let container = ContainerRecord::Box {
        min: [0.0; 3],
        max: [edge; 3],
        periodic: [false, true, false],
    };
    let packing = Packing::new(container, ideal_gas(12000, edge, 0.5, 0.5, 3));
    let g = radial_distribution(&packing, 30, 3.0).unwrap();
    // References at least 3 diameters from the x and z walls.
    assert!((g.wall_margin - 3.0).abs() < 1e-12, "{}", g.wall_margin);
    let inner = (edge - 6.0) * edge * (edge - 6.0);
    assert_ideal(&packing, 30, 3.0, inner);
}

/// FCC crystal of unit nearest-neighbour distance: `cells³` cubic cells of edge √2.
fn fcc(cells: usize) -> Packing {
    let a = 2.0_f64.sqrt();
    let basis = [
        [0.0, 0.0, 0.0],
        [0.5, 0.5, 0.0],
        [0.5, 0.0, 0.5],
        [0.0, 0.5, 0.5],
    ];
    let mut particles = Vec::new();
    for x in 0..cells {
        for y in 0..cells {
            for z in 0..cells {
                for b in basis {
                    particles.push(ParticleRecord::Sphere(SphereRecord {
                        center: [
                            (x as f64 + b[0] + 0.25) * a,
                            (y as f64 + b[1] + 0.25) * a,
                            (z as f64 + b[2] + 0.25) * a,
                        ],
                        radius: 0.5,
                    }));
                }
            }
        }
    }
    Packing::new(periodic_box(cells as f64 * a), particles)
}

/// Coordination shells of FCC at distance √k nearest-neighbour distances, k = 1 … 8.
const FCC_SHELLS: [usize; 8] = [12, 6, 24, 12, 24, 8, 48, 6];

#[test]
fn g_of_fcc_is_its_coordination_shells_exactly() {
    let packing = fcc(6); // 864 spheres, box 8.49: half of it beyond s = 3
    let n = packing.particles.len() as f64;
    let volume = (6.0 * 2.0_f64.sqrt()).powi(3);
    // Width 0.03: no shell √k (k = 1 … 8) lies within 0.1 bin widths of an edge.
    let g = radial_distribution(&packing, 100, 3.0).unwrap();
    assert!(!g.range_cut);
    let w = g.bin_width;
    let mut shells = vec![0usize; g.g.len()];
    for (k, &z) in FCC_SHELLS.iter().enumerate() {
        let s = ((k + 1) as f64).sqrt();
        shells[(s / w) as usize] = z;
    }
    for (k, (&value, &z)) in g.g.iter().zip(&shells).enumerate() {
        // Exactly z neighbours per particle in the bin: g = z / (ρ (4π/3)(b³ − a³)).
        let (a, b) = (k as f64 * w, (k + 1) as f64 * w);
        let expected = z as f64 / ((n - 1.0) / volume * 4.0 / 3.0 * PI * (b.powi(3) - a.powi(3)));
        assert!(
            (value - expected).abs() <= 1e-12 * expected,
            "bin {k} [{a:.2}, {b:.2}): g = {value}, exact {expected}"
        );
    }
    // The default bins (0.02): peaks in the bins [1, 1.02), [√2 ∓], [√3 ∓] and [2, 2.02),
    // contacts at 1 and the third-in-line at 2 exactly on a bin edge.
    let g = radial_distribution(&packing, 150, 3.0).unwrap();
    let w = g.bin_width;
    // The bin of centre p holds s (edges up to rounding of the centre).
    let holds = |p: f64, s: f64| (p - s).abs() <= 0.5 * w + 1e-12;
    let first = g.first_peak.unwrap();
    assert!(holds(first.position, 1.0), "{first:?}");
    let second = g.second_peak.unwrap();
    assert!(second.split);
    assert!(holds(second.near_sqrt3.position, 3f64.sqrt()), "{second:?}");
    assert!(holds(second.near_2.position, 2.0), "{second:?}");
    let nonzero: Vec<f64> =
        g.g.iter()
            .zip(&g.centres)
            .filter(|(&v, _)| v > 0.0)
            .map(|(_, &c)| c)
            .collect();
    assert_eq!(nonzero.len(), 8, "{nonzero:?}");
    for (c, k) in nonzero.iter().zip(1..) {
        assert!(
            holds(*c, f64::from(k).sqrt()),
            "shell √{k} in the bin at {c}"
        );
    }
}

#[test]
fn the_range_is_cut_to_half_a_small_periodic_box() {
    let packing = fcc(4); // box 5.66: s ≤ 2.83
    let g = radial_distribution(&packing, 150, 3.0).unwrap();
    assert!(g.range_cut);
    assert!(
        g.range <= 0.5 * 4.0 * 2.0_f64.sqrt() && g.range > 2.8,
        "{}",
        g.range
    );
    assert_eq!(g.bin_width, 0.02);
}

#[test]
fn a_jammed_packing_has_the_split_second_peak_at_sqrt3_and_2() {
    let dir = common::temp_dir("jammed_gr");
    let path = dir.join("jammed.json");
    let out = common::densepack(&[
        "run",
        "examples/scenes/mono_periodic_jam.toml",
        "--set",
        "particles.count=2000",
        "--set",
        "container.size=[14.62,14.62,14.62]",
        "--quiet",
        "--out",
        path.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = common::densepack(&["analyse", "--no-lp", "--json", path.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    // The jamming report's fields stay at the top level.
    assert_eq!(json["particles"], 2000);
    let g = &json["structure"]["radial_distribution"];
    let w = g["bin_width"].as_f64().unwrap();
    assert_eq!(w, 0.02);
    let at = |p: &serde_json::Value| p["position"].as_f64().unwrap();
    assert!((at(&g["first_peak"]) - 1.0).abs() <= w, "{g}");
    let second = &g["second_peak"];
    assert_eq!(second["split"], true, "{second}");
    assert!(
        (at(&second["near_sqrt3"]) - 3f64.sqrt()).abs() <= w,
        "{second}"
    );
    assert!((at(&second["near_2"]) - 2.0).abs() <= w, "{second}");
    // Hard spheres do not overlap: g = 0 in every bin below contact.
    let values = g["g"].as_array().unwrap();
    assert!(values[..50].iter().all(|v| v.as_f64() == Some(0.0)), "{g}");
    // The text report names the peaks.
    let out = common::densepack(&["analyse", "--no-lp", path.to_str().unwrap()]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("second peak: split"), "{text}");
    // A periodic box has no wall profiles.
    assert_eq!(
        json["structure"]["wall_profiles"].as_array().unwrap().len(),
        0
    );
}

#[test]
fn slabs_of_a_sphere_add_up_to_its_volume_and_halve_it_through_its_centre() {
    for r in [0.75, 0.5, 1.3, 1e-3, 7.0] {
        let full = 4.0 / 3.0 * PI * r * r * r;
        // Slabs of width w from below the sphere to above it, in an odd offset.
        let w = r / 7.3;
        let start = -r - 0.37 * w;
        let total: f64 = (0..20)
            .map(|m| sphere_slab_volume(r, start + m as f64 * w, start + (m + 1) as f64 * w))
            .sum();
        assert!(
            (total - full).abs() <= 1e-14 * full,
            "r = {r}: {total} vs {full}"
        );
        // Centre on a slab boundary: half below, half above.
        let below = sphere_slab_volume(r, -2.0 * r, 0.0);
        let above = sphere_slab_volume(r, 0.0, 2.0 * r);
        assert!((below - 0.5 * full).abs() <= 1e-15 * full, "{below}");
        assert!((above - 0.5 * full).abs() <= 1e-15 * full, "{above}");
        // A cap of height h: π h² (3r − h)/3.
        let h = 0.3 * r;
        let cap = PI * h * h * (3.0 * r - h) / 3.0;
        let got = sphere_slab_volume(r, r - h, 10.0 * r);
        assert!((got - cap).abs() <= 1e-14 * full, "{got} vs {cap}");
    }
}

/// One sphere of radius 0.5 (mean diameter 1: slabs of 0.1) in `container`.
fn one_sphere(container: ContainerRecord, center: [f64; 3]) -> Packing {
    Packing::new(
        container,
        vec![ParticleRecord::Sphere(SphereRecord {
            center,
            radius: 0.5,
        })],
    )
}

#[test]
fn wall_profiles_hold_the_sphere_volume_exactly() {
    let container = ContainerRecord::Box {
        min: [0.0; 3],
        max: [10.0, 4.0, 4.0],
        periodic: [false, true, true],
    };
    // Centre 2.0 from the x− wall: on the boundary between slabs 19 and 20.
    let packing = one_sphere(container, [2.0, 1.0, 3.9]);
    let jam = jamming_report(&packing, 1e-9, false, 1, 1.0).unwrap();
    let s = structure_report(&packing, &jam, 150, 3.0).unwrap();
    assert_eq!(s.wall_profiles.len(), 2, "x− and x+");
    let p = &s.wall_profiles[0];
    assert_eq!(p.wall, "x-");
    assert_eq!(p.fraction.len(), 50, "5 mean diameters in slabs of 0.1");
    let slab_volume = 0.1 * 4.0 * 4.0;
    let full = 4.0 / 3.0 * PI * 0.125;
    let volume = |range: std::ops::Range<usize>| -> f64 {
        p.fraction[range].iter().map(|f| f * slab_volume).sum()
    };
    assert!((volume(0..50) - full).abs() <= 1e-13 * full);
    assert!((volume(0..20) - 0.5 * full).abs() <= 1e-13 * full);
    assert!((volume(20..50) - 0.5 * full).abs() <= 1e-13 * full);
    assert_eq!(volume(0..15), 0.0);
    // The x+ wall is 8 away: its 5 diameters see nothing.
    assert!(s.wall_profiles[1].fraction.iter().all(|&f| f == 0.0));
    // A small box: slabs up to half of it.
    let small = ContainerRecord::Box {
        min: [0.0; 3],
        max: [3.0, 3.0, 3.0],
        periodic: [false; 3],
    };
    let packing = one_sphere(small, [1.5, 1.5, 1.5]);
    let jam = jamming_report(&packing, 1e-9, false, 1, 1.0).unwrap();
    let s = structure_report(&packing, &jam, 150, 3.0).unwrap();
    assert_eq!(s.wall_profiles.len(), 6);
    for p in &s.wall_profiles {
        assert_eq!(p.fraction.len(), 15, "{}", p.wall);
        let half: f64 = p.fraction.iter().map(|f| f * 0.1 * 9.0).sum();
        assert!(
            (half - 0.5 * full).abs() <= 1e-13 * full,
            "{}: {half}",
            p.wall
        );
    }
    // g(r) of one sphere: no pairs, said so.
    assert!(s.radial_distribution.is_none());
    assert!(s.notes.iter().any(|n| n.contains("g(r)")), "{:?}", s.notes);
}

#[test]
fn sphere_cylinder_volumes_match_closed_forms() {
    // Coaxial: (4π/3)(r³ − (r² − a²)^{3/2}); through the quadrature just off the axis.
    let (r, a) = (1.0_f64, 0.6_f64);
    let coaxial = 4.0 / 3.0 * PI * (r.powi(3) - (r * r - a * a).powf(1.5));
    assert!((sphere_cylinder_volume(r, 0.0, a) - coaxial).abs() < 1e-15);
    let off = sphere_cylinder_volume(r, 1e-7, a);
    assert!(
        (off - coaxial).abs() < 1e-10 * coaxial,
        "{off} vs {coaxial}"
    );
    // Viviani's solid: the sphere of radius r inside the cylinder of radius r/2 through its
    // centre, (2/3)(π − 4/3) r³.
    for r in [1.0, 2.5] {
        let viviani = 2.0 / 3.0 * (PI - 4.0 / 3.0) * r * r * r;
        let got = sphere_cylinder_volume(r, 0.5 * r, 0.5 * r);
        assert!(
            (got - viviani).abs() < 1e-10 * viviani,
            "{got} vs {viviani}"
        );
    }
    // Inside and outside.
    assert_eq!(sphere_cylinder_volume(0.5, 1.0, 2.0), PI / 6.0);
    assert_eq!(sphere_cylinder_volume(0.5, 3.0, 2.0), 0.0);
}

#[test]
fn the_side_profile_of_a_cylinder_holds_the_sphere_volume() {
    let container = ContainerRecord::Cylinder {
        base_center: [0.0; 3],
        radius: 5.0,
        height: 20.0,
    };
    // Touching the side wall, halfway up.
    let packing = one_sphere(container, [4.5 * 0.6, 4.5 * 0.8, 10.0]);
    let jam = jamming_report(&packing, 1e-9, false, 1, 1.0).unwrap();
    let s = structure_report(&packing, &jam, 150, 3.0).unwrap();
    let walls: Vec<&str> = s.wall_profiles.iter().map(|p| p.wall.as_str()).collect();
    assert_eq!(walls, ["z-", "z+", "side"]);
    let side = &s.wall_profiles[2];
    assert_eq!(side.fraction.len(), 50);
    let volume: f64 = side
        .fraction
        .iter()
        .enumerate()
        .map(|(m, f)| {
            let (ro, ri) = (5.0 - 0.1 * m as f64, 5.0 - 0.1 * (m + 1) as f64);
            f * PI * (ro * ro - ri * ri) * 20.0
        })
        .sum();
    let full = PI / 6.0;
    assert!((volume - full).abs() < 1e-10 * full, "{volume} vs {full}");
    // Nothing in the first slab beyond what a sphere touching the wall puts there: more
    // than the plane cap of height 0.1 (the wall curves towards the sphere), less than the
    // slab cap of a sphere in a flat slab twice as deep.
    let first = side.fraction[0] * PI * (25.0 - 4.9 * 4.9) * 20.0;
    let cap = sphere_slab_volume(0.5, 0.4, 0.5);
    assert!(
        first > cap && first < sphere_slab_volume(0.5, 0.3, 0.5),
        "{first} vs {cap}"
    );
}

#[test]
fn rock_salt_size_classes_have_six_contacts_each() {
    // Two FCC lattices of radii 0.3 and 0.2 (r_A + r_B = a/2 = 0.5): each sphere touches
    // six of the other kind; like neighbours are 0.707 apart, no contact.
    let cells = 4;
    let mut particles = Vec::new();
    for x in 0..2 * cells {
        for y in 0..2 * cells {
            for z in 0..2 * cells {
                let radius = if (x + y + z) % 2 == 0 { 0.3 } else { 0.2 };
                particles.push(ParticleRecord::Sphere(SphereRecord {
                    center: [x, y, z].map(|k| 0.5 * k as f64 + 0.25),
                    radius,
                }));
            }
        }
    }
    let packing = Packing::new(periodic_box(cells as f64), particles);
    let jam = jamming_report(&packing, 1e-9, false, 1, 1.0).unwrap();
    let s = structure_report(&packing, &jam, 150, 3.0).unwrap();
    let filled: Vec<_> = s.size_classes.iter().filter(|c| c.count > 0).collect();
    assert_eq!(filled.len(), 2);
    let share_big = 0.3f64.powi(3) / (0.3f64.powi(3) + 0.2f64.powi(3));
    for (c, share) in filled.iter().zip([1.0 - share_big, share_big]) {
        assert_eq!(c.count, 256);
        assert!((c.volume_share - share).abs() < 1e-12, "{c:?}");
        assert_eq!(c.mean_contacts, Some(6.0));
        assert_eq!(c.rattler_fraction, Some(0.0));
    }
    // Classes span the smallest to the largest diameter.
    assert_eq!(filled[0].lo, 0.4);
    assert_eq!(filled[1].hi, 0.6);
}

#[test]
fn bad_gr_arguments_exit_with_code_2_naming_the_flag() {
    let dir = common::temp_dir("bad_gr");
    let path = dir.join("fcc.json");
    fcc(3).write(&path).unwrap();
    let file = path.to_str().unwrap();
    for (args, flag) in [
        (["--gr-bins", "0"], "--gr-bins"),
        (["--gr-range", "-1"], "--gr-range"),
        (["--gr-range", "0"], "--gr-range"),
        (["--gr-range", "NaN"], "--gr-range"),
    ] {
        let out = common::densepack(&["analyse", args[0], args[1], "--no-lp", file]);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(err.contains(flag), "{args:?}: {err}");
    }
    assert_eq!(
        radial_distribution(&fcc(3), 0, 3.0).unwrap_err(),
        StructureError::Bins(0)
    );
    assert_eq!(
        radial_distribution(&fcc(3), 10, -2.0).unwrap_err(),
        StructureError::Range(-2.0)
    );
}
