//! A declared problem's compiled solver as a library value.
//!
//! A problem implements [`DeclaredProblem`] (its compiled instances, a validator, a scene
//! sampler, optional hooks); [`Solver`] assembles the solve from it once (weights, start
//! system) and then solves any number of times from any thread, without heap allocation per
//! validated solve; [`Solver::estimate`] is the robust estimator over correspondences with
//! outliers. The `simhc-cli` commands (`train`, `bench`, `solve`, `monodromy`) adapt the same
//! trait, and the built-in problems' toolkits ([`SquareSubsystem`] for the all-roots fallback,
//! [`crate::start_system`] for its start system) live here too, so a problem library depends
//! on the runtime only.
//!
//! - [`problem`]: the trait and its hook types;
//! - [`parts`]: the parts a solve is assembled from (tracked parameters, random and refined
//!   starts, the canonical frame);
//! - [`subsystem`]: all roots of a square subsystem;
//! - [`instance`]: what a solver needs of a problem, for data of any type
//!   ([`InstanceProblem`]), and the blanket impl for every [`DeclaredProblem`];
//! - [`hypotheses`]: a learned start's several hypotheses, ranked on the data;
//! - [`library`]: the solver, [`Solver`];
//! - [`restarts`]: restarts around the learned start, before the fallback;
//! - [`estimate`]: the robust estimator, [`Solver::estimate`].

pub mod estimate;
pub mod hypotheses;
pub mod instance;
pub mod library;
pub mod parts;
pub mod problem;
pub mod restarts;
pub mod subsystem;

pub use estimate::{row_residual, EstimateError, EstimateInfo};
pub use instance::{InstanceProblem, LearnedHypotheses, Ranked, RowwiseLearned};
pub use library::{
    sample_schedule, shipped_schedule, Certification, InstanceOutcome, InstanceSolver, Outcome, ProblemOutputs, ProblemRows, Solution,
    SolveError, Solver, SolverError, StartId, MAX_OTHERS,
};
pub use parts::{Canon, DegenerateInput, FirstRows, FirstRowsError, GivenStart, RandomStart};
pub use problem::{CanonicalFrame, DeclaredProblem, OtherSimulator, OtherStart, Refinement};
pub use restarts::{restart_rotation, rotated_restart, MAX_RESTARTS, RESTART_AXES};
pub use subsystem::{AllRoots, AllRootsFallback, SquareSubsystem};
