//! One robust estimator for every problem and data type, in the shape PoseLib users know:
//! [`InstanceSolver::estimate`]`(correspondences, &options) -> (model, info)`.
//!
//! A problem says what its correspondences are ([`Correspondences`]): how many a sample takes,
//! the data instance of some of them, the model of a solution (the unknowns, or a pose with a
//! translation solved from the sample), one correspondence's error under a model and the local
//! optimization on the inliers. A row-wise problem has all of it from its declaration
//! ([`super::estimate_rows`]: rows and globals in, the unknowns out); UPnP implements it for its
//! correspondences (`simhc_problems::upnp::estimate`). The rest is the same for all:
//!
//! - **Samples**: each gets the first attempt of the shipped schedule only
//!   ([`super::sample_schedule`]: Gauss-Newton from the learned start) and no fallback: a
//!   sample that does not validate at once yields no model. A problem may ask for more
//!   ([`Correspondences::sample_attempts`] of the solver's schedule) and for up to
//!   [`Correspondences::sample_candidates`] distinct validated end points per sample, each
//!   scored as a model: a minimal sample's real roots all fit it, and the consensus picks.
//! - **Scoring**: MSAC on the problem's per-correspondence error
//!   ([`Correspondences::model_error`]).
//! - **Local optimization** (LO-RANSAC) every time a better model appears, and on the final
//!   model ([`Correspondences::refine_model`]); kept when it lowers the MSAC cost.
//! - **Stopping**: the exact rule of [`crate::ransac`] (a sample drawn without replacement),
//!   between [`RansacOptions::min_iterations`] and [`RansacOptions::max_iterations`];
//!   [`RansacOptions::poselib`] gives PoseLib's defaults.
//! - **One sample's worth** of correspondences is solved once, as [`InstanceSolver::solve`]
//!   does, and scored like a model; every model is certified on the inliers it fits best.

use super::instance::InstanceProblem;
use super::library::InstanceSolver;
use super::parts::FirstRowsError;
use super::problem::DegenerateInput;
use super::schedule::{sample_schedule, SolverAttempt};
use crate::pipeline::learned::NonFiniteParameter;
use crate::pipeline::Method;
use crate::ransac::{ransac, Estimator, RansacOptions, RansacResult};
use nalgebra::SVector;
use std::borrow::Cow;
use thiserror::Error;

/// What a robust estimate did.
#[derive(Debug, Clone, PartialEq)]
pub struct EstimateInfo {
    /// Samples drawn.
    pub iterations: usize,
    /// Models scored (validated sample solutions and refinements).
    pub hypotheses: usize,
    /// Inliers of the returned model, increasing.
    pub inliers: Vec<usize>,
    /// Whether each row is an inlier.
    pub inlier_mask: Vec<bool>,
    /// Inliers over rows.
    pub inlier_ratio: f64,
    /// MSAC cost of the returned model, `sum_i min(e_i², threshold²)` (lower is better).
    pub score: f64,
    /// Refinements kept (local optimizations and the final rounds).
    pub refinements: usize,
    /// The certificate of the returned model (`simhc::certify`): the proved bound on its
    /// distance to an exact root of the tracked system made of the inliers it fits best (for
    /// noisy data that root is the exact solution of those correspondences, not the truth), or
    /// why there is none; `None` where the estimator does not certify (fewer inliers than a
    /// data instance has rows, or an estimator without a certificate).
    pub certified: Option<Result<f64, crate::certify::CertifyError>>,
}

impl EstimateInfo {
    /// A RANSAC result as its model and this info (every estimator reports the same fields).
    pub fn split<M>(r: RansacResult<M>) -> (M, EstimateInfo) {
        let info = EstimateInfo {
            iterations: r.iterations,
            hypotheses: r.hypotheses,
            inlier_ratio: r.inlier_ratio(),
            inliers: r.inliers,
            inlier_mask: r.inlier_mask,
            score: r.score,
            refinements: r.refinements,
            certified: None,
        };
        (r.model, info)
    }
}

/// Why there is no robust estimate.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum EstimateError {
    /// `rows` is not a whole number of rows.
    #[error("{len} numbers are not whole rows of {per_row}")]
    Length {
        /// Numbers given.
        len: usize,
        /// Numbers per row.
        per_row: usize,
    },
    /// The globals have the wrong length.
    #[error("{got} global numbers, the problem has {expected}")]
    Globals {
        /// Numbers given.
        got: usize,
        /// Numbers expected.
        expected: usize,
    },
    /// Fewer rows than one sample.
    #[error("too few correspondences: got {rows}, need at least {needed} (one sample)")]
    TooFew {
        /// Rows given.
        rows: usize,
        /// Rows in a sample.
        needed: usize,
    },
    /// A NaN or infinite number, and where.
    #[error("{0}")]
    NonFinite(NonFiniteParameter),
    /// The correspondences are degenerate as a whole or one of them is (a zero bearing, all
    /// rays from one origin): where and why.
    #[error("{0}")]
    Degenerate(DegenerateInput),
    /// No sample gave a validated model.
    #[error("no sample of {iterations} gave a validated model")]
    NoModel {
        /// Samples drawn.
        iterations: usize,
    },
    /// [`super::Solver::solve_rows`]: the data instance's rows (the first) gave no validated solution;
    /// why.
    #[error("the first {rows} correspondences (the data instance) gave no validated solution: {reason}")]
    FirstRowsNotSolved {
        /// Rows of the data instance.
        rows: usize,
        /// The solve's error.
        reason: String,
    },
    /// [`super::Solver::solve_rows`]: neither the first rows' solution nor its refinement on all rows
    /// validates on every run of rows; the first run the better of them does not explain.
    #[error("the solution of the first {instance} correspondences, refined on all {rows}, does not validate on correspondences {first}..={last} (check {check})")]
    NotValidatedOnAll {
        /// Rows given.
        rows: usize,
        /// Rows of the data instance.
        instance: usize,
        /// First row of the run that does not validate.
        first: usize,
        /// Last row of that run.
        last: usize,
        /// The validator's check of that run (its `Debug`).
        check: String,
    },
    /// Exactly one sample's worth of rows: the one solve of them ([`InstanceSolver::solve`], fallback
    /// included) gave no validated solution; why.
    #[error("{rows} correspondences make one sample, and its solve gave no validated solution: {reason}")]
    NotSolved {
        /// Rows given (the sample size).
        rows: usize,
        /// The solve's error.
        reason: String,
    },
}

impl From<FirstRowsError> for EstimateError {
    fn from(e: FirstRowsError) -> Self {
        match e {
            FirstRowsError::NonFinite(at) => EstimateError::NonFinite(at),
            FirstRowsError::Degenerate(d) => EstimateError::Degenerate(d),
            FirstRowsError::TooFew { got, need } => EstimateError::TooFew { rows: got, needed: need },
            // A problem whose tracked instance is not the first rows of its data: no input
            // makes a solve of it, so it is the data the estimator cannot use.
            FirstRowsError::Sizes { .. } => EstimateError::Degenerate(DegenerateInput {
                row: None,
                reason: "the problem's tracked instance is not the first rows of its data instance",
            }),
        }
    }
}

/// A problem's data as the robust estimator's correspondences ([module docs](self)): what only
/// the problem knows about sampling, scoring and refitting it. Every row-wise problem has it
/// ([`super::estimate_rows`]); a problem of another data type implements it beside
/// [`InstanceProblem`]. The items are named apart from [`super::DeclaredProblem`]'s.
pub trait Correspondences<const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized>:
    InstanceProblem<NX, NF, NP, NC, D>
{
    /// All the correspondences of an estimate (a row-wise problem: its rows and globals).
    type Input<'a>: Copy;
    /// What an estimate returns: the unknowns, or a model made of them and the sample (a pose
    /// with the translation solved from the correspondences).
    type Model: Clone;

    /// How many correspondences `input` holds, after the checks every estimate makes: an error
    /// names the correspondence and field of a number that is not finite, too few, degenerate.
    fn checked_count(&self, input: Self::Input<'_>) -> Result<usize, EstimateError>;
    /// Correspondences in a sample.
    fn sample_size(&self) -> usize;
    /// Attempts a sample runs: the first this many of the solver's schedule short of the paths
    /// with the other simulators (the fallback never). Default `1`: Gauss-Newton from the
    /// learned start ([`super::sample_schedule`]).
    fn sample_attempts(&self) -> usize {
        1
    }
    /// Models a sample may give: at most this many distinct end points
    /// ([`Correspondences::same_end_point`]) that validate on the sample. Default `1`: the
    /// first. More helps a minimal sample, whose every real root fits it exactly.
    fn sample_candidates(&self) -> usize {
        1
    }
    /// Whether two end points of one sample are the same solution. Default: every unknown within
    /// `1e-6` relative.
    fn same_end_point(&self, a: &SVector<f64, NX>, b: &SVector<f64, NX>) -> bool {
        (a - b).amax() <= 1e-6 * (1.0 + a.amax())
    }
    /// `run` on the data instance of the correspondences `indices` of `input`, best first (a
    /// problem whose instance has a fixed count takes the first that many): a sample, the one
    /// sample of an estimate, or the inliers a model is certified on.
    fn with_instance<R>(&self, input: Self::Input<'_>, indices: &[usize], run: impl FnOnce(&D) -> R) -> R;
    /// The model of the unknowns `x`, solved on `instance`; `None` when they make none.
    fn model(&self, x: &SVector<f64, NX>, instance: &D) -> Option<Self::Model>;
    /// The unknowns of a model (what is certified).
    fn model_unknowns(&self, model: &Self::Model) -> SVector<f64, NX>;
    /// The error of correspondence `i` of `input` under `model`, in the units of
    /// [`RansacOptions::threshold`] (NaN counts as infinite).
    fn model_error(&self, input: Self::Input<'_>, model: &Self::Model, i: usize) -> f64;
    /// `model` fitted to the correspondences `inliers` of `input` (`threshold`: the inlier
    /// threshold, a robust loss's scale); `None` when the fit fails.
    fn refine_model(&self, input: Self::Input<'_>, model: &Self::Model, inliers: &[usize], threshold: f64) -> Option<Self::Model>;
}

/// The RANSAC view of a solver: correspondences (their indices) in, validated sample models out.
pub(super) struct Samples<'s, 'i, S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized>
where
    S: Correspondences<NX, NF, NP, NC, D>,
{
    solver: &'s InstanceSolver<S, NX, NF, NP, NC, D>,
    input: S::Input<'i>,
    threshold: f64,
    /// The attempts on a sample ([`sample_attempts_of`]), made once per estimate.
    attempts: Cow<'static, [SolverAttempt]>,
}

/// The attempts a sample of `problem` runs on `solver`: the shipped schedule's first
/// ([`sample_schedule`], no allocation) unless the problem asks for more.
fn sample_attempts_of<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized>(
    solver: &InstanceSolver<S, NX, NF, NP, NC, D>,
) -> Cow<'static, [SolverAttempt]>
where
    S: Correspondences<NX, NF, NP, NC, D>,
{
    let problem = solver.problem();
    if first_end_point_only(problem) {
        Cow::Borrowed(sample_schedule(solver.plan().refine))
    } else {
        Cow::Owned(sample_attempts(solver.schedule(), problem.sample_attempts()))
    }
}

/// Whether a sample of `problem` runs one attempt and keeps its first validated end point: the
/// shipped schedule's first, through the allocation-free pipeline.
fn first_end_point_only<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized>(problem: &S) -> bool
where
    S: Correspondences<NX, NF, NP, NC, D>,
{
    problem.sample_candidates() <= 1 && problem.sample_attempts() <= 1
}

/// The attempts a RANSAC sample runs when the problem asks for more than the first
/// ([`Correspondences::sample_attempts`]): the first that many of the solver's `schedule`,
/// leaving out the paths with the problem's other simulators. Why not those paths: most samples
/// hold an outlier, no attempt validates them, and every attempt then runs; the other
/// simulators' paths doubled the paths of such a sample, and a clean sample that the own
/// simulator's paths miss is replaced by the next clean one. On GRPS at 40 % outliers (`simhc
/// bench grps --experiment ransac --ransac-trials 300 --seed 1`): 99.7 % in 115 ms a call
/// with the first 8 of these, against 99.7 % in 242 ms with the first 13 of the schedule
/// (BENCHMARKS.md, 2026-12-05).
fn sample_attempts(schedule: &[SolverAttempt], attempts: usize) -> Vec<SolverAttempt> {
    schedule.iter().filter(|a| !matches!(a.method, Method::OtherSimulatorHc(_))).take(attempts).copied().collect()
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized> Estimator for Samples<'_, '_, S, NX, NF, NP, NC, D>
where
    S: Correspondences<NX, NF, NP, NC, D>,
{
    /// A correspondence's index in the input: the data of [`ransac`] are `0..n`.
    type Datum = usize;
    type Model = S::Model;

    fn sample_size(&self) -> usize {
        self.solver.problem().sample_size()
    }

    fn solve(&self, data: &[usize], indices: &[usize], out: &mut Vec<S::Model>) {
        // The data are `0..n`, so a sample's indices are the correspondences' own.
        debug_assert!(indices.iter().all(|&i| data[i] == i));
        self.solver.solve_sample_with(self.input, indices, &self.attempts, out);
    }

    fn residual(&self, model: &S::Model, i: &usize) -> f64 {
        let e = self.solver.problem().model_error(self.input, model, *i);
        if e.is_nan() {
            f64::INFINITY
        } else {
            e
        }
    }

    fn refine(&self, model: &S::Model, _data: &[usize], inliers: &[usize]) -> Option<S::Model> {
        self.solver.problem().refine_model(self.input, model, inliers, self.threshold)
    }
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized> InstanceSolver<S, NX, NF, NP, NC, D>
where
    S: Correspondences<NX, NF, NP, NC, D>,
{
    /// A robust estimate from `input` (any number of correspondences with outliers: a row-wise
    /// problem's `(rows, globals)`, UPnP's correspondences) ([module docs](self)).
    /// `options.threshold` is in the units of [`Correspondences::model_error`].
    pub fn estimate(&self, input: S::Input<'_>, options: &RansacOptions) -> Result<(S::Model, EstimateInfo), EstimateError> {
        let problem = self.problem();
        let n = problem.checked_count(input)?;
        let needed = problem.sample_size();
        if n < needed {
            return Err(EstimateError::TooFew { rows: n, needed });
        }
        let samples = Samples { solver: self, input, threshold: options.threshold, attempts: sample_attempts_of(self) };
        let data: Vec<usize> = (0..n).collect();
        if n == needed {
            return self.estimate_one_sample(&samples, &data);
        }
        let r = ransac(&samples, &data, options).ok_or(EstimateError::NoModel { iterations: options.max_iterations })?;
        let (model, mut info) = EstimateInfo::split(r);
        info.certified = self.certify_model(&samples, &model, &info.inliers);
        Ok((model, info))
    }

    /// The models of one RANSAC sample, the correspondences `indices` of `input`, pushed onto
    /// `out`, as [`InstanceSolver::estimate`] solves a sample: its first attempts without the
    /// fallback ([`Correspondences::sample_attempts`]), at most
    /// [`Correspondences::sample_candidates`] end points that validate on the sample. Nothing
    /// when none does (a sample with an outlier, or one that missed its basin). No heap
    /// allocation for a problem of one attempt and one candidate whose instance is held inline
    /// (UPnP, every row-wise problem).
    pub fn solve_sample(&self, input: S::Input<'_>, indices: &[usize], out: &mut Vec<S::Model>) {
        self.solve_sample_with(input, indices, &sample_attempts_of(self), out);
    }

    fn solve_sample_with(&self, input: S::Input<'_>, indices: &[usize], attempts: &[SolverAttempt], out: &mut Vec<S::Model>) {
        let problem = self.problem();
        problem.with_instance(input, indices, |sample| {
            if first_end_point_only(problem) {
                if let Ok(s) = self.run_pipeline(sample, attempts, false, None) {
                    out.extend(problem.model(&s.x, sample));
                }
                return;
            }
            let max = problem.sample_candidates().max(1);
            if let Ok(found) = self.plausible_end_points(sample, attempts, max, |a, b| problem.same_end_point(a, b)) {
                out.extend(found.iter().filter_map(|s| problem.model(&s.x, sample)));
            }
        })
    }

    /// The certificate of a robust estimate: on the data instance of its inliers, those with
    /// the smallest errors first (a fixed-size instance takes those), so that the certified
    /// system is the one the model fits most closely.
    fn certify_model(
        &self,
        samples: &Samples<'_, '_, S, NX, NF, NP, NC, D>,
        model: &S::Model,
        inliers: &[usize],
    ) -> Option<Result<f64, crate::certify::CertifyError>> {
        let problem = self.problem();
        if inliers.len() < problem.sample_size() {
            return None;
        }
        let mut best: Vec<(f64, usize)> = inliers.iter().map(|&i| (samples.residual(model, &i), i)).collect();
        best.sort_by(|a, b| a.0.total_cmp(&b.0));
        let order: Vec<usize> = best.iter().map(|&(_, i)| i).collect();
        let x = problem.model_unknowns(model);
        Some(problem.with_instance(samples.input, &order, |d| self.certify(d, &x).map(|c| c.error_bound())))
    }

    /// With exactly one sample's worth of correspondences every draw is the same sample:
    /// RANSAC would draw it up to `max_iterations` times and, as a sample gets only Gauss-Newton
    /// from the learned start, fail where a solve succeeds. So it is solved once, as
    /// [`InstanceSolver::solve`] does (every start, the fallback), and scored like a RANSAC
    /// model.
    fn estimate_one_sample(
        &self,
        samples: &Samples<'_, '_, S, NX, NF, NP, NC, D>,
        all: &[usize],
    ) -> Result<(S::Model, EstimateInfo), EstimateError> {
        let problem = self.problem();
        let not_solved = |reason: String| EstimateError::NotSolved { rows: all.len(), reason };
        let (model, certified) = problem.with_instance(samples.input, all, |d| {
            let x = self.solve(d).map_err(|e| not_solved(e.to_string()))?.x;
            let model = problem.model(&x, d).ok_or_else(|| not_solved("its solution makes no model".into()))?;
            Ok::<_, EstimateError>((model, self.certify(d, &x).map(|c| c.error_bound())))
        })?;
        let t2 = samples.threshold * samples.threshold;
        let errors: Vec<f64> = all.iter().map(|i| samples.residual(&model, i)).collect();
        let inlier_mask: Vec<bool> = errors.iter().map(|e| *e <= samples.threshold).collect();
        let inliers: Vec<usize> = (0..all.len()).filter(|&i| inlier_mask[i]).collect();
        let info = EstimateInfo {
            iterations: 1,
            hypotheses: 1,
            inlier_ratio: inliers.len() as f64 / all.len() as f64,
            inliers,
            inlier_mask,
            score: errors.iter().map(|e| (e * e).min(t2)).sum(),
            refinements: 0,
            certified: Some(certified),
        };
        Ok((model, info))
    }
}

#[cfg(test)]
mod tests {
    use super::super::schedule::{SolverAttempt, StartId};
    use super::sample_attempts;
    use crate::pipeline::Method;

    #[test]
    fn samples_leave_out_the_other_simulators_paths_and_keep_the_order() {
        let (refined, learned, other) =
            (StartId::Learned { rank: 0, refined: true }, StartId::Learned { rank: 0, refined: false }, StartId::Other(0));
        let at = |start, method| SolverAttempt { start, method };
        let schedule = [
            at(refined, Method::Start),
            at(refined, Method::GaussNewton),
            at(other, Method::GaussNewton),
            at(learned, Method::SimulatorHc),
            at(learned, Method::OtherSimulatorHc(0)),
            at(other, Method::SimulatorHc),
            at(other, Method::OtherSimulatorHc(0)),
            at(StartId::Other(1), Method::SimulatorHc),
        ];
        let expected = [
            at(refined, Method::Start),
            at(refined, Method::GaussNewton),
            at(other, Method::GaussNewton),
            at(learned, Method::SimulatorHc),
            at(other, Method::SimulatorHc),
        ];
        assert_eq!(sample_attempts(&schedule, 5), expected);
        assert_eq!(sample_attempts(&schedule, 2), expected[..2]);
        // Fewer attempts than asked: all of them, still without the other simulators.
        assert_eq!(sample_attempts(&schedule, 100).len(), 6);
    }
}
