//! The Python exceptions, made for each module under its own name: bad input is
//! `<module>.InputError`, a `ValueError` that says where (which array or correspondence, which
//! field); a solve without a validated answer is `<module>.SolveError`, a `RuntimeError`, and
//! never a pose.
//!
//! `pyo3::create_exception!` fixes a type's module when the library is compiled, so a user's
//! module would raise `simhc.InputError`. Here the types are created when the module is
//! imported ([`Exceptions::new`]), named for it: `gen_relpose.InputError`, `simhc.InputError`.

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyType;
use std::ffi::CString;

/// Why a solve has no answer, before it becomes a Python exception.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Failure {
    /// Bad input (`InputError`).
    Input(String),
    /// End points, none validated (`NotValidatedError`).
    NotValidated(String),
    /// No end point (`NoSolutionError`).
    NoSolution(String),
}

/// A call's error before it is raised: a [`Failure`] (raised as the module's own exception)
/// or an exception Python raised on the way (numpy missing, an object that cannot be read).
#[derive(Debug)]
pub enum Error {
    /// The input or the solve failed.
    Failure(Failure),
    /// Python raised this exception.
    Python(PyErr),
}

impl From<Failure> for Error {
    fn from(f: Failure) -> Self {
        Self::Failure(f)
    }
}

impl From<PyErr> for Error {
    fn from(e: PyErr) -> Self {
        Self::Python(e)
    }
}

/// What each exception type says (its `__doc__`).
const INPUT_DOC: &str = "The input is not a problem instance: a wrong shape, a NaN or infinity, too few correspondences or degenerate geometry. The message names the array or correspondence and the field.";
const SOLVE_DOC: &str = "No validated solution: never a pose to use.";
const NOT_VALIDATED_DOC: &str = "End points were found and none passed validation on all the data (the best one is flagged, not returned).";
const NO_SOLUTION_DOC: &str = "No attempt reached an end point (and the fallback found none).";

/// One module's exception types: `InputError` (a `ValueError`), `SolveError` (a
/// `RuntimeError`) and its subclasses `NotValidatedError` and `NoSolutionError`, each with
/// `__module__` the module's name.
#[derive(Debug)]
pub struct Exceptions {
    input: Py<PyType>,
    solve: Py<PyType>,
    not_validated: Py<PyType>,
    no_solution: Py<PyType>,
}

/// A new exception type `module.name` deriving from `base`.
fn new_type(py: Python<'_>, module: &str, name: &str, doc: &str, base: &Bound<'_, PyType>) -> PyResult<Py<PyType>> {
    let cstring = |s: String| CString::new(s).map_err(|e| PyValueError::new_err(format!("module name `{module}`: {e}")));
    let qualified = cstring(format!("{module}.{name}"))?;
    let doc = cstring(doc.to_string())?;
    PyErr::new_type(py, &qualified, Some(&doc), Some(base), None)
}

impl Exceptions {
    /// The four types for the module named `module` (`gen_relpose.InputError`, ...).
    pub fn new(py: Python<'_>, module: &str) -> PyResult<Self> {
        let input = new_type(py, module, "InputError", INPUT_DOC, &py.get_type::<PyValueError>())?;
        let solve = new_type(py, module, "SolveError", SOLVE_DOC, &py.get_type::<PyRuntimeError>())?;
        let not_validated = new_type(py, module, "NotValidatedError", NOT_VALIDATED_DOC, solve.bind(py))?;
        let no_solution = new_type(py, module, "NoSolutionError", NO_SOLUTION_DOC, solve.bind(py))?;
        Ok(Self { input, solve, not_validated, no_solution })
    }

    /// Adds the types to a module under their names.
    pub fn add_to(&self, m: &Bound<'_, PyModule>) -> PyResult<()> {
        let py = m.py();
        m.add("InputError", self.input.bind(py))?;
        m.add("SolveError", self.solve.bind(py))?;
        m.add("NotValidatedError", self.not_validated.bind(py))?;
        m.add("NoSolutionError", self.no_solution.bind(py))?;
        Ok(())
    }

    /// The exception to raise for `e`: a failure as this module's type, Python's own as it is.
    pub fn err(&self, py: Python<'_>, e: impl Into<Error>) -> PyErr {
        let (ty, message) = match e.into() {
            Error::Python(e) => return e,
            Error::Failure(Failure::Input(m)) => (&self.input, m),
            Error::Failure(Failure::NotValidated(m)) => (&self.not_validated, m),
            Error::Failure(Failure::NoSolution(m)) => (&self.no_solution, m),
        };
        PyErr::from_type(ty.bind(py).clone(), message)
    }
}
