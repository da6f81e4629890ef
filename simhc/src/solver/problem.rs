//! The problem trait of a compiled solver: what a solve of a declared problem needs (its
//! compiled instances and a validator) and its optional hooks (refinement on all rows, a
//! canonical frame, learned-start rows, an all-roots fallback, a per-correspondence error).
//! [`super::Solver`] assembles a solve from it; what only the `simhc-cli` commands need (a
//! scene sampler, the errors a bench reports, training settings) is [`super::Scenes`].

use super::plan::Plan;
use super::subsystem::AllRoots;
use crate::pipeline::{InputRows, OutputDecoding, Validator};
use crate::{CoefficientForm, InstanceSizes, OnlineSimulator, ParamDerivative, ProblemLayout};
use nalgebra::SVector;
use smallbox::{smallbox, space, SmallBox};

/// A declared problem: what its solver and its robust estimator need. The commands need more
/// ([`super::Scenes`], implemented beside this one): a solve has no use for a scene sampler or
/// a bench's errors, so a problem used only as a library ([`super::Solver`], Python) implements
/// this trait alone.
///
/// Two compiled instances of the declaration take part: `Data`, whose rows are the user's
/// correspondences (all of them: the learned start reads them, the validator checks them), and
/// `Tracked`, the system of the homotopy paths: the same declaration on the first rows. When
/// some rows only validate (6 correspondences determine a relative pose, a 7th checks it),
/// `Tracked` is the square instance and its paths are consistent from start to end; a path of
/// an overdetermined system follows least-squares points of inconsistent intermediate systems
/// and often fails. Without validation rows, both are the same instance. Measure both: on GRPS
/// one path on all 8 correspondences validates more often than one on the square first 7
/// (`simhc_problems::grps::declared`).
///
/// `NX, NF, NP, NC` are the sizes of `Tracked` (unknowns, equations, parameters, coefficients:
/// `Foo6::NC`); `ND` is the parameter count of `Data`.
#[diagnostic::on_unimplemented(
    message = "`{Self}` does not implement `simhc::solver::DeclaredProblem` with these sizes",
    label = "not a declared problem of sizes NX = {NX}, NF = {NF}, NP = {NP}, NC = {NC}, ND = {ND}",
    note = "implement `simhc::solver::DeclaredProblem<NX, NF, NP, NC, ND>` for it: the sizes of its tracked instance, then the parameter count of its data instance"
)]
pub trait DeclaredProblem<const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>: 'static {
    /// The instance whose paths are tracked: the first rows of the data (`#[simhc_problem]`).
    /// Its own [`OnlineSimulator`] builds the start problems: the generated minimum-norm one,
    /// or yours with `#[simhc_problem(simulator = custom)]`.
    type Tracked: CoefficientForm<NX, NF, NP, NC> + ParamDerivative<NX, NF, NP> + ProblemLayout + OnlineSimulator<NX, NF, NP> + Default;
    /// The instance of all the user's rows (its layout reads input files and feeds the learned
    /// start).
    type Data: ProblemLayout + InstanceSizes<NX, ND>;
    /// What decides that an end point is a solution of all the data.
    type Validator: Validator<SVector<f64, ND>, NX>;
    /// The name on the command line (lower case); errors of a solve name the problem by it.
    const NAME: &'static str;
    /// Models a RANSAC sample may give ([`super::Solver::estimate`]): at most this many distinct
    /// end points ([`DeclaredProblem::same_solution`]) that validate on the sample. Default `1`:
    /// the first. More helps a minimal sample, whose every real root fits it exactly: the
    /// consensus then picks the true one among them.
    const SAMPLE_CANDIDATES: usize = 1;
    /// Attempts a RANSAC sample runs: the first this many of the solver's schedule
    /// ([`super::Solver::schedule`]) short of the paths with the other simulators (the fallback
    /// never). Default `1`: Gauss-Newton from the learned start ([`super::sample_schedule`]).
    const SAMPLE_ATTEMPTS: usize = 1;

    /// The validator for data with noise of size `noise`.
    fn validator(&self, noise: f64) -> Self::Validator;

    /// Rejects data that no solve can use, before any attempt: a zero bearing, all rays from one
    /// origin (a scale that the data does not fix), too little spread. Such data has no
    /// isolated solution, so attempts fail slowly or, worse, validate one of a family; a
    /// [`DegenerateInput`] says which row and why. NaN and infinity are checked before this
    /// (the error names the row and field). Default: every finite data vector is used.
    fn check_input(&self, _p: &SVector<f64, ND>) -> Result<(), DegenerateInput> {
        Ok(())
    }
    /// Gauss-Newton on all the data's rows from `x0` (typically one line:
    /// `crate::pipeline::path::gauss_newton::<Self::Data, NX, NFD, ND>(x0, p, &Default::default())`).
    /// With validation rows this is far more selective than Gauss-Newton on the tracked
    /// rows: an extra row removes the basins of the other roots.
    /// [`Refinement::Unsupported`] (the default): the Gauss-Newton attempts run on the tracked
    /// rows. Set [`Plan::refine`] in [`DeclaredProblem::plan`] when you implement it.
    fn refine(&self, _p: &SVector<f64, ND>, _x0: &SVector<f64, NX>) -> Refinement<NX> {
        Refinement::Unsupported
    }
    /// The data in a frame computed from the data itself (centred, rotated, scaled), with the
    /// maps of the unknowns into and out of it. The learned start is trained and run in that
    /// frame, the paths are tracked there, and the solution is validated again in the user's
    /// frame; so a learned start trained on one sampler holds on data in any frame. `None`
    /// (the default): the data is used as given.
    fn canonicalize(&self, _p: &SVector<f64, ND>) -> Option<(SVector<f64, ND>, CanonicalFrame<NX>)> {
        None
    }
    /// The learned start's input rows, in training and in use (of the data in the canonical
    /// frame, if [`DeclaredProblem::canonicalize`] makes one). `None` (the default): the data
    /// layout's rows, `[row parameters, global parameters]` per row
    /// ([`crate::pipeline::LayoutRows`]). Implement [`InputRows`] when other numbers make
    /// better features (distances, ratios, invariants); weights trained on one kind of rows do
    /// not load with another.
    fn input_rows(&self) -> Option<&dyn InputRows> {
        None
    }
    /// How the learned start's outputs become unknowns (in the canonical frame, if
    /// [`DeclaredProblem::canonicalize`] makes one). `None` (the default): the network outputs
    /// the unknowns in layout order ([`crate::pipeline::LayoutOutputs`]), as `train` makes it.
    /// Implement [`OutputDecoding`] when the network is trained on another representation (a
    /// 6D rotation, the log of a scale); `train` then refuses the problem (its generic trainer
    /// fits the unknowns), and the weights come from the problem's own trainer.
    fn outputs(&self) -> Option<&dyn OutputDecoding> {
        None
    }
    /// What a solver of the problem tries by default ([`Plan`]): refinement of the learned
    /// hypotheses ([`DeclaredProblem::refine`]), restarts ([`DeclaredProblem::restart`]),
    /// other starts and simulators, and the options of the tracker, Gauss-Newton and the
    /// schedule. Write the return type as plain `Plan`: `#[declared_problem]` gives it the
    /// problem's sizes. Called once, when a [`super::Solver`] is built; a caller may change it
    /// ([`super::InstanceSolver::with_plan`]). Default: the learned start alone, then the
    /// all-roots fallback.
    fn plan(&self) -> Plan<SVector<f64, ND>, NX, NF, NP> {
        Plan::default()
    }
    /// The shipped weights (for example `include_bytes!`), used when no `--weights` is given.
    fn weights(&self) -> Option<&'static [u8]> {
        None
    }
    /// Restart `k` around `x`, the learned start's first-ranked hypothesis for the data `p`
    /// (both in the canonical frame, if [`DeclaredProblem::canonicalize`] makes one): a start
    /// for Gauss-Newton on the tracked rows, tried after every other attempt and before the
    /// all-roots fallback, for `k` in `0..plan().restarts` ([`super::restarts`]). For a layout with a
    /// rotation, [`super::rotated_restart`] turns the prediction about fixed axes; a problem
    /// can then re-solve the unknowns that follow from the rotation (GRPS: the least-squares
    /// translation and scale). `None` (the default): no restart `k`.
    fn restart(&self, _p: &SVector<f64, ND>, _x: &SVector<f64, NX>, _k: usize) -> Option<SVector<f64, NX>> {
        None
    }
    /// All roots of a square subsystem: the pipeline's fallback, the All-roots bench row and
    /// `monodromy` ([`super::SquareSubsystem`]).
    fn all_roots(&self) -> Option<&dyn AllRoots<NX, ND>> {
        None
    }
    /// The error of one correspondence under `x`, which the robust estimator
    /// ([`super::Solver::estimate`]) compares with its threshold: `row` holds the row's numbers
    /// in the layout's order, `globals` the global ones. Default: the largest absolute residual
    /// of the row's equations ([`super::residual::row_residual`]); a geometric error (angular,
    /// Sampson) makes the threshold mean the same for every correspondence.
    fn row_error(&self, x: &SVector<f64, NX>, row: &[f64], globals: &[f64]) -> f64 {
        super::residual::row_residual::<Self::Tracked, NX, NF, NP, NC>(x, row, globals)
    }
    /// Whether two end points of one RANSAC sample are the same solution (only one is kept,
    /// [`DeclaredProblem::SAMPLE_CANDIDATES`]). Default: every unknown within `1e-6` relative;
    /// a problem with a sign ambiguity (a quaternion `q` and `-q`) says so here.
    fn same_solution(&self, a: &SVector<f64, NX>, b: &SVector<f64, NX>) -> bool {
        (a - b).amax() <= 1e-6 * (1.0 + a.amax())
    }
}

/// The five sizes of a type's [`DeclaredProblem`] impl, as constants, so that a second impl
/// for the same type can name them without a number: `#[declared_problem]` implements this
/// trait beside a `DeclaredProblem` impl (from its `type Tracked` and `type Data`) and sizes
/// a [`super::Scenes`] impl of the same type from it. Const generics cannot be read back from
/// a trait impl, so the sizes need a home of their own.
#[diagnostic::on_unimplemented(
    message = "`{Self}` has no `#[declared_problem]` impl of `simhc::solver::DeclaredProblem`",
    label = "the sizes of this `Scenes` impl come from the type's `DeclaredProblem` impl",
    note = "put `#[simhc::declared_problem]` on the type's `impl DeclaredProblem` too, or write the five sizes of both impls"
)]
pub trait DeclaredSizes {
    /// `[NX, NF, NP, NC, ND]`: the tracked instance's unknowns, equations, parameters and
    /// coefficients, then the data instance's parameters. One array, not five constants named
    /// like an instance's (`Foo7::NP`): rustc would then suggest implementing this trait
    /// wherever a type that is no instance is given as one.
    const SIZES: [usize; 5];
}

/// A map of the unknowns from one frame to another, held inline: a closure whose captures fit
/// in 32 words (256 bytes on 64-bit targets: two rotations, two offsets and two scales, say)
/// and need no more than a word's alignment is stored without a heap allocation; another is
/// boxed on the heap ([`smallbox`]). Private: [`CanonicalFrame`]'s API does not name it.
type UnknownsMap<const NX: usize> = SmallBox<dyn Fn(&SVector<f64, NX>) -> SVector<f64, NX>, space::S32>;

/// The maps of the unknowns between the user's frame and a canonical frame of the data
/// ([`DeclaredProblem::canonicalize`]), made by [`CanonicalFrame::new`].
///
/// Why not two `Box<dyn Fn>`: a frame is made on every solve, and two boxes were the only heap
/// allocations of a validated solve of a problem with a frame. The maps are held inline when
/// their captures fit in 256 bytes (on 64-bit targets; [`CanonicalFrame::is_inline`]).
pub struct CanonicalFrame<const NX: usize> {
    to_canonical: UnknownsMap<NX>,
    to_user: UnknownsMap<NX>,
}

impl<const NX: usize> CanonicalFrame<NX> {
    /// The frame of the two maps: `to_canonical` takes the user's unknowns to canonical ones,
    /// `to_user` back (its inverse).
    pub fn new<C, U>(to_canonical: C, to_user: U) -> Self
    where
        C: Fn(&SVector<f64, NX>) -> SVector<f64, NX> + 'static,
        U: Fn(&SVector<f64, NX>) -> SVector<f64, NX> + 'static,
    {
        // `smallbox!` is the crate's stable way to make an unsized box: its unsafe block (the
        // crate's own, with its own allow) only pairs the value with a pointer to it, which
        // unsizes `C` to `dyn Fn`; the value goes inline when it fits, to the heap otherwise.
        Self { to_canonical: smallbox!(to_canonical), to_user: smallbox!(to_user) }
    }

    /// The user's unknowns `x` in the canonical frame.
    pub fn to_canonical(&self, x: &SVector<f64, NX>) -> SVector<f64, NX> {
        (*self.to_canonical)(x)
    }

    /// Canonical unknowns `x` in the user's frame.
    pub fn to_user(&self, x: &SVector<f64, NX>) -> SVector<f64, NX> {
        (*self.to_user)(x)
    }

    /// Whether both maps are held without a heap allocation (their captures fit in 256 bytes).
    pub fn is_inline(&self) -> bool {
        !self.to_canonical.is_heap() && !self.to_user.is_heap()
    }
}

/// What [`DeclaredProblem::refine`] did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Refinement<const NX: usize> {
    /// The problem has no refinement on all rows.
    Unsupported,
    /// Converged here.
    Converged(SVector<f64, NX>),
    /// Did not converge.
    Failed,
}

impl<const NX: usize, E> From<Result<SVector<f64, NX>, E>> for Refinement<NX> {
    fn from(r: Result<SVector<f64, NX>, E>) -> Self {
        r.map_or(Refinement::Failed, Refinement::Converged)
    }
}

/// Data that no solve can use ([`DeclaredProblem::check_input`]): where and why. Plain data,
/// so that a check allocates nothing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{}{reason}", match row { Some(r) => format!("row {r}: "), None => String::new() })]
pub struct DegenerateInput {
    /// The row (correspondence) at fault, `None` when the rows together are (all rays from one
    /// origin, all points on a line).
    pub row: Option<usize>,
    /// What is wrong, and what it makes unobservable.
    pub reason: &'static str,
}
