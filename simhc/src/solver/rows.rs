//! The learned start of a row-wise problem: its input rows and output decoding, the problem's
//! own ([`super::DeclaredProblem::input_rows`], [`super::DeclaredProblem::outputs`]) or its data layout's.

use super::problem::DeclaredProblem;
use crate::pipeline::{InputRows, LayoutOutputs, LayoutRows, LearnedStart, OutputDecoding};
use crate::ProblemLayout;
use std::marker::PhantomData;
use std::sync::Arc;

/// A problem's learned-start input rows: its own ([`super::DeclaredProblem::input_rows`]) or its data
/// layout's. Shares the problem, so a solver that holds it is `Send + Sync` when the problem is.
pub struct ProblemRows<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> {
    problem: Arc<S>,
    sizes: PhantomData<fn() -> [(); NX]>,
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> ProblemRows<S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    /// The rows of `problem`.
    pub fn new(problem: Arc<S>) -> Self {
        Self { problem, sizes: PhantomData }
    }
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> InputRows
    for ProblemRows<S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    fn shape(&self) -> (usize, usize) {
        match self.problem.input_rows() {
            Some(rows) => rows.shape(),
            None => LayoutRows(S::Data::LAYOUT).shape(),
        }
    }
    fn write(&self, p: &[f64], out: &mut [f32]) -> bool {
        match self.problem.input_rows() {
            Some(rows) => rows.write(p, out),
            None => LayoutRows(S::Data::LAYOUT).write(p, out),
        }
    }
}

/// A problem's learned-start output decoding: its own ([`super::DeclaredProblem::outputs`]) or the
/// unknowns of its data layout. Shares the problem, as [`ProblemRows`].
pub struct ProblemOutputs<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> {
    problem: Arc<S>,
    sizes: PhantomData<fn() -> [(); NX]>,
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> ProblemOutputs<S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    /// The output decoding of `problem`.
    pub fn new(problem: Arc<S>) -> Self {
        Self { problem, sizes: PhantomData }
    }
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> OutputDecoding
    for ProblemOutputs<S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    fn width(&self) -> usize {
        match self.problem.outputs() {
            Some(outputs) => outputs.width(),
            None => LayoutOutputs(S::Data::LAYOUT).width(),
        }
    }
    fn decode(&self, out: &[f64], x: &mut [f64]) -> bool {
        match self.problem.outputs() {
            Some(outputs) => outputs.decode(out, x),
            None => LayoutOutputs(S::Data::LAYOUT).decode(out, x),
        }
    }
}

/// The learned start of a row-wise solver.
pub type SolverStart<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> =
    LearnedStart<ProblemRows<S, NX, NF, NP, NC, ND>, ProblemOutputs<S, NX, NF, NP, NC, ND>>;
