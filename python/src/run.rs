//! `_run`: one run of a scene on a worker thread, with progress, Ctrl-C and checkpoints.
//!
//! The run goes on a thread of its own while the calling thread waits without the GIL in
//! slices of at most `POLL`: between slices it delivers progress to the Python callback
//! and checks for signals. A `KeyboardInterrupt` sets the run's cancel flag (the kernel
//! looks at it every thousand events) and is raised once the run has stopped; nothing is
//! written.

use crate::packing::Packing;
use crate::scene::Scene;
use crate::{value_error, RunFailed};
use densepack::io::checkpoint::CheckpointFile;
use densepack::io::scene::AnyScene;
use densepack::run::{CheckpointPlan, RunError, RunOptions};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Duration;

/// Longest wait without the GIL between two looks at signals and progress.
const POLL: Duration = Duration::from_millis(50);
/// Least time between two progress messages from the run.
const PROGRESS_EVERY: Duration = Duration::from_millis(250);

/// What the run thread tells the waiting thread.
enum Message {
    /// Progress of stage `stage` at a time barrier.
    Progress {
        stage: usize,
        progress: densepack::kernel::Progress,
    },
    /// Stage `stage` finished.
    Stage {
        stage: usize,
        report: densepack::kernel::StageReport,
    },
}

/// Runs `scene` and returns its verified packing. `progress(kind, stage, stages, record)` is
/// called from the calling thread with `kind` "progress" (about four times a second) or
/// "stage" (once per finished stage) and `record` a dict. `checkpoint` (a path) makes
/// the run write checkpoints there every `checkpoint_every` seconds and resume from it when
/// the file exists. Raises `RunFailed` (with the verdict) when the run ends without a
/// packing, `KeyboardInterrupt` when interrupted.
#[pyfunction(name = "_run")]
#[pyo3(signature = (scene, progress=None, checkpoint=None, checkpoint_every=600.0))]
pub fn run_scene(
    py: Python<'_>,
    scene: &Scene,
    progress: Option<Bound<'_, PyAny>>,
    checkpoint: Option<std::path::PathBuf>,
    checkpoint_every: f64,
) -> PyResult<Packing> {
    let plan = checkpoint_plan(checkpoint, checkpoint_every)?;
    let resume = match &plan {
        Some(plan) if plan.path.exists() => Some(resumable(&plan.path, &scene.scene)?),
        _ => None,
    };
    let scene = scene.scene.clone();
    let stages = match &scene {
        // `[jam]` reports as one more stage.
        AnyScene::Spheres(s) => s.stages.len() + usize::from(s.jam.is_some()),
        AnyScene::Mixture(_) => 0,
    };
    let cancel = Arc::new(AtomicBool::new(false));
    let (tx, rx) = mpsc::channel::<Message>();
    // A `Receiver` is not `Sync`; the mutex lets the GIL-free wait borrow it.
    let rx = std::sync::Mutex::new(rx);
    let worker = {
        let cancel = Arc::clone(&cancel);
        std::thread::spawn(move || run_on_thread(&scene, resume.as_ref(), plan, cancel, &tx))
    };
    loop {
        match py.detach(|| rx.lock().expect("one waiter").recv_timeout(POLL)) {
            Ok(message) => {
                if let Some(callback) = &progress {
                    let (kind, stage, record) = match &message {
                        Message::Progress { stage, progress } => {
                            ("progress", *stage, progress_dict(py, progress)?)
                        }
                        Message::Stage { stage, report } => {
                            ("stage", *stage, pythonize::pythonize(py, report)?)
                        }
                    };
                    if let Err(e) = callback.call1((kind, stage, stages, record)) {
                        stop(py, &cancel, worker);
                        return Err(e);
                    }
                }
            }
            Err(mpsc::RecvTimeoutError::Timeout) => {}
            Err(mpsc::RecvTimeoutError::Disconnected) => break,
        }
        if let Err(e) = py.check_signals() {
            stop(py, &cancel, worker);
            return Err(e);
        }
    }
    let result = py.detach(|| worker.join());
    match result {
        Ok(Ok(packing)) => Ok(Packing { packing }),
        Ok(Err(failure)) => Err(failure.into_py_err(py)),
        Err(panic) => std::panic::resume_unwind(panic),
    }
}

/// Sets the cancel flag and waits (without the GIL) for the run to stop.
fn stop(py: Python<'_>, cancel: &AtomicBool, worker: std::thread::JoinHandle<RunResult>) {
    cancel.store(true, Ordering::Relaxed);
    let _ = py.detach(|| worker.join());
}

/// Why a run gave no packing, as the library says it.
struct Failure {
    verdict: String,
    stage: Option<usize>,
    message: String,
}

impl Failure {
    fn into_py_err(self, py: Python<'_>) -> PyErr {
        let err = RunFailed::new_err(self.message.clone());
        let value = err.value(py);
        let _ = value.setattr("verdict", self.verdict);
        let _ = value.setattr("stage", self.stage);
        let _ = value.setattr("message", self.message);
        err
    }
}

type RunResult = Result<densepack::io::packing::Packing, Failure>;

fn run_on_thread(
    scene: &AnyScene,
    resume: Option<&CheckpointFile>,
    checkpoints: Option<CheckpointPlan>,
    cancel: Arc<AtomicBool>,
    tx: &mpsc::Sender<Message>,
) -> RunResult {
    let mut last = std::time::Instant::now() - PROGRESS_EVERY;
    let mut on_stage = |stage: usize, report: &densepack::kernel::StageReport| {
        let _ = tx.send(Message::Stage {
            stage,
            report: report.clone(),
        });
    };
    let mut on_progress = |stage: usize, progress: &densepack::kernel::Progress| {
        if last.elapsed() >= PROGRESS_EVERY {
            last = std::time::Instant::now();
            let _ = tx.send(Message::Progress {
                stage,
                progress: progress.clone(),
            });
        }
    };
    let options = RunOptions {
        checkpoints,
        cancel: Some(cancel),
        on_stage: Some(&mut on_stage),
        on_progress: Some(&mut on_progress),
    };
    match resume {
        Some(file) => densepack::run::resume_run(file, options),
        None => densepack::run::run(scene, options),
    }
    .map(|outcome| outcome.packing)
    .map_err(|e| Failure {
        verdict: match &e {
            RunError::StageFailed { reason, .. } => (*reason).to_owned(),
            RunError::Seeding(_) => "seeding_failed".into(),
            RunError::Adsorption(_) => "adsorption_failed".into(),
            RunError::Relaxation(_) => "relaxation_failed".into(),
            RunError::Cancelled => "cancelled".into(),
            RunError::Unsupported(_) => "unsupported".into(),
            RunError::Verification(_) => "verification_failed".into(),
            RunError::Checkpoint(_) => "checkpoint".into(),
            RunError::Start(_) => "start_packing".into(),
        },
        stage: match &e {
            RunError::StageFailed { stage, .. } => Some(*stage),
            _ => None,
        },
        message: e.to_string(),
    })
}

/// The checkpoint plan of `checkpoint` every `every` seconds (validated).
fn checkpoint_plan(
    checkpoint: Option<std::path::PathBuf>,
    every: f64,
) -> PyResult<Option<CheckpointPlan>> {
    let Some(path) = checkpoint else {
        return Ok(None);
    };
    let every = std::time::Duration::try_from_secs_f64(every).map_err(|_| {
        value_error(format!(
            "checkpoint_every = {every}: seconds, a finite number ≥ 0"
        ))
    })?;
    Ok(Some(CheckpointPlan { path, every }))
}

/// The checkpoint at `path`, when it continues `scene` (else `ValueError`: a checkpoint of
/// another scene is never resumed silently).
fn resumable(path: &std::path::Path, scene: &AnyScene) -> PyResult<CheckpointFile> {
    let file = CheckpointFile::read(path).map_err(value_error)?;
    let same = AnyScene::from_toml(&file.header.scene_toml).is_ok_and(|s| &s == scene);
    if !same {
        return Err(value_error(format!(
            "checkpoint {}: it was written by a run of another scene (or seed); remove it or \
             name another file",
            path.display()
        )));
    }
    Ok(file)
}

fn progress_dict<'py>(
    py: Python<'py>,
    p: &densepack::kernel::Progress,
) -> PyResult<Bound<'py, PyAny>> {
    let d = PyDict::new(py);
    d.set_item("packing_fraction", p.packing_fraction)?;
    d.set_item("reduced_pressure", p.reduced_pressure)?;
    d.set_item("events", p.counts.events)?;
    d.set_item("collisions", p.counts.collisions)?;
    d.set_item("stage_time", p.stage_time)?;
    d.set_item("goal_time", p.goal_time)?;
    d.set_item("wall_seconds", p.wall_seconds)?;
    d.set_item("rate", p.rate)?;
    d.set_item("gap", p.gap)?;
    Ok(d.into_any())
}
