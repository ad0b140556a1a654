//! numpy arrays of the planner's fixed-width rows: N + 1 states of NX columns, N controls
//! of NU columns, and plain vectors.

use numpy::{PyArray1, PyArray2, PyArrayMethods};
use pyo3::prelude::*;

/// The rows as a 2-D float64 array of shape (rows, W), row-major.
pub fn matrix<'py, const W: usize>(
    py: Python<'py>,
    rows: &[[f64; W]],
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    PyArray1::from_vec(py, flat).reshape([rows.len(), W])
}

/// The values as a 1-D float64 array.
pub fn vector<'py>(py: Python<'py>, v: &[f64]) -> Bound<'py, PyArray1<f64>> {
    PyArray1::from_slice(py, v)
}

/// Column `j` of the rows as a 1-D float64 array.
pub fn column<'py, const W: usize>(
    py: Python<'py>,
    rows: &[[f64; W]],
    j: usize,
) -> Bound<'py, PyArray1<f64>> {
    let v: Vec<f64> = rows.iter().map(|r| r[j]).collect();
    PyArray1::from_vec(py, v)
}
