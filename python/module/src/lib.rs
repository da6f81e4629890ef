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
//! - [`problem`]: any problem behind [`DynSolver`] (a declared problem's library solver has it),
//!   [`register`] and [`add_problem`];
//! - [`class`]: [`ProblemSolver`], the one Python class of every problem, built-ins included;
//! - [`solution`]: what a solve returns, its fields by name;
//! - [`errors`]: the exceptions, created for each module under its name (`gen_relpose.InputError`);
//! - [`arrays`]: numpy in, checked, with errors that name the array, row and field.
//!
//! Every solve copies its inputs, then releases the GIL (`Python::detach`).

pub mod arrays;
pub mod class;
pub mod errors;
pub mod problem;
pub mod solution;

pub use class::{info_dict, ransac_options, ProblemSolver};
pub use errors::{Error, Exceptions, Failure};
pub use problem::{add_problem, add_solver, estimate_failure, public_name, register, solve_failure, DynSolver, Field, Fields, MakeSolver};
pub use pyo3;
pub use solution::Solution;
