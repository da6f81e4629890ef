//! A robust estimator for every declared problem, in the shape PoseLib users know:
//! [`Solver::estimate`]`(rows, globals, &options) -> (x, info)`.
//!
//! - **Samples** are as many rows as the problem's data instance has (the tracked rows and the
//!   rows that validate them, e.g. 6 + 1). Each gets the first attempt of the shipped schedule
//!   only ([`super::sample_schedule`]: Gauss-Newton from the learned start) and no
//!   fallback: a sample that does not validate at once yields no model. A problem may ask for
//!   more ([`DeclaredProblem::SAMPLE_ATTEMPTS`] of the solver's schedule) and for up to
//!   [`DeclaredProblem::SAMPLE_CANDIDATES`] distinct validated end points per sample, each
//!   scored as a model: a minimal sample's real roots all fit it, and the consensus picks.
//! - **Scoring**: MSAC on the problem's per-correspondence error
//!   ([`DeclaredProblem::row_error`]; by default the largest absolute row residual,
//!   [`super::row_residual`]).
//! - **Local optimization** (LO-RANSAC) every time a better model appears, and on the final
//!   model: Gauss-Newton with a Cauchy loss on the problem's errors of all inliers, whatever
//!   their count (each error's gradient by forward differences), the equations without
//!   parameters held as stiff constraints and restored after each step
//!   ([`crate::onto_parameter_free`]); kept when it lowers the MSAC cost.
//! - **Stopping**: the exact rule of [`crate::ransac`] (a sample drawn without replacement),
//!   between [`RansacOptions::min_iterations`] and [`RansacOptions::max_iterations`];
//!   [`RansacOptions::poselib`] gives PoseLib's defaults.
//!
//! The row residual and its Jacobian come from the tracked instance's compiled one-row kernel
//! ([`crate::ParamLanes::row_equations`]: one row's parameters in, one row's equations out);
//! an instance without one (its global equations have parameters) evaluates the whole system
//! with the row written into every row slot (its first row's equations are the row's).

use super::library::Solver;
use super::problem::DeclaredProblem;
use super::residual::row_equations;
use super::schedule::{sample_schedule, SolverAttempt};
use crate::pipeline::learned::NonFiniteParameter;
use crate::pipeline::Method;
use crate::ransac::{ransac, Estimator, RansacOptions, RansacResult};
use crate::{Problem, ProblemLayout};
use nalgebra::{SMatrix, SVector};
use std::marker::PhantomData;
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
    /// No sample gave a validated model.
    #[error("no sample of {iterations} gave a validated model")]
    NoModel {
        /// Samples drawn.
        iterations: usize,
    },
    /// [`Solver::solve_rows`]: the data instance's rows (the first) gave no validated solution;
    /// why.
    #[error("the first {rows} correspondences (the data instance) gave no validated solution: {reason}")]
    FirstRowsNotSolved {
        /// Rows of the data instance.
        rows: usize,
        /// The solve's error.
        reason: String,
    },
    /// [`Solver::solve_rows`]: neither the first rows' solution nor its refinement on all rows
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
    /// Exactly one sample's worth of rows: the one solve of them ([`Solver::solve`], fallback
    /// included) gave no validated solution; why.
    #[error("{rows} correspondences make one sample, and its solve gave no validated solution: {reason}")]
    NotSolved {
        /// Rows given (the sample size).
        rows: usize,
        /// The solve's error.
        reason: String,
    },
}

/// Gauss-Newton iterations of the local optimization.
const LO_ITERATIONS: usize = 10;

/// Relative step, and relative fall of the robust cost, below which the local optimization
/// stops (PoseLib's step tolerance).
const LO_TOLERANCE: f64 = 1e-8;

/// Relative step of the forward differences of the local optimization's error gradients.
const DIFFERENCE_STEP: f64 = 1e-7;

/// Halvings of a local optimization step that does not lower the robust cost, before giving up.
const HALVINGS: i32 = 4;

/// Weight of the equations without parameters in the local optimization's normal equations,
/// relative to the largest curvature of the rows'.
const CONSTRAINT_WEIGHT: f64 = 1e6;

/// The residuals and Jacobian rows of the equations without parameters at `x` (they do not
/// depend on the parameters: zeros).
fn constraint_rows<Q, const NX: usize, const NF: usize, const NP: usize>(
    x: &SVector<f64, NX>,
    f: &mut SVector<f64, NF>,
    j: &mut SMatrix<f64, NF, NX>,
) where
    Q: Problem<NX, NF, NP>,
{
    Q::residual_jacobian(x, &SVector::<f64, NP>::zeros(), f, j);
}

/// The RANSAC view of a solver: rows in, validated sample solutions out.
pub(super) struct Samples<'a, S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    solver: &'a Solver<S, NX, NF, NP, NC, ND>,
    globals: &'a [f64],
    threshold: f64,
    /// The attempts on a sample ([`sample_attempts`]), made once per estimate.
    attempts: Vec<SolverAttempt>,
    sizes: PhantomData<fn() -> [(); NC]>,
}

/// The attempts a RANSAC sample runs when the problem asks for more than the first
/// ([`DeclaredProblem::SAMPLE_ATTEMPTS`]): the first that many of the solver's `schedule`,
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

impl<'a, S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Estimator
    for Samples<'a, S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    type Datum = &'a [f64];
    type Model = SVector<f64, NX>;

    fn sample_size(&self) -> usize {
        S::Data::LAYOUT.rows
    }

    fn solve(&self, data: &[&'a [f64]], indices: &[usize], out: &mut Vec<SVector<f64, NX>>) {
        let p = self.instance(data, indices.iter().copied());
        if S::SAMPLE_CANDIDATES <= 1 && S::SAMPLE_ATTEMPTS <= 1 {
            if let Ok(s) = self.solver.run_pipeline(&p, sample_schedule(S::REFINES), false, None) {
                out.push(s.x);
            }
            return;
        }
        let problem = self.solver.problem();
        let max = S::SAMPLE_CANDIDATES.max(1);
        if let Ok(found) = self.solver.plausible_end_points(&p, &self.attempts, max, |a, b| problem.same_solution(a, b)) {
            out.extend(found.iter().map(|s| s.x));
        }
    }

    fn residual(&self, x: &SVector<f64, NX>, row: &&'a [f64]) -> f64 {
        self.row_error(x, row)
    }

    /// Gauss-Newton with a Cauchy loss on the inliers' errors ([`DeclaredProblem::row_error`],
    /// the unit of the threshold and of the Cauchy scale), then back onto the equations without
    /// parameters, each step halved until the robust cost falls.
    fn refine(&self, x0: &SVector<f64, NX>, data: &[&'a [f64]], inliers: &[usize]) -> Option<SVector<f64, NX>> {
        let c2 = self.threshold * self.threshold;
        let cost = |x: &SVector<f64, NX>| -> f64 {
            inliers
                .iter()
                .map(|&i| {
                    let e = self.row_error(x, data[i]);
                    (1.0 + e * e / c2).ln()
                })
                .sum()
        };
        let mut x = *x0;
        let mut current = cost(&x);
        let (mut f, mut j) = (SVector::<f64, NF>::zeros(), SMatrix::<f64, NF, NX>::zeros());
        for _ in 0..LO_ITERATIONS {
            let mut h = SMatrix::<f64, NX, NX>::zeros();
            let mut g = SVector::<f64, NX>::zeros();
            for &i in inliers {
                let Some((e, de)) = self.signed_error_gradient(&x, data[i]) else { continue };
                // Cauchy weight (iteratively reweighted least squares) on the signed error.
                let w = 1.0 / (1.0 + e * e / c2);
                h += w * de * de.transpose();
                g += w * e * de;
            }
            // The equations without parameters (unit quaternions, unit vectors) as stiff
            // constraints on the step: the problem's error does not change with the norm of a
            // quaternion, so that direction has no curvature, and a step along it would only be
            // undone by the projection below. (Added when the rows were the algebraic
            // equations, whose residual did fall along it and stalled the descent.)
            let scale = 1.0 + h.diagonal().amax();
            constraint_rows::<S::Tracked, NX, NF, NP>(&x, &mut f, &mut j);
            for &e in S::Tracked::LAYOUT.parameter_free {
                let row = j.row(e);
                h += CONSTRAINT_WEIGHT * scale * row.transpose() * row;
                g += CONSTRAINT_WEIGHT * scale * f[e] * row.transpose();
            }
            // A little damping: unit-norm unknowns leave directions with no curvature.
            let damping = 1e-9 * scale;
            h += SMatrix::<f64, NX, NX>::identity() * damping;
            let step = h.cholesky()?.solve(&g);
            // The reweighted step can overshoot the robust cost: halve it a few times first.
            let Some((moved, next)) = (0..HALVINGS).find_map(|k| {
                let moved = crate::onto_parameter_free::<S::Tracked, NX, NF, NP>(&(x - step * 0.5f64.powi(k)), 1e-12, 8).ok()?;
                let next = cost(&moved);
                (next < current).then_some((moved, next))
            }) else {
                break;
            };
            // Converged when the step or the cost's relative fall is below PoseLib's step
            // tolerance: later iterations of the reweighted steps move the estimate far below
            // the noise and only cost time (on `robust_grp.py`, 1.8x less time per call at
            // 0 % outliers, the same success and median errors; BENCHMARKS.md 2026-12-04).
            let small = (moved - x).amax() <= LO_TOLERANCE * (1.0 + x.amax()) || current - next <= LO_TOLERANCE * current;
            (x, current) = (moved, next);
            if small {
                break;
            }
        }
        x.iter().all(|v| v.is_finite()).then_some(x)
    }
}

impl<'a, S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Samples<'a, S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    /// The view of `solver` for the rows' `globals`, with the Cauchy scale `threshold` of
    /// [`Estimator::refine`] and no sample attempts (a caller that refines and scores only).
    pub(super) fn new(solver: &'a Solver<S, NX, NF, NP, NC, ND>, globals: &'a [f64], threshold: f64) -> Self {
        Self { solver, globals, threshold, attempts: Vec::new(), sizes: PhantomData }
    }

    /// The problem's error of `row` at `x` ([`DeclaredProblem::row_error`]), NaN counted as
    /// infinite: a row no model explains is an outlier, and a robust cost stays ordered.
    pub(super) fn row_error(&self, x: &SVector<f64, NX>, row: &[f64]) -> f64 {
        let e = self.solver.problem().row_error(x, row, self.globals);
        if e.is_nan() {
            f64::INFINITY
        } else {
            e
        }
    }

    /// The data instance of the rows `indices` (as many as the instance has) and the globals:
    /// a sample, or the inliers a model is certified on.
    pub(super) fn instance(&self, data: &[&[f64]], indices: impl Iterator<Item = usize>) -> SVector<f64, ND> {
        let layout = S::Data::LAYOUT;
        let mut p = SVector::<f64, ND>::zeros();
        for (k, i) in indices.take(layout.rows).enumerate() {
            p.as_mut_slice()[k * layout.per_row..(k + 1) * layout.per_row].copy_from_slice(data[i]);
        }
        p.as_mut_slice()[layout.rows * layout.per_row..].copy_from_slice(self.globals);
        p
    }

    /// The problem's error of `row` at `x` as a smooth residual through zero, and its gradient
    /// by forward differences: the error's own gradient, not that of the algebraic row
    /// equations scaled to it (a geometric error divides by a norm that moves with the
    /// unknowns, the baseline's length in a generalized epipolar error, and Gauss-Newton on
    /// the scaled equations with that scale frozen stops at a point biased along it, short of
    /// the error's minimum). `None` where it is not finite.
    ///
    /// The sign is that of the row's largest equation, from one call of the compiled one-row
    /// kernel ([`row_equations`]): at `x` its value, and at each difference step its first-order
    /// change along the Jacobian row, so the sign follows the equation through zero without
    /// evaluating it again (the second-order term at a step of [`DIFFERENCE_STEP`] matters only
    /// for an equation within about `1e-14` of zero, where the error itself is that small).
    fn signed_error_gradient(&self, x: &SVector<f64, NX>, row: &[f64]) -> Option<(f64, SVector<f64, NX>)> {
        let size = self.row_error(x, row);
        let (mut f, mut j) = (SVector::<f64, NF>::zeros(), SMatrix::<f64, NF, NX>::zeros());
        let epr = row_equations::<S::Tracked, NX, NF, NP, NC>(x, row, self.globals, &mut f, &mut j)?;
        let k = (0..epr).max_by(|a, b| f[*a].abs().total_cmp(&f[*b].abs()))?;
        if !size.is_finite() {
            return None;
        }
        let signed = |value: f64, error: f64| if value < 0.0 { -error } else { error };
        let e = signed(f[k], size);
        let mut grad = SVector::<f64, NX>::zeros();
        for m in 0..NX {
            let step = DIFFERENCE_STEP * (1.0 + x[m].abs());
            let mut moved = *x;
            moved[m] += step;
            let error = self.row_error(&moved, row);
            grad[m] = (signed(f[k] + j[(k, m)] * step, error) - e) / step;
        }
        grad.iter().all(|g| g.is_finite()).then_some((e, grad))
    }
}

/// `rows` (row after row, `layout.per_row` numbers each) as rows, after the checks every
/// solve of rows makes: whole rows, the globals' length, at least the data instance's rows, and
/// finite numbers (an error names the row and field of the first that is not).
pub(super) fn checked_rows<'r>(layout: &crate::layout::Layout, rows: &'r [f64], globals: &[f64]) -> Result<Vec<&'r [f64]>, EstimateError> {
    let per_row = layout.per_row;
    if per_row == 0 || rows.len() % per_row != 0 {
        return Err(EstimateError::Length { len: rows.len(), per_row });
    }
    if globals.len() != layout.globals_len() {
        return Err(EstimateError::Globals { got: globals.len(), expected: layout.globals_len() });
    }
    let n = rows.len() / per_row;
    if n < layout.rows {
        return Err(EstimateError::TooFew { rows: n, needed: layout.rows });
    }
    if let Some(index) = rows.iter().position(|v| !v.is_finite()) {
        let mut at = NonFiniteParameter::locate(layout, index % per_row);
        (at.row, at.index) = (Some(index / per_row), index);
        return Err(EstimateError::NonFinite(at));
    }
    if let Some(k) = globals.iter().position(|v| !v.is_finite()) {
        return Err(EstimateError::NonFinite(NonFiniteParameter::locate(layout, layout.rows * per_row + k)));
    }
    Ok(rows.chunks_exact(per_row).collect())
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Solver<S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    /// A robust estimate from `rows` (any number of correspondences, `per_row` numbers each in
    /// the data layout's order, row after row) and the global numbers `globals` ([module
    /// docs](self)). `options.threshold` is in the units of [`DeclaredProblem::row_error`].
    pub fn estimate(
        &self,
        rows: &[f64],
        globals: &[f64],
        options: &RansacOptions,
    ) -> Result<(SVector<f64, NX>, EstimateInfo), EstimateError> {
        let layout = S::Data::LAYOUT;
        let data = checked_rows(&layout, rows, globals)?;
        let n = data.len();
        let attempts = sample_attempts(self.schedule(), S::SAMPLE_ATTEMPTS);
        let samples =
            Samples::<S, NX, NF, NP, NC, ND> { solver: self, globals, threshold: options.threshold, attempts, sizes: PhantomData };
        if n == layout.rows {
            return self.estimate_one_sample(&samples, &data);
        }
        let r = ransac(&samples, &data, options).ok_or(EstimateError::NoModel { iterations: options.max_iterations })?;
        let (x, mut info) = EstimateInfo::split(r);
        info.certified = self.certify_model(&samples, &data, &x, &info.inliers);
        Ok((x, info))
    }

    /// The certificate of a robust estimate: on the data instance made of the inliers with the
    /// smallest errors (as many as the instance has rows), so that the certified system is the
    /// one the model fits most closely.
    fn certify_model(
        &self,
        samples: &Samples<'_, S, NX, NF, NP, NC, ND>,
        data: &[&[f64]],
        x: &SVector<f64, NX>,
        inliers: &[usize],
    ) -> Option<Result<f64, crate::certify::CertifyError>> {
        let layout = S::Data::LAYOUT;
        if inliers.len() < layout.rows {
            return None;
        }
        let mut best: Vec<(f64, usize)> = inliers.iter().map(|&i| (samples.residual(x, &data[i]), i)).collect();
        best.sort_by(|a, b| a.0.total_cmp(&b.0));
        let p = samples.instance(data, best.iter().map(|&(_, i)| i));
        Some(self.certify(&p, x).map(|c| c.error_bound()))
    }

    /// With exactly one sample's worth of rows every draw is the same sample: RANSAC would
    /// draw it up to `max_iterations` times and, as a sample gets only Gauss-Newton from the
    /// learned start, fail where a solve succeeds. So it is solved once, as [`Solver::solve`]
    /// does (every start, the fallback), and scored like a RANSAC model.
    fn estimate_one_sample(
        &self,
        samples: &Samples<'_, S, NX, NF, NP, NC, ND>,
        data: &[&[f64]],
    ) -> Result<(SVector<f64, NX>, EstimateInfo), EstimateError> {
        let p = samples.instance(data, 0..data.len());
        let x = self.solve(&p).map_err(|e| EstimateError::NotSolved { rows: data.len(), reason: e.to_string() })?.x;
        let t2 = samples.threshold * samples.threshold;
        let errors: Vec<f64> = data.iter().map(|row| samples.residual(&x, row)).collect();
        let inlier_mask: Vec<bool> = errors.iter().map(|e| *e <= samples.threshold).collect();
        let inliers: Vec<usize> = (0..data.len()).filter(|&i| inlier_mask[i]).collect();
        let info = EstimateInfo {
            iterations: 1,
            hypotheses: 1,
            inlier_ratio: inliers.len() as f64 / data.len() as f64,
            inliers,
            inlier_mask,
            score: errors.iter().map(|e| (e * e).min(t2)).sum(),
            refinements: 0,
            certified: Some(self.certify(&p, &x).map(|c| c.error_bound())),
        };
        Ok((x, info))
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
