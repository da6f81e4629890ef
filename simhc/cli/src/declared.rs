//! The four commands for any `#[simhc_problem]`: a user implements [`DeclaredProblem`] (the
//! compiled instance, a scene sampler, a validator, the errors a bench reports) and registers
//! `Declared::new(problem)` in an [`crate::App`]:
//!
//! - `train`: the generic learned start ([`simhc_regressor::generic`]) on the sampler's scenes,
//!   with a progress bar; writes a `.folded` weights file;
//! - `bench`: the paper's rows on the same seeded trials (Pred Initial, Pred + Gauss-Newton,
//!   Rand + Sim HC, Pred + Sim HC, the full pipeline, All-roots), as a table or `--json`, on
//!   the sampler's scenes, with noise, permuted rows, or in random frames;
//! - `solve`: a JSON file of correspondences (read through the layout) to a validated solution;
//! - `monodromy`: all solutions of a generic instance of the problem's square subsystem
//!   ([`SquareSubsystem`]), written as the start system of the fallback and the All-roots row.

use crate::app::{progress_bar, Registration, Verb};
use crate::builtin::MonodromyArgs;
use crate::solver::{shipped_schedule, ProblemRows, SolveError, Solver};
use clap::{ArgMatches, Args, Command, FromArgMatches};
use nalgebra::SVector;
use rand::seq::SliceRandom;
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use simhc::all_roots::{solve_all_fast, AllRootsOptions, StartSystem};
use simhc::layout::{FieldKind, Layout};
use simhc::monodromy::SignFlip;
use simhc::pipeline::bench::{bench_estimate_row, bench_row, table, BenchRow, Score};
use simhc::pipeline::learned::NonFiniteParameter;
use simhc::pipeline::{
    Attempt, Canonicalize, Fallback, Generic, InputRows, Method, Pipeline, PipelineOptions, StartError, StartProvider, TargetParameters,
    Validator,
};
use simhc::{CoefficientForm, OnlineSimulator, ParamDerivative, ProblemInfo, ProblemLayout};
use simhc_problems::start_systems::{run_monodromy, MonodromyConfig, MonodromyReport, StartSystemError, StartSystemFile};
#[cfg(feature = "train")]
use simhc_regressor::generic::{train_learned_start_with, LearnedStartConfig};
use std::cell::RefCell;
use std::marker::PhantomData;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// A declared problem with what its commands need.
///
/// Two compiled instances of the declaration take part: `Data`, whose rows are the user's
/// correspondences (all of them: the learned start reads them, the validator checks them), and
/// `Tracked`, the system of the homotopy paths: the same declaration on the first rows. When
/// some rows only validate (6 correspondences determine a relative pose, a 7th checks it),
/// `Tracked` is the square instance and its paths are consistent from start to end; a path of
/// an overdetermined system follows least-squares points of inconsistent intermediate systems
/// and often fails. Without validation rows, both are the same instance.
///
/// `NX, NF, NP, NC` are the sizes of `Tracked` (unknowns, equations, parameters, coefficients:
/// `Foo6::NC`); `ND` is the parameter count of `Data`.
#[diagnostic::on_unimplemented(
    message = "`{Self}` does not implement `simhc_cli::DeclaredProblem` with these sizes",
    label = "not a declared problem of sizes NX = {NX}, NF = {NF}, NP = {NP}, NC = {NC}, ND = {ND}",
    note = "implement `simhc_cli::DeclaredProblem<NX, NF, NP, NC, ND>` for it: the sizes of its tracked instance, then the parameter count of its data instance"
)]
pub trait DeclaredProblem<const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>: 'static {
    /// The instance whose paths are tracked: the first rows of the data (`#[simhc_problem]`).
    /// Its own [`OnlineSimulator`] builds the start problems: the generated minimum-norm one,
    /// or yours with `#[simhc_problem(simulator = custom)]`.
    type Tracked: CoefficientForm<NX, NF, NP, NC> + ParamDerivative<NX, NF, NP> + ProblemLayout + OnlineSimulator<NX, NF, NP> + Default;
    /// The instance of all the user's rows (its layout reads input files and feeds the learned
    /// start).
    type Data: ProblemLayout;
    /// What decides that an end point is a solution of all the data.
    type Validator: Validator<SVector<f64, ND>, NX>;
    /// The name on the command line (lower case).
    const NAME: &'static str;
    /// One line for `--help`.
    const ABOUT: &'static str;
    /// Names of the errors [`DeclaredProblem::errors`] returns (bench columns).
    const ERRORS: &'static [&'static str];
    /// Whether [`DeclaredProblem::refine`] is implemented: the shipped schedule then starts
    /// with Gauss-Newton on all rows, and bench adds that row.
    const REFINES: bool = false;

    /// A scene with noise of size `noise` (the problem's unit, for example pixels): the
    /// parameters of all its rows (`Data`) and its true unknowns.
    fn scene(&self, rng: &mut ChaCha8Rng, noise: f64) -> (SVector<f64, ND>, SVector<f64, NX>);
    /// The validator for data with noise of size `noise`.
    fn validator(&self, noise: f64) -> Self::Validator;
    /// The errors of an estimate against the truth, in the order of [`DeclaredProblem::ERRORS`].
    fn errors(&self, x: &SVector<f64, NX>, truth: &SVector<f64, NX>) -> Vec<f64>;
    /// Whether errors of [`DeclaredProblem::errors`] count as a success.
    fn correct(&self, errors: &[f64]) -> bool;

    /// Gauss-Newton on all the data's rows from `x0` (typically one line:
    /// `simhc::pipeline::path::gauss_newton::<Self::Data, NX, NFD, ND>(x0, p, &Default::default())`).
    /// With validation rows this is far more selective than Gauss-Newton on the tracked
    /// rows: an extra row removes the basins of the other roots.
    /// [`Refinement::Unsupported`] (the default): the Gauss-Newton attempts run on the tracked
    /// rows. Set [`DeclaredProblem::REFINES`] when you implement it.
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
    /// ([`simhc::pipeline::LayoutRows`]). Implement [`InputRows`] when other numbers make
    /// better features (distances, ratios, invariants); weights trained on one kind of rows do
    /// not load with another.
    fn input_rows(&self) -> Option<&dyn InputRows> {
        None
    }
    /// Training settings (`train` overrides samples, epochs and seed).
    #[cfg(feature = "train")]
    fn training(&self) -> LearnedStartConfig {
        LearnedStartConfig::default()
    }
    /// The shipped weights (for example `include_bytes!`), used when no `--weights` is given.
    fn weights(&self) -> Option<&'static [u8]> {
        None
    }
    /// The same scene seen in random frames (random rigid changes of every frame), for
    /// `bench --random-frames`; `None`: the problem has no such change.
    fn move_frames(
        &self,
        _rng: &mut ChaCha8Rng,
        _p: &SVector<f64, ND>,
        _x: &SVector<f64, NX>,
    ) -> Option<(SVector<f64, ND>, SVector<f64, NX>)> {
        None
    }
    /// All roots of a square subsystem: the pipeline's fallback, the All-roots bench row and
    /// `monodromy` ([`SquareSubsystem`]).
    fn all_roots(&self) -> Option<&dyn AllRoots<NX, ND>> {
        None
    }
    /// The error of one correspondence under `x`, which the robust estimator
    /// ([`crate::Solver::estimate`]) compares with its threshold: `row` holds the row's numbers
    /// in the layout's order, `globals` the global ones. Default: the largest absolute residual
    /// of the row's equations ([`crate::estimate::row_residual`]); a geometric error (angular,
    /// Sampson) makes the threshold mean the same for every correspondence.
    fn row_error(&self, x: &SVector<f64, NX>, row: &[f64], globals: &[f64]) -> f64 {
        crate::estimate::row_residual::<Self::Tracked, NX, NF, NP>(x, row, globals)
    }
}

/// A map of the unknowns from one frame to another.
pub type UnknownsMap<const NX: usize> = Box<dyn Fn(&SVector<f64, NX>) -> SVector<f64, NX>>;

/// The maps of the unknowns between the user's frame and a canonical frame of the data
/// ([`DeclaredProblem::canonicalize`]).
pub struct CanonicalFrame<const NX: usize> {
    /// User's unknowns to canonical ones.
    pub to_canonical: UnknownsMap<NX>,
    /// Canonical unknowns to the user's.
    pub to_user: UnknownsMap<NX>,
}

/// A problem's [`DeclaredProblem::canonicalize`] as the pipeline's [`Canonicalize`].
pub(crate) struct Canon<'a, S, const NF: usize, const NP: usize, const NC: usize>(pub(crate) &'a S);

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Canonicalize<SVector<f64, ND>, NX>
    for Canon<'_, S, NF, NP, NC>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    type Frame = CanonicalFrame<NX>;
    type Canonical = SVector<f64, ND>;
    fn canonicalize(&self, data: &SVector<f64, ND>) -> Option<(CanonicalFrame<NX>, SVector<f64, ND>)> {
        self.0.canonicalize(data).map(|(p, frame)| (frame, p))
    }
    fn to_user(&self, frame: &CanonicalFrame<NX>, x: &SVector<f64, NX>) -> SVector<f64, NX> {
        (frame.to_user)(x)
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

/// All real solutions of a problem's data from a start system, and the monodromy run that
/// makes the start system.
pub trait AllRoots<const NX: usize, const NP: usize> {
    /// The real solutions of the square subsystem of `p` (empty without a start system).
    fn candidates(&self, p: &SVector<f64, NP>) -> Vec<SVector<f64, NX>>;
    /// Whether a start system is loaded.
    fn has_start_system(&self) -> bool;
    /// Finds all solutions of a generic complex instance by monodromy.
    fn monodromy(&self, config: &MonodromyConfig) -> Result<MonodromyReport, StartSystemError>;
}

/// The square subsystem `Q` of a problem: its first `Q::LAYOUT.rows` rows and the global
/// parameters (for example 6 of 7 correspondences), with a start system from `monodromy`.
pub struct SquareSubsystem<Q, const NX: usize, const NQ: usize, const NCQ: usize> {
    start: Option<StartSystem<NX, NQ>>,
    expected: Option<usize>,
    /// Settings of the all-roots solve.
    pub options: AllRootsOptions,
    problem: PhantomData<fn() -> Q>,
}

impl<Q, const NX: usize, const NQ: usize, const NCQ: usize> SquareSubsystem<Q, NX, NQ, NCQ>
where
    Q: CoefficientForm<NX, NX, NQ, NCQ> + ParamDerivative<NX, NX, NQ> + ProblemLayout + ProblemInfo,
{
    /// The subsystem with the start system of a `monodromy` JSON file (`None`: not made yet;
    /// then only `monodromy` works). `expected` is the solution count from theory, if known
    /// (modulo the quaternion sign), for the monodromy report.
    pub fn new(start_json: Option<&str>, expected: Option<usize>) -> Result<Self, StartSystemError> {
        let start = start_json.map(|text| StartSystemFile::from_json(text).and_then(|f| f.start_system::<NX, NQ>())).transpose()?;
        Ok(Self { start, expected, options: AllRootsOptions::default(), problem: PhantomData })
    }
}

/// The sign symmetry `q -> -q` of the first quaternion unknown, if any.
fn quaternion_symmetry(layout: &Layout) -> Option<SignFlip> {
    layout.unknowns.iter().find(|f| f.kind == FieldKind::Quat).map(|f| SignFlip::new((f.offset..f.offset + 4).collect::<Vec<_>>()))
}

impl<Q, const NX: usize, const NQ: usize, const NCQ: usize, const NP: usize> AllRoots<NX, NP> for SquareSubsystem<Q, NX, NQ, NCQ>
where
    Q: CoefficientForm<NX, NX, NQ, NCQ> + ParamDerivative<NX, NX, NQ> + ProblemLayout + ProblemInfo,
{
    fn candidates(&self, p: &SVector<f64, NP>) -> Vec<SVector<f64, NX>> {
        let Some(start) = &self.start else { return Vec::new() };
        let Some(q) = Q::LAYOUT.first_rows::<NQ>(p.as_slice()) else { return Vec::new() };
        solve_all_fast::<Q, NX, NQ, NCQ>(start, &q, &self.options).real.iter().map(|s| s.x).collect()
    }

    fn has_start_system(&self) -> bool {
        self.start.is_some()
    }

    fn monodromy(&self, config: &MonodromyConfig) -> Result<MonodromyReport, StartSystemError> {
        let layout = Q::LAYOUT;
        let fields: Vec<&str> = layout.row.iter().map(|f| f.name).collect();
        let description = format!(
            "{} rows of {} scalars [{}], then {} global scalars, as {}::params",
            layout.rows,
            layout.per_row,
            fields.join(", "),
            layout.globals_len(),
            Q::NAME
        );
        run_monodromy::<Q, NX, NQ>(config, quaternion_symmetry(&layout), &description, self.expected)
    }
}

pub(crate) struct AllRootsFallback<'a, const NX: usize, const ND: usize>(pub(crate) &'a dyn AllRoots<NX, ND>);

impl<const NX: usize, const NP: usize, const ND: usize> Fallback<SVector<f64, ND>, NX, NP> for AllRootsFallback<'_, NX, ND> {
    fn candidates(&self, data: &SVector<f64, ND>, _p: &SVector<f64, NP>) -> Vec<SVector<f64, NX>> {
        self.0.candidates(data)
    }
}

/// The tracked parameters of the data: its first `Q::LAYOUT.rows` rows and its globals, after a
/// check that every value is finite (an error names the row and field of `data_layout`).
pub struct FirstRows<Q> {
    data_layout: Layout,
    problem: PhantomData<fn() -> Q>,
}

impl<Q: ProblemLayout> FirstRows<Q> {
    /// The first rows of data laid out as `data_layout`.
    pub fn new(data_layout: Layout) -> Self {
        Self { data_layout, problem: PhantomData }
    }
}

/// Why [`FirstRows`] cannot make the tracked parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FirstRowsError {
    /// A parameter of the data is NaN or infinite.
    #[error(transparent)]
    NonFinite(#[from] NonFiniteParameter),
    /// The tracked instance is not a first-rows part of the data.
    #[error("the tracked instance has {tracked} parameters, which are not the first rows and the globals of the data's {data}")]
    Sizes {
        /// Parameters of the tracked instance.
        tracked: usize,
        /// Parameters of the data.
        data: usize,
    },
}

impl<Q: ProblemLayout, const NP: usize, const ND: usize> TargetParameters<SVector<f64, ND>, NP> for FirstRows<Q> {
    type Error = FirstRowsError;
    fn params(&self, data: &SVector<f64, ND>) -> Result<SVector<f64, NP>, FirstRowsError> {
        if let Some(index) = data.iter().position(|v| !v.is_finite()) {
            return Err(NonFiniteParameter::locate(&self.data_layout, index).into());
        }
        Q::LAYOUT.first_rows(data.as_slice()).ok_or(FirstRowsError::Sizes { tracked: NP, data: ND })
    }
}

/// A random start for any layout: a uniformly random unit quaternion for each quaternion
/// unknown, a random direction for each field whose norm an equation fixes, zero for the others
/// (the paper's "Rand" rows).
pub struct RandomStart {
    layout: Layout,
    rng: RefCell<ChaCha8Rng>,
}

impl RandomStart {
    /// Random starts for `layout`, seeded.
    pub fn new(layout: Layout, seed: u64) -> Self {
        Self { layout, rng: RefCell::new(ChaCha8Rng::seed_from_u64(seed)) }
    }
}

impl<D: ?Sized, const NX: usize> StartProvider<D, NX> for RandomStart {
    fn name(&self) -> &'static str {
        "random"
    }
    fn start(&self, _: &D) -> Result<SVector<f64, NX>, StartError> {
        let mut x = SVector::<f64, NX>::zeros();
        let mut rng = self.rng.borrow_mut();
        for f in self.layout.unknowns.iter().filter(|f| f.kind == FieldKind::Quat) {
            let q = simhc_problems::metrics::random_unit_quaternion(&mut *rng);
            x.as_mut_slice()[f.offset..f.offset + 4].copy_from_slice(&q);
        }
        // A field whose norm an equation fixes (`t.dot(t) - 1`): a random direction on its
        // sphere, since zero cannot be normalized.
        for n in self.layout.norms {
            let f = &self.layout.unknowns[n.field];
            if f.kind != FieldKind::Quat {
                x.as_mut_slice()[f.offset..f.offset + f.kind.len()].iter_mut().for_each(|v| *v = rng.random_range(-1.0..1.0));
            }
        }
        if !self.layout.normalize_unknowns(x.as_mut_slice()) {
            return Err(StartError { provider: "random", reason: "a random field of zero norm".into() });
        }
        Ok(x)
    }
}

/// The start of `inner`, refined by [`DeclaredProblem::refine`] (an error when that fails).
pub(crate) struct Refined<'a, S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> {
    pub(crate) inner: &'a dyn StartProvider<SVector<f64, ND>, NX>,
    pub(crate) problem: &'a S,
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> StartProvider<SVector<f64, ND>, NX>
    for Refined<'_, S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    fn name(&self) -> &'static str {
        "learned, refined on all rows"
    }
    fn start(&self, p: &SVector<f64, ND>) -> Result<SVector<f64, NX>, StartError> {
        let x0 = self.inner.start(p)?;
        let fail = |reason: &str| StartError { provider: "refined", reason: reason.to_string() };
        match self.problem.refine(p, &x0) {
            Refinement::Converged(x) => Ok(x),
            Refinement::Failed => Err(fail("Gauss-Newton on all rows did not converge")),
            Refinement::Unsupported => Err(fail("the problem has no refinement on all rows")),
        }
    }
}

/// A declared problem as a [`Registration`]: `train`, `bench`, `solve` and, with a square
/// subsystem, `monodromy`.
pub struct Declared<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> {
    problem: Arc<S>,
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Declared<S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    /// Registers `problem`.
    pub fn new(problem: S) -> Self {
        Self { problem: Arc::new(problem) }
    }

    /// The problem.
    pub fn problem(&self) -> &S {
        &self.problem
    }
}

/// `<app> train <problem>`.
#[cfg(feature = "train")]
#[derive(Args, Debug)]
struct TrainArgs {
    /// Training scenes (default: the problem's training settings).
    #[arg(long)]
    samples: Option<usize>,
    /// Epochs (default: the problem's training settings).
    #[arg(long)]
    epochs: Option<usize>,
    /// Seed of the scenes and of the training loop.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Noise of the training scenes (the problem's unit).
    #[arg(long, default_value_t = 0.0)]
    noise: f64,
    /// The weights file to write (default: `<problem>.folded` here).
    #[arg(long)]
    out: Option<PathBuf>,
}

/// `<app> bench <problem>`.
#[derive(Args, Debug)]
struct BenchArgs {
    /// Number of sampled trials.
    #[arg(long, default_value_t = 1000)]
    trials: usize,
    /// Seed of the trials and of the random starts (printed; rerun with it to get the same).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Noise of the sampled scenes (the problem's unit, for example pixels); also sets the
    /// validator's tolerance.
    #[arg(long, default_value_t = 0.0)]
    noise: f64,
    /// Move every sampled scene to random frames (the problem's `move_frames`).
    #[arg(long)]
    random_frames: bool,
    /// Shuffle the rows (correspondences) of every trial.
    #[arg(long)]
    permute: bool,
    /// Read the trials from this JSON file (`[{"params": [..], "truth": [..]}, ..]`).
    #[arg(long)]
    trials_file: Option<PathBuf>,
    /// Write the trials used to this JSON file.
    #[arg(long)]
    dump_trials: Option<PathBuf>,
    /// Weights of the learned start (default: the problem's shipped weights).
    #[arg(long)]
    weights: Option<PathBuf>,
    /// Trials of the All-roots row (the first ones; 0: no row).
    #[arg(long, default_value_t = 100)]
    all_roots: usize,
    /// Print one JSON object instead of the table.
    #[arg(long)]
    json: bool,
}

/// `<app> solve <problem>`.
#[derive(Args, Debug)]
struct SolveArgs {
    /// The correspondences: `{"correspondences": [{field: value, ..}, ..], "globals": {..}}`.
    #[arg(long)]
    input: PathBuf,
    /// Noise level of the data (the problem's unit): the validator's tolerance.
    #[arg(long, default_value_t = 0.0)]
    noise: f64,
    /// Weights of the learned start (default: the problem's shipped weights).
    #[arg(long)]
    weights: Option<PathBuf>,
}

/// Trials: the data's parameters and the true unknowns.
type Trials<const ND: usize, const NX: usize> = Vec<(SVector<f64, ND>, SVector<f64, NX>)>;

/// One trial of a `--trials-file`.
#[derive(Debug, Clone, Serialize, Deserialize)]
struct Trial {
    params: Vec<f64>,
    truth: Vec<f64>,
}

fn parse<A: FromArgMatches>(m: &ArgMatches) -> Result<A, String> {
    A::from_arg_matches(m).map_err(|e| e.to_string())
}

fn print_json(value: &serde_json::Value) -> Result<(), String> {
    println!("{}", serde_json::to_string_pretty(value).map_err(|e| e.to_string())?);
    Ok(())
}

/// The errors and criterion of a problem as a bench [`Score`].
struct ProblemScore<'a, S, const NF: usize, const NP: usize, const NC: usize, const ND: usize>(&'a S);

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Score<NX>
    for ProblemScore<'_, S, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    fn names(&self) -> &[&'static str] {
        S::ERRORS
    }
    fn errors(&self, x: &SVector<f64, NX>, truth: &SVector<f64, NX>) -> Vec<f64> {
        self.0.errors(x, truth)
    }
    fn correct(&self, x: &SVector<f64, NX>, truth: &SVector<f64, NX>) -> bool {
        self.0.correct(&self.0.errors(x, truth))
    }
}

fn bench_json(rows: &[BenchRow]) -> serde_json::Value {
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                let errors: serde_json::Map<String, serde_json::Value> =
                    r.median_errors.iter().map(|(n, e)| (n.to_string(), serde_json::json!(e))).collect();
                serde_json::json!({
                    "method": r.name, "trials": r.trials, "success_pct": r.success_pct(), "solved": r.solved, "wrong": r.wrong,
                    "flagged": r.flagged, "failed": r.failed, "median_errors": errors, "median_us": r.median_us, "mean_us": r.mean_us,
                    "failures": {"input": r.failures.input, "start": r.failures.start, "simulator": r.failures.simulator, "tracker": r.failures.tracker},
                })
            })
            .collect(),
    )
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Declared<S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    fn score(&self) -> ProblemScore<'_, S, NF, NP, NC, ND> {
        ProblemScore(&self.problem)
    }

    fn weights(&self, weights: &Option<PathBuf>) -> Result<std::borrow::Cow<'static, [u8]>, String> {
        Ok(match weights {
            Some(path) => std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?.into(),
            None => self
                .problem
                .weights()
                .ok_or_else(|| format!("{} has no shipped weights: pass --weights FILE (made by `train {}`)", S::NAME, S::NAME))?
                .into(),
        })
    }

    fn solver(&self, weights: &Option<PathBuf>, noise: f64) -> Result<Solver<S, NX, NF, NP, NC, ND>, String> {
        Solver::with_shared(self.problem.clone(), &self.weights(weights)?, noise).map_err(|e| e.to_string())
    }

    #[cfg(feature = "train")]
    fn train(&self, a: TrainArgs) -> Result<(), String> {
        let mut config = self.problem.training();
        config.samples = a.samples.unwrap_or(config.samples);
        config.train.epochs = a.epochs.unwrap_or(config.train.epochs);
        config.train.seed = a.seed;
        config.train.progress = true;
        let out = a.out.unwrap_or_else(|| PathBuf::from(format!("{}.folded", S::NAME)));
        println!("train {}: {} scenes (noise {}), {} epochs, seed {}", S::NAME, config.samples, a.noise, config.train.epochs, a.seed);
        let rows = ProblemRows::<S, NX, NF, NP, NC, ND>::new(self.problem.clone());
        let trained = train_learned_start_with(&S::Data::LAYOUT, rows, &config, |rng| {
            let (mut p, mut x) = self.problem.scene(rng, a.noise);
            if let Some((pc, frame)) = self.problem.canonicalize(&p) {
                (p, x) = (pc, (frame.to_canonical)(&x));
            }
            (p.as_slice().to_vec(), x.as_slice().to_vec())
        })
        .map_err(|e| e.to_string())?;
        std::fs::write(&out, trained.start.network().to_bytes()).map_err(|e| format!("{}: {e}", out.display()))?;
        println!(
            "trained in {:.1} s; last epoch loss {:.4e}; weights: {}",
            trained.run.train_seconds,
            trained.run.epoch_losses.last().copied().unwrap_or(f64::NAN),
            out.display()
        );
        Ok(())
    }

    fn trials(&self, a: &BenchArgs) -> Result<(Trials<ND, NX>, String), String> {
        if let Some(path) = &a.trials_file {
            return Ok((read_trials(path)?, format!("file {}", path.display())));
        }
        let mut rng = ChaCha8Rng::seed_from_u64(a.seed);
        let mut trials = Vec::with_capacity(a.trials);
        for i in 0..a.trials {
            let (mut p, mut x) = self.problem.scene(&mut rng, a.noise);
            if a.random_frames {
                (p, x) = self
                    .problem
                    .move_frames(&mut rng, &p, &x)
                    .ok_or_else(|| format!("{} has no random frames (DeclaredProblem::move_frames)", S::NAME))?;
            }
            if a.permute {
                p = permute_rows(&S::Data::LAYOUT, &p, &mut rng);
            }
            if !p.iter().chain(x.iter()).all(|v| v.is_finite()) {
                return Err(format!("the sampler gave a non-finite trial {i}"));
            }
            trials.push((p, x));
        }
        Ok((trials, format!("sampled, seed {}, noise {}, random frames {}, permuted {}", a.seed, a.noise, a.random_frames, a.permute)))
    }

    fn bench(&self, a: BenchArgs) -> Result<(), String> {
        let (trials, source) = self.trials(&a)?;
        if let Some(path) = &a.dump_trials {
            let file: Vec<Trial> =
                trials.iter().map(|(p, x)| Trial { params: p.as_slice().to_vec(), truth: x.as_slice().to_vec() }).collect();
            std::fs::write(path, serde_json::to_string(&file).map_err(|e| e.to_string())?)
                .map_err(|e| format!("{}: {e}", path.display()))?;
        }
        let solver = self.solver(&a.weights, a.noise)?;
        let learned = solver.learned_start();
        let random = RandomStart::new(S::Data::LAYOUT, a.seed.wrapping_add(1));
        let (target, simulator, validator) =
            (FirstRows::<S::Tracked>::new(S::Data::LAYOUT), Generic(S::Tracked::default()), solver.validator());
        let refined = Refined::<S, NX, NF, NP, NC, ND> { inner: learned, problem: &*self.problem };
        let starts: [&dyn StartProvider<SVector<f64, ND>, NX>; 3] = [learned, &refined, &random];
        let has_refine = S::REFINES;
        let all_roots = self.problem.all_roots().filter(|r| r.has_start_system());
        let fallback = all_roots.map(AllRootsFallback);
        let progress = !a.json;
        if progress {
            println!("{} bench: {} trials ({source}), single thread", S::NAME, trials.len());
        }
        let rand = 2;
        let score = self.score();
        let row = |name: &str, schedule: &[Attempt], with_fallback: bool, trials: &[(SVector<f64, ND>, SVector<f64, NX>)]| {
            let mut pipeline = Pipeline::<S::Tracked, _, _, _, _, NX, NF, NP, NC>::new(&target, &starts, &simulator, validator)
                .with_schedule(schedule)
                .with_options(PipelineOptions { fallback: with_fallback, ..PipelineOptions::default() });
            if let (true, Some(f)) = (with_fallback, &fallback) {
                pipeline = pipeline.with_fallback(f);
            }
            let bar = progress_bar(trials.len() as u64, progress);
            bar.set_message(name.to_string());
            let row = bench_row(name, trials, &score, |d| {
                bar.inc(1);
                pipeline.solve_canonical(&Canon(&*self.problem), d)
            });
            bar.finish_and_clear();
            row
        };
        let shipped = shipped_schedule(S::REFINES);
        let (gauss_newton, simulator_hc) = shipped.split_at(shipped.len() - 1);
        let mut rows = vec![
            bench_estimate_row("Pred Initial", &trials, &score, |p| match self.problem.canonicalize(p) {
                Some((pc, frame)) => StartProvider::<SVector<f64, ND>, NX>::start(learned, &pc).ok().map(|x| (frame.to_user)(&x)),
                None => StartProvider::<SVector<f64, ND>, NX>::start(learned, p).ok(),
            }),
            row(if has_refine { "Pred + Gauss-Newton (all rows)" } else { "Pred + Gauss-Newton" }, gauss_newton, false, &trials),
            row("Rand + Sim HC (one path)", &[Attempt { provider: rand, method: Method::SimulatorHc }], false, &trials),
            row("Pred + Sim HC (one path)", simulator_hc, false, &trials),
            row(if fallback.is_some() { "Shipped (GN, Sim HC, all roots)" } else { "Shipped (GN, then Sim HC)" }, shipped, true, &trials),
        ];
        if fallback.is_some() && a.all_roots > 0 {
            rows.push(row("All-roots HC (validated)", &[], true, &trials[..a.all_roots.min(trials.len())]));
        }
        if a.json {
            return print_json(
                &serde_json::json!({"problem": S::NAME, "source": source, "seed": a.seed, "noise": a.noise, "rows": bench_json(&rows)}),
            );
        }
        print!("{}", table(&rows));
        println!(
            "success: validated (rows after Pred Initial) and {}; errors: medians over returned estimates; times: microseconds per solve; flag: failed validation; fail: why, by the last attempt's error",
            S::ERRORS.join(", ")
        );
        if let [.., shipped, all] = rows.as_slice() {
            if all.name.starts_with("All-roots") && shipped.median_us > 0.0 {
                println!("median time, All-roots / Shipped: {:.1}x", all.median_us / shipped.median_us);
            }
        }
        Ok(())
    }

    fn solve(&self, a: SolveArgs) -> Result<(), String> {
        let layout = S::Data::LAYOUT;
        let text = std::fs::read_to_string(&a.input).map_err(|e| format!("{}: {e}", a.input.display()))?;
        let p = simhc_problems::input::parse_layout_params(&layout, &text).map_err(|e| format!("{}: {e}", a.input.display()))?;
        let p = SVector::<f64, ND>::from_column_slice(&p);
        let solver = self.solver(&a.weights, a.noise)?;
        let unknowns = |x: &SVector<f64, NX>| -> serde_json::Value {
            layout
                .unknowns
                .iter()
                .map(|f| (f.name.to_string(), serde_json::json!(&x.as_slice()[f.offset..f.offset + f.kind.len()])))
                .collect::<serde_json::Map<_, _>>()
                .into()
        };
        match solver.solve(&p) {
            Ok(s) => print_json(&serde_json::json!({
                "problem": S::NAME, "validated": true, "unknowns": unknowns(&s.x), "origin": format!("{:?}", s.origin), "attempts": s.attempts, "check": format!("{:?}", s.check),
            })),
            Err(SolveError::NotValidated { best, check, attempts }) => Err(format!(
                "{}: no solution validated after {attempts} attempts (noise {}; pass --noise for noisy data); best, flagged, NOT a solution: {} (check {check:?})",
                a.input.display(),
                a.noise,
                unknowns(&best),
            )),
            Err(e) => Err(format!("{}: {e}", a.input.display())),
        }
    }
}

/// The rows of `p` in a random order (globals stay).
fn permute_rows<const NP: usize>(layout: &Layout, p: &SVector<f64, NP>, rng: &mut ChaCha8Rng) -> SVector<f64, NP> {
    let mut order: Vec<usize> = (0..layout.rows).collect();
    order.shuffle(rng);
    let mut out = *p;
    for (to, &from) in order.iter().enumerate() {
        for k in 0..layout.per_row {
            out[to * layout.per_row + k] = p[from * layout.per_row + k];
        }
    }
    out
}

fn read_trials<const NP: usize, const NX: usize>(path: &Path) -> Result<Trials<NP, NX>, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let trials: Vec<Trial> =
        serde_json::from_str(&text).map_err(|e| format!("{}: line {}, column {}: {e}", path.display(), e.line(), e.column()))?;
    trials
        .into_iter()
        .enumerate()
        .map(|(i, t)| {
            if t.params.len() != NP || t.truth.len() != NX {
                return Err(format!(
                    "{}: trial {i}: {} params and {} unknowns, expected {NP} and {NX}",
                    path.display(),
                    t.params.len(),
                    t.truth.len()
                ));
            }
            Ok((SVector::from_column_slice(&t.params), SVector::from_column_slice(&t.truth)))
        })
        .collect()
}

impl<S, const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize> Registration
    for Declared<S, NX, NF, NP, NC, ND>
where
    S: DeclaredProblem<NX, NF, NP, NC, ND>,
{
    fn name(&self) -> &'static str {
        S::NAME
    }

    fn command(&self, verb: Verb) -> Option<Command> {
        let c = Command::new(S::NAME);
        let c = match verb {
            #[cfg(feature = "train")]
            Verb::Train => TrainArgs::augment_args(c),
            #[cfg(not(feature = "train"))]
            Verb::Train => return None,
            Verb::Bench => BenchArgs::augment_args(c),
            Verb::Solve => SolveArgs::augment_args(c),
            Verb::Monodromy => {
                self.problem.all_roots()?;
                MonodromyArgs::augment_args(c)
            }
        };
        Some(c.about(S::ABOUT))
    }

    fn run(&self, verb: Verb, args: &ArgMatches) -> Result<(), String> {
        let (data, tracked) = (S::Data::LAYOUT, S::Tracked::LAYOUT);
        if data.param_len() != ND
            || tracked.param_len() != NP
            || tracked.unknown_len() != NX
            || data.unknown_len() != NX
            || tracked.rows > data.rows
        {
            return Err(format!(
                "{}: sizes do not match the instances: Data has {} parameters (ND = {ND}), Tracked {} (NP = {NP}), {} unknowns (NX = {NX}), {} rows of Data's {}",
                S::NAME,
                data.param_len(),
                tracked.param_len(),
                tracked.unknown_len(),
                tracked.rows,
                data.rows
            ));
        }
        match verb {
            #[cfg(feature = "train")]
            Verb::Train => self.train(parse(args)?),
            #[cfg(not(feature = "train"))]
            Verb::Train => Err(crate::builtin::NO_TRAINER.into()),
            Verb::Bench => self.bench(parse(args)?),
            Verb::Solve => self.solve(parse(args)?),
            Verb::Monodromy => {
                let roots =
                    self.problem.all_roots().ok_or_else(|| format!("{} has no square subsystem (DeclaredProblem::all_roots)", S::NAME))?;
                MonodromyArgs::run(args, |config| roots.monodromy(config))
            }
        }
    }
}
