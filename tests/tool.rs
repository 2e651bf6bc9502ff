//! The user-facing subcommands around `run`: `init`, `take`, progress output and provenance.

mod common;

use common::{densepack, temp_dir};

#[test]
fn init_spheres_writes_a_scene_that_runs_with_json_progress_and_provenance() {
    let dir = temp_dir("init");
    let scene = dir.join("scene.toml");
    let init = densepack(&["init", "spheres", "--out", scene.to_str().unwrap()]);
    assert!(init.status.success());
    // Not overwritten a second time.
    let again = densepack(&["init", "spheres", "--out", scene.to_str().unwrap()]);
    assert_eq!(again.status.code(), Some(2));

    let out = dir.join("packing.json");
    let run = densepack(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--log-json",
    ]);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{stderr}");
    // stderr: only JSON lines; the stage line reports success.
    let lines: Vec<serde_json::Value> = stderr
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{l}: {e}")))
        .collect();
    let stages: Vec<&serde_json::Value> = lines.iter().filter(|l| l["type"] == "stage").collect();
    assert_eq!(stages.len(), 1);
    assert_eq!(stages[0]["report"]["stop_reason"], "pressure_reached");
    for l in lines.iter().filter(|l| l["type"] == "progress") {
        let phi = l["packing_fraction"].as_f64().unwrap();
        assert!((0.3 - 1e-9..0.75).contains(&phi), "{l}");
    }
    // stdout: the summary (data), no progress.
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(stdout.starts_with("particles 1000"), "{stdout}");

    let packing = densepack::io::packing::Packing::read(&out).unwrap();
    let p = packing.provenance.expect("provenance is recorded");
    assert_eq!(p.densepack_version, env!("CARGO_PKG_VERSION"));
    // Built in a git checkout, the packing names the commit git reports for it; elsewhere
    // (no git, no checkout) it names none.
    let head = std::process::Command::new("git")
        .args(["rev-parse", "HEAD"])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8(o.stdout).unwrap().trim().to_string());
    assert_eq!(p.git_commit, head);
    assert_eq!(p.seed, 1);
    // The resolved scene: defaults the file leaves out are filled in.
    assert_eq!(p.scene["particles"]["count"], 1000);
    assert_eq!(p.scene["queue"], "calendar");
    assert_eq!(p.scene["mass"], "equal");
    assert_eq!(p.scene["temperature"], 1.0);
    assert_eq!(p.scene["stage"][0]["until"]["reduced_pressure"], 1e12);
    assert!(p.timings.stages_seconds > 0.0 && p.timings.verification_seconds >= 0.0);
}

#[test]
fn init_ellipsoids_and_mixture_write_scenes_that_pack_their_shapes() {
    let dir = temp_dir("init-shapes");
    // (kind, record type, bodies of that type, other records)
    for (kind, shape, count, others) in [
        ("ellipsoids", "ellipsoid", 200, 0),
        ("mixture", "cylinder", 30, 30),
    ] {
        let scene = dir.join(format!("{kind}.toml"));
        let packing = dir.join(format!("{kind}.json"));
        let init = densepack(&["init", kind, "--out", scene.to_str().unwrap()]);
        assert!(init.status.success(), "{init:?}");
        let run = densepack(&[
            "run",
            scene.to_str().unwrap(),
            "--out",
            packing.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(run.status.success(), "{kind}: {run:?}");
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&packing).unwrap()).unwrap();
        let particles = json["particles"].as_array().unwrap();
        let of_shape = particles.iter().filter(|p| p["type"] == shape).count();
        assert_eq!(
            (of_shape, particles.len() - of_shape),
            (count, others),
            "{kind}"
        );
        let verify = densepack(&["verify", packing.to_str().unwrap()]);
        assert!(verify.status.success(), "{kind}: {verify:?}");
    }
}

#[test]
fn take_reproduces_the_papers_b16_example_and_draws_the_sizes() {
    // Titscher & Unger: B16, φ_M = 0.70, d_min = 2 mm, 150 mm cube: B16 passes 42 % at 2 mm,
    // so φ_eff = 0.7 · 0.58 = 0.406, and N ≈ 40 049 from the sieve table.
    let r = densepack(&[
        "take",
        "B16",
        "--phi-m",
        "0.7",
        "--d-min",
        "2",
        "--box",
        "150,150,150",
        "--json",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let s: serde_json::Value = serde_json::from_slice(&r.stdout).unwrap();
    assert!((s["phi_eff"].as_f64().unwrap() - 0.406).abs() < 1e-12);
    assert!((s["expected_count"].as_f64().unwrap() - 40_049.0).abs() < 1.0);
    assert_eq!(s["largest_diameter"], 16.0);

    let dir = temp_dir("take");
    let sizes = dir.join("sizes.txt");
    let r = densepack(&[
        "take",
        "fuller:0.5:16",
        "--phi-m",
        "0.75",
        "--d-min",
        "2",
        "--box",
        "80,80,80",
        "--seed",
        "3",
        "--sizes",
        sizes.to_str().unwrap(),
        "--json",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let s: serde_json::Value = serde_json::from_slice(&r.stdout).unwrap();
    let d: Vec<f64> = std::fs::read_to_string(&sizes)
        .unwrap()
        .lines()
        .map(|l| l.parse().unwrap())
        .collect();
    assert_eq!(d.len() as u64, s["drawn"]["count"].as_u64().unwrap());
    assert!(d.iter().all(|&x| (2.0..=16.0).contains(&x)));
    assert!(d.windows(2).all(|w| w[0] >= w[1]));
    // φ_eff = 0.75 (1 − √(2/16)); the drawn volume exceeds it by less than one small grain.
    let phi_eff = 0.75 * (1.0 - (2.0f64 / 16.0).sqrt());
    let drawn: f64 = d
        .iter()
        .map(|x| std::f64::consts::PI / 6.0 * x.powi(3))
        .sum::<f64>()
        / 512_000.0;
    assert!(drawn >= phi_eff && drawn - phi_eff < std::f64::consts::PI / 6.0 * 8.0 / 512_000.0);
}

#[test]
fn take_rejects_unknown_curves_and_missing_specimens_with_exit_code_2() {
    let r = densepack(&[
        "take", "X16", "--phi-m", "0.7", "--d-min", "2", "--volume", "1e6",
    ]);
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("A8, B8, C8, A16, B16, C16"));
    let r = densepack(&["take", "B16", "--phi-m", "0.7", "--d-min", "2"]);
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("--box"));
    let r = densepack(&[
        "take", "B16", "--phi-m", "1.2", "--d-min", "2", "--volume", "1e6",
    ]);
    assert_eq!(r.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&r.stderr).contains("phi_m"));
}

#[test]
fn verify_reports_gaps_and_the_sieve_curve_of_a_constructed_packing() {
    // Two spheres, diameters 1 and 2, centres 1.6 apart: relative gap 1.6 / 1.5 − 1 = 1/15.
    // Sieve table 1 → 0 %, 2 → 100 % (linear in ln d), cut at d_min = 1: at the half-octave
    // sieve √2 the target is ln √2 / ln 2 = 0.5 and the packing passes 1/9 of the volume.
    let dir = temp_dir("verify");
    let packing = dir.join("two.json");
    std::fs::write(
        &packing,
        r#"{"format": "densepack-packing", "version": 1,
            "container": {"type": "box", "min": [0,0,0], "max": [10,10,10], "periodic": [true,true,true]},
            "particles": [{"type": "sphere", "center": [2, 5, 5], "radius": 0.5},
                          {"type": "sphere", "center": [3.6, 5, 5], "radius": 1.0}],
            "min_gap": 0.0, "seed": 0,
            "stats": {"packing_fraction": 0, "reduced_pressure": 0, "events": 0, "collisions": 0,
                      "wall_seconds": 0, "stop_reason": "none"}}"#,
    )
    .unwrap();
    let grading = dir.join("curve.toml");
    std::fs::write(
        &grading,
        "grading = { kind = \"table\", sizes = [1.0, 2.0], passing = [0.0, 100.0] }\n",
    )
    .unwrap();
    let r = densepack(&[
        "verify",
        packing.to_str().unwrap(),
        "--json",
        "--grading",
        grading.to_str().unwrap(),
        "--d-min",
        "1",
    ]);
    assert!(r.status.success(), "{}", String::from_utf8_lossy(&r.stderr));
    let v: serde_json::Value = serde_json::from_slice(&r.stdout).unwrap();
    assert!((v["min_pair_gap_relative"].as_f64().unwrap() - 1.0 / 15.0).abs() < 1e-12);
    let bins = v["gap_histogram"].as_array().unwrap();
    let in_bin = |lo: f64| {
        bins.iter()
            .find(|b| b["lo"].as_f64() == Some(lo))
            .map(|b| b["count"].as_u64().unwrap())
    };
    assert_eq!(in_bin(0.01), Some(2)); // 1/15 ∈ [0.01, 0.1) for both spheres
    let points = v["sieve"]["points"].as_array().unwrap();
    let at = |size: f64| {
        points
            .iter()
            .find(|p| (p["size"].as_f64().unwrap() - size).abs() < 1e-12)
            .unwrap_or_else(|| panic!("no sieve {size}"))
    };
    assert_eq!(at(1.0)["passing"].as_f64(), Some(1.0 / 9.0));
    assert_eq!(at(1.0)["target"].as_f64(), Some(0.0));
    let half = at(2f64.sqrt());
    assert!((half["target"].as_f64().unwrap() - 0.5).abs() < 1e-12);
    assert!((half["passing"].as_f64().unwrap() - 1.0 / 9.0).abs() < 1e-12);
    assert_eq!(at(2.0)["passing"].as_f64(), Some(1.0));
    let worst = v["sieve"]["max_deviation"].as_f64().unwrap();
    assert!((worst - (0.5 - 1.0 / 9.0)).abs() < 1e-12);
}

#[test]
fn an_unknown_key_in_a_tagged_table_is_reported_with_its_line_and_the_allowed_keys() {
    let dir = temp_dir("unknown");
    let scene = dir.join("scene.toml");
    std::fs::write(
        &scene,
        "seed = 1\n[container]\ntype = \"box\"\nsize = [5.0, 5.0, 5.0]\n\
         periodic = [true, true, true]\nsizee = 3\n[particles]\ncount = 10\ndiameter = 1.0\n\
         [[stage]]\ngrowth = \"none\"\nuntil = { time = 1.0 }\n",
    )
    .unwrap();
    let out = dir.join("p.json");
    let r = densepack(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(r.status.code(), Some(2));
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert!(stderr.contains("unknown field `sizee`"), "{stderr}");
    assert!(stderr.contains("`min`, `size`, `periodic`"), "{stderr}");
    assert!(stderr.contains("`sizee` is on line 6"), "{stderr}");
    assert!(!out.exists());
}

#[test]
fn init_concrete_is_the_take_phase_scene_and_packs_to_its_grading_curve() {
    let dir = temp_dir("concrete");
    let regenerated = dir.join("regenerated.toml");
    let take = densepack(&[
        "take",
        "B16",
        "--phi-m",
        "0.7",
        "--d-min",
        "4",
        "--box",
        "50,50,50",
        "--seed",
        "1",
        "--scene",
        regenerated.to_str().unwrap(),
    ]);
    assert!(
        take.status.success(),
        "{}",
        String::from_utf8_lossy(&take.stderr)
    );
    let init = densepack(&["init", "concrete"]);
    assert!(init.status.success());
    assert_eq!(
        String::from_utf8_lossy(&init.stdout),
        std::fs::read_to_string(&regenerated).unwrap(),
        "examples/scenes/concrete_b16_50mm.toml is out of date: regenerate it with `densepack take`"
    );
    let out = dir.join("concrete.json");
    let run = densepack(&[
        "run",
        regenerated.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    // φ_eff = 0.7 (1 − 0.56) = 0.308 targeted; the draw overshoots by less than one 4 mm grain.
    let packing = densepack::io::packing::Packing::read(&out).unwrap();
    let phi = common::recomputed_phi(&packing);
    let one_grain = std::f64::consts::PI / 6.0 * 64.0 / 125_000.0;
    assert!((0.308..0.308 + one_grain).contains(&phi), "{phi}");
    // The sieve curve follows B16 between 4 and 16 mm: 260 grains, each class's volume exact
    // up to one grain, so a few percent at most.
    let verify = densepack(&[
        "verify",
        out.to_str().unwrap(),
        "--json",
        "--grading",
        "B16",
        "--d-min",
        "4",
    ]);
    assert!(verify.status.success());
    let v: serde_json::Value = serde_json::from_slice(&verify.stdout).unwrap();
    let worst = v["sieve"]["max_deviation"].as_f64().unwrap();
    assert!(worst < 0.05, "{worst}");
}
