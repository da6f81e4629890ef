//! A declared problem's compiled solver as a library value.
//!
//! A problem implements [`DeclaredProblem`] (its compiled instances, a validator, optional
//! hooks); [`Solver`] assembles the solve from it once (weights, start system) and then solves
//! any number of times from any thread, without heap allocation per validated solve;
//! [`InstanceSolver::estimate`] is the robust estimator over correspondences with outliers. The
//! `simhc-cli` commands (`train`, `bench`, `ransac`, `solve`, `monodromy`) also need
//! [`Scenes`] (a scene sampler, the errors a bench reports). The built-in problems' toolkits
//! ([`SquareSubsystem`] for the all-roots fallback, [`crate::start_system`] for its start
//! system) live here too, so a problem library depends on the runtime only.
//!
//! The modules stack from the ground up, each importing only those above it in this list:
//!
//! - [`subsystem`]: all roots of a square subsystem;
//! - [`residual`]: a row's equations and the default per-correspondence error;
//! - [`schedule`]: what a solve tries in which order, each attempt naming its start;
//! - [`plan`]: what a solver tries, a value apart from the problem ([`Plan`]);
//! - [`problem`]: the trait of a solve and its hook types;
//! - [`scenes`]: the trait of the commands, on top of it;
//! - [`parts`]: the parts a solve is assembled from (tracked parameters, random and given
//!   starts, the canonical frame);
//! - [`rows`]: a row-wise problem's learned-start rows and outputs;
//! - [`hypotheses`]: a learned start's several hypotheses, ranked on the data;
//! - [`instance`]: what a solver needs of a problem, for data of any type
//!   ([`InstanceProblem`]), and the blanket impl for every [`DeclaredProblem`];
//! - [`restarts`]: restarts around the learned start, before the fallback;
//! - [`library`]: the solver, [`Solver`];
//! - [`estimate`]: the robust estimator for every problem and data type,
//!   [`InstanceSolver::estimate`], and what it needs of a problem ([`Correspondences`]);
//! - [`estimate_rows`]: a row-wise problem's rows as its correspondences;
//! - [`many_rows`]: a solve of more rows than the data instance has, [`Solver::solve_rows`].

pub mod estimate;
pub mod estimate_rows;
pub mod hypotheses;
pub mod instance;
pub mod library;
pub mod many_rows;
pub mod parts;
pub mod plan;
pub mod problem;
pub mod residual;
pub mod restarts;
pub mod rows;
pub mod scenes;
pub mod schedule;
pub mod subsystem;

pub use estimate::{Correspondences, EstimateError, EstimateInfo};
pub use estimate_rows::RowsInput;
pub use hypotheses::{LearnedHypotheses, Ranked};
pub use instance::{InstanceProblem, RowwiseLearned};
pub use library::{
    Certification, InstanceOutcome, InstanceSolver, Outcome, Solution, SolveError, Solver, SolverError, SolverOrigin, MAX_OTHERS,
};
pub use many_rows::RowsSolution;
pub use parts::{Canon, FirstRows, FirstRowsError, GivenStart, RandomStart};
pub use plan::Plan;
pub use problem::{CanonicalFrame, DeclaredProblem, DeclaredSizes, DegenerateInput, Refinement};
pub use residual::row_residual;
pub use restarts::{restart_rotation, rotated_restart, MAX_RESTARTS, RESTART_AXES};
pub use rows::{ProblemOutputs, ProblemRows};
pub use scenes::Scenes;
pub use schedule::{sample_schedule, shipped_schedule, SolverAttempt, StartId};
pub use subsystem::{AllRoots, AllRootsFallback, SquareSubsystem};
