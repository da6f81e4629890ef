//! The `simhc` command line as a library: [`App`] builds `train`, `bench`, `ransac`, `solve`
//! and `monodromy` for every registered problem. The `simhc` binary registers the built-ins
//! ([`Upnp`], [`Grps`], [`TrackerBench`]); a user's crate registers its own declared problem
//! with [`Declared`]:
//!
//! ```ignore
//! fn main() -> std::process::ExitCode {
//!     simhc_cli::App::new("grp", "generalized relative pose").register(simhc_cli::Declared::new(MyProblem)).main()
//! }
//! ```
//!
//! The problem traits ([`simhc::solver::DeclaredProblem`] for a solve, [`simhc::solver::Scenes`]
//! for the commands) and the library solver
//! ([`simhc::solver::Solver`]: built once, `solve`, `solve_batch`, and the robust `estimate`
//! over any number of correspondences with outliers) live in the runtime; this crate adapts
//! them to commands.
//!
//! The `train` commands need the default feature `train` (the burn trainer); without it the
//! crate builds without burn, and `bench`, `solve` and `monodromy` stay.

pub mod app;
pub mod builtin;
mod certificates;
pub mod declared;
mod grps;
mod plots;
pub mod ransac;
mod stats;
mod tracker_bench;
mod upnp;

pub use app::{progress_bar, App, Registration, Verb};
pub use builtin::{Grps, TrackerBench, Upnp};
pub use declared::Declared;

/// The `simhc` application: the built-in problems and the tracker benchmark.
pub fn simhc_app() -> App {
    App::new("simhc", "Simulator HC: regression + online simulator + single-path homotopy continuation")
        .register(Upnp)
        .register(Grps)
        // GRPS through the generic assembly, beside the hand-assembled `grps` (same weights).
        .register(Declared::new(simhc_problems::grps::declared::Grps7Problem::new()))
        .register(Declared::new(simhc_problems::grps::declared::Grps8Problem::new()))
        .register(TrackerBench)
}
