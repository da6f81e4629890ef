//! simhc from Python: the `simhc` package's extension module (`simhc._simhc`), and the
//! library a user's crate calls to make a Python module of its own declared problem
//! ([`python_module!`]).
//!
//! - [`builtin`]: `simhc.upnp`, `simhc.grps`, `simhc.estimate_upnp`, `simhc.estimate_grps`
//!   (the built-ins' solvers and robust estimators);
//! - [`relpose`]: `simhc.gen_relpose`, `simhc.estimate_gen_relpose` (the example problem) and
//!   `simhc.grp`, the same problem's module made by [`python_module!`];
//! - [`problem`]: any declared problem as a [`problem::ProblemSolver`];
//! - [`arrays`], [`pose`], [`errors`]: numpy conversion, the returned pose, the exceptions.
//!
//! Every solve copies its inputs, then releases the GIL (`Python::detach`).

// `python_module!` names `::simhc_python`, which this crate uses for its own `grp` module.
extern crate self as simhc_python;

pub mod arrays;
pub mod builtin;
pub mod errors;
pub mod pose;
pub mod problem;
pub mod relpose;

pub use problem::{add_problem, DynSolver, ProblemSolver};
pub use pyo3;

use pyo3::prelude::*;

/// The extension module of the `simhc` package.
#[pymodule]
fn _simhc(m: &Bound<'_, PyModule>) -> PyResult<()> {
    errors::register(m)?;
    m.add_class::<pose::Pose>()?;
    m.add_class::<ProblemSolver>()?;
    m.add_function(wrap_pyfunction!(builtin::upnp, m)?)?;
    m.add_function(wrap_pyfunction!(builtin::grps, m)?)?;
    m.add_function(wrap_pyfunction!(builtin::estimate_upnp, m)?)?;
    m.add_function(wrap_pyfunction!(builtin::estimate_grps, m)?)?;
    m.add_function(wrap_pyfunction!(relpose::gen_relpose, m)?)?;
    m.add_function(wrap_pyfunction!(relpose::estimate_gen_relpose, m)?)?;
    m.add_wrapped(pyo3::wrap_pymodule!(relpose::grp))?;
    Ok(())
}
