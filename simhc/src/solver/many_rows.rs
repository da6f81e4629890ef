//! A solve of more correspondences than the problem's data instance has, without outliers:
//! [`Solver::solve_rows`] (the `solve` command takes such data too).
//!
//! 1. The first rows (as many as the data instance has) are solved as [`Solver::solve`] does:
//!    every start, the restarts, the fallback, validated on those rows.
//! 2. That solution is refined on all rows: the robust estimator's Gauss-Newton on the problem's
//!    per-correspondence errors ([`DeclaredProblem::row_error`]) with every row an inlier and a
//!    Cauchy scale of the largest error at the start, so that no row starts in the loss's flat
//!    tail.
//! 3. The validator, which takes one data instance, checks every run of consecutive rows (rows
//!    `0..n`, `n..2n`, ..., the last run ending at the last row), so every row is validated.
//!
//! The refined solution is returned when every run validates, else the first rows' solution
//! when every run validates it; else an error naming the first run that the one with the
//! fewer rejected runs does not explain (a wrong row, or a solution of the first rows that the
//! others contradict). Why not the estimator: data without outliers needs no sampling, and a
//! solve of the first rows has the solver's every start and its fallback, where a RANSAC sample
//! gets one attempt.

use super::estimate::EstimateError;
use super::estimate_rows::{checked_rows, data_instance, refine_on_rows, row, row_error, RowsInput};
use super::library::Solver;
use super::problem::DeclaredProblem;
use crate::pipeline::{Validator, Verdict};
use crate::ProblemLayout;
use nalgebra::SVector;

/// A solution of all rows ([`Solver::solve_rows`]).
#[derive(Debug, Clone, PartialEq)]
pub struct RowsSolution<const NX: usize> {
    /// The unknowns, validated on every run of rows.
    pub x: SVector<f64, NX>,
    /// Rows solved.
    pub rows: usize,
    /// Whether `x` is the refinement on all rows (`false`: the first rows' solution, which the
    /// refinement did not improve on, or the data is one instance).
    pub refined: bool,
    /// The largest per-correspondence error at `x` ([`DeclaredProblem::row_error`]).
    pub max_row_error: f64,
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Solver<S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    /// A solve of `rows` (at least the data instance's count, `per_row` numbers each in the
    /// data layout's order, row after row, no outliers) and the global numbers `globals`
    /// ([module docs](super::many_rows)): solved on the first rows, refined on all, validated on
    /// all. Bad input is an error naming the row and field.
    pub fn solve_rows(&self, rows: &[f64], globals: &[f64]) -> Result<RowsSolution<NX>, EstimateError> {
        let layout = S::Data::LAYOUT;
        let n = checked_rows(&layout, rows, globals)?;
        let input: RowsInput<'_> = (rows, globals);
        let instance = layout.rows;
        let problem = self.problem();
        let x0 = self
            .solve(&data_instance::<ND>(&layout, input, 0..instance))
            .map_err(|e| EstimateError::FirstRowsNotSolved { rows: instance, reason: e.to_string() })?
            .x;
        let largest = |x: &SVector<f64, NX>| {
            (0..n).map(|i| row_error::<S, NX, NF, NP, NC, ND>(problem, x, row(&layout, input, i), globals)).fold(0.0, f64::max)
        };
        let e0 = largest(&x0);
        if n == instance {
            return Ok(RowsSolution { x: x0, rows: n, refined: false, max_row_error: e0 });
        }
        let refined = if e0.is_finite() && e0 > 0.0 {
            let all: Vec<usize> = (0..n).collect();
            refine_on_rows::<S, NX, NF, NP, NC, ND>(problem, input, &x0, &all, e0)
        } else {
            None
        };
        // The refinement first; the first rows' solution is checked on every run only when the
        // refinement is not accepted.
        let runs = |x: &SVector<f64, NX>| self.rejected_runs(input, n, x);
        let refined = refined.map(|x| (runs(&x), x));
        if let Some(((0, _), x)) = refined {
            return Ok(RowsSolution { x, rows: n, refined: true, max_row_error: largest(&x) });
        }
        let (rejected0, first_rejected0) = runs(&x0);
        if rejected0 == 0 {
            return Ok(RowsSolution { x: x0, rows: n, refined: false, max_row_error: e0 });
        }
        let (x, at) = match refined {
            Some(((count, at), x)) if count < rejected0 => (x, at),
            _ => (x0, first_rejected0),
        };
        let start = at.unwrap_or(0);
        let check = self.validator().check(&data_instance::<ND>(&layout, input, start..start + instance), &x);
        Err(EstimateError::NotValidatedOnAll { rows: n, instance, first: start, last: start + instance - 1, check: format!("{check:?}") })
    }

    /// How many runs of rows (module docs, step 3) of the `n` rows of `input` the validator
    /// rejects at `x`, and the first row of the first one rejected.
    fn rejected_runs(&self, input: RowsInput<'_>, n: usize, x: &SVector<f64, NX>) -> (usize, Option<usize>) {
        let layout = S::Data::LAYOUT;
        let instance = layout.rows;
        let mut rejected = (0, None);
        for start in (0..n).step_by(instance.max(1)).map(|s| s.min(n - instance)) {
            let p = data_instance::<ND>(&layout, input, start..start + instance);
            if self.validator().verdict(&self.validator().check(&p, x)) == Verdict::Reject {
                rejected = (rejected.0 + 1, rejected.1.or(Some(start)));
            }
        }
        rejected
    }
}
