//! The `simhc` command line as a library: [`App`] builds `train`, `bench`, `solve` and
//! `monodromy` for every registered problem. The `simhc` binary registers the built-ins
//! ([`Upnp`], [`Grps`], [`TrackerBench`]); a user's crate registers its own declared problem
//! with [`Declared`]:
//!
//! ```ignore
//! fn main() -> std::process::ExitCode {
//!     simhc_cli::App::new("grp", "generalized relative pose").register(simhc_cli::Declared::new(MyProblem)).main()
//! }
//! ```
//!
//! The same registration is a library value: [`Solver`] (built once, `solve`, `solve_batch`,
//! and the robust [`Solver::estimate`] over any number of correspondences with outliers).
//!
//! The `train` commands need the default feature `train` (the burn trainer); without it the
//! crate builds without burn, and `bench`, `solve` and `monodromy` stay.

pub mod app;
pub mod builtin;
pub mod declared;
pub mod estimate;
mod grps;
mod plots;
pub mod solver;
mod stats;
mod tracker_bench;
mod upnp;

pub use app::{progress_bar, App, Registration, Verb};
pub use builtin::{Grps, TrackerBench, Upnp};
pub use declared::{
    AllRoots, CanonicalFrame, Declared, DeclaredProblem, FirstRows, FirstRowsError, RandomStart, Refinement, SquareSubsystem,
};
pub use estimate::{EstimateError, EstimateInfo};
#[cfg(feature = "train")]
pub use simhc_regressor::generic::LearnedStartConfig;
#[cfg(feature = "train")]
pub use simhc_regressor::TrainConfig;
pub use solver::{Solution, SolveError, Solver, SolverError};

/// The `simhc` application: the built-in problems and the tracker benchmark.
pub fn simhc_app() -> App {
    App::new("simhc", "Simulator HC: regression + online simulator + single-path homotopy continuation")
        .register(Upnp)
        .register(Grps)
        .register(TrackerBench)
}
