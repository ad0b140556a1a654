//! Python bindings of the planner (`import trajopt`): the OCP of paper eq. (3) built from a
//! scenario file or a stretch of an indexed track, solved by the planner's interior-point
//! method with the options of `trajopt solve`, the solution returned as numpy arrays with
//! named columns.
//!
//! The extension module is `trajopt._trajopt`; the Python package `trajopt`
//! (`python/trajopt/__init__.py`) re-exports it. Every error of the library becomes a
//! `trajopt.TrajoptError` carrying the library's message unchanged (file, field, value).
#![deny(missing_docs)]

mod arrays;
mod options;
mod problem;
mod solution;

use std::path::PathBuf;

use planner::config::paths::resolve_path;
use planner::config::{list_selections, load_vehicle};
use planner::model::{CONTROL_NAMES, STATE_NAMES};
use planner::HORIZON;
use pyo3::prelude::*;

pyo3::create_exception!(
    _trajopt,
    TrajoptError,
    pyo3::exceptions::PyException,
    "An input the planner refuses (file, field, option) or a problem it cannot set up; \
     the message is the library's."
);

/// The error of `e` as a [`TrajoptError`] with the library's message.
pub(crate) fn err(e: impl std::fmt::Display) -> PyErr {
    TrajoptError::new_err(e.to_string())
}

/// The equilibrium guess of a vehicle (paper eq. 8), as `trajopt guess` computes it:
/// speed bounds `v_min..v_max` \[m/s\], least-squares start speed `v_start` \[m/s\].
#[pyfunction]
#[pyo3(signature = (vehicle = PathBuf::from(options::VEHICLE), v_min = 5.0, v_max = 40.0, v_start = planner::plan::DEFAULT_GUESS_SPEED))]
fn equilibrium_guess(
    py: Python<'_>,
    vehicle: PathBuf,
    v_min: f64,
    v_max: f64,
    v_start: f64,
) -> PyResult<solution::Equilibrium> {
    let vehicle = load_vehicle(&resolve_path(&vehicle)).map_err(err)?;
    if !(v_min > 0.0 && v_max > v_min && v_start.is_finite()) {
        return Err(err("need 0 < v_min < v_max and a finite v_start"));
    }
    let eq = py
        .detach(|| planner::guess::equilibrium(&vehicle, v_min, v_max, v_start))
        .map_err(err)?;
    Ok(solution::Equilibrium::from(eq))
}

/// The segment or scenario names a multi-entry scenario file offers (`segment=` of
/// `load_scenario`); empty for a single-road file such as the oval.
#[pyfunction]
fn selections(path: PathBuf) -> PyResult<Vec<String>> {
    list_selections(&resolve_path(&path)).map_err(err)
}

/// The module `trajopt._trajopt`.
#[pymodule]
fn _trajopt(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("TrajoptError", m.py().get_type::<TrajoptError>())?;
    m.add("HORIZON", HORIZON)?;
    m.add("STATE_NAMES", STATE_NAMES.to_vec())?;
    m.add("CONTROL_NAMES", CONTROL_NAMES.to_vec())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<problem::Problem>()?;
    m.add_class::<solution::Solution>()?;
    m.add_class::<solution::Equilibrium>()?;
    m.add_function(wrap_pyfunction!(problem::load_scenario, m)?)?;
    m.add_function(wrap_pyfunction!(problem::track_stretch, m)?)?;
    m.add_function(wrap_pyfunction!(equilibrium_guess, m)?)?;
    m.add_function(wrap_pyfunction!(selections, m)?)?;
    Ok(())
}
