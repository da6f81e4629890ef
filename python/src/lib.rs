//! The `simhc` package's extension module (`simhc._simhc`): the built-in problems' solvers and
//! robust estimators (UPnP, GRPS). A user's own problem gets a module of its own from
//! `simhc_pymodule::python_module!` (`python/module/`), which compiles none of this.
//!
//! - [`builtin`]: `simhc.upnp`, `simhc.grps`, `simhc.estimate_upnp`, `simhc.estimate_grps`;
//! - [`pose`]: the returned pose.
//!
//! Errors are `simhc.InputError` and `simhc.SolveError` ([`simhc_pymodule::Exceptions`]).
//! Every solve copies its inputs, then releases the GIL (`Python::detach`).

pub mod builtin;
pub mod pose;

use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use simhc_pymodule::{Error, Exceptions};

/// The package's exception types, `simhc.InputError` and the rest (made once).
fn exceptions(py: Python<'_>) -> PyResult<&Exceptions> {
    static EXCEPTIONS: PyOnceLock<Exceptions> = PyOnceLock::new();
    EXCEPTIONS.get_or_try_init(py, || Exceptions::new(py, "simhc"))
}

/// `e` raised as the package's exception.
pub(crate) fn raise(py: Python<'_>, e: impl Into<Error>) -> PyErr {
    match exceptions(py) {
        Ok(exceptions) => exceptions.err(py, e),
        Err(e) => e,
    }
}

/// The extension module of the `simhc` package.
#[pymodule]
fn _simhc(m: &Bound<'_, PyModule>) -> PyResult<()> {
    exceptions(m.py())?.add_to(m)?;
    m.add_class::<pose::Pose>()?;
    m.add_function(wrap_pyfunction!(builtin::upnp, m)?)?;
    m.add_function(wrap_pyfunction!(builtin::grps, m)?)?;
    m.add_function(wrap_pyfunction!(builtin::estimate_upnp, m)?)?;
    m.add_function(wrap_pyfunction!(builtin::estimate_grps, m)?)?;
    Ok(())
}
