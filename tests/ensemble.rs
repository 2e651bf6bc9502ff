//! `densepack ensemble` and `densepack run --seed/--set`: one packing per seed, the summary
//! that describes them, the resume rule, failures as verdicts, bad input before any run.

mod common;

use common::{assert_gap_and_containment, densepack, recomputed_phi, temp_dir};
use densepack::ensemble::{packing_path, read_summary, Status};
use densepack::io::packing::Packing;
use std::path::Path;

/// 50 equal spheres in a periodic box grown from φ 0.3 to 0.55: a fraction of a second.
const SCENE: &str = r#"
seed = 1
[container]
type = "box"
size = [4.8, 4.8, 4.8]
periodic = [true, true, true]
[particles]
count = 50
diameter = 1.0
packing_fraction = 0.3
[[stage]]
growth = "relative"
rate = 0.1
until = { packing_fraction = 0.55 }
"#;

fn write_scene(dir: &Path, text: &str) -> String {
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path.to_str().unwrap().to_string()
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

fn ensemble(scene: &str, seeds: &str, out: &Path, extra: &[&str]) -> std::process::Output {
    let mut args = vec![
        "ensemble",
        scene,
        "--seeds",
        seeds,
        "--out",
        out.to_str().unwrap(),
    ];
    if !extra.contains(&"--jobs") {
        args.extend(["--jobs", "2"]);
    }
    args.extend_from_slice(extra);
    densepack(&args)
}

#[test]
fn four_seeds_give_four_verified_packings_that_the_summary_describes() {
    let dir = temp_dir("four");
    let scene = write_scene(&dir, SCENE);
    let out = dir.join("ens");
    let o = ensemble(&scene, "3..6", &out, &[]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let stdout = text(&o.stdout);
    assert_eq!(
        stdout.matches(": ok ").count(),
        4,
        "one line per seed: {stdout}"
    );

    let rows = read_summary(&out).unwrap();
    assert_eq!(
        rows.iter().map(|r| r.seed).collect::<Vec<_>>(),
        [3, 4, 5, 6]
    );
    let mut seen: Vec<Vec<densepack::io::packing::ParticleRecord>> = Vec::new();
    for row in &rows {
        assert_eq!(row.status, Status::Ok, "{row:?}");
        assert!(row.message.is_empty());
        let path = packing_path(&out, row.seed);
        // The independent check of the binary accepts it.
        let v = densepack(&["verify", path.to_str().unwrap()]);
        assert!(v.status.success(), "seed {}: {}", row.seed, text(&v.stdout));
        let packing = Packing::read(&path).unwrap();
        assert_eq!(packing.seed, row.seed);
        assert_eq!(packing.particles.len(), 50);
        // φ and the smallest gap, recomputed from the file by brute force.
        let phi = recomputed_phi(&packing);
        assert!(
            (row.packing_fraction.unwrap() - phi).abs() < 1e-12,
            "{row:?} vs {phi}"
        );
        assert!((phi - 0.55).abs() < 1e-9, "the goal is met: {phi}");
        let gap = assert_gap_and_containment(&packing);
        let min_gap = row.min_gap.unwrap();
        assert!(
            (min_gap - gap).abs() <= 1e-9 * (1.0 + gap.abs()),
            "seed {}: summary {min_gap} vs recomputed {gap}",
            row.seed
        );
        assert_eq!(row.events, Some(packing.stats.events));
        assert!(row.wall_seconds > 0.0);
        assert!(
            !seen.contains(&packing.particles),
            "seed {} repeats another seed's packing",
            row.seed
        );
        seen.push(packing.particles);
    }

    // Seed 5 of the ensemble is `densepack run --seed 5`, bit for bit.
    let single = dir.join("single.json");
    let o = densepack(&[
        "run",
        &scene,
        "--seed",
        "5",
        "--out",
        single.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let single = Packing::read(&single).unwrap();
    let member = Packing::read(&packing_path(&out, 5)).unwrap();
    assert_eq!(single.seed, 5);
    assert_eq!(single.particles, member.particles);

    // A rerun after losing one packing runs that seed alone, to the same particles.
    std::fs::remove_file(packing_path(&out, 4)).unwrap();
    let summary_before = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let o = ensemble(&scene, "3..6", &out, &[]);
    assert!(o.status.success(), "{}", text(&o.stderr));
    let stdout = text(&o.stdout);
    assert!(stdout.contains("1 of 4 seeds to run"), "{stdout}");
    assert_eq!(stdout.matches(": ok ").count(), 1, "{stdout}");
    assert!(stdout.contains("seed 4: ok"), "{stdout}");
    let summary_after = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let appended = summary_after
        .strip_prefix(&summary_before)
        .expect("rows are appended");
    assert_eq!(appended.lines().count(), 1);
    assert!(appended.starts_with("4,ok,"), "{appended}");
    let again = Packing::read(&packing_path(&out, 4)).unwrap();
    assert_eq!(again.particles, seen[1]);

    // Nothing left to do: no run, and the ensemble is still all ok.
    let o = ensemble(&scene, "3..6", &out, &[]);
    assert!(o.status.success());
    assert!(text(&o.stdout).contains("0 of 4 seeds to run"));
}

#[test]
fn failed_seeds_are_verdicts_with_exit_1_and_are_not_rerun() {
    let dir = temp_dir("failed");
    // Equal spheres cannot grow to 0.74 (they jam near 0.64): every seed fails.
    let scene = write_scene(
        &dir,
        &SCENE.replace("packing_fraction = 0.55", "packing_fraction = 0.74"),
    );
    let out = dir.join("ens");
    let o = ensemble(&scene, "1,2", &out, &[]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o.stderr));
    let rows = read_summary(&out).unwrap();
    assert_eq!(rows.len(), 2);
    for row in &rows {
        assert_eq!(row.status, Status::Failed);
        assert!(
            row.message
                .contains("stage 0 stopped without reaching its goal")
                && row.message.contains("jammed_before_goal"),
            "{}",
            row.message
        );
        assert_eq!(row.packing_fraction, None);
        assert!(
            !packing_path(&out, row.seed).exists(),
            "no packing for a failure"
        );
    }
    let stdout = text(&o.stdout);
    assert!(stdout.contains("0 ok, 2 failed, 0 lost"), "{stdout}");
    // A verdict stands: the rerun runs nothing and still exits 1.
    let o = ensemble(&scene, "1,2", &out, &[]);
    assert_eq!(o.status.code(), Some(1));
    assert!(text(&o.stdout).contains("0 of 2 seeds to run"));
}

#[test]
fn overrides_reach_the_run_and_bad_input_exits_2_before_any_run() {
    let dir = temp_dir("input");
    let scene = write_scene(&dir, SCENE);
    let out = dir.join("ens");
    // An override is the edited scene: φ 0.5 instead of 0.55.
    let o = ensemble(
        &scene,
        "1",
        &out,
        &["--set", "stage.0.until.packing_fraction=0.5"],
    );
    assert!(o.status.success(), "{}", text(&o.stderr));
    let phi = recomputed_phi(&Packing::read(&packing_path(&out, 1)).unwrap());
    assert!((phi - 0.5).abs() < 1e-9, "{phi}");

    let bad_out = dir.join("bad");
    for (extra, seeds, says) in [
        (
            vec!["--set", "stage.0.rate=1e9"],
            "1..2",
            "stage[0].rate: = 1e9 is outside the allowed range",
        ),
        (
            vec!["--set", "stage.3.rate=0.1"],
            "1",
            "stage.3.rate: index 3 is out of range",
        ),
        (vec!["--set", "rate"], "1", "`rate`: expected key=value"),
        (
            vec![],
            "5..1",
            "--seeds: seeds `5..1`: the range 5..1 is empty",
        ),
        (vec!["--jobs", "0"], "1", "--jobs 0: at least 1"),
        // Every worker holds a run: 2 × 4·10⁹ spheres is refused before anything is made.
        (
            vec!["--set", "particles.count=4000000000"],
            "1,2",
            "needs about",
        ),
    ] {
        let o = ensemble(&scene, seeds, &bad_out, &extra);
        let stderr = text(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {stderr}");
        assert!(stderr.contains(says), "{extra:?}: {stderr}");
        assert!(!bad_out.exists(), "{extra:?}: nothing was written");
    }
    // `run --set` checks the same way.
    let o = densepack(&[
        "run",
        &scene,
        "--set",
        "particles.packing_fraction=1.5",
        "--out",
        dir.join("p.json").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        text(&o.stderr).contains("particles.packing_fraction: = 1.5"),
        "{}",
        text(&o.stderr)
    );
    assert!(!dir.join("p.json").exists());
}
