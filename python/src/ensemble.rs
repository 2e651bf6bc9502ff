//! The ensemble layout of the library (`densepack::ensemble`) for the Dask driver in
//! `densepack/_ensemble.py`: one realisation, the summary file and the resume rule.

use crate::scene::Scene;
use crate::{os_error, value_error};
use densepack::ensemble::{self, Status, SummaryRow, SummaryWriter};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use std::path::PathBuf;

/// Runs `scene` with `seed` into the ensemble directory `dir` (which must exist): the
/// verified packing `seed-<seed>.json` and the summary row as a dict. Never raises for a
/// failed run: the row says `failed` (a verdict) or `lost`.
#[pyfunction(name = "_run_realisation")]
pub fn run_realisation<'py>(
    py: Python<'py>,
    scene: &Scene,
    seed: u64,
    dir: PathBuf,
) -> PyResult<Bound<'py, PyDict>> {
    let scene = &scene.scene;
    let row = py.detach(|| ensemble::run_realisation(scene, seed, &dir, None));
    row_dict(py, &row)
}

/// The seeds of `seeds` a run into `dir` still has to do (the library's resume rule).
#[pyfunction(name = "_seeds_to_run")]
pub fn seeds_to_run(dir: PathBuf, seeds: Vec<u64>) -> PyResult<Vec<u64>> {
    ensemble::seeds_to_run(&dir, &seeds).map_err(os_error)
}

/// Appends `row` (a dict with `seed`, `status` and, as known, the measurements and a
/// `message`; `wall_seconds` NaN when unknown) to `dir/summary.csv`.
#[pyfunction(name = "_append_summary")]
pub fn append_summary(dir: PathBuf, row: &Bound<'_, PyDict>) -> PyResult<()> {
    let get = |key: &str| row.get_item(key);
    let required = |key: &str| {
        get(key)?.ok_or_else(|| value_error(format!("summary row: `{key}` is missing")))
    };
    fn optional<'py, T: FromPyObjectOwned<'py>>(
        value: Option<Bound<'py, PyAny>>,
    ) -> PyResult<Option<T>> {
        match value {
            Some(v) if !v.is_none() => Ok(Some(v.extract().map_err(Into::into)?)),
            _ => Ok(None),
        }
    }
    let status: String = required("status")?.extract()?;
    let row = SummaryRow {
        seed: required("seed")?.extract()?,
        status: match status.as_str() {
            "ok" => Status::Ok,
            "failed" => Status::Failed,
            "lost" => Status::Lost,
            other => {
                return Err(value_error(format!(
                    "summary row: status {other:?} is not ok, failed or lost"
                )))
            }
        },
        packing_fraction: optional(get("packing_fraction")?)?,
        min_gap: optional(get("min_gap")?)?,
        reduced_pressure: optional(get("reduced_pressure")?)?,
        events: optional(get("events")?)?,
        wall_seconds: optional(get("wall_seconds")?)?.unwrap_or(f64::NAN),
        message: optional(get("message")?)?.unwrap_or_default(),
    };
    SummaryWriter::open(&dir)
        .and_then(|mut w| w.append(&row))
        .map_err(os_error)
}

/// The last row of each seed in `dir/summary.csv`, by ascending seed, as dicts.
#[pyfunction(name = "_read_summary")]
pub fn read_summary<'py>(py: Python<'py>, dir: PathBuf) -> PyResult<Vec<Bound<'py, PyDict>>> {
    ensemble::read_summary(&dir)
        .map_err(os_error)?
        .iter()
        .map(|row| row_dict(py, row))
        .collect()
}

fn row_dict<'py>(py: Python<'py>, row: &SummaryRow) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("seed", row.seed)?;
    d.set_item("status", row.status.as_str())?;
    d.set_item("packing_fraction", row.packing_fraction)?;
    d.set_item("min_gap", row.min_gap)?;
    d.set_item("reduced_pressure", row.reduced_pressure)?;
    d.set_item("events", row.events)?;
    d.set_item("wall_seconds", row.wall_seconds)?;
    d.set_item("message", &row.message)?;
    Ok(d)
}
