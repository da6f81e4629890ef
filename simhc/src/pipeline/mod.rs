//! The Simulator HC pipeline, written once for every problem: start -> online simulator ->
//! one homotopy path -> validation -> next start -> all-roots fallback, with a typed result
//! that says which attempt produced the solution, what each stage cost, and whether it was
//! validated. A problem plugs in through small traits, one capability each (argmin's style):
//!
//! - [`StartProvider`]: a rough solution `x0` (a regressor, a closed-form relaxation, a
//!   caller's guess); the pipeline tries the providers in order;
//! - [`TargetParameters`]: the parameters `p` of the user's data;
//! - [`StartSimulator`]: start parameters `p0` that `x0` solves exactly. Every
//!   [`crate::OnlineSimulator`] is one (it ignores the data) through [`Generic`]; a
//!   problem whose simulator needs the raw data (reprojection) implements it directly;
//! - [`Validator`]: does an end point explain *all* the data (residual on redundant rows,
//!   inequalities such as positive depth)? Accept, keep as plausible, or reject;
//! - [`Fallback`] (optional): candidate solutions from all roots, validated like any end
//!   point;
//! - [`Canonicalize`] (optional): the data in a frame computed from itself, the solution
//!   mapped back ([`Pipeline::solve_canonical`]);
//! - [`LearnedStart`]: the generic learned start of a declared problem, trained from its
//!   sampler by `simhc_regressor::generic`.
//!
//! [`Pipeline::solve`] (in [`executor`]) drives them. The path of one attempt is
//! [`path::simulator_hc`]. Nothing is returned as `Ok` unless it validated; otherwise the
//! best end point comes back inside [`PipelineError::NotValidated`], flagged.

pub mod bench;
pub mod executor;
pub mod learned;
pub mod path;

use nalgebra::SVector;
use std::fmt::Debug;
use std::time::Duration;
use thiserror::Error;

pub use executor::{Pipeline, PipelineOptions};
pub use learned::{InputRows, LayoutOutputs, LayoutRows, LearnedStart, OutputDecoding, ParameterVector, MAX_HYPOTHESES};

use crate::tracker::{TrackError, TrackStats};
use crate::SimulatorError;

/// Why a start provider has no start for this data.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("{provider}: {reason}")]
pub struct StartError {
    /// The provider's name.
    pub provider: &'static str,
    /// What went wrong, for the user (a fixed message, or one made for the case: a fixed one
    /// allocates nothing, and inside RANSAC most samples fail).
    pub reason: std::borrow::Cow<'static, str>,
}

/// A rough solution `x0` of the data (stage 1 of the paper).
pub trait StartProvider<D: ?Sized, const NX: usize> {
    /// A short name for reports (`"linear"`, `"regressor"`).
    fn name(&self) -> &'static str;
    /// The start, or why there is none.
    fn start(&self, data: &D) -> Result<SVector<f64, NX>, StartError>;
}

/// The target parameters `p` of the data.
pub trait TargetParameters<D: ?Sized, const NP: usize> {
    /// The problem's error for bad input.
    type Error: std::error::Error + Clone + PartialEq;
    /// `p`, or why the data is not a problem instance (wrong length, degenerate geometry).
    fn params(&self, data: &D) -> Result<SVector<f64, NP>, Self::Error>;
}

/// Start parameters `p0` with `F(x0; p0) = 0` near the target `p` (stage 2 of the paper).
pub trait StartSimulator<D: ?Sized, const NX: usize, const NF: usize, const NP: usize> {
    /// `p0` for the start `x0`, the data and its target parameters `p`.
    fn simulate(&self, data: &D, x0: &SVector<f64, NX>, p: &SVector<f64, NP>) -> Result<SVector<f64, NP>, SimulatorError>;
}

/// Any [`crate::OnlineSimulator`] as a [`StartSimulator`] that ignores the data.
#[derive(Debug, Clone, Copy, Default)]
pub struct Generic<S>(pub S);

impl<D: ?Sized, S, const NX: usize, const NF: usize, const NP: usize> StartSimulator<D, NX, NF, NP> for Generic<S>
where
    S: crate::OnlineSimulator<NX, NF, NP>,
{
    fn simulate(&self, _data: &D, x0: &SVector<f64, NX>, p: &SVector<f64, NP>) -> Result<SVector<f64, NP>, SimulatorError> {
        self.0.simulate(x0, p)
    }
}

/// What the validator says of an end point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// A solution: return it at once.
    Accept,
    /// Explains the data within the noise, but so might a better one: keep it, try up to
    /// [`PipelineOptions::extra_attempts`] more, return the best plausible one.
    Plausible,
    /// Not a solution of the data.
    Reject,
}

impl Verdict {
    /// `Accept` when the check passes, else `Reject` (a validator without a plausible band).
    pub fn accept_if(passes: bool) -> Self {
        if passes {
            Self::Accept
        } else {
            Self::Reject
        }
    }
}

/// Does an end point explain all the data?
pub trait Validator<D: ?Sized, const NX: usize> {
    /// The figures of one check (residuals, violated inequalities). `Serialize`: `solve`
    /// prints them as JSON with the solution; a number or a tuple of numbers needs nothing
    /// more, a struct derives `serde::Serialize` (an object of its named figures).
    type Check: Copy + Debug + PartialEq + serde::Serialize;
    /// Checks `x` on `data`.
    fn check(&self, data: &D, x: &SVector<f64, NX>) -> Self::Check;
    /// The verdict of a check.
    fn verdict(&self, check: &Self::Check) -> Verdict;
    /// Whether `a` explains the data better than `b` (ranks plausible and rejected end points).
    fn better(&self, a: &Self::Check, b: &Self::Check) -> bool;
}

/// An optional change of the data to a frame computed from the data itself (centring,
/// principal axes, units), so that the start, the simulator and the paths see the same numbers
/// whatever frame the user's data came in ([`Pipeline::solve_canonical`]).
pub trait Canonicalize<D: ?Sized, const NX: usize> {
    /// What is needed to map a solution back.
    type Frame;
    /// The data in the canonical frame.
    type Canonical: std::borrow::Borrow<D>;
    /// The frame and the canonical data; `None` when the data has no frame (the pipeline then
    /// solves the data as given).
    fn canonicalize(&self, data: &D) -> Option<(Self::Frame, Self::Canonical)>;
    /// A canonical solution in the user's frame.
    fn to_user(&self, frame: &Self::Frame, x: &SVector<f64, NX>) -> SVector<f64, NX>;
}

/// Candidate solutions when no path validated, typically all real roots of a start system.
pub trait Fallback<D: ?Sized, const NX: usize, const NP: usize> {
    /// The candidates for `data` with target parameters `p`.
    fn candidates(&self, data: &D, p: &SVector<f64, NP>) -> Vec<SVector<f64, NX>>;
}

/// Wall time of each stage of one solve, all attempts included.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    /// Target parameters.
    pub target: Duration,
    /// Start providers.
    pub start: Duration,
    /// Online simulators.
    pub simulator: Duration,
    /// Path tracking and validation.
    pub tracking: Duration,
    /// The fallback, its validation included.
    pub fallback: Duration,
}

/// How an attempt goes from its start to an end point. In JSON: the variant's name, and
/// `{"OtherSimulatorHc": k}` for another simulator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum Method {
    /// One Simulator HC path (the paper's method) with the pipeline's simulator.
    #[default]
    SimulatorHc,
    /// One Simulator HC path with another simulator: number `k` of
    /// [`Pipeline::with_other_simulators`] (a problem with a geometric and a generic one).
    OtherSimulatorHc(usize),
    /// Gauss-Newton on the target system from the start (no homotopy).
    GaussNewton,
    /// The start itself, validated as it is: for a provider that already refines on all the
    /// data (a least-squares point that the tracked rows' own root would move away from).
    Start,
}

/// One scheduled attempt: a start provider (index into the pipeline's providers) and a method.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Attempt {
    /// Index of the start provider.
    pub provider: usize,
    /// The method.
    pub method: Method,
}

/// The attempts a pipeline runs, in order, read one at a time ([`Pipeline::with_schedule`]): a
/// slice of [`Attempt`]s, or a caller's schedule in its own terms that it turns into positions
/// of the providers it gave the pipeline as the pipeline reads them (the library solver's
/// attempts name their starts, `simhc::solver::SolverAttempt`). Read one at a time so that such
/// a schedule needs no copy, and a solve no allocation.
pub trait Schedule {
    /// Attempt `i` of the schedule (0 is the first); `None` past its end.
    fn attempt(&self, i: usize) -> Option<Attempt>;
}

impl Schedule for [Attempt] {
    fn attempt(&self, i: usize) -> Option<Attempt> {
        self.get(i).copied()
    }
}

/// What produced a solution.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// An attempt from start provider number `provider` (in the pipeline's order).
    Path {
        /// Index of the start provider.
        provider: usize,
        /// The attempt's method.
        method: Method,
    },
    /// Candidate number `candidate` of the fallback.
    Fallback {
        /// Index among the fallback's candidates.
        candidate: usize,
    },
}

/// A solution with its diagnostics. `O` says what produced it: the pipeline's [`Origin`] (a
/// provider by its index), or a caller's origin in its own terms ([`Solved::with_origin`]; the
/// library solver names its starts).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solved<C, const NX: usize, O = Origin> {
    /// The unknowns.
    pub x: SVector<f64, NX>,
    /// The start of the path that produced `x` (`x` itself for the fallback).
    pub start: SVector<f64, NX>,
    /// What produced `x`.
    pub origin: O,
    /// Attempts made, the fallback counted as one.
    pub attempts: usize,
    /// The validation of `x`.
    pub check: C,
    /// Work of the path that produced `x` (zero for the fallback).
    pub stats: TrackStats,
    /// Stage times.
    pub times: StageTimes,
}

impl<C, const NX: usize, O> Solved<C, NX, O> {
    /// The same solution with its origin told as `name` tells it.
    pub fn with_origin<Q>(self, name: impl FnOnce(O) -> Q) -> Solved<C, NX, Q> {
        let Solved { x, start, origin, attempts, check, stats, times } = self;
        Solved { x, start, origin: name(origin), attempts, check, stats, times }
    }
}

/// Why one attempt produced no end point.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum AttemptError {
    /// The start provider had no start.
    #[error(transparent)]
    Start(#[from] StartError),
    /// The simulator failed.
    #[error("simulator: {0}")]
    Simulator(#[from] SimulatorError),
    /// The path failed.
    #[error("tracker: {0}")]
    Tracker(#[from] TrackError),
}

/// Why a solve returned no validated solution.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum PipelineError<E: std::error::Error, C: Debug, const NX: usize, O: Debug = Origin> {
    /// The data is not a problem instance.
    #[error("input: {0}")]
    Input(E),
    /// No attempt produced an end point (and the fallback had no candidate).
    #[error("no end point after {attempts} attempts; last: {last:?}")]
    NoEndPoint {
        /// Attempts made.
        attempts: usize,
        /// The last attempt's error, if any attempt ran.
        last: Option<AttemptError>,
    },
    /// End points were found but none validated: the best one, flagged. Do not use it as a
    /// solution. Held inline, not boxed: inside RANSAC most samples end here, and a solve
    /// allocates nothing.
    #[error("no end point validated after {} attempts (best: {:?})", .0.attempts, .0.check)]
    NotValidated(Solved<C, NX, O>),
}

impl<E: std::error::Error, C: Debug, const NX: usize, O: Debug> PipelineError<E, C, NX, O> {
    /// The same error with the origin of a flagged end point told as `name` tells it
    /// ([`Solved::with_origin`]).
    pub fn with_origin<Q: Debug>(self, name: impl FnOnce(O) -> Q) -> PipelineError<E, C, NX, Q> {
        match self {
            PipelineError::Input(e) => PipelineError::Input(e),
            PipelineError::NoEndPoint { attempts, last } => PipelineError::NoEndPoint { attempts, last },
            PipelineError::NotValidated(s) => PipelineError::NotValidated(s.with_origin(name)),
        }
    }
}
