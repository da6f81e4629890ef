//! The library a user's crate calls to make a Python module of its own declared problem, in one
//! line ([`python_module!`]):
//!
//! ```ignore
//! simhc_pymodule::python_module!(gen_relpose, generalized_relative_pose::GenRelPose::new());
//! ```
//!
//! It depends on `simhc`, PyO3, numpy and nalgebra only: the built-in problems and their
//! `simhc` wheel (`python/`) are not compiled for a user's module.
//!
//! - [`problem`]: any declared problem as a [`ProblemSolver`], one class for every problem;
//! - [`errors`]: the exceptions, created for each module under its name (`gen_relpose.InputError`);
//! - [`arrays`]: numpy in, checked, with errors that name the array, row and field.
//!
//! Every solve copies its inputs, then releases the GIL (`Python::detach`).

pub mod arrays;
pub mod errors;
pub mod problem;

pub use errors::{Error, Exceptions, Failure};
pub use problem::{add_problem, info_dict, public_name, ransac_options, solve_failure, DynSolver, ProblemSolver};
pub use pyo3;
