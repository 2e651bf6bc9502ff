//! Checkpoint and resume through the real binary: a run killed with SIGKILL mid-way and
//! resumed from its last checkpoint writes the same particles, bit for bit, as a run that
//! was never interrupted; writing checkpoints does not change a run. Spheres and ellipsoids
//! (whose checkpoints also carry orientations and angular velocities).

mod common;

use common::{densepack, temp_dir};

use densepack::io::packing::{Packing, ParticleRecord};
use densepack::io::record::{EllipsoidRecord, SphereRecord};
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// A few seconds of work in release mode: two sizes (ratio 2, so the cell grid has two
/// levels), walls on z, growth to a packing fraction, then jamming.
const SCENE: &str = r#"seed = 2024
[container]
type = "box"
size = [13.0, 13.0, 13.0]
periodic = [true, true, false]
[particles]
components = [{ count = 1070, diameter = 1.0 }, { count = 135, diameter = 2.0 }]
packing_fraction = 0.3
[[stage]]
growth = "relative"
rate = 0.1
until = { packing_fraction = 0.5 }
[[stage]]
growth = "relative"
rate = 0.05
until = { reduced_pressure = 1e12 }
"#;

/// A few seconds of ellipsoid work: triaxial ellipsoids (semi-axes a : a/2 : a/3), walls on
/// z (the ellipsoids' own wall contacts), growth to a packing fraction, then towards jamming.
const ELLIPSOID_SCENE: &str = r#"seed = 77
[container]
type = "box"
size = [6.0, 6.0, 6.0]
periodic = [true, true, false]
[particles]
count = 90
diameter = 1.0
packing_fraction = 0.05
[particles.ellipsoid]
aspect_ratios = [2.0, 3.0]
[[stage]]
growth = "relative"
rate = 0.1
until = { packing_fraction = 0.4 }
[[stage]]
growth = "relative"
rate = 0.05
until = { reduced_pressure = 1e5 }
"#;

/// Needles as long as the box (paper 004, Table 2: prolate R = 20 at N = 175, longest axis
/// 0.96 of the edge at the end): the kernel tracks periodic images (entries carrying lattice
/// shifts, self-images) and neighbour envelopes, all of which the checkpoint must restore.
const IMAGE_SCENE: &str = r#"seed = 4
[container]
type = "box"
size = [10.0, 10.0, 10.0]
periodic = [true, true, true]
[particles]
count = 175
diameter = 1.0
packing_fraction = 0.0001
[particles.ellipsoid]
aspect_ratios = [20.0, 20.0]
[[stage]]
growth = "relative"
rate = 2.0
until = { packing_fraction = 0.2 }
"#;

fn run_ok(args: &[&str]) -> Output {
    let out = densepack(args);
    assert!(
        out.status.success(),
        "densepack {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out
}

fn assert_same_packing(a: &Path, b: &Path) {
    let (a, b) = (Packing::read(a).unwrap(), Packing::read(b).unwrap());
    assert_eq!(a.particles.len(), b.particles.len());
    // Bit for bit: PartialEq on f64 would also accept -0.0 == 0.0.
    let bits = |p: &Packing| -> Vec<u64> {
        p.particles
            .iter()
            .flat_map(|r| match r {
                ParticleRecord::Sphere(SphereRecord { center, radius }) => {
                    [center.as_slice(), &[*radius]].concat()
                }
                ParticleRecord::Ellipsoid(EllipsoidRecord {
                    center,
                    semi_axes,
                    orientation,
                }) => [center.as_slice(), semi_axes, orientation].concat(),
                other => panic!("an EDMD scene wrote {other:?}"),
            })
            .map(f64::to_bits)
            .collect()
    };
    assert!(bits(&a) == bits(&b), "the particles differ");
    assert_eq!(a.stats.events, b.stats.events);
    assert_eq!(a.stats.collisions, b.stats.collisions);
    assert_eq!(
        a.stats.reduced_pressure.map(f64::to_bits),
        b.stats.reduced_pressure.map(f64::to_bits)
    );
    assert_eq!(a.stats.stop_reason, b.stats.stop_reason);
    // Ellipsoids: the numerical-failure count of the whole run survives the resume.
    assert_eq!(
        a.stats.extra.get("ellipsoid_prediction_failures"),
        b.stats.extra.get("ellipsoid_prediction_failures")
    );
}

#[test]
fn a_run_killed_mid_way_resumes_to_the_same_packing() {
    kill_and_resume("kill", SCENE);
}

#[test]
fn an_ellipsoid_run_killed_mid_way_resumes_to_the_same_packing() {
    kill_and_resume("kill-ellipsoids", ELLIPSOID_SCENE);
}

#[test]
fn an_ellipsoid_run_with_periodic_images_resumes_to_the_same_packing() {
    kill_and_resume("kill-images", IMAGE_SCENE);
}

/// Runs `scene_text` through; again with a checkpoint at every barrier; again killed with
/// SIGKILL mid-way and resumed from its last checkpoint; and resumed from the every-barrier
/// checkpoint (the run's last barrier): every run writes the same packing, bit for bit.
fn kill_and_resume(name: &str, scene_text: &str) {
    let dir = temp_dir(name);
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, scene_text).unwrap();
    let scene = scene.to_str().unwrap();
    let whole = dir.join("whole.json");
    let started = Instant::now();
    run_ok(&["run", scene, "--out", whole.to_str().unwrap(), "--quiet"]);
    let uninterrupted = started.elapsed();
    eprintln!("uninterrupted run: {uninterrupted:.2?}");

    // Writing checkpoints (at every barrier here) does not change the run.
    let checked = dir.join("checked.json");
    let every_barrier = dir.join("every.ckpt");
    run_ok(&[
        "run",
        scene,
        "--out",
        checked.to_str().unwrap(),
        "--quiet",
        "--checkpoint",
        every_barrier.to_str().unwrap(),
        "--checkpoint-every",
        "0",
    ]);
    assert_same_packing(&whole, &checked);
    eprintln!(
        "run with a checkpoint at every barrier: {:.2?}",
        started.elapsed() - uninterrupted
    );

    // Kill a checkpointing run with SIGKILL once it has written a checkpoint and is well
    // into its work, then resume.
    let ckpt = dir.join("run.ckpt");
    let killed_out = dir.join("killed.json");
    let mut child = Command::new(env!("CARGO_BIN_EXE_densepack"))
        .args([
            "run",
            scene,
            "--out",
            killed_out.to_str().unwrap(),
            "--quiet",
            "--checkpoint",
            ckpt.to_str().unwrap(),
            "--checkpoint-every",
            "0.2",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // A third of the way, or once the run has replaced its checkpoint three times, whichever
    // comes first: on a shared machine the uninterrupted run's time says little about this
    // one's (it may be the faster of the two), while its own checkpoints show its progress.
    let kill_after = uninterrupted.mul_f64(0.3);
    let spawned = Instant::now();
    let mut last_write = None;
    let mut writes = 0;
    loop {
        if let Ok(modified) = std::fs::metadata(&ckpt).and_then(|m| m.modified()) {
            if last_write != Some(modified) {
                last_write = Some(modified);
                writes += 1;
            }
            if spawned.elapsed() >= kill_after || writes >= 3 {
                break;
            }
        }
        assert!(
            child.try_wait().unwrap().is_none(),
            "the run ended before it could be killed"
        );
        assert!(
            spawned.elapsed() < uninterrupted * 10,
            "no checkpoint written"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL on Unix
    let status = child.wait().unwrap();
    assert!(!status.success(), "the run was killed, not finished");
    assert!(!killed_out.exists(), "a killed run wrote no packing");

    let resumed = dir.join("resumed.json");
    let out = run_ok(&[
        "run",
        "--resume",
        ckpt.to_str().unwrap(),
        "--out",
        resumed.to_str().unwrap(),
    ]);
    eprintln!("{}", String::from_utf8_lossy(&out.stderr));
    assert_same_packing(&whole, &resumed);
    let verify = densepack(&["verify", resumed.to_str().unwrap()]);
    assert!(verify.status.success());

    // A checkpoint of the last stage's first barriers also resumes exactly (the file
    // written at every barrier holds the run's last barrier).
    let from_last = dir.join("from_last.json");
    run_ok(&[
        "run",
        "--resume",
        every_barrier.to_str().unwrap(),
        "--out",
        from_last.to_str().unwrap(),
        "--quiet",
    ]);
    assert_same_packing(&whole, &from_last);
}

#[test]
fn damaged_checkpoints_are_refused_with_exit_code_2() {
    let dir = temp_dir("damaged");
    let scene = dir.join("scene.toml");
    std::fs::write(
        &scene,
        "seed = 3\n[container]\ntype = \"box\"\nsize = [6.0, 6.0, 6.0]\nperiodic = [true, true, true]\n\
         [particles]\ncount = 50\ndiameter = 1.0\n\
         [[stage]]\ngrowth = \"none\"\nuntil = { collisions_per_particle = 20 }\n",
    )
    .unwrap();
    let ckpt = dir.join("good.ckpt");
    let out = dir.join("out.json");
    run_ok(&[
        "run",
        scene.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
        "--checkpoint",
        ckpt.to_str().unwrap(),
        "--checkpoint-every",
        "0",
    ]);
    let good = std::fs::read(&ckpt).unwrap();
    // The magic line and the header alone: the kernel record is missing, not "taken".
    let header = densepack::io::checkpoint::CheckpointFile::from_bytes(good.clone(), "good")
        .unwrap()
        .header;
    let header_end =
        densepack::io::checkpoint::MAGIC.len() + postcard::to_allocvec(&header).unwrap().len();
    let previous = std::fs::read(&out).unwrap();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("empty", Vec::new(), "not a densepack checkpoint"),
        (
            "a scene file",
            b"seed = 1\n".to_vec(),
            "not a densepack checkpoint",
        ),
        (
            "truncated header",
            good[..good.len().min(40)].to_vec(),
            "damaged checkpoint header",
        ),
        (
            "truncated kernel record",
            good[..good.len() - 100].to_vec(),
            "damaged kernel record",
        ),
        (
            "no kernel record",
            good[..header_end].to_vec(),
            "damaged kernel record",
        ),
        (
            "trailing bytes",
            [good.as_slice(), b"extra"].concat(),
            "unexpected bytes",
        ),
    ];
    for (name, bytes, needle) in cases {
        let bad = dir.join("bad.ckpt");
        std::fs::write(&bad, &bytes).unwrap();
        let run = densepack(&[
            "run",
            "--resume",
            bad.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(2), "{name}: {stderr}");
        assert!(
            stderr.contains(needle),
            "{name}: {stderr:?} lacks {needle:?}"
        );
        assert_eq!(
            std::fs::read(&out).unwrap(),
            previous,
            "{name}: output changed"
        );
    }
    // A scene and --resume together is a usage error.
    let run = densepack(&[
        "run",
        scene.to_str().unwrap(),
        "--resume",
        ckpt.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(run.status.code(), Some(2));
}

/// A graded scene in a walled box (offset from the origin): growth to the true sizes, then a
/// 1 mm gap stage that keeps less than Δd/2 to the walls (wall_gap 0.2: the walls see the
/// grains grow at 0.4 times the pair rate).
const GAP_SCENE: &str = r#"seed = 11
mass = "volume"
[container]
type = "box"
min = [100.0, -50.0, 7.0]
size = [40.0, 40.0, 40.0]
periodic = [false, false, true]
[particles]
grading = { kind = "din", name = "A16" }
mixture_fraction = 0.45
d_min = 2.0
[[stage]]
growth = "relative"
rate = 0.05
until = { full_size = true }
[[stage]]
growth = "absolute"
rate = 0.02
until = { gap = 1.0 }
wall_gap = 0.2
"#;

#[test]
fn a_gap_stage_resumes_to_the_same_gap_and_particles() {
    use densepack::io::checkpoint::CheckpointFile;
    use densepack::io::scene::{AnyScene, Scene};
    use densepack::run::{resume_run, run, run_scene, CheckpointPlan, RunOptions};
    let dir = temp_dir("gap");
    let scene = Scene::from_toml(GAP_SCENE).unwrap();
    let straight = run_scene(&scene, &mut |_, _| {}).unwrap().packing;
    // A checkpoint at every barrier: the file left is the last barrier of the gap stage.
    let plan = CheckpointPlan {
        path: dir.join("gap.ckpt"),
        every: Duration::ZERO,
    };
    let options = RunOptions {
        checkpoints: Some(plan.clone()),
        ..RunOptions::default()
    };
    let checkpointed = run(&AnyScene::Spheres(Box::new(scene)), options)
        .unwrap()
        .packing;
    let file = CheckpointFile::read(&plan.path).unwrap();
    assert_eq!(
        file.header.stage, 1,
        "the last checkpoint is in the gap stage"
    );
    let mut finished = Vec::new();
    let mut on_stage = |k: usize, _: &_| finished.push(k);
    let options = RunOptions {
        on_stage: Some(&mut on_stage),
        ..RunOptions::default()
    };
    let resumed = resume_run(&file, options).unwrap().packing;
    assert_eq!(finished, [1], "only the gap stage is left to finish");
    // The resume released the file's kernel record (as large as the kernel: it must not stay
    // resident for the run's length), so the same file cannot be resumed twice.
    let again = resume_run(&file, RunOptions::default());
    assert!(
        again.is_err_and(|e| e.to_string().contains("kernel record was already taken")),
        "a second resume from the same file must fail clearly"
    );
    for p in [&checkpointed, &resumed] {
        assert_eq!(p.particles, straight.particles);
        assert_eq!(p.min_gap.to_bits(), straight.min_gap.to_bits());
        assert_eq!(
            p.wall_gap.map(f64::to_bits),
            straight.wall_gap.map(f64::to_bits)
        );
        assert_eq!(p.container, straight.container);
    }
    // The gap asked for (rounding only), and the walls' share of it: 0.2 of the 1 mm.
    assert!(
        (straight.min_gap - 1.0).abs() < 1e-9,
        "{}",
        straight.min_gap
    );
    assert!(
        straight.wall_gap.is_some_and(|w| (w - 0.2).abs() < 1e-9),
        "{:?}",
        straight.wall_gap
    );
}
