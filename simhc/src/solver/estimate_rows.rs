//! A row-wise problem's rows as the robust estimator's correspondences: [`Correspondences`] for
//! every [`DeclaredProblem`], so that `solver.estimate((&rows, &globals), &options)` needs
//! nothing more of its declaration.
//!
//! - **Input**: the rows, row after row in the data layout's order, and the global numbers
//!   ([`RowsInput`]); a sample is as many rows as the data instance has (the tracked rows and
//!   the rows that validate them, e.g. 6 + 1).
//! - **Model**: the unknowns. **Error**: [`DeclaredProblem::row_error`] (by default the largest
//!   absolute row residual, [`super::row_residual`]).
//! - **Local optimization**: Gauss-Newton with a Cauchy loss on the problem's errors of all
//!   inliers, whatever their count (each error's gradient by forward differences), the
//!   equations without parameters held as stiff constraints and restored after each step
//!   ([`crate::onto_parameter_free`]).
//!
//! The row residual and its Jacobian come from the tracked instance's compiled one-row kernel
//! ([`crate::ParamLanes::row_equations`]: one row's parameters in, one row's equations out);
//! an instance without one (its global equations have parameters) evaluates the whole system
//! with the row written into every row slot (its first row's equations are the row's).

use super::estimate::{Correspondences, EstimateError};
use super::problem::DeclaredProblem;
use super::residual::row_equations;
use crate::layout::Layout;
use crate::pipeline::learned::NonFiniteParameter;
use crate::{Problem, ProblemLayout};
use nalgebra::{SMatrix, SVector};

/// A row-wise problem's correspondences: its rows (row after row, `per_row` numbers each in
/// the data layout's order) and its global numbers.
pub type RowsInput<'a> = (&'a [f64], &'a [f64]);

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

/// How many rows `rows` holds after the checks every solve of rows makes: whole rows, the
/// globals' length, at least the data instance's rows, and finite numbers (an error names the
/// row and field of the first that is not).
pub(super) fn checked_rows(layout: &Layout, rows: &[f64], globals: &[f64]) -> Result<usize, EstimateError> {
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
    Ok(n)
}

/// Row `i` of checked rows.
pub(super) fn row<'a>(layout: &Layout, (rows, _): RowsInput<'a>, i: usize) -> &'a [f64] {
    &rows[i * layout.per_row..(i + 1) * layout.per_row]
}

/// The data instance of the rows `indices` (the first as many as the instance has) and the
/// globals.
pub(super) fn data_instance<const ND: usize>(
    layout: &Layout,
    input: RowsInput<'_>,
    indices: impl Iterator<Item = usize>,
) -> SVector<f64, ND> {
    let mut p = SVector::<f64, ND>::zeros();
    let per_row = layout.per_row;
    for (k, i) in indices.take(layout.rows).enumerate() {
        p.as_mut_slice()[k * per_row..(k + 1) * per_row].copy_from_slice(row(layout, input, i));
    }
    p.as_mut_slice()[layout.rows * per_row..].copy_from_slice(input.1);
    p
}

/// The problem's error of `row` at `x` ([`DeclaredProblem::row_error`]), NaN counted as
/// infinite: a row no model explains is an outlier, and a robust cost stays ordered.
pub(super) fn row_error<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>(
    problem: &S,
    x: &SVector<f64, NX>,
    row: &[f64],
    globals: &[f64],
) -> f64
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    let e = problem.row_error(x, row, globals);
    if e.is_nan() {
        f64::INFINITY
    } else {
        e
    }
}

/// The problem's error of `row` at `x` as a smooth residual through zero, and its gradient by
/// forward differences: the error's own gradient, not that of the algebraic row equations
/// scaled to it (a geometric error divides by a norm that moves with the unknowns, the
/// baseline's length in a generalized epipolar error, and Gauss-Newton on the scaled equations
/// with that scale frozen stops at a point biased along it, short of the error's minimum).
/// `None` where it is not finite.
///
/// The sign is that of the row's largest equation, from one call of the compiled one-row kernel
/// ([`row_equations`]): at `x` its value, and at each difference step its first-order change
/// along the Jacobian row, so the sign follows the equation through zero without evaluating it
/// again (the second-order term at a step of [`DIFFERENCE_STEP`] matters only for an equation
/// within about `1e-14` of zero, where the error itself is that small).
fn signed_error_gradient<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>(
    problem: &S,
    x: &SVector<f64, NX>,
    row: &[f64],
    globals: &[f64],
) -> Option<(f64, SVector<f64, NX>)>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    let error = |x: &SVector<f64, NX>| row_error::<S, NX, NF, NP, NC, ND>(problem, x, row, globals);
    let size = error(x);
    let (mut f, mut j) = (SVector::<f64, NF>::zeros(), SMatrix::<f64, NF, NX>::zeros());
    let epr = row_equations::<S::Tracked, NX, NF, NP, NC>(x, row, globals, &mut f, &mut j)?;
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
        grad[m] = (signed(f[k] + j[(k, m)] * step, error(&moved)) - e) / step;
    }
    grad.iter().all(|g| g.is_finite()).then_some((e, grad))
}

/// Gauss-Newton from `x0` with a Cauchy loss of scale `threshold` on the errors of the rows
/// `inliers` ([`DeclaredProblem::row_error`], the unit of the threshold), then back onto the
/// equations without parameters, each step halved until the robust cost falls.
pub(super) fn refine_on_rows<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>(
    problem: &S,
    input: RowsInput<'_>,
    x0: &SVector<f64, NX>,
    inliers: &[usize],
    threshold: f64,
) -> Option<SVector<f64, NX>>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    let layout = S::Data::LAYOUT;
    let globals = input.1;
    let c2 = threshold * threshold;
    let cost = |x: &SVector<f64, NX>| -> f64 {
        inliers
            .iter()
            .map(|&i| {
                let e = row_error::<S, NX, NF, NP, NC, ND>(problem, x, row(&layout, input, i), globals);
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
            let Some((e, de)) = signed_error_gradient::<S, NX, NF, NP, NC, ND>(problem, &x, row(&layout, input, i), globals) else {
                continue;
            };
            // Cauchy weight (iteratively reweighted least squares) on the signed error.
            let w = 1.0 / (1.0 + e * e / c2);
            h += w * de * de.transpose();
            g += w * e * de;
        }
        // The equations without parameters (unit quaternions, unit vectors) as stiff
        // constraints on the step: the problem's error does not change with the norm of a
        // quaternion, so that direction has no curvature, and a step along it would only be
        // undone by the projection below. (Added when the rows were the algebraic equations,
        // whose residual did fall along it and stalled the descent.)
        let scale = 1.0 + h.diagonal().amax();
        // They do not depend on the parameters: evaluated at zeros.
        <S::Tracked as Problem<NX, NF, NP>>::residual_jacobian(&x, &SVector::<f64, NP>::zeros(), &mut f, &mut j);
        for &e in S::Tracked::LAYOUT.parameter_free {
            let r = j.row(e);
            h += CONSTRAINT_WEIGHT * scale * r.transpose() * r;
            g += CONSTRAINT_WEIGHT * scale * f[e] * r.transpose();
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
        // tolerance: later iterations of the reweighted steps move the estimate far below the
        // noise and only cost time (on `robust_grp.py`, 1.8x less time per call at 0 %
        // outliers, the same success and median errors; BENCHMARKS.md 2026-12-04).
        let small = (moved - x).amax() <= LO_TOLERANCE * (1.0 + x.amax()) || current - next <= LO_TOLERANCE * current;
        (x, current) = (moved, next);
        if small {
            break;
        }
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Every row-wise problem's rows are correspondences of the robust estimator.
impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>
    Correspondences<NX, NF, NP, NC, SVector<f64, ND>> for S
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    type Input<'a> = RowsInput<'a>;
    type Model = SVector<f64, NX>;

    fn checked_count(&self, (rows, globals): RowsInput<'_>) -> Result<usize, EstimateError> {
        checked_rows(&S::Data::LAYOUT, rows, globals)
    }
    fn sample_size(&self) -> usize {
        S::Data::LAYOUT.rows
    }
    fn sample_attempts(&self) -> usize {
        S::SAMPLE_ATTEMPTS
    }
    fn sample_candidates(&self) -> usize {
        S::SAMPLE_CANDIDATES
    }
    fn same_end_point(&self, a: &SVector<f64, NX>, b: &SVector<f64, NX>) -> bool {
        self.same_solution(a, b)
    }
    fn with_instance<R>(&self, input: RowsInput<'_>, indices: &[usize], run: impl FnOnce(&SVector<f64, ND>) -> R) -> R {
        run(&data_instance::<ND>(&S::Data::LAYOUT, input, indices.iter().copied()))
    }
    fn model(&self, x: &SVector<f64, NX>, _: &SVector<f64, ND>) -> Option<SVector<f64, NX>> {
        Some(*x)
    }
    fn model_unknowns(&self, x: &SVector<f64, NX>) -> SVector<f64, NX> {
        *x
    }
    fn model_error(&self, input: RowsInput<'_>, x: &SVector<f64, NX>, i: usize) -> f64 {
        row_error::<S, NX, NF, NP, NC, ND>(self, x, row(&S::Data::LAYOUT, input, i), input.1)
    }
    fn refine_model(&self, input: RowsInput<'_>, x: &SVector<f64, NX>, inliers: &[usize], threshold: f64) -> Option<SVector<f64, NX>> {
        refine_on_rows::<S, NX, NF, NP, NC, ND>(self, input, x, inliers, threshold)
    }
}
