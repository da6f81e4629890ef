//! GRPS as a declared problem ([`simhc::solver::DeclaredProblem`], and
//! [`simhc::solver::Scenes`] for the commands), on 7 and on 8 correspondences
//! ([`Grps7Problem`], [`Grps8Problem`]; [`GrpsSolvers`] dispatches by count), assembled by the
//! runtime's generic [`Solver`]: the one GRPS solver behind `simhc solve grps`, `simhc bench
//! grps|grps7|grps8`, Python `simhc.grps` / `simhc.grps.estimate` and the
//! trainer's evaluation.
//!
//! - tracked and data instance [`Grps8`] (or [`Grps7`]): measured, one path on all 8 correspondences
//!   validates more often than one on the square first 7 (81 against 53 % with the geometric
//!   simulator, `simhc bench grps --experiment stability`), although its intermediate systems
//!   are inconsistent;
//! - the tracked instance's own simulator is the geometric one (`simulator = custom`,
//!   [`super::simulator`]); the minimum-norm one is the other simulator;
//! - the learned start reads [`GrpsFrame`] rows of the canonical data and decodes a 6D
//!   rotation, the translation and the log scale ([`GrpsOutputs`]);
//! - the other starts are the network's predicted rotation with least-squares `(t, s)`, and the
//!   network on the swapped views ([`PredictedStart`]);
//! - the restarts ([`DeclaredProblem::restart`]) are 65: the prediction turned by 20-180
//!   degrees about 13 fixed axes ([`GRPS_RESTART_ANGLES_DEG`]), with least-squares `(t, s)`;
//! - the solve settings (the plan's options, [`grps_pipeline_options`]): end points
//!   polished by Gauss-Newton, 4 more attempts after a plausible (noisy) one;
//! - a RANSAC sample ([`Solver::estimate`]) of 7 keeps up to 4 distinct validated end points
//!   ([`sample_candidates`], [`sample_attempts`]).
//!
//! [`GrpsSolvers`] takes any number of correspondences from 7: more than 8 are checked as a
//! whole, solved on 8 spread over the camera pairs ([`super::spread_first`]), refined on all
//! and validated on all.
//!
//! [`Solver`]: simhc::solver::Solver
//! [`Solver::estimate`]: simhc::solver::Solver::estimate

use super::features::{swap_pose, GrpsFrame, GRPS_OUTPUTS, GRPS_ROW_WIDTH};
use super::geometry::{validate, GrpsError};
use super::learned::{GrpsNetwork, GRPS_WEIGHTS};
use super::pose::GrpsPose;
use super::refine::{angular_residual, refine_pose, translation_scale_for_rotation, LmOptions};
use super::scene::{GrpsCorrespondence, GrpsScene, GrpsSceneConfig};
use super::validation::{GrpsValidator, Validation};
use super::{correspondence_of_row, correspondences_of, row_numbers, spread_first, unknowns_of, Grps7, Grps8, ROW_LEN};
use crate::metrics::{random_unit_quaternion, rotation_error_deg, rotation_from_quat, scale_error_pct, translation_error_pct};
use crate::start_systems::{run_monodromy_grps7, solve_grps7};
use nalgebra::{Matrix3, SVector, Vector3};
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use simhc::all_roots::AllRootsOptions;
use simhc::layout::Layout;
use simhc::pipeline::learned::NonFiniteParameter;
use simhc::pipeline::path::gauss_newton;
use simhc::pipeline::{Generic, InputRows, OutputDecoding, PipelineOptions, StartError, StartProvider, Validator, Verdict};
use simhc::solver::{
    rotated_restart, AllRoots, CanonicalFrame, DeclaredProblem, DegenerateInput, FirstRowsError, Plan, Refinement, Scenes, Solution,
    SolveError, Solver, SolverError,
};
use simhc::start_system::{MonodromyConfig, MonodromyReport, StartSystemError};
use simhc::tracker::{NewtonOptions, TrackerOptions};
use simhc::{MinNormSimulator, ProblemLayout};
use std::sync::Arc;

/// Unknowns `[q, t, s]`.
pub type Unknowns = SVector<f64, 8>;

/// GRPS on `N` correspondences (7 or 8) through the generic assembly (module docs).
pub struct GrpsProblem<const N: usize> {
    all_roots: GrpsAllRoots,
    outputs: GrpsOutputs,
    rows: GrpsRows<N>,
    /// The network of the other starts ([`PredictedStart`]); `None` when it did not load (no
    /// other starts then).
    network: Option<Arc<GrpsNetwork>>,
}

/// GRPS on 7 correspondences (minimal: every real root fits them exactly, so a validated pose
/// may be another root; on the benchmark's 7-point trials about a fifth of the validated poses
/// are. Give 8 or more for a unique pose, or estimate from many with outliers).
pub type Grps7Problem = GrpsProblem<7>;
/// GRPS on 8 correspondences.
pub type Grps8Problem = GrpsProblem<8>;

impl<const N: usize> GrpsProblem<N> {
    /// The problem with the shipped start system and network.
    pub fn new() -> Self {
        Self::with_network(GrpsNetwork::shipped().ok())
    }

    /// The problem whose other starts run `network` (give the one of the solver's weights).
    pub fn with_network(network: Option<GrpsNetwork>) -> Self {
        Self { all_roots: GrpsAllRoots, outputs: GrpsOutputs, rows: GrpsRows, network: network.map(Arc::new) }
    }
}

impl<const N: usize> Default for GrpsProblem<N> {
    fn default() -> Self {
        Self::new()
    }
}

/// The data vector of `NP / 12` correspondences (the declared row order `[f, v, fp, vp]`,
/// rows after rows, no globals: what `Grps7::params` and `Grps8::params` make), or `None` for
/// another count.
pub fn params_of<const NP: usize>(corrs: &[GrpsCorrespondence]) -> Option<SVector<f64, NP>> {
    if corrs.len() * ROW_LEN != NP {
        return None;
    }
    Some(SVector::from_iterator(row_numbers(corrs)))
}

/// Pose errors: rotation (deg), translation and scale (percent).
fn errors(x: &Unknowns, truth: &Unknowns) -> [f64; 3] {
    match (GrpsPose::from_unknowns(x), GrpsPose::from_unknowns(truth)) {
        (Some(a), Some(b)) => [
            rotation_error_deg(&a.rotation, &b.rotation),
            translation_error_pct(&a.translation, &b.translation),
            scale_error_pct(a.scale, b.scale),
        ],
        _ => [f64::INFINITY; 3],
    }
}

/// The unknowns of `(R, t, s)` mapped by `map`.
fn map_unknowns(x: &Unknowns, map: impl Fn(&Matrix3<f64>, &Vector3<f64>, f64) -> (Matrix3<f64>, Vector3<f64>, f64)) -> Unknowns {
    match GrpsPose::from_unknowns(x) {
        Some(p) => {
            let (r, t, s) = map(&p.rotation, &p.translation, p.scale);
            unknowns_of(&r, &t, s)
        }
        None => Unknowns::from_element(f64::NAN),
    }
}

/// A GRPS input error as the runtime's [`DegenerateInput`].
fn degenerate(e: GrpsError) -> DegenerateInput {
    let at = |row: usize, reason| DegenerateInput { row: Some(row), reason };
    let all = |reason| DegenerateInput { row: None, reason };
    match e {
        GrpsError::ZeroBearing { index } => at(index, "zero-length bearing (f or fp)"),
        GrpsError::NonFinite { index } => at(index, "non-finite value"),
        GrpsError::Degenerate { index } => at(index, "degenerate simulated ray"),
        GrpsError::SingleCameraPair => all("all correspondences from one camera pair: scale unobservable"),
        GrpsError::CentralView { view: 1 } => all("all rays of view 1 share one origin: scale unobservable"),
        GrpsError::CentralView { .. } => all("all rays of view 2 share one origin: scale unobservable"),
        GrpsError::TooFewCorrespondences { .. } => all("too few correspondences: GRPS needs at least 7"),
    }
}

/// The restarts' rotations (degrees, each about 13 fixed axes,
/// [`simhc::solver::restart_rotation`]): 65 Gauss-Newton restarts of about 5 us each, which
/// leave a third as many trials to the 12 ms all-roots fallback as 24 restarts did
/// (BENCHMARKS.md, 2026-12-04).
pub const GRPS_RESTART_ANGLES_DEG: [f64; 5] = [20.0, 45.0, 90.0, 135.0, 180.0];

/// Restarts of the declared problems: 13 axes times [`GRPS_RESTART_ANGLES_DEG`].
pub const RESTARTS: usize = 13 * GRPS_RESTART_ANGLES_DEG.len();

/// Attempts of a RANSAC sample of `rows` correspondences ([`DeclaredProblem::SAMPLE_ATTEMPTS`]):
/// the solver's schedule short of the restarts and of the minimum-norm simulator's paths, with
/// the shipped network of one hypothesis: Gauss-Newton from the learned start (refined on all
/// rows, then again) and from the three other starts, then the geometric simulator's path from
/// the learned start and from the first two other starts. Measured on `simhc bench grps
/// --experiment ransac --ransac-trials 300 --seed 1` at 40 % outliers (BENCHMARKS.md,
/// 2026-12-05):
/// - 7 (minimal): 99.7 % with these 8 attempts, 99.3 % with 7, 99.7 % with 9; time a call 115,
///   82 and 138 ms;
/// - 8 (`--ransac-sample 8`, 100 trials): the 5 Gauss-Newton attempts only, 97 % at 41 ms a
///   call against 98 % at 290 ms with 8.
pub const fn sample_attempts(rows: usize) -> usize {
    if rows == 7 {
        8
    } else {
        5
    }
}

/// Distinct validated end points a RANSAC sample of `rows` correspondences may give
/// ([`DeclaredProblem::SAMPLE_CANDIDATES`]): with 7 (minimal) every real root fits the sample
/// exactly and the consensus picks among up to 4 (99.7 % at 40 % outliers, 97 % with one);
/// with 8 only the true pose fits them all, so the first is the model and the search stops.
pub const fn sample_candidates(rows: usize) -> usize {
    if rows == 7 {
        4
    } else {
        1
    }
}

/// The noise (pixels at 800 px) of the validator of a RANSAC sample's pose: plausible up to an
/// angular residual of `0.02` (`10 noise / 800`), two points behind a camera allowed; the
/// threshold of the hand-wired estimator this one replaced.
pub const RANSAC_NOISE_PX: f64 = 1.6;

/// The solve settings of GRPS: paths not required to converge to the last digit (an end point
/// short of the final tolerance is polished by Gauss-Newton, at most 20 iterations, and must
/// then reach an update below `1e-7`), 4 more attempts after a plausible (noisy) end point, the
/// best returned, and the all-roots fallback.
pub fn grps_pipeline_options() -> PipelineOptions {
    PipelineOptions {
        tracker: TrackerOptions { require_final_convergence: false, ..TrackerOptions::single_path() },
        extra_attempts: 4,
        fallback: true,
        newton: NewtonOptions { max_iterations: 20, ..NewtonOptions::default() },
        polish: true,
    }
}

/// Restart `k` around `x` for the correspondences `corrs` ([`DeclaredProblem::restart`]).
fn restart(corrs: &[GrpsCorrespondence], x: &Unknowns, k: usize) -> Option<Unknowns> {
    let turned = rotated_restart(&Grps8::LAYOUT, x, k, &GRPS_RESTART_ANGLES_DEG)?;
    let rotation = GrpsPose::from_unknowns(&turned)?.rotation;
    match translation_scale_for_rotation(&rotation, corrs) {
        Some((t, s)) if s > 0.0 => Some(unknowns_of(&rotation, &t, s)),
        _ => Some(turned),
    }
}

/// The learned start's input rows: [`GrpsFrame`] rows of the `N` (canonical) correspondences.
pub struct GrpsRows<const N: usize>;

impl<const N: usize> InputRows for GrpsRows<N> {
    fn shape(&self) -> (usize, usize) {
        (N, GRPS_ROW_WIDTH)
    }
    fn write(&self, p: &[f64], out: &mut [f32]) -> bool {
        p.len() == N * ROW_LEN && GrpsFrame::IDENTITY.rows(&correspondences_of::<N>(p), out)
    }
}

/// The network's outputs `[a1, a2, t, ln s]` (a 6D rotation, the translation, the log scale)
/// as unknowns `[q, t, s]` ([`GrpsFrame::decode`] in the identity frame: the data is already
/// canonical).
pub struct GrpsOutputs;

impl OutputDecoding for GrpsOutputs {
    fn width(&self) -> usize {
        GRPS_OUTPUTS
    }
    fn decode(&self, out: &[f64], x: &mut [f64]) -> bool {
        let (Ok(out), true) = (<&[f64; GRPS_OUTPUTS]>::try_from(out), x.len() == 8) else { return false };
        match GrpsFrame::IDENTITY.decode(out) {
            Some((r, t, s)) => {
                x.copy_from_slice(unknowns_of(&r, &t, s).as_slice());
                true
            }
            None => false,
        }
    }
}

/// A start from the problem's network beside the learned start's own hypotheses (one per
/// [`PredictedKind`]). Tried only after the learned hypotheses' Gauss-Newton; allocates
/// nothing when the network gives a pose (the correspondences on the stack, the pose cached
/// per thread in fixed-size storage); an error's message is a `String`.
pub struct PredictedStart {
    network: Arc<GrpsNetwork>,
    kind: PredictedKind,
}

/// Which [`PredictedStart`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PredictedKind {
    /// The predicted rotation with its least-squares translation and scale (`s > 0`).
    RotationLeastSquares,
    /// The network on the swapped views (view 2 first, its pose mapped back by [`swap_pose`]: a
    /// second, different input).
    Swapped,
    /// The swapped prediction's rotation with its least-squares translation and scale.
    SwappedRotationLeastSquares,
}

impl PredictedKind {
    /// All three, in the order they are tried.
    pub const ALL: [PredictedKind; 3] = [Self::RotationLeastSquares, Self::Swapped, Self::SwappedRotationLeastSquares];

    fn swapped(self) -> bool {
        self != Self::RotationLeastSquares
    }

    fn least_squares(self) -> bool {
        self != Self::Swapped
    }
}

/// A predicted pose `(R, t, s)`, or why there is none.
type Prediction = Result<(Matrix3<f64>, Vector3<f64>, f64), String>;

/// Parameters a [`PredictedStart`] keeps of the data it last ran on (8 correspondences).
const CACHED_PARAMS: usize = 8 * ROW_LEN;

/// One cached prediction: the network's address, the data's length and numbers, the pose.
type CachedPrediction = (usize, usize, [f64; CACHED_PARAMS], Prediction);

thread_local! {
    /// The network and data of the last prediction in this thread, and its pose, for the plain
    /// and the swapped views: the three [`PredictedStart`]s of a solve, each tried with
    /// Gauss-Newton first and with paths later, run the network twice in all instead of once
    /// per start and method. Keyed by the network's address too, so solvers of other weights
    /// in one thread do not share poses. Fixed-size, so a solve allocates nothing here (but
    /// the message of a cached error).
    static PREDICTED: std::cell::RefCell<[CachedPrediction; 2]> = const {
        std::cell::RefCell::new([(0, 0, [0.0; CACHED_PARAMS], Err(String::new())), (0, 0, [0.0; CACHED_PARAMS], Err(String::new()))])
    };
}

impl<const NP: usize> StartProvider<SVector<f64, NP>, 8> for PredictedStart {
    fn name(&self) -> &'static str {
        match self.kind {
            PredictedKind::RotationLeastSquares => "learned rotation, least-squares (t, s)",
            PredictedKind::Swapped => "learned, swapped views",
            PredictedKind::SwappedRotationLeastSquares => "learned, swapped views, rotation with least-squares (t, s)",
        }
    }
    fn start(&self, p: &SVector<f64, NP>) -> Result<Unknowns, StartError> {
        let fail = |reason: std::borrow::Cow<'static, str>| StartError { provider: "predicted", reason };
        // On the stack: the declared problems have 7 or 8 correspondences.
        let n = NP / ROW_LEN;
        if n == 0 || n * ROW_LEN != NP || NP > CACHED_PARAMS {
            return Err(fail(format!("{NP} parameters are not 7 or 8 correspondences").into()));
        }
        let mut rows = p.as_slice().chunks_exact(ROW_LEN).map(correspondence_of_row);
        let first = rows.next().ok_or_else(|| fail("no correspondence".into()))?;
        let mut held = [first; 8];
        for (slot, c) in held[1..].iter_mut().zip(rows) {
            *slot = c;
        }
        let corrs = &held[..n];
        let predict = || {
            let pose = if self.kind.swapped() {
                let mut swapped = held;
                for c in &mut swapped[..n] {
                    *c = GrpsCorrespondence { f: c.fp, v: c.vp, fp: c.f, vp: c.v };
                }
                let pose = self.network.predict(&swapped[..n]).map_err(|e| e.to_string())?;
                swap_pose(&pose.rotation, &pose.translation, pose.scale)
            } else {
                let pose = self.network.predict(corrs).map_err(|e| e.to_string())?;
                (pose.rotation, pose.translation, pose.scale)
            };
            Ok(pose)
        };
        let (r, t, s) = PREDICTED
            .with_borrow_mut(|cache| {
                let address = Arc::as_ptr(&self.network) as usize;
                let (network, len, data, pose) = &mut cache[usize::from(self.kind.swapped())];
                if *network != address || data[..*len] != *p.as_slice() {
                    *network = address;
                    *len = NP;
                    data[..NP].copy_from_slice(p.as_slice());
                    *pose = predict();
                }
                pose.clone()
            })
            .map_err(|e| fail(e.into()))?;
        if !self.kind.least_squares() {
            return Ok(unknowns_of(&r, &t, s));
        }
        match translation_scale_for_rotation(&r, corrs) {
            Some((t, s)) if s > 0.0 => Ok(unknowns_of(&r, &t, s)),
            _ => Err(fail("no least-squares translation with a positive scale".into())),
        }
    }
}

/// All real roots of the first 7 correspondences from the shipped start system
/// ([`solve_grps7`]).
pub struct GrpsAllRoots;

impl<const NP: usize> AllRoots<8, NP> for GrpsAllRoots {
    fn candidates(&self, p: &SVector<f64, NP>) -> Vec<Unknowns> {
        let Some(first) = p.as_slice().get(..84) else { return Vec::new() };
        let p7 = SVector::<f64, 84>::from_column_slice(first);
        solve_grps7(&p7, &AllRootsOptions::default()).real.iter().map(|s| s.x).collect()
    }
    fn has_start_system(&self) -> bool {
        true
    }
    fn monodromy(&self, config: &MonodromyConfig) -> Result<MonodromyReport, StartSystemError> {
        run_monodromy_grps7(config)
    }
    /// The generic square subsystem of the first 7 correspondences with that start system.
    fn with_start_system(&self, json: &str) -> Result<Box<dyn AllRoots<8, NP> + Send + Sync>, StartSystemError> {
        Ok(Box::new(Grps7::square_subsystem(Some(json), None)?))
    }
}

/// The `DeclaredProblem` and `Scenes` impls of `GrpsProblem<$rows>` on instance `$instance`
/// (`$nf` equations, `$np` parameters): the two differ in their sizes only.
macro_rules! grps_problem {
    ($rows:literal, $instance:ident, $nf:literal, $np:literal, $name:literal, $about:literal) => {
        impl DeclaredProblem<8, $nf, $np, { $instance::NC }, $np> for GrpsProblem<$rows> {
            type Tracked = $instance;
            type Data = $instance;
            type Validator = GrpsValidator;
            const NAME: &'static str = $name;
            /// [`sample_candidates`].
            const SAMPLE_CANDIDATES: usize = sample_candidates($rows);
            /// [`sample_attempts`].
            const SAMPLE_ATTEMPTS: usize = sample_attempts($rows);

            fn validator(&self, noise: f64) -> GrpsValidator {
                GrpsValidator::for_noise(noise, GrpsSceneConfig::default().focal_px)
            }
            /// [`validate`]: zero bearings, a single camera pair, a central view.
            fn check_input(&self, p: &SVector<f64, $np>) -> Result<(), DegenerateInput> {
                validate(&correspondences_of::<$rows>(p.as_slice())).map_err(degenerate)
            }
            fn refine(&self, p: &SVector<f64, $np>, x0: &Unknowns) -> Refinement<8> {
                gauss_newton::<$instance, 8, $nf, $np>(x0, p, &Default::default()).map(|(x, _)| x).into()
            }
            fn canonicalize(&self, p: &SVector<f64, $np>) -> Option<(SVector<f64, $np>, CanonicalFrame<8>)> {
                let corrs = correspondences_of::<$rows>(p.as_slice());
                let frame = GrpsFrame::new(&corrs)?;
                let canonical = params_of::<$np>(&corrs.map(|c| frame.canonical_one(&c)))?;
                let to_canonical = move |x: &Unknowns| map_unknowns(x, |r, t, s| frame.to_canonical(r, t, s));
                let to_user = move |x: &Unknowns| map_unknowns(x, |r, t, s| frame.from_canonical(r, t, s));
                Some((canonical, CanonicalFrame::new(to_canonical, to_user)))
            }
            /// Gauss-Newton on all rows from each learned hypothesis; [`RESTARTS`] restarts; the
            /// other starts ([`PredictedStart`]: the predicted rotation with least-squares
            /// `(t, s)`, the swapped prediction and its rotation with least-squares `(t, s)`) and
            /// the minimum-norm simulator beside the tracked instance's own;
            /// [`grps_pipeline_options`].
            fn plan(&self) -> Plan<SVector<f64, $np>, 8, $nf, $np> {
                let other_starts = match &self.network {
                    Some(network) => PredictedKind::ALL.map(|kind| Box::new(PredictedStart { network: network.clone(), kind }) as _).into(),
                    None => Vec::new(),
                };
                Plan {
                    refine: true,
                    restarts: RESTARTS,
                    other_starts,
                    other_simulators: vec![Box::new(Generic(MinNormSimulator::<$instance>::new()))],
                    options: grps_pipeline_options(),
                    ..Plan::default()
                }
            }
            fn input_rows(&self) -> Option<&dyn InputRows> {
                Some(&self.rows)
            }
            fn outputs(&self) -> Option<&dyn OutputDecoding> {
                Some(&self.outputs)
            }
            fn weights(&self) -> Option<&'static [u8]> {
                Some(GRPS_WEIGHTS)
            }
            /// The prediction's rotation turned about fixed axes ([`rotated_restart`]) with its
            /// least-squares `(t, s)` (the prediction's own where there is none with `s > 0`),
            /// around the first-ranked hypothesis.
            fn restart(&self, p: &SVector<f64, $np>, x: &Unknowns, k: usize) -> Option<Unknowns> {
                restart(&correspondences_of::<$rows>(p.as_slice()), x, k)
            }
            fn all_roots(&self) -> Option<&dyn AllRoots<8, $np>> {
                Some(&self.all_roots)
            }
            /// The robust estimator's error: the angular residual of the correspondence (radians).
            fn row_error(&self, x: &Unknowns, row: &[f64], _globals: &[f64]) -> f64 {
                match (GrpsPose::from_unknowns(x), row.len() == ROW_LEN) {
                    (Some(pose), true) => {
                        let e = angular_residual(&pose.rotation, &pose.translation, pose.scale, &correspondence_of_row(row)).abs();
                        if e.is_nan() {
                            f64::INFINITY
                        } else {
                            e
                        }
                    }
                    _ => f64::INFINITY,
                }
            }
            /// The same pose ([`GrpsPose::same`]): `q` and `-q` are one rotation.
            fn same_solution(&self, a: &Unknowns, b: &Unknowns) -> bool {
                match (GrpsPose::from_unknowns(a), GrpsPose::from_unknowns(b)) {
                    (Some(a), Some(b)) => a.same(&b),
                    _ => false,
                }
            }
        }

        impl Scenes<8, $nf, $np, { $instance::NC }, $np> for GrpsProblem<$rows> {
            const ABOUT: &'static str = $about;
            const ERRORS: &'static [&'static str] = &["E_R deg", "E_t %", "E_s %"];
            fn scene(&self, rng: &mut ChaCha8Rng, noise: f64) -> (SVector<f64, $np>, Unknowns) {
                let config = GrpsSceneConfig { points: $rows, noise_px: noise, ..GrpsSceneConfig::default() };
                // Only a bad noise (negative, not finite) fails: its scene is NaN, which every
                // solve reports as an input error naming row 0.
                match config.sample(rng).ok().and_then(|scene| Some((params_of::<$np>(&scene.correspondences)?, scene))) {
                    Some((p, scene)) => (p, unknowns_of(&scene.rotation, &scene.translation, scene.scale)),
                    None => (SVector::from_element(f64::NAN), Unknowns::from_element(f64::NAN)),
                }
            }
            fn errors(&self, x: &Unknowns, truth: &Unknowns) -> Vec<f64> {
                errors(x, truth).to_vec()
            }
            /// The paper's criterion: `E_R < 2 deg`, `E_t < 5 %`, `E_s < 5 %`.
            fn correct(&self, e: &[f64]) -> bool {
                e.len() == 3 && e[0] < 2.0 && e[1] < 5.0 && e[2] < 5.0
            }
            /// Random rotations of both views, random offsets of their origins, and random units of
            /// view 2 (a factor in `[0.1, 10]`): [`GrpsScene::transformed`].
            fn move_frames(&self, rng: &mut ChaCha8Rng, p: &SVector<f64, $np>, x: &Unknowns) -> Option<(SVector<f64, $np>, Unknowns)> {
                let pose = GrpsPose::from_unknowns(x)?;
                let scene = GrpsScene {
                    correspondences: correspondences_of::<$rows>(p.as_slice()).to_vec(),
                    rotation: pose.rotation,
                    translation: pose.translation,
                    scale: pose.scale,
                };
                let mut frame =
                    || (rotation_from_quat(random_unit_quaternion(rng)), Vector3::from_fn(|_, _| rng.random_range(-10.0..10.0)));
                let (v1, v2) = (frame(), frame());
                let units = 10f64.powf(rng.random_range(-1.0..1.0));
                let moved = scene.transformed((&v1.0, &v1.1), (&v2.0, &v2.1), units);
                Some((params_of::<$np>(&moved.correspondences)?, unknowns_of(&moved.rotation, &moved.translation, moved.scale)))
            }
            /// The problem's sampler with `rows` correspondences (at least the instance's):
            /// rows of 12 numbers `[f, v, fp, vp]`, no globals (`simhc ransac grps7|grps8`).
            fn scene_rows(&self, rng: &mut ChaCha8Rng, rows: usize, noise: f64) -> Option<(Vec<f64>, Vec<f64>, Unknowns)> {
                let config = GrpsSceneConfig { points: rows.max($rows), noise_px: noise, ..GrpsSceneConfig::default() };
                let scene = config.sample(rng).ok()?;
                let data = row_numbers(&scene.correspondences).collect();
                Some((data, Vec::new(), unknowns_of(&scene.rotation, &scene.translation, scene.scale)))
            }
        }
    };
}

grps_problem!(
    7,
    Grps7,
    8,
    84,
    "grps7",
    "Generalized relative pose and scale, 7 correspondences (minimal), through the generic solver assembly"
);
grps_problem!(8, Grps8, 9, 96, "grps8", "Generalized relative pose and scale, 8 correspondences, through the generic solver assembly");

/// The generic solvers of GRPS on 7 and on 8 correspondences behind one call that picks the
/// instance by the number of correspondences; more than 8 are solved on 8 spread over the
/// camera pairs ([`super::spread_first`]), refined on all of them and validated again on all.
/// Both return the runtime's own [`simhc::solver::Solution`] and [`simhc::solver::SolveError`]
/// (the same types for both instances, nothing translated).
pub struct GrpsSolvers {
    /// The solver on 7 correspondences.
    pub seven: Solver<Grps7Problem, 8, 8, 84, { Grps7::NC }, 84>,
    /// The solver on 8 correspondences.
    pub eight: Solver<Grps8Problem, 8, 9, 96, { Grps8::NC }, 96>,
}

/// Why [`GrpsSolvers::solve`] did not return a validated pose.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum GrpsSolversError {
    /// Fewer than 7 correspondences.
    #[error("{0} correspondences: GRPS needs at least 7")]
    Count(usize),
    /// The solve's own error ([`simhc::solver::SolveError`]: input, flagged, no end point).
    #[error(transparent)]
    Solve(#[from] SolveError<Validation, 8>),
}

impl GrpsSolvers {
    /// Both solvers with the shipped weights, validating for noise of `noise_px` pixels.
    pub fn new(noise_px: f64) -> Result<Self, SolverError> {
        Self::with_weights(GRPS_WEIGHTS, noise_px)
    }

    /// Both solvers with the network of `weights` (a `.folded` file of `simhc train grps`) for
    /// the learned start and the other starts, validating for noise of `noise_px` pixels.
    pub fn with_weights(weights: &[u8], noise_px: f64) -> Result<Self, SolverError> {
        let network = GrpsNetwork::from_bytes(weights)?;
        Ok(Self {
            seven: Solver::with_weights(Grps7Problem::with_network(Some(network.clone())), weights, noise_px)?,
            eight: Solver::with_weights(Grps8Problem::with_network(Some(network)), weights, noise_px)?,
        })
    }

    /// Both solvers certifying their solutions as `certification` says
    /// ([`simhc::solver::Certification`]).
    pub fn certifying(self, certification: simhc::solver::Certification) -> Self {
        Self { seven: self.seven.certifying(certification), eight: self.eight.certifying(certification) }
    }

    /// Solves 7 or 8 correspondences with the instance of that count. More: all are checked
    /// (a NaN names its row and field, degenerate geometry is an input error as for 8), 8 of
    /// them spread over the camera pairs are solved ([`super::spread_first`]), and the pose is
    /// refined on all ([`refine_pose`], Levenberg-Marquardt on the angular residuals) and
    /// validated on all: the refined pose, or
    /// the unrefined one where that one passes and the refined does not, or validates better.
    pub fn solve(&self, corrs: &[GrpsCorrespondence]) -> Result<Solution<Validation, 8>, GrpsSolversError> {
        if let Some(p) = params_of::<84>(corrs) {
            return Ok(self.seven.solve(&p)?);
        }
        if let Some(p) = params_of::<96>(corrs) {
            return Ok(self.eight.solve(&p)?);
        }
        if corrs.len() < 7 {
            return Err(GrpsSolversError::Count(corrs.len()));
        }
        let input = |e: FirstRowsError| GrpsSolversError::Solve(SolveError::Input(e));
        if let Some(index) = row_numbers(corrs).position(|v| !v.is_finite()) {
            let layout = Layout { rows: corrs.len(), ..Grps8::LAYOUT };
            return Err(input(NonFiniteParameter::locate(&layout, index).into()));
        }
        validate(corrs).map_err(|e| input(degenerate(e).into()))?;
        // The system is built from the first 8 of `spread_first`: spread over the camera pairs.
        let spread = spread_first(corrs);
        let eight = params_of::<96>(&spread[..8]).expect("more than 8 correspondences");
        let solution = self.eight.solve(&eight)?;
        let validator = self.eight.validator();
        let on_all = |x: SVector<f64, 8>| (x, Validator::<[GrpsCorrespondence], 8>::check(validator, corrs, &x));
        let rejected = |c: &Validation| matches!(Validator::<[GrpsCorrespondence], 8>::verdict(validator, c), Verdict::Reject);
        let unrefined = on_all(solution.x);
        let refined = GrpsPose::from_unknowns(&solution.x).map(|pose| {
            let r = refine_pose(&pose.rotation, &pose.translation, pose.scale, corrs, &LmOptions::default());
            on_all(unknowns_of(&r.rotation, &r.translation, r.scale))
        });
        let (x, check) = match refined {
            Some(r) => match (rejected(&unrefined.1), rejected(&r.1)) {
                (false, true) => unrefined,
                (true, false) => r,
                _ if Validator::<[GrpsCorrespondence], 8>::better(validator, &unrefined.1, &r.1) => unrefined,
                _ => r,
            },
            None => unrefined,
        };
        if rejected(&check) {
            return Err(SolveError::NotValidated { best: x, check, attempts: solution.attempts }.into());
        }
        // The certificate of the pose returned (refined on all), on the 8 solved.
        Ok(Solution { x, check, certified: solution.certified.map(|_| self.eight.certify(&eight, &x)), ..solution })
    }
}
