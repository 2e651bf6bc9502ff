//! `densepack export`: what the files contain is checked with real readers by
//! `tests/readers/run_export_checks.sh` (Gmsh, meshio, the VTK Python package, numpy; run by
//! `.ci/run`). These tests cover the command line: bad options fail with exit code 2, name
//! the option and write nothing; sphere-only formats refuse other shapes; the CSV round-trips
//! bit for bit; a compact packing reads back equal.

mod common;

use common::{densepack, temp_dir, TempDir};
use densepack::io::record::SphereRecord;

use std::path::PathBuf;

fn packing_file(name: &str) -> (TempDir, PathBuf) {
    let dir = temp_dir(name);
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/scenes/export_periodic.toml"
    );
    let out = dir.join("p.json");
    let run = densepack(&["run", scene, "--out", out.to_str().unwrap(), "--quiet"]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    (dir, out)
}

#[test]
fn bad_export_options_fail_with_exit_code_2_name_the_option_and_write_nothing() {
    let (dir, packing) = packing_file("bad");
    let p = packing.to_str().unwrap();
    let cases: [(&[&str], &str); 11] = [
        (
            &[
                "--format",
                "gmsh",
                "--out",
                "x.geo",
                "--partial-volume",
                "2",
            ],
            "--partial-volume",
        ),
        (
            &["--format", "csv", "--out", "x.csv", "--labels", "particle"],
            "--labels",
        ),
        (&["--format", "vtk", "--out", "x.vtk"], "--out"),
        (&["--format", "vti", "--out", "x.vtk"], "--out"),
        (&["--format", "abaqus", "--out", "x.abq"], "--out"),
        (
            &[
                "--format",
                "abaqus",
                "--out",
                "y.inp",
                "--partial-volume",
                "2",
            ],
            "--partial-volume",
        ),
        (
            &["--format", "lammps", "--out", "x.data", "--voxels", "10"],
            "--voxels",
        ),
        (
            &["--format", "gmsh", "--out", "x.geo", "--interface", "0.9"],
            "--interface",
        ),
        (
            &["--format", "gmsh", "--out", "x.geo", "--shrink", "1.5"],
            "--shrink",
        ),
        (
            &["--format", "csv", "--out", "x.csv", "--shrink", "0.1"],
            "--shrink",
        ),
        (
            &["--format", "npy", "--out", "x.npy", "--voxels", "0"],
            "--voxels",
        ),
    ];
    for (args, option) in cases {
        let out = dir.join(args[3]);
        let mut full = vec!["export", p];
        full.extend_from_slice(args);
        full[5] = out.to_str().unwrap();
        let result = densepack(&full);
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(option), "{args:?}: {stderr}");
        assert!(!out.exists(), "{args:?} wrote {}", out.display());
    }
}

#[test]
#[allow(irrefutable_let_patterns)] // spheres are the only particles today
fn csv_export_round_trips_every_sphere_bit_for_bit() {
    let (dir, packing) = packing_file("csv");
    let out = dir.join("p.csv");
    let result = densepack(&[
        "export",
        packing.to_str().unwrap(),
        "--format",
        "csv",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(result.status.success());
    let text = std::fs::read_to_string(&out).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("x,y,z,r"));
    let packing = densepack::io::packing::Packing::read(&packing).unwrap();
    let rows: Vec<Vec<f64>> = lines
        .map(|l| l.split(',').map(|x| x.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), packing.particles.len());
    for (row, p) in rows.iter().zip(&packing.particles) {
        let densepack::io::packing::ParticleRecord::Sphere(SphereRecord { center, radius }) = p
        else {
            panic!("the packing holds only spheres");
        };
        assert_eq!(row, &vec![center[0], center[1], center[2], *radius]);
    }
}

#[test]
fn sphere_only_formats_refuse_other_shapes_with_exit_code_2_and_write_nothing() {
    let dir = temp_dir("shapes");
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/scenes/export_mixture.toml"
    );
    let packing = dir.join("m.json");
    let run = densepack(&["run", scene, "--out", packing.to_str().unwrap(), "--quiet"]);
    assert!(run.status.success());
    for (format, file) in [("xyzd", "m.xyzd"), ("lammps", "m.data")] {
        let out = dir.join(file);
        let result = densepack(&[
            "export",
            packing.to_str().unwrap(),
            "--format",
            format,
            "--out",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&result.stderr);
        assert_eq!(result.status.code(), Some(2), "{format}: {stderr}");
        assert!(
            stderr.contains(&format!("{format} takes spheres only")) && stderr.contains("cylinder"),
            "{format}: {stderr}"
        );
        assert!(!out.exists());
    }
}

#[test]
fn a_compact_packing_is_one_line_and_reads_back_equal_to_the_pretty_one() {
    let (dir, pretty) = packing_file("compact");
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/scenes/export_periodic.toml"
    );
    let compact = dir.join("c.json");
    let run = densepack(&[
        "run",
        scene,
        "--out",
        compact.to_str().unwrap(),
        "--quiet",
        "--compact",
    ]);
    assert!(run.status.success());
    let text = std::fs::read_to_string(&compact).unwrap();
    assert_eq!(text.lines().count(), 1);
    let read = |p: &std::path::Path| densepack::io::packing::Packing::read(p).unwrap();
    let (a, b) = (read(&pretty), read(&compact));
    assert_eq!(a.particles, b.particles);
    assert_eq!(a.container, b.container);
    assert!(text.len() < std::fs::metadata(&pretty).unwrap().len() as usize);
}
