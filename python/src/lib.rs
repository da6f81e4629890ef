//! The `simhc` package's extension module (`simhc._simhc`): the built-in problems, UPnP and
//! GRPS, registered as `simhc.upnp` and `simhc.grps` ([`builtin`]), each the one class of every
//! problem, `simhc.ProblemSolver` (`simhc_pymodule`). A user's own problem gets a module of its
//! own from `simhc_pymodule::python_module!` (`python/module/`), which compiles none of this.
//!
//! Errors are `simhc.InputError` and `simhc.SolveError` ([`simhc_pymodule::Exceptions`]).
//! Every solve copies its inputs, then releases the GIL (`Python::detach`).

pub mod builtin;

use pyo3::prelude::*;
use simhc_pymodule::{register, Exceptions};
use std::sync::Arc;

/// The extension module of the `simhc` package.
#[pymodule]
fn _simhc(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let exceptions = Arc::new(Exceptions::new(m.py(), "simhc")?);
    exceptions.add_to(m)?;
    register(m, "upnp", Box::new(builtin::upnp), exceptions.clone())?;
    register(m, "grps", Box::new(builtin::grps), exceptions)?;
    Ok(())
}
