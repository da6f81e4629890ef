//! The Python exceptions: bad input is a `ValueError` that says where (which array or
//! correspondence, which field); a solve without a validated answer is a `RuntimeError`, and
//! never a pose.

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;

pyo3::create_exception!(
    simhc,
    InputError,
    PyValueError,
    "The input is not a problem instance: a wrong shape, a NaN or infinity, too few correspondences or degenerate geometry. The message names the array or correspondence and the field."
);
pyo3::create_exception!(simhc, SolveError, PyRuntimeError, "No validated solution: never a pose to use.");
pyo3::create_exception!(
    simhc,
    NotValidatedError,
    SolveError,
    "End points were found and none passed validation on all the data (the best one is flagged, not returned)."
);
pyo3::create_exception!(simhc, NoSolutionError, SolveError, "No attempt reached an end point (and the fallback found none).");

/// Why a solve has no answer, before it becomes a Python exception.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Failure {
    /// Bad input ([`InputError`]).
    Input(String),
    /// End points, none validated ([`NotValidatedError`]).
    NotValidated(String),
    /// No end point ([`NoSolutionError`]).
    NoSolution(String),
}

impl From<Failure> for PyErr {
    fn from(f: Failure) -> Self {
        match f {
            Failure::Input(m) => InputError::new_err(m),
            Failure::NotValidated(m) => NotValidatedError::new_err(m),
            Failure::NoSolution(m) => NoSolutionError::new_err(m),
        }
    }
}

/// Adds the exception types to a module.
pub fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("InputError", py.get_type::<InputError>())?;
    m.add("SolveError", py.get_type::<SolveError>())?;
    m.add("NotValidatedError", py.get_type::<NotValidatedError>())?;
    m.add("NoSolutionError", py.get_type::<NoSolutionError>())?;
    Ok(())
}
