//! What a [`super::Solver`] needs of a problem, for data of any type `D`: [`InstanceProblem`].
//!
//! Most problems are row-wise: their data is a fixed-length parameter vector whose first rows
//! are the tracked system's parameters, and they implement [`DeclaredProblem`] (and
//! [`super::Scenes`] for the commands); every such problem implements [`InstanceProblem`] for
//! `D = SVector<f64, ND>` through the blanket impl below, without a line more. A problem whose
//! tracked parameters are *derived* from the data implements [`InstanceProblem`] directly:
//! UPnP (`simhc_problems::upnp::instance`) takes any number of correspondences
//! (`D = [UpnpCorrespondence]`) and tracks the 66 entries of its cost matrix, which no rows of
//! the data are.
//!
//! Where an item means what a [`DeclaredProblem`] item means, it has its name (`plan`,
//! `validator`, `weights`, `canonicalize`, `refine`, `restart`), and the blanket impl forwards
//! each. Code with both traits in scope names the trait of a declared problem's call:
//! `DeclaredProblem::validator(&problem, noise)`.

use super::hypotheses::{LearnedHypotheses, Ranked, RankedStarts};
use super::parts::{Canon, FirstRows, FirstRowsError};
use super::plan::Plan;
use super::problem::{CanonicalFrame, DeclaredProblem, Refinement};
use super::rows::{ProblemOutputs, ProblemRows, SolverStart};
use crate::pipeline::learned::NonFiniteParameter;
use crate::pipeline::{
    Canonicalize, Fallback, Generic, LearnedStart, StartError, StartProvider, StartSimulator, TargetParameters, Validator, MAX_HYPOTHESES,
};
use crate::regressor::{FoldedNetwork, RegressorError};
use crate::{CoefficientForm, ParamDerivative, ProblemLayout, SimulatorError};
use nalgebra::SVector;
use std::borrow::Borrow;
use std::sync::Arc;

/// A problem a [`super::Solver`] solves, for data of type `D` (the [module docs](self)).
///
/// `NX, NF, NP, NC` are the sizes of the tracked system. [`InstanceProblem::check_data`] and
/// [`InstanceProblem::canonicalize`] see the user's data; the other methods see it as the
/// pipeline does, in the canonical frame when [`InstanceProblem::canonicalize`] makes one (the
/// validator also checks the final solution on the user's data).
#[diagnostic::on_unimplemented(
    message = "`{Self}` is not a problem a solver takes for data `{D}` with these sizes",
    label = "no `InstanceProblem<{NX}, {NF}, {NP}, {NC}, {D}>`",
    note = "a row-wise problem implements `simhc::solver::DeclaredProblem<NX, NF, NP, NC, ND>` (its data is then `SVector<f64, ND>`); other data implements `simhc::solver::InstanceProblem` directly"
)]
pub trait InstanceProblem<const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized>: 'static {
    /// The system of the homotopy paths.
    type Tracked: CoefficientForm<NX, NF, NP, NC> + ParamDerivative<NX, NF, NP> + ProblemLayout;
    /// Accepts or rejects an end point on all the data.
    type Validator: Validator<D, NX>;
    /// The learned start, built once from the weights.
    type Learned: LearnedHypotheses<D, NX>;
    /// The data in a canonical frame (an owned `D`).
    type Canonical: Borrow<D>;

    /// The problem's name, for errors.
    fn name(&self) -> &'static str;
    /// What a solver of the problem tries by default ([`Plan`]): the learned start alone,
    /// then the fallback, unless the problem says more (refinement, restarts, other starts and
    /// simulators, options). A caller may change it ([`super::InstanceSolver::with_plan`]).
    fn plan(&self) -> Plan<D, NX, NF, NP> {
        Plan::default()
    }
    /// The weights the problem ships, if any.
    fn weights(&self) -> Option<&'static [u8]> {
        None
    }
    /// The learned start of `weights` (a file made by `train`); an error when they were made
    /// for other input rows or outputs.
    fn learned(problem: &Arc<Self>, weights: &[u8]) -> Result<Self::Learned, RegressorError>
    where
        Self: Sized;
    /// The validator of solutions, for data with noise of size `noise`.
    fn validator(&self, noise: f64) -> Self::Validator;
    /// Checks the user's data before anything else: which correspondence and field is not
    /// finite, too few correspondences, degenerate geometry.
    fn check_data(&self, data: &D) -> Result<(), FirstRowsError>;
    /// The tracked system's parameters of the data.
    fn tracked_params(&self, data: &D) -> Result<SVector<f64, NP>, FirstRowsError>;
    /// Start parameters `p0` that `x0` solves exactly, near the target `p` (the paper's
    /// online simulator).
    fn simulate_start(&self, data: &D, x0: &SVector<f64, NX>, p: &SVector<f64, NP>) -> Result<SVector<f64, NP>, SimulatorError>;
    /// The data in a canonical frame and the maps of the unknowns; `None`: solved as given.
    fn canonicalize(&self, _data: &D) -> Option<(Self::Canonical, CanonicalFrame<NX>)> {
        None
    }
    /// The learned start refined on all the data (tried when [`Plan::refine`]).
    fn refine(&self, _data: &D, _x0: &SVector<f64, NX>) -> Refinement<NX> {
        Refinement::Unsupported
    }
    /// Restart `k` around `x`, the first-ranked learned hypothesis (for `k <` [`Plan::restarts`]).
    fn restart(&self, _data: &D, _x: &SVector<f64, NX>, _k: usize) -> Option<SVector<f64, NX>> {
        None
    }
    /// Whether [`InstanceProblem::fallback_candidates`] can return candidates.
    fn has_fallback(&self) -> bool {
        false
    }
    /// Candidate solutions when no path validated (all real roots, a global minimum).
    fn fallback_candidates(&self, _data: &D, _p: &SVector<f64, NP>) -> Vec<SVector<f64, NX>> {
        Vec::new()
    }
}

/// The learned start of a row-wise problem: its input rows and outputs
/// ([`DeclaredProblem::input_rows`], [`DeclaredProblem::outputs`]), several hypotheses ranked
/// by their scores or by [`DeclaredProblem::row_error`] on all rows.
pub struct RowwiseLearned<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> {
    /// The network with its rows and outputs.
    pub start: SolverStart<S, NX, NF, NP, NC, ND>,
    problem: Arc<S>,
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> RowwiseLearned<S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    /// The learned start of `network` for `problem`.
    pub fn new(problem: &Arc<S>, network: FoldedNetwork) -> Result<Self, RegressorError> {
        let start =
            LearnedStart::with_outputs(network, S::Data::LAYOUT, ProblemRows::new(problem.clone()), ProblemOutputs::new(problem.clone()))?;
        Ok(Self { start, problem: problem.clone() })
    }

    fn score(&self, x: &SVector<f64, NX>, p: &SVector<f64, ND>) -> f64 {
        let layout = S::Data::LAYOUT;
        let (rows, per_row) = (layout.rows, layout.per_row);
        let globals = &p.as_slice()[rows * per_row..];
        let total: f64 = (0..rows).map(|i| self.problem.row_error(x, &p.as_slice()[i * per_row..(i + 1) * per_row], globals).powi(2)).sum();
        if total.is_nan() {
            f64::INFINITY
        } else {
            total
        }
    }
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> LearnedHypotheses<SVector<f64, ND>, NX>
    for RowwiseLearned<S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    fn hypotheses(&self) -> usize {
        self.start.hypotheses()
    }

    fn rank(&self, p: &SVector<f64, ND>) -> Result<Ranked<NX>, StartError> {
        let blocks = self.start.blocks();
        let fail = |e: RegressorError| StartError { provider: "learned", reason: e.to_string().into() };
        let mut out = [0.0f64; crate::regressor::MAX_WIDTH];
        let out = &mut out[..blocks.outputs()];
        self.start.predict_all(p.as_slice(), out).map_err(fail)?;
        let mut decoded = [SVector::<f64, NX>::zeros(); MAX_HYPOTHESES];
        let mut ok = [false; MAX_HYPOTHESES];
        let mut last = None;
        for k in 0..blocks.count {
            match self.start.decode(out, k, decoded[k].as_mut_slice()) {
                Ok(()) => ok[k] = true,
                Err(e) => last = Some(e),
            }
        }
        // An unscored network of several hypotheses: ranked by the data's residual. One that
        // does not decode ranks last and is dropped below.
        let order = blocks.ranked::<MAX_HYPOTHESES>(out, |k| if ok[k] { self.score(&decoded[k], p) } else { f64::INFINITY });
        let mut ranked = Ranked { x: [SVector::zeros(); MAX_HYPOTHESES], count: 0 };
        for &k in order[..blocks.count].iter().filter(|&&k| ok[k]) {
            ranked.x[ranked.count] = decoded[k];
            ranked.count += 1;
        }
        match (ranked.count, last) {
            (0, Some(e)) => Err(fail(e)),
            _ => Ok(ranked),
        }
    }
}

/// Every row-wise problem is an instance problem of its data vector.
impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>
    InstanceProblem<NX, NF, NP, NC, SVector<f64, ND>> for S
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    type Tracked = S::Tracked;
    type Validator = S::Validator;
    type Learned = RowwiseLearned<S, NX, NF, NP, NC, ND>;
    type Canonical = SVector<f64, ND>;

    fn name(&self) -> &'static str {
        S::NAME
    }
    fn plan(&self) -> Plan<SVector<f64, ND>, NX, NF, NP> {
        DeclaredProblem::plan(self)
    }
    fn weights(&self) -> Option<&'static [u8]> {
        DeclaredProblem::weights(self)
    }
    fn learned(problem: &Arc<Self>, weights: &[u8]) -> Result<Self::Learned, RegressorError> {
        RowwiseLearned::new(problem, FoldedNetwork::from_bytes(weights)?)
    }
    fn validator(&self, noise: f64) -> S::Validator {
        DeclaredProblem::validator(self, noise)
    }
    fn check_data(&self, p: &SVector<f64, ND>) -> Result<(), FirstRowsError> {
        if let Some(index) = p.iter().position(|v| !v.is_finite()) {
            return Err(NonFiniteParameter::locate(&S::Data::LAYOUT, index).into());
        }
        repeated_row(&S::Data::LAYOUT, p.as_slice())?;
        Ok(self.check_input(p)?)
    }
    fn tracked_params(&self, p: &SVector<f64, ND>) -> Result<SVector<f64, NP>, FirstRowsError> {
        FirstRows::<S::Tracked>::new().params(p)
    }
    fn simulate_start(
        &self,
        p: &SVector<f64, ND>,
        x0: &SVector<f64, NX>,
        target: &SVector<f64, NP>,
    ) -> Result<SVector<f64, NP>, SimulatorError> {
        Generic(S::Tracked::default()).simulate(p, x0, target)
    }
    fn canonicalize(&self, p: &SVector<f64, ND>) -> Option<(SVector<f64, ND>, CanonicalFrame<NX>)> {
        Canon(self).canonicalize(p).map(|(frame, p)| (p, frame))
    }
    fn refine(&self, p: &SVector<f64, ND>, x0: &SVector<f64, NX>) -> Refinement<NX> {
        DeclaredProblem::refine(self, p, x0)
    }
    fn restart(&self, p: &SVector<f64, ND>, x: &SVector<f64, NX>, k: usize) -> Option<SVector<f64, NX>> {
        DeclaredProblem::restart(self, p, x, k)
    }
    fn has_fallback(&self) -> bool {
        self.all_roots().is_some_and(|r| r.has_start_system())
    }
    fn fallback_candidates(&self, p: &SVector<f64, ND>, _target: &SVector<f64, NP>) -> Vec<SVector<f64, NX>> {
        self.all_roots().map(|r| r.candidates(p)).unwrap_or_default()
    }
}

/// A row with the same numbers as an earlier one: it adds no equation, so the system is
/// underdetermined (a singular Jacobian at every point) and, worse, a validating row that
/// repeats a tracked row validates nothing (a RANSAC sample that draws one correspondence
/// twice would be accepted on a pose fitted to fewer rows). Every row-wise problem rejects it,
/// naming the later row. `layout.rows` is small (a data instance), so the pairs are few.
fn repeated_row(layout: &crate::layout::Layout, p: &[f64]) -> Result<(), super::problem::DegenerateInput> {
    let per_row = layout.per_row;
    if per_row == 0 {
        return Ok(());
    }
    let row = |i: usize| &p[i * per_row..(i + 1) * per_row];
    for j in 1..layout.rows {
        if (0..j).any(|i| row(i) == row(j)) {
            return Err(super::problem::DegenerateInput {
                row: Some(j),
                reason: "the same numbers as an earlier row (a repeated correspondence adds no equation)",
            });
        }
    }
    Ok(())
}

/// The problem's tracked parameters of the data ([`InstanceProblem::tracked_params`]).
pub struct Parts<'a, S, const NX: usize, const NF: usize, const NC: usize>(pub &'a S);

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized> TargetParameters<D, NP> for Parts<'_, S, NX, NF, NC>
where
    S: InstanceProblem<NX, NF, NP, NC, D>,
{
    type Error = FirstRowsError;
    fn params(&self, data: &D) -> Result<SVector<f64, NP>, FirstRowsError> {
        self.0.tracked_params(data)
    }
}

/// The problem's own simulator ([`InstanceProblem::simulate_start`]).
pub struct OwnSimulator<'a, S, const NC: usize>(pub &'a S);

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized> StartSimulator<D, NX, NF, NP>
    for OwnSimulator<'_, S, NC>
where
    S: InstanceProblem<NX, NF, NP, NC, D>,
{
    fn simulate(&self, data: &D, x0: &SVector<f64, NX>, p: &SVector<f64, NP>) -> Result<SVector<f64, NP>, SimulatorError> {
        self.0.simulate_start(data, x0, p)
    }
}

/// The problem's canonical frame ([`InstanceProblem::canonicalize`]).
pub struct OwnCanon<'a, S, const NF: usize, const NP: usize, const NC: usize>(pub &'a S);

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized> Canonicalize<D, NX> for OwnCanon<'_, S, NF, NP, NC>
where
    S: InstanceProblem<NX, NF, NP, NC, D>,
{
    type Frame = CanonicalFrame<NX>;
    type Canonical = S::Canonical;
    fn canonicalize(&self, data: &D) -> Option<(CanonicalFrame<NX>, S::Canonical)> {
        self.0.canonicalize(data).map(|(d, frame)| (frame, d))
    }
    fn to_user(&self, frame: &CanonicalFrame<NX>, x: &SVector<f64, NX>) -> SVector<f64, NX> {
        frame.to_user(x)
    }
}

/// The problem's fallback ([`InstanceProblem::fallback_candidates`]).
pub struct OwnFallback<'a, S, const NF: usize, const NC: usize>(pub &'a S);

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized> Fallback<D, NX, NP> for OwnFallback<'_, S, NF, NC>
where
    S: InstanceProblem<NX, NF, NP, NC, D>,
{
    fn candidates(&self, data: &D, p: &SVector<f64, NP>) -> Vec<SVector<f64, NX>> {
        self.0.fallback_candidates(data, p)
    }
}

/// The learned start refined on all the data ([`InstanceProblem::refine`]); an error
/// when that fails.
pub struct RefinedStart<'h, 'a, S, L, const NX: usize, const NF: usize, const NP: usize, const NC: usize> {
    /// The solve's hypotheses.
    pub set: &'h RankedStarts<'a, L, NX>,
    /// Which hypothesis.
    pub rank: usize,
    /// The problem.
    pub problem: &'a S,
}

impl<S, L, const NX: usize, const NF: usize, const NP: usize, const NC: usize, D: ?Sized> StartProvider<D, NX>
    for RefinedStart<'_, '_, S, L, NX, NF, NP, NC>
where
    S: InstanceProblem<NX, NF, NP, NC, D>,
    L: LearnedHypotheses<D, NX>,
{
    fn name(&self) -> &'static str {
        "learned, refined on all rows"
    }
    fn start(&self, data: &D) -> Result<SVector<f64, NX>, StartError> {
        let x0 = self.set.start(data, self.rank)?;
        let fail = |reason: &'static str| StartError { provider: "refined", reason: reason.into() };
        match self.problem.refine(data, &x0) {
            Refinement::Converged(x) => Ok(x),
            Refinement::Failed => Err(fail("Gauss-Newton on all rows did not converge")),
            Refinement::Unsupported => Err(fail("the problem has no refinement on all rows")),
        }
    }
}
