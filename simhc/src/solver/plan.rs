//! What a solver tries, apart from what only the problem knows: a value, built once. A problem
//! gives its default ([`super::InstanceProblem::plan`], [`super::DeclaredProblem::plan`]), and a caller may
//! change it before the solver is built ([`super::InstanceSolver::with_plan`]), as PoseLib's
//! option structs and HomotopyContinuation.jl's keywords sit apart from the system solved.

use crate::pipeline::{PipelineOptions, StartProvider, StartSimulator};
use std::fmt;

/// A start provider of the data `D`, shared by the threads of a solver.
pub type SharedStart<D, const NX: usize> = Box<dyn StartProvider<D, NX> + Send + Sync>;

/// A simulator of the data `D`, shared by the threads of a solver.
pub type SharedSimulator<D, const NX: usize, const NF: usize, const NP: usize> = Box<dyn StartSimulator<D, NX, NF, NP> + Send + Sync>;

/// What a solve of data `D` tries, in which order, and with which options. The learned start
/// comes first (its weights are given to the solver); then, in the shipped schedule's order,
/// the other starts and simulators, the restarts, and the all-roots fallback.
pub struct Plan<D: ?Sized, const NX: usize, const NF: usize, const NP: usize> {
    /// Refine each learned hypothesis on the data (the problem's `refine`) before it
    /// is tracked: Gauss-Newton on the data, then the path from the refined start.
    pub refine: bool,
    /// Restarts from rotated learned hypotheses, after the other attempts (at most
    /// [`super::MAX_RESTARTS`]).
    pub restarts: usize,
    /// Starts other than the learned one (closed-form, linear, the swapped views: a start that
    /// holds where the learned one was not trained), tried after every learned hypothesis and
    /// before the all-roots fallback: each with Gauss-Newton on the tracked rows, then one path
    /// with the problem's simulator, then one with each other simulator. A provider sees the
    /// data, and returns unknowns, in the canonical frame when the problem makes one. At most
    /// [`super::MAX_OTHERS`].
    pub other_starts: Vec<SharedStart<D, NX>>,
    /// Online simulators beside the problem's own (a geometric one that re-projects the
    /// scene): after the paths of the learned hypotheses with the own simulator, one path from
    /// each hypothesis with each of these ([`crate::pipeline::Method::OtherSimulatorHc`]`(k)`
    /// for the `k`-th), in the canonical frame as the starts. At most [`super::MAX_OTHERS`].
    pub other_simulators: Vec<SharedSimulator<D, NX, NF, NP>>,
    /// Try the other starts before the learned one: for a start that is cheaper and exact on
    /// noise-free data (UPnP's linear start).
    pub other_starts_first: bool,
    /// End with the all-roots fallback when nothing validated, if the solver has one (the
    /// problem's start system or one given at run time).
    pub fallback: bool,
    /// The tracker of every path, Gauss-Newton, the polish of end points short of the
    /// tracker's tolerance, and how many more attempts run after a plausible end point
    /// ([`crate::pipeline::Verdict::Plausible`], the best then returned). The solver sets the
    /// options' own `fallback` (on for a solve, off on a RANSAC sample).
    pub options: PipelineOptions,
}

impl<D: ?Sized, const NX: usize, const NF: usize, const NP: usize> Default for Plan<D, NX, NF, NP> {
    /// The learned start alone (not refined), then the fallback; the pipeline's default options.
    fn default() -> Self {
        Self {
            refine: false,
            restarts: 0,
            other_starts: Vec::new(),
            other_simulators: Vec::new(),
            other_starts_first: false,
            fallback: true,
            options: PipelineOptions::default(),
        }
    }
}

impl<D: ?Sized, const NX: usize, const NF: usize, const NP: usize> fmt::Debug for Plan<D, NX, NF, NP> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let names = |starts: Vec<&'static str>| starts.join(", ");
        f.debug_struct("Plan")
            .field("refine", &self.refine)
            .field("restarts", &self.restarts)
            .field("other_starts", &names(self.other_starts.iter().map(|s| s.name()).collect()))
            .field("other_simulators", &self.other_simulators.len())
            .field("other_starts_first", &self.other_starts_first)
            .field("fallback", &self.fallback)
            .field("options", &self.options)
            .finish()
    }
}
