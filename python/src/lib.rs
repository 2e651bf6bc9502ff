//! `densepack._densepack`: the Python face of the densepack library.
//!
//! Bindings only: every rule (scene validation, running, verification, export, the take
//! phase, the ensemble layout) is the library's; this crate converts arguments and results
//! between Python and Rust and maps errors to Python exceptions. The Python package
//! (`pysrc/densepack`) adds progress display and the Dask ensemble driver on top.
//!
//! Conventions: lengths in the scene's unit; arrays are new numpy arrays (float64, C order)
//! owned by Python; a `Scene` and a `Packing` are immutable (methods return new objects)
//! and pickle (Dask ships them to worker processes).

mod ensemble;
mod packing;
mod run;
mod scene;

use pyo3::prelude::*;

pyo3::create_exception!(
    densepack,
    DensepackError,
    pyo3::exceptions::PyException,
    "Base class of densepack's own errors."
);
pyo3::create_exception!(
    densepack,
    RunFailed,
    DensepackError,
    "A run ended without a packing: a stage missed its goal, seeding failed, or the \
     independent overlap check rejected the result. Nothing was written. Attributes: \
     `verdict` (str, the stop reason or failure kind), `stage` (int or None), `message`."
);

#[pymodule]
fn _densepack(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("DensepackError", py.get_type::<DensepackError>())?;
    m.add("RunFailed", py.get_type::<RunFailed>())?;
    m.add_class::<scene::Scene>()?;
    m.add_class::<packing::Packing>()?;
    m.add_function(wrap_pyfunction!(run::run_scene, m)?)?;
    m.add_function(wrap_pyfunction!(packing::take, m)?)?;
    m.add_function(wrap_pyfunction!(ensemble::run_realisation, m)?)?;
    m.add_function(wrap_pyfunction!(ensemble::seeds_to_run, m)?)?;
    m.add_function(wrap_pyfunction!(ensemble::append_summary, m)?)?;
    m.add_function(wrap_pyfunction!(ensemble::read_summary, m)?)?;
    Ok(())
}

/// A `ValueError` carrying `message`.
pub(crate) fn value_error(message: impl std::fmt::Display) -> PyErr {
    pyo3::exceptions::PyValueError::new_err(message.to_string())
}

/// An `OSError` carrying `message`.
pub(crate) fn os_error(message: impl std::fmt::Display) -> PyErr {
    pyo3::exceptions::PyOSError::new_err(message.to_string())
}
