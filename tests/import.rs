//! `densepack import`: export → import round trips give the same particles to the printed
//! precision (the formats print shortest round-trip floats, or binary doubles: bit for bit);
//! malformed files fail with exit code 2 naming the line and the field and write nothing;
//! imported packings verify.

mod common;

use common::densepack;
use densepack::io::packing::{ContainerRecord, Packing};
use densepack::io::record::SphereRecord;
use std::path::{Path, PathBuf};

fn run_scene(dir: &Path, scene: &str) -> PathBuf {
    let out = dir.join("p.json");
    let scene = format!("{}/tests/scenes/{scene}", env!("CARGO_MANIFEST_DIR"));
    let run = densepack(&["run", &scene, "--out", out.to_str().unwrap(), "--quiet"]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    out
}

fn ok(args: &[&str]) -> String {
    let r = densepack(args);
    assert!(
        r.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&r.stderr)
    );
    String::from_utf8_lossy(&r.stdout).into_owned()
}

#[test]
fn export_then_import_gives_the_same_particles_and_container_and_verifies() {
    for scene in ["export_periodic.toml", "export_cylinder.toml"] {
        let dir = common::temp_dir(scene);
        let original = run_scene(&dir, scene);
        let p = Packing::read(&original).unwrap();
        // The flags that give back the container of a file that holds none (or only a box).
        let flags: Vec<String> = match &p.container {
            ContainerRecord::Box { min, max, periodic } => {
                assert_eq!(min, &[0.0; 3], "the test scene's box starts at the origin");
                vec![
                    "--box".into(),
                    format!("{},{},{}", max[0], max[1], max[2]),
                    "--periodic".into(),
                    format!("{},{},{}", periodic[0], periodic[1], periodic[2]),
                ]
            }
            ContainerRecord::Cylinder {
                base_center,
                radius,
                height,
            } => {
                assert_eq!(base_center, &[0.0; 3]);
                vec!["--cylinder".into(), format!("{radius},{height}")]
            }
        };
        for (format, file, from, with_flags) in [
            ("csv", "p.csv", "csv", true),
            ("xyzd", "p.xyzd", "xyzd", true),
            // A LAMMPS box is the container's (bounding) box and its title names the
            // periodic axes: a periodic box comes back without flags, a cylinder needs them.
            (
                "lammps",
                "p.data",
                "lammps-data",
                matches!(p.container, ContainerRecord::Cylinder { .. }),
            ),
        ] {
            let exported = dir.join(file);
            let imported = dir.join(format!("{file}.json"));
            ok(&[
                "export",
                original.to_str().unwrap(),
                "--format",
                format,
                "--out",
                exported.to_str().unwrap(),
            ]);
            let mut args = vec![
                "import",
                exported.to_str().unwrap(),
                "--from",
                from,
                "--out",
                imported.to_str().unwrap(),
            ];
            if with_flags {
                args.extend(flags.iter().map(String::as_str));
            }
            ok(&args);
            let back = Packing::read(&imported).unwrap();
            assert_eq!(back.particles, p.particles, "{scene} {format}");
            assert_eq!(back.container, p.container, "{scene} {format}");
            assert_eq!(back.min_gap, 0.0);
            let from_file = back.provenance.unwrap().imported_from.unwrap();
            assert_eq!(
                (from_file.file.as_str(), from_file.format.as_str()),
                (file, from)
            );
            let verified = ok(&["verify", imported.to_str().unwrap(), "--json"]);
            let report: serde_json::Value = serde_json::from_str(&verified).unwrap();
            assert_eq!(report["overlap_count"], 0, "{scene} {format}: {verified}");
            assert_eq!(report["violation_count"], 0, "{scene} {format}: {verified}");
        }
    }
}

#[test]
fn a_packing_json_without_min_gap_seed_and_stats_reads_and_verifies() {
    let dir = common::temp_dir("json");
    let foreign = dir.join("foreign.json");
    std::fs::write(
        &foreign,
        r#"{"format": "densepack-packing", "version": 1,
            "container": {"type": "box", "min": [0, 0, 0], "max": [4, 4, 4], "periodic": [true, true, true]},
            "particles": [{"type": "sphere", "center": [0.1, 2, 2], "radius": 0.5},
                          {"type": "sphere", "center": [3.0, 2, 2], "radius": 0.5}]}"#,
    )
    .unwrap();
    let out = dir.join("p.json");
    ok(&[
        "import",
        foreign.to_str().unwrap(),
        "--from",
        "json",
        "--out",
        out.to_str().unwrap(),
    ]);
    let p = Packing::read(&out).unwrap();
    assert_eq!(p.particles.len(), 2);
    assert_eq!((p.min_gap, p.seed), (0.0, 0));
    ok(&["verify", out.to_str().unwrap()]);
    // 1.1 apart across the periodic face x = 0 / 4; moved to 3.2, 0.9 apart: an overlap.
    std::fs::write(
        &foreign,
        std::fs::read_to_string(&foreign)
            .unwrap()
            .replace("3.0", "3.2"),
    )
    .unwrap();
    ok(&[
        "import",
        foreign.to_str().unwrap(),
        "--from",
        "json",
        "--out",
        out.to_str().unwrap(),
    ]);
    let r = densepack(&["verify", out.to_str().unwrap()]);
    assert!(
        !r.status.success(),
        "an overlap across the periodic face must fail verify"
    );
}

#[test]
fn malformed_files_fail_with_exit_code_2_name_the_line_and_the_field_and_write_nothing() {
    let dir = common::temp_dir("bad");
    let cases: [(&str, &[u8], &[&str], &str); 7] = [
        ("a.csv", b"x,y,z,r\n1,2,3,0.5\n1,2,oops,0.5\n", &["--box", "4,4,4"], "line 3: z:"),
        ("b.csv", b"x,y,z,r\n1,2,3,0.5\n", &[], "--box"),
        ("c.xyzd", &[0u8; 40], &["--box", "4,4,4"], "end of file: length: 40 bytes"),
        (
            "d.data",
            b"LAMMPS\n\n1 atoms\n\n0 4 xlo xhi\n0 4 ylo yhi\n0 4 zlo zhi\n\nAtoms # sphere\n\n1 1 -1 1 2 2 2\n",
            &[],
            "line 11: diameter: = -1 must be > 0",
        ),
        (
            "e.dump",
            b"ITEM: TIMESTEP\n0\nITEM: NUMBER OF ATOMS\n2\nITEM: BOX BOUNDS pp pp pp\n0 4\n0 4\n0 4\nITEM: ATOMS id x y z radius\n1 1 1 1 0.5\n",
            &[],
            "line 11: ITEM: the file ends inside a snapshot",
        ),
        ("f.csv", b"x,y,z,r\n1,2,3,0.5\n", &["--box", "4,0,4"], "container.max[1]"),
        ("g.csv", b"x,y,z,r\n1,2,3,0.5\n", &["--periodic", "true,true,true"], "--periodic"),
    ];
    for (file, content, flags, expected) in cases {
        let input = dir.join(file);
        std::fs::write(&input, content).unwrap();
        let from = match file.rsplit('.').next().unwrap() {
            "data" => "lammps-data",
            "dump" => "lammps-dump",
            ext => ext,
        };
        let out = dir.join(format!("{file}.json"));
        let mut args = vec![
            "import",
            input.to_str().unwrap(),
            "--from",
            from,
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(flags);
        let r = densepack(&args);
        let stderr = String::from_utf8_lossy(&r.stderr);
        assert_eq!(r.status.code(), Some(2), "{file}: {stderr}");
        assert!(stderr.contains(expected), "{file}: {stderr}");
        assert!(!out.exists(), "{file} wrote {}", out.display());
    }
}

/// A scene that starts from `from` (relative to the scene file) in a walled 3-cube and
/// opens a gap of 0.2 between the spheres (and 0.1 to the walls).
fn start_scene(from: &str, size: f64, extra: &str) -> String {
    format!(
        "seed = 1\n{extra}[container]\ntype = \"box\"\nsize = [{size}, {size}, {size}]\n\
         periodic = [false, false, false]\n[particles]\nfrom = \"{from}\"\n\
         [[stage]]\ngrowth = \"absolute\"\nrate = 0.01\nuntil = {{ gap = 0.2 }}\n"
    )
}

/// 27 spheres of radius 0.3 on the cubic lattice of spacing 1 in the 3-cube (gaps 0.4,
/// 0.2 to the walls), as a foreign CSV of `x,y,z,r`; `overlap` moves the first sphere onto
/// its neighbour.
fn lattice_csv(overlap: bool) -> String {
    let mut text = String::from("x,y,z,r\n");
    for k in 0..27 {
        let (i, j, l) = (k % 3, k / 3 % 3, k / 9);
        let x = if overlap && k == 0 {
            1.0
        } else {
            0.5 + i as f64
        };
        text.push_str(&format!("{x},{},{},0.3\n", 0.5 + j as f64, 0.5 + l as f64));
    }
    text
}

/// Writes the lattice as `DIR/NAME.csv` and imports it into `DIR/NAME.json` (the walled
/// 3-cube), which it returns.
fn import_lattice(dir: &Path, name: &str, overlap: bool) -> PathBuf {
    let csv = dir.join(format!("{name}.csv"));
    let json = dir.join(format!("{name}.json"));
    std::fs::write(&csv, lattice_csv(overlap)).unwrap();
    ok(&[
        "import",
        csv.to_str().unwrap(),
        "--from",
        "csv",
        "--box",
        "3,3,3",
        "--periodic",
        "false,false,false",
        "--out",
        json.to_str().unwrap(),
    ]);
    json
}

#[test]
fn a_scene_starts_from_an_imported_packing_and_opens_a_gap_that_verifies() {
    let dir = common::temp_dir("start-from");
    let imported = import_lattice(&dir, "lattice", false);
    // The scene names the packing relative to itself; the test runs from the crate root.
    let scene = dir.join("gap.toml");
    std::fs::write(&scene, start_scene("lattice.json", 3.0, "")).unwrap();
    let out = dir.join("gapped.json");
    ok(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    ok(&["verify", out.to_str().unwrap()]);
    let p = Packing::read(&out).unwrap();
    // The particles are the file's, at their true sizes, moved by the run, with the gap the
    // stage opened claimed and (verify above) kept.
    assert_eq!(p.particles.len(), 27);
    assert_eq!(p.min_gap, 0.2);
    assert_eq!(p.stats.stop_reason, "gap_reached");
    let start = Packing::read(&imported).unwrap();
    let mut moved = 0;
    for (a, b) in p.particles.iter().zip(&start.particles) {
        let (
            densepack::io::packing::ParticleRecord::Sphere(SphereRecord {
                center: ca,
                radius: ra,
            }),
            densepack::io::packing::ParticleRecord::Sphere(SphereRecord {
                center: cb,
                radius: rb,
            }),
        ) = (a, b)
        else {
            panic!("spheres");
        };
        assert_eq!(ra, rb, "true sizes are written");
        moved += usize::from(ca != cb);
    }
    assert!(moved > 20, "the stage moved the spheres ({moved} moved)");
}

#[test]
fn a_bad_start_packing_fails_with_exit_code_2_naming_the_field() {
    let dir = common::temp_dir("start-from-bad");
    for (name, overlap) in [("good", false), ("overlap", true)] {
        import_lattice(&dir, name, overlap);
    }
    let cases = [
        (start_scene("overlap.json", 3.0, ""), "overlap"),
        (start_scene("good.json", 4.0, ""), "container.size"),
        (start_scene("missing.json", 3.0, ""), "particles.from"),
        (
            start_scene("good.json", 3.0, "").replace("[particles]\n", "[particles]\ncount = 27\n"),
            "particles.count",
        ),
        (
            start_scene("good.json", 3.0, "method = \"rsa\"\n"),
            "particles.from",
        ),
    ];
    for (text, expected) in cases {
        let scene = dir.join("bad.toml");
        std::fs::write(&scene, &text).unwrap();
        let out = dir.join("out.json");
        let run = densepack(&[
            "run",
            scene.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{text}\n{stderr}");
        assert!(stderr.contains(expected), "{expected}: {stderr}");
        assert!(!out.exists());
    }
}
