//! What only the `simhc-cli` commands need of a declared problem: a scene sampler (`train`,
//! `bench`), the errors a bench reports and when they count as a success, the training
//! settings, random frames (`bench --random-frames`) and many-row scenes (`ransac`). A solve
//! needs none of it, so it is a trait of its own beside [`DeclaredProblem`]: the library solver
//! ([`super::Solver`], its robust estimator, the Python module) asks for `DeclaredProblem`
//! only, the commands for [`Scenes`], which implies it.

use super::problem::DeclaredProblem;
use crate::training::LearnedStartConfig;
use nalgebra::SVector;
use rand_chacha::ChaCha8Rng;

/// A declared problem's scenes and scores: what `train`, `bench`, `ransac`, `solve` and
/// `monodromy` need beyond a solve ([`DeclaredProblem`], a supertrait, so the commands still
/// solve). The sizes are those of the problem's [`DeclaredProblem`] impl; under
/// `#[declared_problem]` the impl writes none, as the `DeclaredProblem` impl does not:
///
/// ```ignore
/// #[simhc::declared_problem]
/// impl simhc::solver::Scenes for GenRelPose {
///     const ABOUT: &'static str = "Generalized relative pose with known scale";
///     const ERRORS: &'static [&'static str] = &["E_R deg", "E_t %"];
///     fn scene(&self, rng: &mut ChaCha8Rng, noise: f64) -> (Params, Unknowns) { scene(rng, noise) }
///     fn errors(&self, x: &Unknowns, truth: &Unknowns) -> Vec<f64> { errors(x, truth).to_vec() }
///     fn correct(&self, e: &[f64]) -> bool { e[0] < 2.0 && e[1] < 5.0 }
/// }
/// ```
#[diagnostic::on_unimplemented(
    message = "`{Self}` does not implement `simhc::solver::Scenes` with these sizes",
    label = "no scenes of sizes NX = {NX}, NF = {NF}, NP = {NP}, NC = {NC}, ND = {ND}: the commands need them",
    note = "implement `simhc::solver::Scenes` for it (a scene sampler, the errors a bench reports) beside `simhc::solver::DeclaredProblem`, both under `#[simhc::declared_problem]`"
)]
pub trait Scenes<const NX: usize, const NF: usize, const NP: usize, const NC: usize, const ND: usize>:
    DeclaredProblem<NX, NF, NP, NC, ND>
{
    /// One line for `--help`.
    const ABOUT: &'static str;
    /// Names of the errors [`Scenes::errors`] returns (bench columns).
    const ERRORS: &'static [&'static str];

    /// A scene with noise of size `noise` (the problem's unit, for example pixels): the
    /// parameters of all its rows (`Data`) and its true unknowns.
    fn scene(&self, rng: &mut ChaCha8Rng, noise: f64) -> (SVector<f64, ND>, SVector<f64, NX>);
    /// The errors of an estimate against the truth, in the order of [`Scenes::ERRORS`].
    fn errors(&self, x: &SVector<f64, NX>, truth: &SVector<f64, NX>) -> Vec<f64>;
    /// Whether errors of [`Scenes::errors`] count as a success.
    fn correct(&self, errors: &[f64]) -> bool;

    /// Training settings of the learned start (`train` overrides samples, epochs and seed):
    /// plain data, the trainer is `simhc-regressor`.
    fn training(&self) -> LearnedStartConfig {
        LearnedStartConfig::default()
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
    /// A scene of `rows` correspondences (at least the data's rows) with noise of size `noise`:
    /// its rows in the data layout's order, row after row, its global numbers and its true
    /// unknowns. The `ransac` command makes wrong matches of some rows (rows of another
    /// scene) and runs [`super::Solver::estimate`] on them. `None` (the default): the problem
    /// has no such sampler, and no `ransac` command.
    fn scene_rows(&self, _rng: &mut ChaCha8Rng, _rows: usize, _noise: f64) -> Option<(Vec<f64>, Vec<f64>, SVector<f64, NX>)> {
        None
    }
}
