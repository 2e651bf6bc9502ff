//! `densepack plot` and `densepack run --run-log`: every figure is well-formed SVG holding
//! the elements its data calls for (counted against oracles written here), and bad input
//! exits with code 2 and writes nothing.

mod common;

use common::{densepack, temp_dir};
use densepack::analysis::{section, SectionCut};
use densepack::io::packing::{ContainerRecord, Packing, ParticleRecord};
use densepack::io::record::{CylinderRecord, EllipsoidRecord, SphereRecord};
use std::path::{Path, PathBuf};

/// A deterministic pseudo-random number in [0, 1) (a small LCG: the tests need no quality).
fn uniform(state: &mut u64) -> f64 {
    *state = state
        .wrapping_mul(6364136223846793005)
        .wrapping_add(1442695040888963407);
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

/// `particles` in the box `[0, 10]³`, periodic on every axis or walled on every axis.
fn in_box(particles: Vec<ParticleRecord>, periodic: bool) -> Packing {
    Packing::new(
        ContainerRecord::Box {
            min: [0.0; 3],
            max: [10.0; 3],
            periodic: [periodic; 3],
        },
        particles,
    )
}

/// `count` spheres with radii in [0.3, 1.2) at random centres in the box `[0, 10]³` (kept a
/// radius away from walled faces). Overlaps do not matter to a plot.
fn spheres(count: usize, periodic: bool, seed: u64) -> Packing {
    let mut s = seed;
    let particles = (0..count)
        .map(|_| {
            let radius = 0.3 + 0.9 * uniform(&mut s);
            let margin = if periodic { 0.0 } else { radius };
            let center = std::array::from_fn(|_| margin + (10.0 - 2.0 * margin) * uniform(&mut s));
            ParticleRecord::Sphere(SphereRecord { center, radius })
        })
        .collect();
    in_box(particles, periodic)
}

fn write(dir: &Path, name: &str, packing: &Packing) -> PathBuf {
    let path = dir.join(name);
    packing.write(&path).unwrap();
    path
}

/// Runs `densepack plot ARGS`, asserts success, and parses the SVG it wrote to `out`.
fn plot(args: &[&str], out: &Path) -> String {
    let mut all: Vec<&str> = vec!["plot"];
    all.extend_from_slice(args);
    all.extend_from_slice(&["--out", out.to_str().unwrap()]);
    let run = densepack(&all);
    assert!(
        run.status.success(),
        "plot {args:?}: {}",
        String::from_utf8_lossy(&run.stderr)
    );
    let text = std::fs::read_to_string(out).unwrap();
    roxmltree::Document::parse(&text).unwrap_or_else(|e| panic!("{out:?} is not XML: {e}"));
    text
}

/// The elements named `tag` of an SVG text.
fn elements<'a>(doc: &'a roxmltree::Document<'a>, tag: &str) -> Vec<roxmltree::Node<'a, 'a>> {
    doc.descendants().filter(|n| n.has_tag_name(tag)).collect()
}

fn number(node: &roxmltree::Node, attribute: &str) -> f64 {
    node.attribute(attribute)
        .unwrap_or_else(|| panic!("<{}> without {attribute}", node.tag_name().name()))
        .parse()
        .unwrap()
}

/// The points of a `<polyline>`.
fn points(node: &roxmltree::Node) -> Vec<(f64, f64)> {
    node.attribute("points")
        .unwrap()
        .split_whitespace()
        .map(|p| {
            let (x, y) = p.split_once(',').unwrap();
            (x.parse().unwrap(), y.parse().unwrap())
        })
        .collect()
}

/// The longest polyline stroked in `colour` (the data series; legends and axes are 2-point
/// polylines).
fn series<'a>(doc: &'a roxmltree::Document<'a>, colour: &str) -> Vec<(f64, f64)> {
    elements(doc, "polyline")
        .iter()
        .filter(|n| n.attribute("stroke") == Some(colour))
        .map(points)
        .max_by_key(|p| p.len())
        .unwrap_or_default()
}

/// Filled circles (the section's discs; outlines have fill="none").
fn discs<'a>(doc: &'a roxmltree::Document<'a>) -> Vec<roxmltree::Node<'a, 'a>> {
    elements(doc, "circle")
        .into_iter()
        .filter(|n| n.attribute("fill") != Some("none"))
        .collect()
}

/// Pixels per packing unit of a section: the outline rectangle's pixel width over the
/// container's width.
fn section_scale(doc: &roxmltree::Document, width: f64) -> f64 {
    let outline = elements(doc, "rect")
        .into_iter()
        .find(|n| n.attribute("fill") == Some("none") && n.attribute("stroke") == Some("#000000"))
        .expect("the container outline");
    number(&outline, "width") / width
}

#[test]
fn section_of_walled_spheres_draws_one_disc_per_cut_sphere_with_its_chord_radius() {
    let dir = temp_dir("section-walled");
    let packing = spheres(60, false, 7);
    let path = write(&dir, "p.json", &packing);
    for (axis, index, at) in [("z", 2, 4.3), ("x", 0, 6.1)] {
        let out = dir.join(format!("{axis}.svg"));
        let text = plot(
            &[
                "section",
                path.to_str().unwrap(),
                "--axis",
                axis,
                "--at",
                &at.to_string(),
            ],
            &out,
        );
        let doc = roxmltree::Document::parse(&text).unwrap();
        // Oracle: a sphere is cut when the plane is closer to its centre than its radius, as
        // a disc of radius √(r² − t²).
        let mut expected: Vec<f64> = packing
            .particles
            .iter()
            .filter_map(|p| match p {
                ParticleRecord::Sphere(SphereRecord { center, radius }) => {
                    let t = at - center[index];
                    (t.abs() < *radius).then(|| (radius * radius - t * t).sqrt())
                }
                _ => None,
            })
            .collect();
        assert!(expected.len() > 5, "the plane should cut several spheres");
        let scale = section_scale(&doc, 10.0);
        assert!((scale - 720.0 / 10.0).abs() < 0.2, "scale {scale}");
        let mut drawn: Vec<f64> = discs(&doc).iter().map(|c| number(c, "r")).collect();
        assert_eq!(drawn.len(), expected.len(), "axis {axis}");
        expected.sort_by(f64::total_cmp);
        drawn.sort_by(f64::total_cmp);
        for (r, px) in expected.iter().zip(&drawn) {
            assert!((r * scale - px).abs() <= 1.0, "radius {r} drawn as {px} px");
        }
    }
}

#[test]
fn section_of_a_periodic_box_includes_the_images_across_faces() {
    let dir = temp_dir("section-periodic");
    let packing = spheres(80, true, 11);
    let path = write(&dir, "p.json", &packing);
    let at = 0.4; // near the lower z face: images of spheres near z = 10 are cut too
    let out = dir.join("z.svg");
    let text = plot(
        &["section", path.to_str().unwrap(), "--at", &at.to_string()],
        &out,
    );
    let doc = roxmltree::Document::parse(&text).unwrap();
    // Oracle: every periodic image (27 per sphere) that the plane cuts and whose disc reaches
    // into the square [0, 10]².
    let mut expected = 0;
    let mut from_images_along_z = 0;
    for p in &packing.particles {
        let ParticleRecord::Sphere(SphereRecord { center, radius }) = p else {
            unreachable!()
        };
        for i in -1..=1 {
            for j in -1..=1 {
                for k in -1..=1 {
                    let c = [
                        center[0] + 10.0 * f64::from(i),
                        center[1] + 10.0 * f64::from(j),
                        center[2] + 10.0 * f64::from(k),
                    ];
                    let t = at - c[2];
                    if t.abs() >= *radius {
                        continue;
                    }
                    let rho = (radius * radius - t * t).sqrt();
                    if (0..2).all(|a| c[a] + rho > 0.0 && c[a] - rho < 10.0) {
                        expected += 1;
                        from_images_along_z += usize::from(k != 0);
                    }
                }
            }
        }
    }
    assert!(
        from_images_along_z > 0,
        "the test should exercise images along z"
    );
    assert_eq!(discs(&doc).len(), expected);
    let cuts = section(&packing, 2, at).unwrap().cuts;
    assert_eq!(cuts.len(), expected);
}

/// Quaternion `[w, x, y, z]` of a rotation by `angle` about the unit vector `axis`.
fn quaternion(axis: [f64; 3], angle: f64) -> [f64; 4] {
    let (s, c) = (0.5 * angle).sin_cos();
    [c, s * axis[0], s * axis[1], s * axis[2]]
}

/// The world point of body coordinates `b` of an ellipsoid at `center` with orientation `q`
/// (q b q*, written out here rather than taken from nalgebra).
fn body_to_world(q: [f64; 4], center: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    let [w, x, y, z] = q;
    let r = [
        [
            1.0 - 2.0 * (y * y + z * z),
            2.0 * (x * y - w * z),
            2.0 * (x * z + w * y),
        ],
        [
            2.0 * (x * y + w * z),
            1.0 - 2.0 * (x * x + z * z),
            2.0 * (y * z - w * x),
        ],
        [
            2.0 * (x * z - w * y),
            2.0 * (y * z + w * x),
            1.0 - 2.0 * (x * x + y * y),
        ],
    ];
    std::array::from_fn(|i| center[i] + (0..3).map(|j| r[i][j] * b[j]).sum::<f64>())
}

/// The inverse of [`body_to_world`] (the transpose of the rotation).
fn world_to_body(q: [f64; 4], center: [f64; 3], x: [f64; 3]) -> [f64; 3] {
    let inverse = [q[0], -q[1], -q[2], -q[3]];
    let d = std::array::from_fn(|i| x[i] - center[i]);
    body_to_world(inverse, [0.0; 3], d)
}

#[test]
fn ellipsoid_sections_lie_on_the_ellipsoid_surface() {
    // Generic orientations and planes off the centre: points on the reported ellipse, mapped
    // back into the body frame, satisfy Σ (b_k / a_k)² = 1; points just inside are inside.
    let semi_axes = [3.0, 1.0, 2.0];
    let center = [5.0, 5.0, 5.0];
    let mut s = 3;
    for case in 0..20 {
        let axis = {
            let v: [f64; 3] = std::array::from_fn(|_| uniform(&mut s) - 0.5);
            let n = v.iter().map(|x| x * x).sum::<f64>().sqrt();
            v.map(|x| x / n)
        };
        let q = quaternion(axis, 6.0 * uniform(&mut s));
        let normal = case % 3;
        let at = center[normal] + 1.5 * (uniform(&mut s) - 0.5);
        let packing = in_box(
            vec![ParticleRecord::Ellipsoid(EllipsoidRecord {
                center,
                semi_axes,
                orientation: q,
            })],
            false,
        );
        let cuts = section(&packing, normal, at).unwrap().cuts;
        let [SectionCut::Ellipse {
            center: c,
            semi_axes: [a, b],
            angle,
            ..
        }] = cuts[..]
        else {
            panic!("case {case}: one ellipse expected, got {cuts:?}");
        };
        let [h, v] = densepack::analysis::section_axes(normal);
        for k in 0..12 {
            let phi = std::f64::consts::TAU * f64::from(k) / 12.0;
            for (shrink, inside) in [(1.0, None), (0.99, Some(true)), (1.01, Some(false))] {
                let (u, w) = (shrink * a * phi.cos(), shrink * b * phi.sin());
                let mut x = [0.0; 3];
                x[normal] = at;
                x[h] = c[0] + angle.cos() * u - angle.sin() * w;
                x[v] = c[1] + angle.sin() * u + angle.cos() * w;
                let body = world_to_body(q, center, x);
                let level: f64 = (0..3).map(|i| (body[i] / semi_axes[i]).powi(2)).sum();
                match inside {
                    None => assert!((level - 1.0).abs() < 1e-9, "case {case}: level {level}"),
                    Some(true) => assert!(level < 1.0),
                    Some(false) => assert!(level > 1.0),
                }
            }
        }
    }
}

#[test]
fn ellipsoid_section_svg_draws_one_polygon_per_cut_ellipsoid_with_its_aspect() {
    let dir = temp_dir("section-ellipsoid");
    // Long axis 3 along x (identity) and, for the second, turned onto y by 90° about z.
    let quarter = quaternion([0.0, 0.0, 1.0], std::f64::consts::FRAC_PI_2);
    let packing = Packing::new(
        ContainerRecord::Box {
            min: [0.0; 3],
            max: [20.0, 10.0, 10.0],
            periodic: [false; 3],
        },
        vec![
            ParticleRecord::Ellipsoid(EllipsoidRecord {
                center: [5.0, 5.0, 5.0],
                semi_axes: [3.0, 1.0, 2.0],
                orientation: [1.0, 0.0, 0.0, 0.0],
            }),
            ParticleRecord::Ellipsoid(EllipsoidRecord {
                center: [15.0, 5.0, 5.0],
                semi_axes: [3.0, 1.0, 2.0],
                orientation: quarter,
            }),
            ParticleRecord::Ellipsoid(EllipsoidRecord {
                center: [10.0, 5.0, 8.5],
                semi_axes: [1.0, 1.0, 1.0],
                orientation: [1.0, 0.0, 0.0, 0.0],
            }),
        ],
    );
    let path = write(&dir, "e.json", &packing);
    let out = dir.join("e.svg");
    let text = plot(&["section", path.to_str().unwrap(), "--at", "6"], &out);
    let doc = roxmltree::Document::parse(&text).unwrap();
    let polygons = elements(&doc, "polygon");
    // The plane z = 6 cuts the two long ellipsoids (|t| = 1 < 2), not the third (|t| = 2.5).
    assert_eq!(polygons.len(), 2);
    let scale = section_scale(&doc, 20.0);
    let mut boxes: Vec<(f64, f64, f64)> = polygons
        .iter()
        .map(|p| {
            let pts: Vec<(f64, f64)> = p
                .attribute("points")
                .unwrap()
                .split_whitespace()
                .map(|q| {
                    let (x, y) = q.split_once(',').unwrap();
                    (x.parse().unwrap(), y.parse().unwrap())
                })
                .collect();
            let span = |f: fn(&(f64, f64)) -> f64| {
                pts.iter().map(f).fold(f64::NEG_INFINITY, f64::max)
                    - pts.iter().map(f).fold(f64::INFINITY, f64::min)
            };
            let cx = pts.iter().map(|p| p.0).sum::<f64>() / pts.len() as f64;
            (cx, span(|p| p.0), span(|p| p.1))
        })
        .collect();
    boxes.sort_by(|a, b| a.0.total_cmp(&b.0));
    // At |t| = 1 of c = 2 the section's semi-axes are 3·√(3/4) and 1·√(3/4).
    let long = 2.0 * 3.0 * 0.75f64.sqrt() * scale;
    let short = 2.0 * 1.0 * 0.75f64.sqrt() * scale;
    let near = |px: f64, expected: f64| (px - expected).abs() <= 2.0;
    assert!(
        near(boxes[0].1, long) && near(boxes[0].2, short),
        "{boxes:?}"
    );
    assert!(
        near(boxes[1].1, short) && near(boxes[1].2, long),
        "{boxes:?}"
    );
}

#[test]
fn sieve_plot_draws_the_packing_and_the_target_curve() {
    let dir = temp_dir("sieve");
    // Spheres from 2 to 16 mm, equal numbers per octave (not the target's distribution).
    let mut s = 5;
    let particles = (0..120)
        .map(|_| {
            ParticleRecord::Sphere(SphereRecord {
                center: std::array::from_fn(|_| 10.0 + 80.0 * uniform(&mut s)),
                radius: 0.5 * 2.0 * 8f64.powf(uniform(&mut s)),
            })
        })
        .collect();
    let packing = Packing::new(
        ContainerRecord::Box {
            min: [0.0; 3],
            max: [100.0; 3],
            periodic: [false; 3],
        },
        particles,
    );
    let path = write(&dir, "p.json", &packing);
    let out = dir.join("sieve.svg");
    let text = plot(
        &[
            "sieve",
            path.to_str().unwrap(),
            "--grading",
            "fuller:0.5:16",
            "--d-min",
            "2",
        ],
        &out,
    );
    let doc = roxmltree::Document::parse(&text).unwrap();
    // Half-octave sieves from 2 to 16 (the Fuller curve adds none): 2, 2.83, …, 16.
    let target = series(&doc, "#000000");
    let passing = series(&doc, "#C0392B");
    assert_eq!(target.len(), 7, "{target:?}");
    assert_eq!(passing.len(), 7, "{passing:?}");
    // Both start at 0 % at d_min and end at 100 % at d_max (same pixels); in between the
    // curves differ and neither falls (pixel y grows downwards).
    assert_eq!(target[0], passing[0]);
    assert_eq!(target[6], passing[6]);
    assert!(target[0].1 > target[6].1);
    for curve in [&target, &passing] {
        assert!(curve
            .windows(2)
            .all(|w| w[1].0 > w[0].0 && w[1].1 <= w[0].1));
    }
    assert!(target[1..6] != passing[1..6]);
    // The legend names the curve.
    assert!(text.contains("Fuller q = 0.5, d_max = 16 mm"));
    // A curve from a TOML table is named by its file and its range, in words (it printed a
    // Rust debug structure, `Table { sizes: … }`).
    let table = dir.join("grading.toml");
    std::fs::write(
        &table,
        "[grading]\nkind = \"table\"\nsizes = [2.0, 8.0, 16.0]\npassing = [0.0, 60.0, 100.0]\n",
    )
    .unwrap();
    let text = plot(
        &[
            "sieve",
            path.to_str().unwrap(),
            "--grading",
            table.to_str().unwrap(),
        ],
        &out,
    );
    assert!(text.contains("sieve table 2–16 mm"), "{text}");
    assert!(!text.contains("Table {"));
}

#[test]
fn sieve_plot_defaults_to_the_curve_of_the_packings_scene() {
    let dir = temp_dir("sieve-scene");
    let scene = dir.join("c.toml");
    let take = densepack(&[
        "take",
        "B16",
        "--phi-m",
        "0.7",
        "--d-min",
        "4",
        "--box",
        "30,30,30",
        "--seed",
        "2",
        "--scene",
        scene.to_str().unwrap(),
    ]);
    assert!(
        take.status.success(),
        "{}",
        String::from_utf8_lossy(&take.stderr)
    );
    let packing = dir.join("c.json");
    let run = densepack(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        packing.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let own = plot(&["sieve", packing.to_str().unwrap()], &dir.join("own.svg"));
    let given = plot(
        &[
            "sieve",
            packing.to_str().unwrap(),
            "--grading",
            "B16",
            "--d-min",
            "4",
        ],
        &dir.join("given.svg"),
    );
    assert!(own.contains("DIN 1045-2 B16"));
    assert_eq!(own, given, "the scene's curve and d_min are B16 and 4");
}

#[test]
fn sizes_plot_bars_are_proportional_to_the_counts() {
    let dir = temp_dir("sizes");
    let sphere = |x: f64, radius: f64| {
        ParticleRecord::Sphere(SphereRecord {
            center: [x, 5.0, 5.0],
            radius,
        })
    };
    let mut particles: Vec<ParticleRecord> =
        (0..3).map(|k| sphere(1.0 + f64::from(k), 0.5)).collect();
    particles.extend((0..5).map(|k| sphere(1.0 + f64::from(k), 1.0)));
    let packing = in_box(particles, true);
    let path = write(&dir, "p.json", &packing);
    let text = plot(&["sizes", path.to_str().unwrap()], &dir.join("s.svg"));
    let doc = roxmltree::Document::parse(&text).unwrap();
    let bars: Vec<roxmltree::Node> = elements(&doc, "rect")
        .into_iter()
        .filter(|r| r.attribute("fill") == Some("#4682B4"))
        .collect();
    assert_eq!(bars.len(), 2, "one bar per size");
    let mut heights: Vec<f64> = bars.iter().map(|b| number(b, "height")).collect();
    heights.sort_by(f64::total_cmp);
    assert!(
        (heights[1] / heights[0] - 5.0 / 3.0).abs() < 0.02,
        "{heights:?}"
    );
}

#[test]
fn a_narrow_size_range_gets_a_labelled_linear_size_axis() {
    // Diameters 1.10 … 1.30: no power of 2 lies in the range, so a log axis (labelled at
    // powers of 2) would print no size at all.
    let dir = temp_dir("sizes-narrow");
    let particles = (0..20)
        .map(|k| {
            ParticleRecord::Sphere(SphereRecord {
                center: [0.5 + 0.45 * f64::from(k), 5.0, 5.0],
                radius: 0.55 + 0.005 * f64::from(k % 5 * 5),
            })
        })
        .collect();
    let packing = in_box(particles, true);
    let path = write(&dir, "p.json", &packing);
    let text = plot(&["sizes", path.to_str().unwrap()], &dir.join("s.svg"));
    let doc = roxmltree::Document::parse(&text).unwrap();
    let sizes: Vec<f64> = elements(&doc, "text")
        .iter()
        .filter_map(|t| t.text()?.trim().parse::<f64>().ok())
        .filter(|&x| x > 1.0 && x < 1.4)
        .collect();
    assert!(sizes.len() >= 3, "size ticks {sizes:?}");
    assert!(
        sizes.iter().all(|&x| (1.09..=1.31).contains(&x)),
        "{sizes:?}"
    );
}

#[test]
fn a_section_of_equal_particles_labels_their_one_size_once() {
    let dir = temp_dir("section-equal");
    let particles = (0..4)
        .map(|k| {
            ParticleRecord::Sphere(SphereRecord {
                center: [1.5 + 2.0 * f64::from(k), 5.0, 5.0],
                radius: 0.75,
            })
        })
        .collect();
    let packing = in_box(particles, false);
    let path = write(&dir, "p.json", &packing);
    let text = plot(
        &[
            "section",
            path.to_str().unwrap(),
            "--axis",
            "z",
            "--at",
            "5",
        ],
        &dir.join("s.svg"),
    );
    let doc = roxmltree::Document::parse(&text).unwrap();
    let labels: Vec<String> = elements(&doc, "text")
        .iter()
        .filter_map(|t| Some(t.text()?.trim().to_string()))
        .filter(|t| t.contains("1.5"))
        .collect();
    assert_eq!(labels, vec!["size 1.5".to_string()]);
}

#[test]
fn gr_plot_draws_one_point_per_bin_and_marks_the_contact_and_second_peak_distances() {
    let dir = temp_dir("gr");
    let path = write(&dir, "p.json", &spheres(200, true, 7));
    let text = plot(
        &[
            "gr",
            path.to_str().unwrap(),
            "--gr-bins",
            "40",
            "--gr-range",
            "2.0",
        ],
        &dir.join("g.svg"),
    );
    let doc = roxmltree::Document::parse(&text).unwrap();
    let line = series(&doc, "#C0392B");
    assert_eq!(
        line.len(),
        40,
        "one point per bin (half the box, 5, allows 2.08)"
    );
    assert!(line.windows(2).all(|w| w[1].0 > w[0].0));
    // Dashed marks at 1, √3 and 2: three vertical dashed lines of 4-pixel dashes.
    let dashes = elements(&doc, "polyline")
        .into_iter()
        .filter(|p| {
            let pts = points(p);
            p.attribute("opacity") == Some("0.4") && pts.len() == 2 && pts[0].0 == pts[1].0
        })
        .map(|p| points(&p)[0].0.round() as i64)
        .collect::<std::collections::BTreeSet<_>>()
        .len();
    assert_eq!(dashes, 3, "{text}");
}

/// A small scene with a full-size stage and a gap stage (so the log has Δd).
const GAP_SCENE: &str = r#"
seed = 3
[container]
type = "box"
size = [6.0, 6.0, 6.0]
periodic = [false, false, false]
[particles]
count = 40
diameter = 1.35   # φ ≈ 0.25, seeded at the true size (a gap stage needs it)
[[stage]]
growth = "absolute"
rate = 0.01
until = { gap = 0.1 }
"#;

#[test]
fn run_log_holds_every_barrier_and_the_convergence_plot_draws_phi_pressure_and_gap() {
    let dir = temp_dir("convergence");
    let scene = dir.join("s.toml");
    std::fs::write(&scene, GAP_SCENE).unwrap();
    let log = dir.join("run.jsonl");
    let run = densepack(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        dir.join("p.json").to_str().unwrap(),
        "--run-log",
        log.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let records: Vec<serde_json::Value> = std::fs::read_to_string(&log)
        .unwrap()
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let progress: Vec<&serde_json::Value> =
        records.iter().filter(|r| r["type"] == "progress").collect();
    let stages = records.iter().filter(|r| r["type"] == "stage").count();
    assert_eq!(stages, 1);
    assert_eq!(records.last().unwrap()["type"], "stage");
    let barriers = records.last().unwrap()["report"]["counts"]["barriers"]
        .as_u64()
        .unwrap();
    // One record at the start of the stage and one per barrier after which it goes on.
    assert!(
        progress.len() as u64 >= barriers,
        "{} < {barriers}",
        progress.len()
    );
    // Δd = 2 · rate · t in the gap stage.
    for r in &progress {
        let t = r["stage_time"].as_f64().unwrap();
        let gap = r["gap"].as_f64().unwrap();
        assert!((gap - 2.0 * 0.01 * t).abs() <= 1e-12 * (1.0 + t));
    }
    let pressures = progress
        .iter()
        .filter(|r| r["reduced_pressure"].as_f64().is_some_and(|z| z > 0.0))
        .count()
        + 1; // the stage record's final Z
    let out = dir.join("c.svg");
    let text = plot(&["convergence", log.to_str().unwrap()], &out);
    let doc = roxmltree::Document::parse(&text).unwrap();
    assert_eq!(
        series(&doc, "#0000FF").len(),
        progress.len() + 1,
        "φ: every record"
    );
    assert_eq!(
        series(&doc, "#FF0000").len(),
        pressures,
        "Z: every positive pressure"
    );
    assert_eq!(
        series(&doc, "#00FF00").len(),
        progress.len(),
        "Δd: every progress record"
    );

    // Without a gap stage there is no Δd panel.
    let plain = dir.join("plain.toml");
    std::fs::write(
        &plain,
        GAP_SCENE.replace(
            "growth = \"absolute\"\nrate = 0.01\nuntil = { gap = 0.1 }",
            "growth = \"relative\"\nrate = 0.1\nuntil = { packing_fraction = 0.35 }",
        ),
    )
    .unwrap();
    let log2 = dir.join("plain.jsonl");
    let run = densepack(&[
        "run",
        plain.to_str().unwrap(),
        "--out",
        dir.join("q.json").to_str().unwrap(),
        "--run-log",
        log2.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let text = plot(
        &["convergence", log2.to_str().unwrap()],
        &dir.join("plain.svg"),
    );
    let doc = roxmltree::Document::parse(&text).unwrap();
    assert!(series(&doc, "#0000FF").len() >= 2);
    assert!(series(&doc, "#00FF00").is_empty());
}

#[test]
fn a_failed_run_still_writes_its_complete_run_log() {
    let dir = temp_dir("failed-log");
    let scene = dir.join("s.toml");
    // A gap of 0.8 (coated φ ≈ 1) cannot open: the stage jams.
    std::fs::write(&scene, GAP_SCENE.replace("gap = 0.1", "gap = 0.8")).unwrap();
    let log = dir.join("run.jsonl");
    let out = dir.join("p.json");
    let run = densepack(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--run-log",
        log.to_str().unwrap(),
        "--quiet",
    ]);
    assert_eq!(
        run.status.code(),
        Some(1),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(!out.exists());
    let text = std::fs::read_to_string(&log).unwrap();
    let last: serde_json::Value = serde_json::from_str(text.lines().last().unwrap()).unwrap();
    assert_eq!(last["type"], "stage");
    assert_ne!(last["report"]["stop_reason"], "time_reached");
}

#[test]
fn bad_input_exits_2_and_writes_no_figure() {
    let dir = temp_dir("plot-bad");
    let good = write(&dir, "p.json", &spheres(10, false, 1));
    let cylinders = write(
        &dir,
        "c.json",
        &in_box(
            vec![ParticleRecord::Cylinder(CylinderRecord {
                center: [5.0; 3],
                radius: 0.5,
                half_axis: [0.0, 0.0, 1.0],
            })],
            true,
        ),
    );
    let not_a_log = dir.join("bad.jsonl");
    std::fs::write(&not_a_log, "{\"type\": \"progress\"}\nnot json\n").unwrap();
    let empty_log = dir.join("empty.jsonl");
    std::fs::write(&empty_log, "").unwrap();
    let good = good.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["sieve", "missing.json", "--grading", "B16"],
            "missing.json",
        ),
        (vec!["sieve", good, "--grading", "Z99"], "not a DIN curve"),
        (vec!["sieve", good], "no grading curve"),
        (
            vec!["sieve", good, "--grading", "B16", "--d-min", "20"],
            "--d-min",
        ),
        (vec!["sizes", good, "--bins", "0"], "--bins"),
        (vec!["gr", good, "--gr-bins", "0"], "--gr-bins"),
        (vec!["gr", good, "--gr-range=-1"], "--gr-range"),
        (vec!["gr", cylinders.to_str().unwrap()], "not a sphere"),
        (
            vec!["section", good, "--at", "10.5"],
            "outside the container",
        ),
        (
            vec!["section", good, "--axis", "y", "--at=-1"],
            "outside the container",
        ),
        (
            vec!["convergence", not_a_log.to_str().unwrap()],
            "stage_time",
        ),
        (
            vec!["convergence", empty_log.to_str().unwrap()],
            "no progress records",
        ),
        (vec!["convergence", "missing.jsonl"], "missing.jsonl"),
    ];
    // Cylinders are drawn in sections (as polygons), not refused.
    let section = plot(
        &["section", cylinders.to_str().unwrap(), "--at", "5"],
        &dir.join("cyl.svg"),
    );
    let doc = roxmltree::Document::parse(&section).unwrap();
    let filled = elements(&doc, "polygon")
        .into_iter()
        .filter(|p| p.attribute("fill").is_some_and(|f| f != "none"))
        .count();
    assert_eq!(filled, 1, "one cylinder cut: {section}");
    for (args, message) in cases {
        let out = dir.join("out.svg");
        let mut all = vec!["plot"];
        all.extend(&args);
        all.extend(["--out", out.to_str().unwrap()]);
        let run = densepack(&all);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(message), "{args:?}: {stderr}");
        assert!(!out.exists(), "{args:?} wrote a figure");
    }
    // An output directory that does not exist.
    let run = densepack(&["plot", "sizes", good, "--out", "/nonexistent-dir/x.svg"]);
    assert_eq!(run.status.code(), Some(2));
    // --run-log with a mixture scene (no time barriers).
    let mixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/scenes/mixture_50_50_a5_rsa.toml");
    let log = dir.join("m.jsonl");
    let run = densepack(&[
        "run",
        mixture.to_str().unwrap(),
        "--out",
        dir.join("m.json").to_str().unwrap(),
        "--run-log",
        log.to_str().unwrap(),
    ]);
    assert_eq!(run.status.code(), Some(2));
    assert!(!log.exists());
}
