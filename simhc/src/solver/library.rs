//! A problem's compiled solver as a value you call: built once (weights, start system), then
//! [`InstanceSolver::solve`] any number of times, from any thread (`Send + Sync` when the
//! problem is), or [`InstanceSolver::solve_batch`] across cores. The `solve` command is this
//! solver reading one file. [`InstanceSolver`] takes any [`InstanceProblem`] (UPnP's data is
//! a list of correspondences of any length); [`Solver`] is its name for a row-wise
//! [`super::DeclaredProblem`], whose data is a parameter vector.
//!
//! ```ignore
//! let solver = simhc::solver::Solver::new(GenRelPose::new())?;        // shipped weights, noise 0
//! match solver.solve(&params) {
//!     Ok(s) => println!("{}", s.x),                                // validated on all rows
//!     Err(e) => eprintln!("{e}"),                                  // typed, flagged, never a solution
//! }
//! ```
//!
//! A solve checks the data ([`InstanceProblem::check_data`]; a row-wise problem's NaN check
//! and [`super::DeclaredProblem::check_input`]), then runs its schedule in the problem's canonical
//! frame ([`InstanceSolver::schedule`]: the shipped attempts on the learned start's
//! hypotheses, the problem's other starts and simulators, its restarts), then the all-roots
//! fallback when the problem has one; only an end point that the problem's
//! validator accepts on all the data comes back as `Ok`. A solve makes no heap allocation
//! short of the all-roots fallback (which returns a `Vec`), validated or flagged, when the
//! problem's own hooks do not allocate: a [`super::DeclaredProblem::canonicalize`] frame holds its
//! maps inline ([`super::CanonicalFrame::new`]), and a start that fails with a fixed message
//! allocates nothing. Of the built-ins, UPnP's simulator allocates its reprojected
//! correspondences, and its learned start its rows beyond 32 correspondences.

use super::hypotheses::{LearnedHypotheses, RankedStart, RankedStarts};
use super::instance::{InstanceProblem, OwnCanon, OwnFallback, OwnSimulator, Parts, RefinedStart};
use super::parts::FirstRowsError;
use super::plan::Plan;
use super::restarts::{RestartStart, MAX_RESTARTS};
use super::schedule::{other_starts_first, shipped_schedule, solver_schedule, SolverAttempt, StartId};
use crate::certify::{certify_rows, choose_rows, Certificate, CertifyError};
use crate::pipeline::{
    Attempt, AttemptError, Fallback, Origin, Pipeline, PipelineError, PipelineOptions, Schedule, Solved, StartError, StartProvider,
    StartSimulator, Validator, MAX_HYPOTHESES,
};
use crate::regressor::RegressorError;
use nalgebra::SVector;
use rayon::prelude::*;
use std::borrow::Borrow;
use std::fmt::Debug;
use std::sync::Arc;
use thiserror::Error;

/// A validated solution.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Solution<C, const NX: usize> {
    /// The unknowns, in the layout's order (in the user's frame).
    pub x: SVector<f64, NX>,
    /// What produced them: an attempt of [`InstanceSolver::schedule`] or a fallback candidate.
    pub origin: SolverOrigin,
    /// Attempts made, the fallback counted as one.
    pub attempts: usize,
    /// The validator's figures on all the data.
    pub check: C,
    /// A proof that a box around `x` holds exactly one true root of the tracked system on this
    /// data (or a square subsystem of it, named by [`Certificate::rows`]), or why the proof did
    /// not go through ([`InstanceSolver::certify`]); `None` from a solver that does not certify
    /// ([`Certification::Off`], the default). Validation says the data agree with `x`; the
    /// certificate says an exact root lies within [`Certificate::error_bound`] of it.
    pub certified: Option<Result<Certificate<NX>, CertifyError>>,
}

/// Why a solve returned no validated solution.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SolveError<C: Debug, const NX: usize> {
    /// The data is not a problem instance; says which row (correspondence) and field.
    #[error("input: {0}")]
    Input(FirstRowsError),
    /// End points were found and none validated: the best one, flagged. Not a solution.
    #[error("no solution validated after {attempts} attempts (best, flagged, NOT a solution: check {check:?})")]
    NotValidated {
        /// The best end point.
        best: SVector<f64, NX>,
        /// Its check.
        check: C,
        /// Attempts made.
        attempts: usize,
    },
    /// A validated solution whose certificate did not go through, from a solver that requires
    /// one ([`Certification::Require`]): flagged, not a solution.
    #[error("solution validated but not certified ({reason}): flagged, NOT a solution (check {check:?})")]
    NotCertified {
        /// The validated end point.
        best: SVector<f64, NX>,
        /// Its check.
        check: C,
        /// Attempts made.
        attempts: usize,
        /// Why the certificate failed.
        reason: CertifyError,
    },
    /// No attempt produced an end point, and no fallback candidate.
    #[error("no end point after {attempts} attempts{}", match last { Some(e) => format!("; last: {e}"), None => String::new() })]
    NoEndPoint {
        /// Attempts made.
        attempts: usize,
        /// The last attempt's error.
        last: Option<AttemptError>,
    },
}

/// Whether a solve certifies its solution ([`InstanceSolver::certifying`]).
///
/// Off by default: a certificate costs 1.1-3.7x a solve (scalar interval arithmetic; `bench`
/// prints the ratio, BENCHMARKS.md 2026-12-05), which a hot loop should not pay unasked. The `solve` command, Python and the estimators' final models ask.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Certification {
    /// No certificate (`Solution::certified` is `None`).
    #[default]
    Off,
    /// Every solution reports its certificate, or why there is none.
    Report,
    /// Only certified solutions come back; a validated one that does not certify is
    /// [`SolveError::NotCertified`] (flagged).
    Require,
}

/// What produced a solver's solution: one of its attempts (its start by name), or a candidate
/// of the all-roots fallback.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SolverOrigin {
    /// The attempt from this start with this method.
    Attempt(SolverAttempt),
    /// Candidate number `candidate` of the fallback.
    Fallback {
        /// Index among the fallback's candidates.
        candidate: usize,
    },
}

/// Most other starts, and most other simulators, a problem may bring
/// ([`Plan::other_starts`], [`Plan::other_simulators`]): a solve holds
/// them in fixed arrays, without allocation.
pub const MAX_OTHERS: usize = 8;

/// Why a solver could not be built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SolverError {
    /// The problem brings more other starts, simulators or restarts than a solve holds.
    #[error("{problem} brings {count} {what}; a solver takes at most {most}")]
    TooMany {
        /// The problem's name.
        problem: &'static str,
        /// `"learned hypotheses"`, `"other starts"`, `"other simulators"` or `"restarts"`.
        what: &'static str,
        /// How many it brings.
        count: usize,
        /// How many a solver takes ([`MAX_HYPOTHESES`], [`MAX_OTHERS`], [`MAX_RESTARTS`]).
        most: usize,
    },
    /// The problem ships no weights and none were given.
    #[error("{0} has no shipped weights: pass weights made by `train {0}`")]
    NoWeights(&'static str),
    /// The weights do not load, or were made for other input rows or unknowns.
    #[error("weights: {0}")]
    Weights(#[from] RegressorError),
}

/// The check of a validator `V` of the data `D`.
pub type CheckOf<V, const NX: usize, D> = <V as Validator<D, NX>>::Check;

/// The check of a validator `V` of a data vector.
pub type Check<V, const NX: usize, const ND: usize> = CheckOf<V, NX, SVector<f64, ND>>;

/// What the pipeline of a solve returns ([`InstanceSolver::run_pipeline`]), for a problem whose
/// validator of the data `D` is `V`.
pub type InstancePipelineOutcome<V, const NX: usize, D> =
    Result<Solved<CheckOf<V, NX, D>, NX, SolverOrigin>, PipelineError<FirstRowsError, CheckOf<V, NX, D>, NX, SolverOrigin>>;

/// One end point of [`InstanceSolver::plausible_end_points`], for a problem whose validator of
/// the data `D` is `V`.
pub type PlausibleEndPoint<V, const NX: usize, D> = Solved<CheckOf<V, NX, D>, NX, SolverOrigin>;

/// [`InstancePipelineOutcome`] of a data vector.
pub type PipelineOutcome<V, const NX: usize, const ND: usize> = InstancePipelineOutcome<V, NX, SVector<f64, ND>>;

/// What a solve returns, for a problem whose validator of the data `D` is `V`.
pub type InstanceOutcome<V, const NX: usize, D> = Result<Solution<CheckOf<V, NX, D>, NX>, SolveError<CheckOf<V, NX, D>, NX>>;

/// [`InstanceOutcome`] of a data vector.
pub type Outcome<V, const NX: usize, const ND: usize> = InstanceOutcome<V, NX, SVector<f64, ND>>;

/// A problem's solver for data of type `D` ([module docs](self)); [`Solver`] for a row-wise
/// problem.
pub struct InstanceSolver<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized>
where
    S: InstanceProblem<NX, NF, NP, NC, D>,
{
    problem: Arc<S>,
    learned: S::Learned,
    validator: S::Validator,
    /// What a solve tries ([`InstanceProblem::plan`], or [`InstanceSolver::with_plan`]'s).
    plan: Plan<D, NX, NF, NP>,
    /// [`solver_schedule`] of [`shipped_schedule`] for the plan.
    schedule: Vec<SolverAttempt>,
    /// Whether a solve certifies ([`InstanceSolver::certifying`]).
    certification: Certification,
    /// The all-roots fallback given at run time ([`InstanceSolver::with_fallback`]), instead of
    /// the problem's own.
    fallback: Option<SharedFallback<D, NX, NP>>,
}

/// An all-roots fallback of the data `D`, shared by the threads of a solver.
type SharedFallback<D, const NX: usize, const NP: usize> = Box<dyn Fallback<D, NX, NP> + Send + Sync>;

/// A row-wise problem's solver: its data is the parameter vector of its data instance.
pub type Solver<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> =
    InstanceSolver<S, NX, NF, NP, NC, SVector<f64, ND>>;

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized> InstanceSolver<S, NX, NF, NP, NC, D>
where
    S: InstanceProblem<NX, NF, NP, NC, D>,
{
    /// The solver of `problem` with its shipped weights, for noise-free data.
    pub fn new(problem: S) -> Result<Self, SolverError> {
        let weights = problem.weights().ok_or(SolverError::NoWeights(problem.name()))?;
        Self::with_weights(problem, weights, 0.0)
    }

    /// The solver of `problem` with the learned start of `weights` (a file made by `train`),
    /// validating for data with noise of size `noise` (the problem's unit).
    pub fn with_weights(problem: S, weights: &[u8], noise: f64) -> Result<Self, SolverError> {
        Self::with_shared(Arc::new(problem), weights, noise)
    }

    /// [`InstanceSolver::with_weights`] for a problem shared with other holders.
    pub fn with_shared(problem: Arc<S>, weights: &[u8], noise: f64) -> Result<Self, SolverError> {
        let learned = S::learned(&problem, weights)?;
        Self::with_learned(problem, learned, noise)
    }

    /// The solver of `problem` with a learned start already built (one network shared by
    /// several solvers, or a start that is not a network).
    pub fn with_learned(problem: Arc<S>, learned: S::Learned, noise: f64) -> Result<Self, SolverError> {
        let validator = problem.validator(noise);
        let plan = problem.plan();
        Self::assemble(problem, learned, validator, plan)
    }

    /// The same solver trying `plan` instead of the problem's ([`InstanceProblem::plan`]): for
    /// example more restarts, no fallback, or other tracker options. An error when the plan
    /// asks for more starts, simulators or restarts than a solve has room for.
    pub fn with_plan(self, plan: Plan<D, NX, NF, NP>) -> Result<Self, SolverError> {
        let Self { problem, learned, validator, certification, fallback, .. } = self;
        Ok(Self { certification, fallback, ..Self::assemble(problem, learned, validator, plan)? })
    }

    /// The one place a solver is put together: the plan checked and its schedule made.
    fn assemble(problem: Arc<S>, learned: S::Learned, validator: S::Validator, plan: Plan<D, NX, NF, NP>) -> Result<Self, SolverError> {
        let counts = [
            ("learned hypotheses", learned.hypotheses(), MAX_HYPOTHESES),
            ("other starts", plan.other_starts.len(), MAX_OTHERS),
            ("other simulators", plan.other_simulators.len(), MAX_OTHERS),
            ("restarts", plan.restarts, MAX_RESTARTS),
        ];
        for (what, count, most) in counts {
            if count > most {
                return Err(SolverError::TooMany { problem: problem.name(), what, count, most });
            }
        }
        let mut schedule = solver_schedule(
            shipped_schedule(plan.refine),
            learned.hypotheses(),
            plan.other_starts.len(),
            plan.other_simulators.len(),
            plan.restarts,
        );
        if plan.other_starts_first {
            other_starts_first(&mut schedule, plan.restarts);
        }
        Ok(Self { problem, learned, validator, plan, schedule, certification: Certification::Off, fallback: None })
    }

    /// What a solve tries.
    pub fn plan(&self) -> &Plan<D, NX, NF, NP> {
        &self.plan
    }

    /// Whether a solve ends with an all-roots fallback: the plan asks for it ([`Plan::fallback`])
    /// and there is one, given ([`InstanceSolver::with_fallback`]) or the problem's own with its
    /// start system.
    pub fn has_fallback(&self) -> bool {
        self.plan.fallback && (self.fallback.is_some() || self.problem.has_fallback())
    }

    /// The same solver with `fallback` as its all-roots fallback instead of the problem's own:
    /// for example a start system read at run time, after `monodromy` wrote it, without a
    /// rebuild (`AllRootsFallback::new(Grp6::square_subsystem(Some(&json), None)?)`).
    pub fn with_fallback(mut self, fallback: impl Fallback<D, NX, NP> + Send + Sync + 'static) -> Self {
        self.fallback = Some(Box::new(fallback));
        self
    }

    /// The same solver, certifying its solutions as `certification` says ([`Certification`]).
    pub fn certifying(mut self, certification: Certification) -> Self {
        self.certification = certification;
        self
    }

    /// The interval Krawczyk certificate of `x` on the tracked system of `data` (the user's
    /// data and frame, as a solution is returned): the tracked parameters of the data, and of an
    /// overdetermined tracked system the `NX` best-conditioned equations at `x`
    /// ([`crate::certify::choose_rows`]). Allocation-free; a few Jacobian evaluations over
    /// intervals and an `NX x NX` interval product (the bench prints its time).
    pub fn certify(&self, data: &D, x: &SVector<f64, NX>) -> Result<Certificate<NX>, CertifyError> {
        // The data was checked by the solve that produced `x`; data that cannot give tracked
        // parameters has no system to certify against.
        let p = self.problem.tracked_params(data).map_err(|_| CertifyError::NonFinite)?;
        let rows = choose_rows::<S::Tracked, NX, NF, NP>(x, &p)?;
        certify_rows::<S::Tracked, NX, NF, NP>(x, &p, &rows)
    }

    /// The problem.
    pub fn problem(&self) -> &S {
        &self.problem
    }

    /// The validator of solutions (for the noise given at construction).
    pub fn validator(&self) -> &S::Validator {
        &self.validator
    }

    /// The learned start.
    pub fn learned_start(&self) -> &S::Learned {
        &self.learned
    }

    /// The attempts of [`InstanceSolver::solve`]: [`shipped_schedule`] over the learned start's
    /// ranked hypotheses, the problem's other starts and simulators and its restarts, every
    /// start's Gauss-Newton before the first path ([`solver_schedule`]).
    pub fn schedule(&self) -> &[SolverAttempt] {
        &self.schedule
    }

    /// Solves the data (all rows, the data layout's order for a row-wise problem): a validated
    /// solution or a typed error; a wrong answer is never returned as `Ok`.
    pub fn solve(&self, data: &D) -> InstanceOutcome<S::Validator, NX, D> {
        match self.run_pipeline(data, &self.schedule, true, None) {
            Ok(s) => {
                let certified = (self.certification != Certification::Off).then(|| self.certify(data, &s.x));
                match certified {
                    Some(Err(reason)) if self.certification == Certification::Require => {
                        Err(SolveError::NotCertified { best: s.x, check: s.check, attempts: s.attempts, reason })
                    }
                    _ => Ok(Solution { x: s.x, origin: s.origin, attempts: s.attempts, check: s.check, certified }),
                }
            }
            Err(PipelineError::Input(e)) => Err(SolveError::Input(e)),
            Err(PipelineError::NotValidated(s)) => Err(SolveError::NotValidated { best: s.x, check: s.check, attempts: s.attempts }),
            Err(PipelineError::NoEndPoint { attempts, last }) => Err(SolveError::NoEndPoint { attempts, last }),
        }
    }

    /// The pipeline's own result of a solve with these attempts, with or without the all-roots
    /// fallback: what the bench tallies. `given` is the start of [`StartId::Given`] (the bench's
    /// random start, a caller's guess), handed the data in the problem's canonical frame; an
    /// attempt from a start this solve does not have (no `given`, a rank beyond the learned
    /// start's hypotheses, an other start or restart beyond the problem's) is no attempt.
    pub fn run_pipeline(
        &self,
        data: &D,
        schedule: &[SolverAttempt],
        fallback: bool,
        given: Option<&dyn StartProvider<D, NX>>,
    ) -> InstancePipelineOutcome<S::Validator, NX, D> {
        let result = self.with_pipeline(data, schedule, fallback, given, |pipeline, canon, positions| {
            let name = |origin| positions.named(origin);
            pipeline.solve_canonical(canon, data).map(|s| s.with_origin(name)).map_err(|e| e.with_origin(name))
        });
        result.map_err(PipelineError::Input)?
    }

    /// Up to `max` distinct end points (`same` tells duplicates) that the validator accepts or
    /// finds plausible on all the data, from the attempts of `schedule` in order, without the
    /// fallback: the models of a RANSAC sample ([`super::estimate`]). With a minimal sample
    /// every real root fits it exactly, so several may validate; the consensus picks.
    pub fn plausible_end_points(
        &self,
        data: &D,
        schedule: &[SolverAttempt],
        max: usize,
        same: impl Fn(&SVector<f64, NX>, &SVector<f64, NX>) -> bool,
    ) -> Result<Vec<PlausibleEndPoint<S::Validator, NX, D>>, FirstRowsError> {
        self.with_pipeline(data, schedule, false, None, |pipeline, canon, positions| {
            let found = pipeline.plausible_end_points_canonical(canon, data, max, same)?;
            Ok(found.into_iter().map(|s| s.with_origin(|origin| positions.named(origin))).collect())
        })?
    }

    /// The pipeline of a solve of `data` ([`InstanceSolver::run_pipeline`]), the problem's
    /// canonical frame and where the solve's starts sit among the pipeline's providers (to name
    /// the origins it returns), handed to `run`; an input error when the data is not an
    /// instance. The only place that turns the starts' names into positions.
    fn with_pipeline<R>(
        &self,
        data: &D,
        schedule: &[SolverAttempt],
        fallback: bool,
        given: Option<&dyn StartProvider<D, NX>>,
        run: impl FnOnce(
            &Pipeline<
                '_,
                S::Tracked,
                D,
                Parts<'_, S, NX, NF, NC>,
                OwnSimulator<'_, S, NC>,
                S::Validator,
                NX,
                NF,
                NP,
                NC,
                PositionedSchedule<'_>,
            >,
            &OwnCanon<'_, S, NF, NP, NC>,
            StartPositions,
        ) -> R,
    ) -> Result<R, FirstRowsError> {
        // The user's data is checked before a canonical frame mixes its rows, so that an error
        // names the row and field the user wrote.
        self.problem.check_data(data)?;
        let problem = &*self.problem;
        let target = Parts::<S, NX, NF, NC>(problem);
        let simulator = OwnSimulator::<S, NC>(problem);
        let set = RankedStarts::new(&self.learned);
        let count = set.count::<D>();
        let ranked: [RankedStart<'_, '_, S::Learned, NX>; MAX_HYPOTHESES] = std::array::from_fn(|rank| RankedStart { set: &set, rank });
        let refined: [RefinedStart<'_, '_, S, S::Learned, NX, NF, NP, NC>; MAX_HYPOTHESES] =
            std::array::from_fn(|rank| RefinedStart { set: &set, rank, problem });
        let none = NoStart;
        let restarts: [RestartStart<'_, '_, S, S::Learned, NX, NF, NP, NC>; MAX_RESTARTS] =
            std::array::from_fn(|k| RestartStart { set: &set, problem, k });
        // `with_learned` checked the counts against the arrays' sizes.
        let positions = StartPositions {
            hypotheses: count.min(MAX_HYPOTHESES),
            given: given.is_some(),
            others: self.plan.other_starts.len(),
            restarts: self.plan.restarts.min(MAX_RESTARTS),
        };
        const PROVIDERS: usize = 2 * MAX_HYPOTHESES + 1 + MAX_OTHERS + MAX_RESTARTS + 1;
        let mut starts: [&dyn StartProvider<D, NX>; PROVIDERS] = [&none; PROVIDERS];
        for rank in 0..positions.hypotheses {
            starts[positions.position(StartId::Learned { rank, refined: false })] = &ranked[rank];
            starts[positions.position(StartId::Learned { rank, refined: true })] = &refined[rank];
        }
        if let Some(given) = given {
            starts[positions.position(StartId::Given)] = given;
        }
        for (j, other) in self.plan.other_starts.iter().enumerate() {
            starts[positions.position(StartId::Other(j))] = &**other;
        }
        for (k, restart) in restarts.iter().enumerate().take(positions.restarts) {
            starts[positions.position(StartId::Restart(k))] = restart;
        }
        // The empty provider last: where every start this solve does not have sits.
        let starts = &starts[..=positions.none()];
        let schedule = PositionedSchedule { attempts: schedule, positions };
        let mut others: [&dyn StartSimulator<D, NX, NF, NP>; MAX_OTHERS] = [&simulator; MAX_OTHERS];
        for (slot, other) in others.iter_mut().zip(&self.plan.other_simulators) {
            *slot = &**other;
        }
        let others = &others[..self.plan.other_simulators.len()];
        let all_roots = OwnFallback::<S, NF, NC>(problem);
        let fallback = fallback && self.plan.fallback;
        let mut pipeline = Pipeline::<S::Tracked, _, _, _, _, NX, NF, NP, NC>::new(&target, starts, &simulator, &self.validator)
            .with_schedule_of(&schedule)
            .with_other_simulators(others)
            .with_options(PipelineOptions { fallback, ..self.plan.options });
        if let (true, Some(given)) = (fallback, &self.fallback) {
            pipeline = pipeline.with_fallback(&**given);
        } else if fallback && problem.has_fallback() {
            pipeline = pipeline.with_fallback(&all_roots);
        }
        Ok(run(&pipeline, &OwnCanon::<S, NF, NP, NC>(problem), positions))
    }

    /// [`InstanceSolver::solve`] on every element of `data`, in order, across rayon's threads.
    pub fn solve_batch<T>(&self, data: &[T]) -> Vec<InstanceOutcome<S::Validator, NX, D>>
    where
        T: Borrow<D> + Sync,
        Self: Sync,
        CheckOf<S::Validator, NX, D>: Send,
    {
        data.par_iter().map(|p| self.solve(p.borrow())).collect()
    }
}

/// Where each start of one solve sits in the list of providers the solver gives the pipeline:
/// the learned hypotheses in rank order, each predicted then refined; the caller's given start,
/// when there is one; the problem's other starts; the restarts; last, one empty provider
/// ([`NoStart`]), where every start that this solve does not have sits, so that an attempt from
/// it is no attempt. Private to the solver: schedules name their starts ([`StartId`]), and the
/// origins of what a solve returns are named back ([`StartPositions::named`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct StartPositions {
    /// The learned start's hypotheses.
    hypotheses: usize,
    /// Whether the caller gave a start.
    given: bool,
    /// The problem's other starts.
    others: usize,
    /// The problem's restarts.
    restarts: usize,
}

impl StartPositions {
    fn first_other(&self) -> usize {
        2 * self.hypotheses + usize::from(self.given)
    }

    fn first_restart(&self) -> usize {
        self.first_other() + self.others
    }

    /// The empty provider's position, after every start's.
    fn none(&self) -> usize {
        self.first_restart() + self.restarts
    }

    /// The position of `start`; the empty provider's for a start this solve does not have.
    fn position(&self, start: StartId) -> usize {
        match start {
            StartId::Learned { rank, refined } if rank < self.hypotheses => 2 * rank + usize::from(refined),
            StartId::Given if self.given => 2 * self.hypotheses,
            StartId::Other(j) if j < self.others => self.first_other() + j,
            StartId::Restart(k) if k < self.restarts => self.first_restart() + k,
            _ => self.none(),
        }
    }

    /// The start at `position`, `None` at the empty provider's and past it.
    fn start_at(&self, position: usize) -> Option<StartId> {
        let learned = 2 * self.hypotheses;
        if position < learned {
            return Some(StartId::Learned { rank: position / 2, refined: position % 2 == 1 });
        }
        if self.given && position == learned {
            return Some(StartId::Given);
        }
        if (self.first_other()..self.first_restart()).contains(&position) {
            return Some(StartId::Other(position - self.first_other()));
        }
        (self.first_restart()..self.none()).contains(&position).then(|| StartId::Restart(position - self.first_restart()))
    }

    /// The pipeline's origin of an end point, named.
    fn named(&self, origin: Origin) -> SolverOrigin {
        match origin {
            Origin::Path { provider, method } => match self.start_at(provider) {
                Some(start) => SolverOrigin::Attempt(SolverAttempt { start, method }),
                // The empty provider gives no start, so no end point comes from its position;
                // an origin past every start is not this solve's and is told as a start the
                // solve does not have.
                None => SolverOrigin::Attempt(SolverAttempt { start: StartId::Other(usize::MAX), method }),
            },
            Origin::Fallback { candidate } => SolverOrigin::Fallback { candidate },
        }
    }
}

/// A solver's schedule as the pipeline reads it: each attempt's start at its position.
struct PositionedSchedule<'s> {
    attempts: &'s [SolverAttempt],
    positions: StartPositions,
}

impl Schedule for PositionedSchedule<'_> {
    fn attempt(&self, i: usize) -> Option<Attempt> {
        let a = self.attempts.get(i)?;
        Some(Attempt { provider: self.positions.position(a.start), method: a.method })
    }
}

/// The empty provider: where a start sits that a solve does not have.
struct NoStart;

impl<D: ?Sized, const NX: usize> StartProvider<D, NX> for NoStart {
    fn name(&self) -> &'static str {
        "none"
    }
    fn start(&self, _: &D) -> Result<SVector<f64, NX>, StartError> {
        Err(StartError { provider: "none", reason: "no such start in this solve".into() })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::Method;

    fn every_start(p: &StartPositions) -> Vec<StartId> {
        let mut all: Vec<StartId> =
            (0..p.hypotheses).flat_map(|rank| [false, true].map(|refined| StartId::Learned { rank, refined })).collect();
        all.extend(p.given.then_some(StartId::Given));
        all.extend((0..p.others).map(StartId::Other));
        all.extend((0..p.restarts).map(StartId::Restart));
        all
    }

    #[test]
    fn every_start_has_its_own_position_and_is_named_back() {
        for (hypotheses, given, others, restarts) in
            [(1, false, 0, 0), (1, true, 3, 65), (4, false, 2, 5), (MAX_HYPOTHESES, true, MAX_OTHERS, MAX_RESTARTS)]
        {
            let p = StartPositions { hypotheses, given, others, restarts };
            let all = every_start(&p);
            let positions: Vec<usize> = all.iter().map(|&s| p.position(s)).collect();
            assert_eq!(positions, (0..all.len()).collect::<Vec<_>>(), "{p:?}: the starts fill the list in order");
            assert_eq!(p.none(), all.len(), "{p:?}: the empty provider comes last");
            for &start in &all {
                let origin = Origin::Path { provider: p.position(start), method: Method::GaussNewton };
                assert_eq!(p.named(origin), SolverOrigin::Attempt(SolverAttempt { start, method: Method::GaussNewton }));
            }
            assert_eq!(p.start_at(p.none()), None);
            assert_eq!(p.named(Origin::Fallback { candidate: 3 }), SolverOrigin::Fallback { candidate: 3 });
        }
    }

    #[test]
    fn a_start_the_solve_does_not_have_sits_at_the_empty_provider() {
        let p = StartPositions { hypotheses: 2, given: false, others: 1, restarts: 3 };
        let missing = [
            StartId::Learned { rank: 2, refined: false },
            StartId::Learned { rank: 7, refined: true },
            StartId::Given,
            StartId::Other(1),
            StartId::Restart(3),
        ];
        for start in missing {
            assert_eq!(p.position(start), p.none(), "{start}");
        }
        let schedule = [
            SolverAttempt { start: StartId::Given, method: Method::Start },
            SolverAttempt { start: StartId::Other(0), method: Method::Start },
        ];
        let read = PositionedSchedule { attempts: &schedule, positions: p };
        assert_eq!(read.attempt(0), Some(Attempt { provider: p.none(), method: Method::Start }));
        assert_eq!(read.attempt(1), Some(Attempt { provider: 4, method: Method::Start }));
        assert_eq!(read.attempt(2), None);
        let no_start: Result<SVector<f64, 2>, StartError> = StartProvider::<(), 2>::start(&NoStart, &());
        assert!(no_start.is_err());
    }
}
