//! The GRPS Simulator HC solver: regressor -> online simulator (geometric or generic) ->
//! single-path homotopy continuation on the compiled GRPS7 / GRPS8 system, with failure
//! detection and retries.
//!
//! It runs on [`simhc::pipeline`], as every problem does; what is GRPS's own is a few pieces:
//! the start hypotheses (one [`StartProvider`] each), the geometric simulator (a
//! [`StartSimulator`] beside the generic one, which attempts name as
//! [`simhc::pipeline::Method::OtherSimulatorHc`]), the [`Validation`] thresholds (a
//! [`Validator`]), the all-roots fallback (a [`Fallback`]) and, after the pipeline, the
//! refinement on all correspondences.
//!
//! # Pipeline ([`GrpsSolver::solve_report`])
//!
//! 1. Input checks ([`super::geometry::validate`]): at least 7 correspondences, finite values,
//!    non-zero bearings, neither view central (scale observable); typed [`GrpsSolveError`].
//! 2. Canonical frames ([`GrpsFrame`]): both views are rotated, centred and scaled by frames
//!    computed from the data, and everything below runs on the canonical correspondences; the
//!    pose is mapped back at the end and validated again on the user's data. So the regressor,
//!    the simulators and the paths see the same numbers in whatever frames and units the data
//!    came, and success and time do not depend on them (`simhc bench grps --random-frames`).
//!    Regressor ([`GrpsSolver::predict`]): canonical rows ([`super::features`]), the folded
//!    network, `(R, t, s)` decoded from the 6D rotation, canonical translation and log scale.
//! 3. Attempts (start hypothesis x method), in order, until one is accepted:
//!    the prediction (with a network of several hypotheses: the first-ranked, then the others
//!    in rank order, [`GrpsSolver::predict_all`]), its rotation with the least-squares `(t, s)`
//!    ([`super::refine::translation_scale_for_rotation`]), the prediction of the swapped
//!    problem (view 2 first, [`super::features::swap_views`]) and its rotation with
//!    least-squares `(t, s)`, each with the [`GrpsSolverOptions::methods`] (default:
//!    Gauss-Newton on every hypothesis, then Simulator HC with the generic simulator on every
//!    one, then with the geometric one, [`GrpsSolverOptions::by_method`]);
//!    then restarts: the prediction rotated by 20, 45, 90, 135 and 180 degrees about 13 fixed
//!    axes (least-squares `(t, s)`), each with [`GrpsSolverOptions::restart_method`] (default
//!    Gauss-Newton). Simulator HC is the straight-line homotopy in coefficient form from the
//!    simulated start problem, tracked by the adaptive single-path tracker.
//!    `max_attempts = 1` and no fallback is the paper's single path
//!    ([`GrpsSolverOptions::single_path`]).
//! 4. Validation of an end point ([`Validation`]): `s > 0`, every triangulated point in front
//!    of both cameras (cheirality), and the largest angular residual
//!    ([`super::refine::angular_residual`]) over *all* correspondences. Accepted at once when
//!    it is at most `accept_angle` (1e-9: an exact root); *plausible* when at most
//!    `plausible_angle` — then `extra_attempts` more attempts run and the plausible end point
//!    with the smallest residual is returned. Why: with 8 correspondences there is one
//!    redundant equation, and wrong least-squares points of failed paths have residuals of
//!    1e-4 .. 1e-3 (measured), so only exactness (noise-free) or comparison (noisy,
//!    [`GrpsSolverOptions::for_noise`]) tells them from the truth.
//! 5. Fallback ([`GrpsSolverOptions::all_roots_fallback`]): if nothing is plausible, all roots of
//!    the first 7 correspondences (complex homotopy from the shipped 140-solution start
//!    system, ~0.1 s), validated on all correspondences. On the benchmark this runs for ~2 %
//!    of noise-free 8-point problems (regressor far off or an ill-conditioned instance), so
//!    it moves the mean time, not the median.
//! 6. With more than 8 correspondences the system is built from 8 spread over the camera pairs
//!    ([`super::eight_rows`]: 8 of one pair fix only its relative pose up to scale); the
//!    accepted pose is then refined on all of them ([`super::refine::refine_pose`]).
//!
//! If nothing validates, [`GrpsSolveError::NotValidated`] carries the best end point (fewest
//! cheirality violations, then smallest residual): a flagged result, never a silent one. All
//! attempts are counted in the reported times.

use super::features::{swap_pose, swap_views, GrpsFrame, GRPS_OUTPUTS, GRPS_ROW_WIDTH};
use super::geometry::{triangulate_depths, validate, GrpsError};
use super::refine::{angular_residual, refine_pose, rotation_residual, translation_scale_for_rotation, LmOptions};
use super::scene::GrpsCorrespondence;
use super::{spread_first, Grps7, Grps8, Row};
use crate::metrics::rotation_from_quat;
use nalgebra::{Matrix3, SVector, Vector3};
use simhc::pipeline::{
    self, Attempt, Fallback, Generic, Origin, Pipeline, PipelineError, PipelineOptions, Solved, StartError, StartProvider, StartSimulator,
    TargetParameters, Validator, Verdict,
};
use simhc::regressor::{FoldedNetwork, HypothesisBlocks, RegressorError};
use simhc::solver::{restart_rotation, RESTART_AXES};
use simhc::tracker::{solve_newton, NewtonOptions, TrackStats, TrackerOptions};
use simhc::{CoefficientForm, MinNormSimulator, ParamDerivative};
use std::cell::{Cell, OnceCell};
use std::convert::Infallible;
use std::time::{Duration, Instant};

pub use simhc::pipeline::AttemptError;
use thiserror::Error;

/// Most start hypotheses per prediction a GRPS network may output: the runtime's bound, the
/// same for every learned start.
pub use simhc::pipeline::MAX_HYPOTHESES;

/// The shipped GRPS regressor (trained by `simhc train grps`).
pub static GRPS_WEIGHTS: &[u8] = include_bytes!("../../weights/grps.folded");

/// A relative pose and scale: `alpha f + v = R (alpha' f' + s v') + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrpsPose {
    /// Rotation view 2 -> view 1.
    pub rotation: Matrix3<f64>,
    /// Translation.
    pub translation: Vector3<f64>,
    /// Scale (metric length of one view-2 unit).
    pub scale: f64,
}

impl GrpsPose {
    /// The unknown vector `[q, t, s]` of the polynomial system.
    pub fn unknowns(&self) -> SVector<f64, 8> {
        super::unknowns_of(&self.rotation, &self.translation, self.scale)
    }

    /// The pose of an unknown vector (the quaternion normalized), or `None` for a zero or
    /// non-finite quaternion.
    pub fn from_unknowns(x: &SVector<f64, 8>) -> Option<Self> {
        let n = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]).sqrt();
        if !(n > 1e-12 && x.iter().all(|v| v.is_finite())) {
            return None;
        }
        let q = [x[0] / n, x[1] / n, x[2] / n, x[3] / n];
        Some(Self { rotation: rotation_from_quat(q), translation: Vector3::new(x[4], x[5], x[6]), scale: x[7] })
    }
}

/// Which online simulator builds the start problem.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum SimulatorKind {
    /// The paper's: least-squares depths, reprojected first-view ray (flipped when the point is
    /// behind the first camera), [`super::geometry::simulate_ray`].
    Geometric,
    /// The generic minimum-norm parameter correction ([`MinNormSimulator`]).
    Generic,
}

/// One way of going from a start hypothesis to an end point.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Method {
    /// Simulator HC with this simulator.
    Hc(SimulatorKind),
    /// Plain Gauss-Newton on the target system (no homotopy).
    GaussNewton,
    /// All roots of the first 7 correspondences ([`GrpsSolverOptions::all_roots_fallback`]).
    AllRoots,
}

impl Method {
    /// The pipeline's method of an attempt (`None` for [`Method::AllRoots`], the fallback).
    fn in_pipeline(self) -> Option<pipeline::Method> {
        match self {
            Method::Hc(SimulatorKind::Geometric) => Some(pipeline::Method::SimulatorHc),
            Method::Hc(SimulatorKind::Generic) => Some(pipeline::Method::OtherSimulatorHc(0)),
            Method::GaussNewton => Some(pipeline::Method::GaussNewton),
            Method::AllRoots => None,
        }
    }

    /// The method of a pipeline attempt ([`GrpsSolver::pipeline`]).
    fn of(method: pipeline::Method) -> Self {
        match method {
            pipeline::Method::SimulatorHc => Method::Hc(SimulatorKind::Geometric),
            pipeline::Method::OtherSimulatorHc(_) => Method::Hc(SimulatorKind::Generic),
            // GRPS schedules have no `Start` attempts; its starts are never validated as they are.
            pipeline::Method::GaussNewton | pipeline::Method::Start => Method::GaussNewton,
        }
    }
}

/// Where a start hypothesis came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StartKind {
    /// The regressor's `(R, t, s)`.
    Prediction,
    /// The regressor's rotation with the least-squares translation and scale.
    PredictedRotation,
    /// The regressor on the swapped problem (view 2 first), mapped back.
    Swapped,
    /// The swapped prediction's rotation with the least-squares translation and scale.
    SwappedRotation,
    /// The prediction rotated by `restart_angles_deg[k / 13]` about the fixed axis `k % 13`.
    Perturbed(u8),
    /// The regressor's hypothesis of rank `k >= 1` (a network with several hypotheses per
    /// prediction; [`StartKind::Prediction`] is rank 0), ranked by
    /// [`super::refine::rotation_residual`].
    Hypothesis(u8),
    /// A start given by the caller.
    Given,
}

impl StartKind {
    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            StartKind::Prediction => "prediction",
            StartKind::PredictedRotation => "predicted rotation, least-squares t and s",
            StartKind::Swapped => "swapped prediction",
            StartKind::SwappedRotation => "swapped rotation, least-squares t and s",
            StartKind::Perturbed(_) => "perturbed prediction",
            StartKind::Hypothesis(_) => "another hypothesis of the regressor",
            StartKind::Given => "given start",
        }
    }
}

/// The shipped restarts' rotations (degrees, each about 13 fixed axes,
/// [`simhc::solver::restart_rotation`]): [`GrpsSolverOptions::restart_angles_deg`] and the
/// declared problems' [`simhc::solver::DeclaredProblem::restart`].
pub const GRPS_RESTART_ANGLES_DEG: [f64; 5] = [20.0, 45.0, 90.0, 135.0, 180.0];

/// The pipeline's settings of `o`: its tracker, Gauss-Newton and extra attempts; the fallback
/// when `o` has one and more than one attempt; end points the tracker returns short of its
/// final tolerance are polished (module docs).
pub fn pipeline_options(o: &GrpsSolverOptions) -> PipelineOptions {
    PipelineOptions {
        tracker: o.tracker,
        extra_attempts: o.extra_attempts,
        fallback: o.all_roots_fallback && o.max_attempts > 1,
        newton: o.newton,
        polish: true,
    }
}

/// Solver settings; the default is the shipped configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrpsSolverOptions {
    /// Methods tried on each of the first start hypotheses (the prediction, its rotation with
    /// least-squares `(t, s)`, the swapped prediction), in order.
    pub methods: [Option<Method>; 3],
    /// Method tried on each restart (the prediction rotated by `restart_angles_deg` about 13
    /// fixed axes); `None`: no restarts.
    pub restart_method: Option<Method>,
    /// Rotations of the restarts (degrees), each about 13 fixed axes: 65 Gauss-Newton restarts
    /// of about 5 us each, which leave a third as many trials to the 12 ms all-roots fallback as
    /// 24 restarts did (BENCHMARKS.md, 2026-12-04).
    pub restart_angles_deg: [f64; 5],
    /// Attempts (start hypothesis x method) at most; `1` is the paper's single path.
    pub max_attempts: usize,
    /// An end point whose largest angular residual is at most this (and that passes
    /// cheirality) is returned at once. Default `1e-9`: an exact root (noise-free data).
    pub accept_angle: f64,
    /// An end point with residual at most this (and cheirality) is *plausible*: after the first
    /// plausible one, `extra_attempts` more are made and the plausible end point with the
    /// smallest residual is returned. With 8 correspondences there is only one redundant
    /// equation, so wrong least-squares points can have residuals of `1e-4 .. 1e-3`: they are
    /// told apart from the truth only on exact data, or by comparison. Default `1e-6` (exact
    /// data); [`GrpsSolverOptions::for_noise`] sets it from the noise level.
    pub plausible_angle: f64,
    /// Attempts after the first plausible end point. Default `4`.
    pub extra_attempts: usize,
    /// Correspondences allowed behind a camera in a plausible end point. Default `0`; with
    /// noise, the least-squares depth of a far point (nearly parallel rays) can change sign, so
    /// [`GrpsSolverOptions::for_noise`] allows `2`.
    pub max_behind: usize,
    /// Tracker settings of the homotopy paths. Default: [`TrackerOptions::single_path`] without
    /// `require_final_convergence` (an end point that misses the final tolerance is polished by
    /// Gauss-Newton and must then reach an update below `1e-7`).
    pub tracker: TrackerOptions,
    /// Gauss-Newton settings (the Gauss-Newton method).
    pub newton: NewtonOptions,
    /// Last resort when no end point is plausible: all 140 roots of the first 7
    /// correspondences by complex homotopy from the shipped start system
    /// ([`crate::start_systems::solve_grps7`], about 0.1 s), each real one with `s > 0`
    /// polished by Gauss-Newton on the first 8 and validated on all correspondences; the best
    /// by validation wins (with exactly 7 correspondences every root has zero residual, so the
    /// cheirality-valid root closest in rotation to the first start is taken).
    pub all_roots_fallback: bool,
    /// Order of the first attempts: `false`, every method on one start hypothesis before the
    /// next hypothesis; `true`, the first method on every hypothesis, then the second on every
    /// one, and so on (Gauss-Newton, cheap, from each start before any path).
    pub by_method: bool,
}

impl Default for GrpsSolverOptions {
    fn default() -> Self {
        Self {
            // Gauss-Newton on every start hypothesis before any path (`by_method`): on the
            // 8-point trials it validates as often as a path first at half the mean time, and on
            // 7 points it picks the same roots or better (BENCHMARKS.md, 2026-12-04); the paths
            // then take the hypotheses Gauss-Newton could not.
            methods: [Some(Method::GaussNewton), Some(Method::Hc(SimulatorKind::Generic)), Some(Method::Hc(SimulatorKind::Geometric))],
            restart_method: Some(Method::GaussNewton),
            restart_angles_deg: GRPS_RESTART_ANGLES_DEG,
            max_attempts: 80,
            accept_angle: 1e-9,
            plausible_angle: 1e-6,
            extra_attempts: 4,
            max_behind: 0,
            tracker: TrackerOptions { require_final_convergence: false, ..TrackerOptions::single_path() },
            newton: NewtonOptions { max_iterations: 20, ..NewtonOptions::default() },
            all_roots_fallback: true,
            by_method: true,
        }
    }
}

impl GrpsSolverOptions {
    /// The paper's Simulator HC: one path with `simulator`, no retries; the end point is
    /// returned whatever its residual (flagged by [`GrpsSolveError::NotValidated`] when it does
    /// not validate).
    pub fn single_path(simulator: SimulatorKind) -> Self {
        Self {
            methods: [Some(Method::Hc(simulator)), None, None],
            restart_method: None,
            max_attempts: 1,
            all_roots_fallback: false,
            ..Self::default()
        }
    }

    /// The retries with `simulator` first, all three methods on each start hypothesis before the
    /// next (then Gauss-Newton, then the other simulator): the shipped order until 2026-12-04.
    pub fn with_simulator(simulator: SimulatorKind) -> Self {
        let other = match simulator {
            SimulatorKind::Geometric => SimulatorKind::Generic,
            SimulatorKind::Generic => SimulatorKind::Geometric,
        };
        Self {
            methods: [Some(Method::Hc(simulator)), Some(Method::GaussNewton), Some(Method::Hc(other))],
            by_method: false,
            ..Self::default()
        }
    }

    /// For bearing noise of `noise_px` pixels at focal length `focal_px`: plausible end points
    /// up to `max(1e-3, 10 noise_px / focal_px)`, two points behind a camera allowed, and
    /// Gauss-Newton as the method of every start hypothesis (measured: on noisy overdetermined
    /// systems the homotopy's Gauss-Newton corrector converges only linearly, paths take
    /// 100-300 us, and the plausible end points are compared anyway).
    pub fn for_noise(noise_px: f64, focal_px: f64) -> Self {
        Self {
            methods: [Some(Method::GaussNewton), None, None],
            plausible_angle: (10.0 * noise_px / focal_px).max(1e-3),
            max_behind: 2,
            ..Self::default()
        }
    }

    /// The minimal solver inside RANSAC: Simulator HC (geometric) then Gauss-Newton on the
    /// prediction, its rotation with least-squares `(t, s)`, the swapped prediction and its
    /// rotation (8 attempts at most), no restarts, no fallback; used with
    /// [`super::ransac::GrpsEstimator`], which keeps up to 4 distinct plausible end points per
    /// sample (with 7 correspondences every real root is exact: consensus picks).
    pub fn for_ransac() -> Self {
        Self {
            methods: [Some(Method::Hc(SimulatorKind::Geometric)), Some(Method::GaussNewton), None],
            restart_method: None,
            max_attempts: 8,
            plausible_angle: 0.02,
            extra_attempts: 0,
            all_roots_fallback: false,
            // As measured in the RANSAC bench: both methods on a start before the next.
            by_method: false,
            ..Self::default()
        }
    }
}

/// Why a solve failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum GrpsSolveError {
    /// Bad or degenerate input (too few correspondences, non-finite values, zero bearings, one
    /// camera pair or a central view: scale unobservable).
    #[error(transparent)]
    Input(#[from] GrpsError),
    /// The regressor could not run on the input.
    #[error("regressor: {0}")]
    Regressor(#[from] RegressorError),
    /// The regressor's output is not a pose (degenerate 6D rotation or non-finite values).
    #[error("regressor output is not a valid pose")]
    BadPrediction,
    /// The input has no canonical frame: its values are too large to centre and scale.
    #[error("the correspondences have no canonical frame (values too large to centre and scale)")]
    NoCanonicalFrame,
    /// Every attempt failed to track (and the fallback had no candidate).
    #[error("all {attempts} attempts failed; last: {}", match .last { Some(e) => e.to_string(), None => "no end point is a pose".to_string() })]
    NoEndPoint {
        /// Attempts made.
        attempts: usize,
        /// The last failure, if an attempt ran.
        last: Option<AttemptError>,
    },
    /// End points were found but none passed validation; the best one is attached (flagged
    /// result).
    #[error("no end point passed validation (best: max angular residual {:e}, {} behind a camera)", .0.validation.max_angle, .0.validation.behind)]
    NotValidated(Box<GrpsSolveReport>),
}

/// How well an end point explains the correspondences.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Validation {
    /// Largest angular residual over the correspondences ([`angular_residual`]).
    pub max_angle: f64,
    /// Correspondences whose triangulated point is behind one of its cameras (or undefined).
    pub behind: usize,
    /// `s > 0`.
    pub positive_scale: bool,
}

impl Validation {
    /// Validates `pose` on `corrs`.
    pub fn of(pose: &GrpsPose, corrs: &[GrpsCorrespondence]) -> Self {
        let (r, t, s) = (&pose.rotation, &pose.translation, pose.scale);
        let mut max_angle = 0.0f64;
        let mut behind = 0;
        for c in corrs {
            let a = angular_residual(r, t, s, c).abs();
            max_angle = if a.is_nan() { f64::INFINITY } else { max_angle.max(a) };
            match triangulate_depths(r, t, s, c) {
                Some((a1, a2)) if a1 > 0.0 && a2 > 0.0 => {}
                _ => behind += 1,
            }
        }
        Self { max_angle, behind, positive_scale: s > 0.0 }
    }

    /// Whether the end point has `s > 0`, at most `max_behind` points behind a camera and a
    /// residual of at most `angle`.
    pub fn passes(&self, angle: f64, max_behind: usize) -> bool {
        self.positive_scale && self.behind <= max_behind && self.max_angle <= angle
    }

    /// Ordering key of candidates: fewer violations first, then the smaller residual.
    fn key(&self) -> (usize, f64) {
        (self.behind + usize::from(!self.positive_scale) * 1000, self.max_angle)
    }
}

/// Wall time of each stage of one solve (all attempts included).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    /// Canonical rows and forward passes.
    pub regressor: Duration,
    /// Start hypotheses and start problems (simulators).
    pub simulator: Duration,
    /// Path tracking, Gauss-Newton, validation and refinement.
    pub tracking: Duration,
}

/// A solve with its diagnostics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrpsSolveReport {
    /// The pose.
    pub pose: GrpsPose,
    /// The regressor's pose (first start hypothesis), if the regressor ran.
    pub prediction: Option<GrpsPose>,
    /// Validation of the returned pose on all correspondences.
    pub validation: Validation,
    /// Attempts made (1 when the first path validated).
    pub attempts: usize,
    /// The start and method that produced the pose.
    pub start: StartKind,
    /// Method that produced the pose.
    pub method: Method,
    /// Statistics of the successful path (zero for Gauss-Newton).
    pub stats: TrackStats,
    /// Stage timings.
    pub times: StageTimes,
}

/// Simulator HC for generalized relative pose and scale.
#[derive(Debug, Clone)]
pub struct GrpsSolver {
    network: FoldedNetwork,
    /// Settings.
    pub options: GrpsSolverOptions,
}

impl GrpsSolver {
    /// The solver with the shipped regressor and default options.
    pub fn new() -> Result<Self, RegressorError> {
        Ok(Self::with_network(FoldedNetwork::from_bytes(GRPS_WEIGHTS)?))
    }

    /// The solver with a given network (rows of width [`GRPS_ROW_WIDTH`], [`GRPS_OUTPUTS`]
    /// outputs per start hypothesis, at most [`MAX_HYPOTHESES`] hypotheses).
    pub fn with_network(network: FoldedNetwork) -> Self {
        Self { network, options: GrpsSolverOptions::default() }
    }

    /// The same solver with other options.
    pub fn with_options(mut self, options: GrpsSolverOptions) -> Self {
        self.options = options;
        self
    }

    /// The network.
    pub fn network(&self) -> &FoldedNetwork {
        &self.network
    }

    /// Solves for the pose.
    ///
    /// With exactly 7 correspondences the problem is minimal: every real root of the system
    /// fits them exactly, so validation cannot tell the true pose from another real root (on
    /// the benchmark's 7-point trials about a fifth of the validated poses are another root).
    /// Give 8 or more correspondences for a unique pose, or take every root that fits with
    /// [`GrpsSolver::candidates`] and let more data choose (as RANSAC does).
    pub fn solve(&self, corrs: &[GrpsCorrespondence]) -> Result<GrpsPose, GrpsSolveError> {
        self.solve_report(corrs).map(|r| r.pose)
    }

    /// How the network's outputs hold its start hypotheses (blocks of [`GRPS_OUTPUTS`], scored
    /// when there are several); an error for outputs that are not such blocks.
    pub fn blocks(&self) -> Result<HypothesisBlocks, RegressorError> {
        HypothesisBlocks::of(self.network.output_width(), GRPS_OUTPUTS, MAX_HYPOTHESES)
            .ok_or(RegressorError::Format("GRPS network outputs are not 1 to 8 blocks of 10 (and their scores)"))
    }

    /// Start hypotheses per prediction (1 for a network of the wrong outputs, which
    /// [`GrpsSolver::predict`] reports).
    pub fn hypotheses(&self) -> usize {
        self.blocks().map_or(1, |b| b.count)
    }

    /// The regressor's pose for `corrs` (checked input): its first-ranked hypothesis, as
    /// [`GrpsSolver::predict_all`]'s first. Makes no heap allocation for up to 8
    /// correspondences: the declared problems' other starts
    /// ([`super::declared::PredictedStart`]) run it inside a solve.
    pub fn predict(&self, corrs: &[GrpsCorrespondence]) -> Result<GrpsPose, GrpsSolveError> {
        /// Correspondences held on the stack.
        const STACK: usize = 8;
        validate(corrs)?;
        let frame = frame_of(corrs)?;
        let mut best: Option<(f64, GrpsPose)> = None;
        // The first of the lowest rank: what the stable sort of `predict_all` puts first.
        let mut keep = |rank: f64, pose: GrpsPose| {
            if best.is_none_or(|(b, _)| rank.total_cmp(&b).is_lt()) {
                best = Some((rank, pose));
            }
        };
        if let Some(&first) = corrs.first().filter(|_| corrs.len() <= STACK) {
            let mut canonical = [first; STACK];
            for (out, c) in canonical.iter_mut().zip(corrs) {
                *out = frame.canonical_one(c);
            }
            let mut rows = [0.0f32; GRPS_ROW_WIDTH * STACK];
            self.forward_canonical(&canonical[..corrs.len()], &mut rows[..GRPS_ROW_WIDTH * corrs.len()], &mut keep)?;
        } else {
            let mut rows = vec![0.0f32; GRPS_ROW_WIDTH * corrs.len()];
            self.forward_canonical(&frame.canonical(corrs), &mut rows, &mut keep)?;
        }
        let (_, pose) = best.ok_or(GrpsSolveError::BadPrediction)?;
        Ok(from_canonical(&frame, &pose))
    }

    /// All of the regressor's start hypotheses for `corrs`, best-ranked first (by
    /// [`super::refine::rotation_residual`] on the data, not by the network's scores: measured
    /// better there); one for a network with one hypothesis.
    pub fn predict_all(&self, corrs: &[GrpsCorrespondence]) -> Result<Vec<GrpsPose>, GrpsSolveError> {
        validate(corrs)?;
        let frame = frame_of(corrs)?;
        Ok(self.predict_canonical(&frame.canonical(corrs))?.iter().map(|p| from_canonical(&frame, p)).collect())
    }

    /// The regressor's hypotheses for correspondences already in their canonical frames, ranked
    /// (at least one).
    fn predict_canonical(&self, canonical: &[GrpsCorrespondence]) -> Result<Vec<GrpsPose>, GrpsSolveError> {
        let mut rows = vec![0.0f32; GRPS_ROW_WIDTH * canonical.len()];
        let mut ranked: Vec<(f64, GrpsPose)> = Vec::with_capacity(MAX_HYPOTHESES);
        self.forward_canonical(canonical, &mut rows, |rank, pose| ranked.push((rank, pose)))?;
        // Stable: equal ranks keep the network's order.
        ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
        Ok(ranked.into_iter().map(|(_, p)| p).collect())
    }

    /// Runs the network on canonical correspondences (`rows`: a buffer of their input rows)
    /// and hands each decoded hypothesis to `each` with its rank (lower is better; 0 for a
    /// network of one hypothesis); an error when none decodes.
    fn forward_canonical(
        &self,
        canonical: &[GrpsCorrespondence],
        rows: &mut [f32],
        mut each: impl FnMut(f64, GrpsPose),
    ) -> Result<(), GrpsSolveError> {
        let frame = GrpsFrame::IDENTITY;
        if !frame.rows(canonical, rows) {
            return Err(GrpsSolveError::NoCanonicalFrame);
        }
        let blocks = self.blocks()?;
        let mut out = [0.0f64; (GRPS_OUTPUTS + 1) * MAX_HYPOTHESES];
        let out = &mut out[..blocks.outputs()];
        self.network.forward(rows, out)?;
        let mut decoded = 0;
        for block in out[..blocks.count * GRPS_OUTPUTS].chunks_exact(GRPS_OUTPUTS) {
            let Some((rotation, translation, scale)) = block.try_into().ok().and_then(|b| frame.decode(b)) else { continue };
            // Lower ranks first. The data ranks better than the network's scores here
            // (measured, see `rotation_residual`).
            let rank = if blocks.count > 1 { rotation_residual(&rotation, canonical) } else { 0.0 };
            each(rank, GrpsPose { rotation, translation, scale });
            decoded += 1;
        }
        if decoded == 0 {
            return Err(GrpsSolveError::BadPrediction);
        }
        Ok(())
    }

    /// Solves with the regressor's start and the retries of the options.
    ///
    /// Everything after the input checks runs in the canonical frames of the input
    /// ([`GrpsFrame`]): the regressor, the simulators, the paths and the fallback see the same
    /// numbers whatever frames and units the user's data came in, so success and time do not
    /// depend on them. The pose is mapped back, and validated again on the user's data.
    pub fn solve_report(&self, corrs: &[GrpsCorrespondence]) -> Result<GrpsSolveReport, GrpsSolveError> {
        validate(corrs)?;
        // The system is built from the first 8: these spread over the camera pairs.
        let corrs = &*spread_first(corrs);
        let t0 = Instant::now();
        let frame = frame_of(corrs)?;
        let canonical = frame.canonical(corrs);
        let predictions = self.predict_canonical(&canonical)?;
        let mut times = StageTimes { regressor: t0.elapsed(), ..StageTimes::default() };
        let result = self.run(&canonical, &predictions, None, &mut times);
        to_user(result, &frame, corrs)
    }

    /// Solves from a given start (no regressor; the restarts are built around it). A
    /// non-finite start is [`GrpsError::NonFinite`] with `index == usize::MAX`.
    pub fn solve_from(&self, corrs: &[GrpsCorrespondence], start: &GrpsPose) -> Result<GrpsSolveReport, GrpsSolveError> {
        validate(corrs)?;
        let finite = start.rotation.iter().chain(start.translation.iter()).all(|v| v.is_finite()) && start.scale.is_finite();
        if !finite {
            return Err(GrpsSolveError::Input(GrpsError::NonFinite { index: usize::MAX }));
        }
        let corrs = &*spread_first(corrs);
        let mut times = StageTimes::default();
        let frame = frame_of(corrs)?;
        let (rotation, translation, scale) = frame.to_canonical(&start.rotation, &start.translation, start.scale);
        let start = GrpsPose { rotation, translation, scale };
        let result = self.run(&frame.canonical(corrs), &[], Some(start), &mut times);
        to_user(result, &frame, corrs)
    }

    fn run(
        &self,
        corrs: &[GrpsCorrespondence],
        predictions: &[GrpsPose],
        given: Option<GrpsPose>,
        times: &mut StageTimes,
    ) -> Result<GrpsSolveReport, GrpsSolveError> {
        let prediction = predictions.first().copied();
        let base = given.or(prediction).ok_or(GrpsSolveError::BadPrediction)?;
        let base_kind = if given.is_some() { StartKind::Given } else { StartKind::Prediction };
        let (kinds, schedule) = self.schedule(base_kind, predictions.len());
        let hypotheses = Hypotheses::new(self, base, predictions, kinds);
        let result = if corrs.len() == 7 {
            self.pipeline::<Grps7, 7, 8, 84, 266, _>(&hypotheses, Grps7::params, |p| p.with_schedule(&schedule).solve(corrs))
        } else {
            self.pipeline::<Grps8, 8, 9, 96, 304, _>(&hypotheses, Grps8::params, |p| p.with_schedule(&schedule).solve(corrs))
        };
        let regressor = hypotheses.regressor.get();
        times.regressor += regressor;
        // The pipeline's solution as a report, its stage times added to `times`.
        let report = |s: &Solved<Validation, 8>, times: &mut StageTimes| {
            times.simulator += s.times.start.saturating_sub(regressor) + s.times.simulator;
            times.tracking += s.times.target + s.times.tracking + s.times.fallback;
            let (start, method) = match s.origin {
                Origin::Path { provider, method } => (hypotheses.kinds[provider], Method::of(method)),
                Origin::Fallback { .. } => (base_kind, Method::AllRoots),
            };
            let pose = GrpsPose::from_unknowns(&s.x)?;
            Some(GrpsSolveReport {
                pose,
                prediction,
                validation: s.check,
                attempts: s.attempts,
                start,
                method,
                stats: s.stats,
                times: *times,
            })
        };
        match result {
            Ok(s) => match report(&s, times) {
                Some(r) => Ok(self.finish(corrs, r, times)),
                None => Err(GrpsSolveError::NoEndPoint { attempts: s.attempts, last: None }),
            },
            Err(PipelineError::NotValidated(b)) => match report(&b, times) {
                Some(r) => Err(GrpsSolveError::NotValidated(Box::new(r))),
                None => Err(GrpsSolveError::NoEndPoint { attempts: b.attempts, last: None }),
            },
            Err(PipelineError::NoEndPoint { attempts, last }) => Err(GrpsSolveError::NoEndPoint { attempts, last }),
            Err(PipelineError::Input(never)) => match never {},
        }
    }

    /// The pipeline of the first `N` correspondences (GRPS7 or GRPS8; every correspondence
    /// validates), handed to `run`: the geometric simulator first, the generic one as
    /// [`simhc::pipeline::Method::OtherSimulatorHc`]`(0)`, the all-roots fallback from the
    /// hypotheses' base.
    fn pipeline<P, const N: usize, const NF: usize, const NP: usize, const NC: usize, R>(
        &self,
        hypotheses: &Hypotheses<'_>,
        params: fn(&[Row; N]) -> SVector<f64, NP>,
        run: impl FnOnce(GrpsPipeline<'_, P, N, NF, NP, NC>) -> R,
    ) -> R
    where
        P: CoefficientForm<8, NF, NP, NC> + ParamDerivative<8, NF, NP> + simhc::ProblemLayout + simhc::OnlineSimulator<8, NF, NP> + Default,
    {
        let o = &self.options;
        let providers: Vec<Hypothesis> = hypotheses.kinds.iter().map(|&kind| Hypothesis { set: hypotheses, kind }).collect();
        let starts: Vec<&dyn StartProvider<[GrpsCorrespondence], 8>> =
            providers.iter().map(|h| h as &dyn StartProvider<[GrpsCorrespondence], 8>).collect();
        // The instances' own simulator is the geometric one (`simulator = custom`).
        let (target, geometric) = (FirstRows(params), Generic(P::default()));
        let generic = Generic(MinNormSimulator::<P>::new());
        let others: [&dyn StartSimulator<[GrpsCorrespondence], 8, NF, NP>; 1] = [&generic];
        let validator = GrpsValidator::of(o);
        let fallback = AllRootsFallback { base: hypotheses.base, newton: o.newton };
        let options = pipeline_options(o);
        run(Pipeline::new(&target, &starts, &geometric, &validator)
            .with_other_simulators(&others)
            .with_fallback(&fallback)
            .with_options(options))
    }

    /// The start hypotheses and the attempts in order (module docs): `schedule[i].provider`
    /// indexes the hypotheses.
    /// `predictions` is the number of the regressor's hypotheses (0 for a given start).
    fn schedule(&self, base_kind: StartKind, predictions: usize) -> (Vec<StartKind>, Vec<Attempt>) {
        let o = &self.options;
        let first: Vec<Option<pipeline::Method>> = o.methods.iter().flatten().map(|m| m.in_pipeline()).collect();
        let mut kinds = vec![base_kind];
        if base_kind == StartKind::Prediction {
            kinds.extend((1..predictions.min(MAX_HYPOTHESES)).map(|k| StartKind::Hypothesis(k as u8)));
            kinds.extend([StartKind::PredictedRotation, StartKind::Swapped, StartKind::SwappedRotation]);
        }
        let mut slots: Vec<(usize, Option<pipeline::Method>)> = if o.by_method {
            first.iter().flat_map(|&method| (0..kinds.len()).map(move |provider| (provider, method))).collect()
        } else {
            (0..kinds.len()).flat_map(|provider| first.iter().map(move |&method| (provider, method))).collect()
        };
        if let Some(restart) = o.restart_method {
            for k in 0..(o.restart_angles_deg.len() * RESTART_AXES.len()) as u8 {
                slots.push((kinds.len(), restart.in_pipeline()));
                kinds.push(StartKind::Perturbed(k));
            }
        }
        slots.truncate(o.max_attempts);
        // `Method::AllRoots` is the fallback, not an attempt: its slots count towards
        // `max_attempts` and stay empty.
        let schedule = slots.into_iter().filter_map(|(provider, method)| Some(Attempt { provider, method: method? })).collect();
        (kinds, schedule)
    }

    /// Up to `max` distinct plausible end points (no fallback): the hypotheses of a RANSAC
    /// sample. With 7 correspondences every real root is exact, so several cheirality-valid
    /// roots are returned and the consensus picks; the attempts run in the order of
    /// [`GrpsSolver::solve_report`] until `max` are found or `max_attempts` are spent.
    pub fn candidates(&self, corrs: &[GrpsCorrespondence], max: usize) -> Result<Vec<GrpsPose>, GrpsSolveError> {
        validate(corrs)?;
        let frame = frame_of(corrs)?;
        let canonical = frame.canonical(corrs);
        let predictions = self.predict_canonical(&canonical)?;
        let (kinds, schedule) = self.schedule(StartKind::Prediction, predictions.len());
        let hypotheses = Hypotheses::new(self, predictions[0], &predictions, kinds);
        let same = |a: &SVector<f64, 8>, b: &SVector<f64, 8>| match (GrpsPose::from_unknowns(a), GrpsPose::from_unknowns(b)) {
            (Some(a), Some(b)) => {
                (a.rotation - b.rotation).norm() <= 1e-6 && (a.translation - b.translation).norm() <= 1e-6 * (1.0 + a.translation.norm())
            }
            _ => false,
        };
        let found = if canonical.len() == 7 {
            self.pipeline::<Grps7, 7, 8, 84, 266, _>(&hypotheses, Grps7::params, |p| {
                p.with_schedule(&schedule).plausible_end_points(&canonical[..], max, same)
            })
        } else {
            self.pipeline::<Grps8, 8, 9, 96, 304, _>(&hypotheses, Grps8::params, |p| {
                p.with_schedule(&schedule).plausible_end_points(&canonical[..], max, same)
            })
        };
        let found = match found {
            Ok(found) => found,
            Err(never) => match never {},
        };
        Ok(found.iter().filter_map(|s| GrpsPose::from_unknowns(&s.x)).map(|p| from_canonical(&frame, &p)).collect())
    }

    /// With more than 8 correspondences: refine on all of them.
    fn finish(&self, corrs: &[GrpsCorrespondence], mut report: GrpsSolveReport, times: &mut StageTimes) -> GrpsSolveReport {
        if corrs.len() > 8 {
            let t = Instant::now();
            let p = report.pose;
            let refined = refine_pose(&p.rotation, &p.translation, p.scale, corrs, &LmOptions::default());
            let pose = GrpsPose { rotation: refined.rotation, translation: refined.translation, scale: refined.scale };
            let validation = Validation::of(&pose, corrs);
            if validation.key() <= report.validation.key() {
                report.pose = pose;
                report.validation = validation;
            }
            times.tracking += t.elapsed();
        }
        report.times = *times;
        report
    }
}

/// The pipeline of GRPS on its first `N` correspondences.
type GrpsPipeline<'a, P, const N: usize, const NF: usize, const NP: usize, const NC: usize> =
    Pipeline<'a, P, [GrpsCorrespondence], FirstRows<N, NP>, Generic<P>, GrpsValidator, 8, NF, NP, NC>;

/// The start hypotheses of one solve around `base` (module docs, step 3). The swapped
/// prediction is computed once, by the first swapped hypothesis asked.
struct Hypotheses<'s> {
    solver: &'s GrpsSolver,
    base: GrpsPose,
    /// The regressor's hypotheses, ranked (`predictions[0]` is the base when predicted).
    predictions: Vec<GrpsPose>,
    /// The hypotheses in the schedule's order ([`GrpsSolver::schedule`]).
    kinds: Vec<StartKind>,
    swapped: OnceCell<Option<GrpsPose>>,
    /// Time spent in the regressor for the swapped prediction.
    regressor: Cell<Duration>,
}

impl<'s> Hypotheses<'s> {
    fn new(solver: &'s GrpsSolver, base: GrpsPose, predictions: &[GrpsPose], kinds: Vec<StartKind>) -> Self {
        Self { solver, base, predictions: predictions.to_vec(), kinds, swapped: OnceCell::new(), regressor: Cell::new(Duration::ZERO) }
    }

    /// The start of hypothesis `kind` for the canonical `corrs`.
    fn start(&self, kind: StartKind, corrs: &[GrpsCorrespondence]) -> Option<GrpsPose> {
        let base = &self.base;
        // The rotation with its least-squares (t, s), if `s > 0`.
        let least_squares = |rotation: Matrix3<f64>| {
            let (translation, scale) = translation_scale_for_rotation(&rotation, corrs)?;
            (scale > 0.0).then_some(GrpsPose { rotation, translation, scale })
        };
        match kind {
            StartKind::Prediction | StartKind::Given => Some(*base),
            StartKind::PredictedRotation => least_squares(base.rotation),
            StartKind::Hypothesis(k) => self.predictions.get(k as usize).copied(),
            StartKind::Swapped => self.swapped(corrs),
            StartKind::SwappedRotation => least_squares(self.swapped(corrs)?.rotation),
            StartKind::Perturbed(k) => {
                let rotation = restart_rotation(k as usize, &self.solver.options.restart_angles_deg)?.into_inner() * base.rotation;
                Some(least_squares(rotation).unwrap_or(GrpsPose { rotation, ..*base }))
            }
        }
    }

    /// The regressor on the swapped problem (view 2 first), mapped back.
    fn swapped(&self, corrs: &[GrpsCorrespondence]) -> Option<GrpsPose> {
        *self.swapped.get_or_init(|| {
            let t = Instant::now();
            // The swapped canonical views are canonical too.
            let p = self.solver.predict_canonical(&swap_views(corrs)).ok().map(|p| p[0]);
            self.regressor.set(self.regressor.get() + t.elapsed());
            p.map(|p| {
                let (rotation, translation, scale) = swap_pose(&p.rotation, &p.translation, p.scale);
                GrpsPose { rotation, translation, scale }
            })
        })
    }
}

/// One start hypothesis as a start provider of the pipeline.
struct Hypothesis<'h, 's> {
    set: &'h Hypotheses<'s>,
    kind: StartKind,
}

impl StartProvider<[GrpsCorrespondence], 8> for Hypothesis<'_, '_> {
    fn name(&self) -> &'static str {
        self.kind.name()
    }

    fn start(&self, corrs: &[GrpsCorrespondence]) -> Result<SVector<f64, 8>, StartError> {
        self.set.start(self.kind, corrs).map(|p| p.unknowns()).ok_or_else(|| StartError {
            provider: self.kind.name(),
            reason: "no start: no least-squares translation and positive scale, or no swapped prediction".into(),
        })
    }
}

/// The parameters of the first `N` correspondences (checked input: infallible).
struct FirstRows<const N: usize, const NP: usize>(fn(&[Row; N]) -> SVector<f64, NP>);

impl<const N: usize, const NP: usize> TargetParameters<[GrpsCorrespondence], NP> for FirstRows<N, NP> {
    type Error = Infallible;
    fn params(&self, corrs: &[GrpsCorrespondence]) -> Result<SVector<f64, NP>, Infallible> {
        Ok((self.0)(&rows_array::<N>(corrs)))
    }
}

/// [`Validation`] on every correspondence, with the thresholds of the options: of a slice of
/// correspondences (this solver) or of a parameter vector ([`super::declared::GrpsProblem`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrpsValidator {
    accept_angle: f64,
    plausible_angle: f64,
    max_behind: usize,
}

impl GrpsValidator {
    /// The thresholds of `options` ([`GrpsSolverOptions::accept_angle`],
    /// [`GrpsSolverOptions::plausible_angle`], [`GrpsSolverOptions::max_behind`]).
    pub fn of(options: &GrpsSolverOptions) -> Self {
        Self { accept_angle: options.accept_angle, plausible_angle: options.plausible_angle, max_behind: options.max_behind }
    }

    fn check_slice(&self, corrs: &[GrpsCorrespondence], x: &SVector<f64, 8>) -> Validation {
        match GrpsPose::from_unknowns(x) {
            Some(pose) => Validation::of(&pose, corrs),
            None => Validation { max_angle: f64::INFINITY, behind: corrs.len(), positive_scale: false },
        }
    }

    fn verdict_of(&self, v: &Validation) -> Verdict {
        if v.passes(self.accept_angle, 0) {
            Verdict::Accept
        } else if v.passes(self.plausible_angle, self.max_behind) {
            Verdict::Plausible
        } else {
            Verdict::Reject
        }
    }
}

impl Validator<[GrpsCorrespondence], 8> for GrpsValidator {
    type Check = Validation;

    fn check(&self, corrs: &[GrpsCorrespondence], x: &SVector<f64, 8>) -> Validation {
        self.check_slice(corrs, x)
    }
    fn verdict(&self, v: &Validation) -> Verdict {
        self.verdict_of(v)
    }
    fn better(&self, a: &Validation, b: &Validation) -> bool {
        a.key() < b.key()
    }
}

/// Of a parameter vector of up to 8 correspondences (`NP / 12`; more validate nothing).
impl<const NP: usize> Validator<SVector<f64, NP>, 8> for GrpsValidator {
    type Check = Validation;

    fn check(&self, p: &SVector<f64, NP>, x: &SVector<f64, 8>) -> Validation {
        let n = NP / super::ROW_LEN;
        if n > 8 {
            return Validation { max_angle: f64::INFINITY, behind: n, positive_scale: false };
        }
        let mut corrs = [GrpsCorrespondence::default(); 8];
        for (c, row) in corrs.iter_mut().zip(p.as_slice().chunks_exact(super::ROW_LEN)) {
            *c = super::correspondence_of_row(row);
        }
        self.check_slice(&corrs[..n], x)
    }
    fn verdict(&self, v: &Validation) -> Verdict {
        self.verdict_of(v)
    }
    fn better(&self, a: &Validation, b: &Validation) -> bool {
        a.key() < b.key()
    }
}

/// The all-roots fallback ([`GrpsSolverOptions::all_roots_fallback`]) as the pipeline's: one
/// candidate, the best root by [`all_roots_fallback`].
struct AllRootsFallback {
    base: GrpsPose,
    newton: NewtonOptions,
}

impl<const NP: usize> Fallback<[GrpsCorrespondence], 8, NP> for AllRootsFallback {
    fn candidates(&self, corrs: &[GrpsCorrespondence], _p: &SVector<f64, NP>) -> Vec<SVector<f64, 8>> {
        all_roots_fallback(corrs, &self.base, &self.newton).map(|pose| pose.unknowns()).into_iter().collect()
    }
}

/// The canonical frames of checked input.
fn frame_of(corrs: &[GrpsCorrespondence]) -> Result<GrpsFrame, GrpsSolveError> {
    GrpsFrame::new(corrs).ok_or(GrpsSolveError::NoCanonicalFrame)
}

/// A canonical pose in the user's frames.
fn from_canonical(frame: &GrpsFrame, p: &GrpsPose) -> GrpsPose {
    let (rotation, translation, scale) = frame.from_canonical(&p.rotation, &p.translation, p.scale);
    GrpsPose { rotation, translation, scale }
}

/// A canonical report in the user's frames, validated again on the user's correspondences.
fn to_user_report(mut report: GrpsSolveReport, frame: &GrpsFrame, corrs: &[GrpsCorrespondence]) -> GrpsSolveReport {
    report.pose = from_canonical(frame, &report.pose);
    report.prediction = report.prediction.map(|p| from_canonical(frame, &p));
    report.validation = Validation::of(&report.pose, corrs);
    report
}

/// [`to_user_report`] on a result, flagged reports included.
fn to_user(
    result: Result<GrpsSolveReport, GrpsSolveError>,
    frame: &GrpsFrame,
    corrs: &[GrpsCorrespondence],
) -> Result<GrpsSolveReport, GrpsSolveError> {
    match result {
        Ok(report) => Ok(to_user_report(report, frame, corrs)),
        Err(GrpsSolveError::NotValidated(report)) => Err(GrpsSolveError::NotValidated(Box::new(to_user_report(*report, frame, corrs)))),
        Err(e) => Err(e),
    }
}

/// The rows of exactly `N` correspondences.
fn rows_array<const N: usize>(corrs: &[GrpsCorrespondence]) -> [Row; N] {
    let mut rows = [Row::default(); N];
    for (row, c) in rows.iter_mut().zip(corrs) {
        *row = Row::from(c);
    }
    rows
}

/// The all-roots fallback ([`GrpsSolverOptions::all_roots_fallback`]): the best real root of
/// the first 7 correspondences, validated on all of them.
fn all_roots_fallback(corrs: &[GrpsCorrespondence], start: &GrpsPose, newton: &NewtonOptions) -> Option<GrpsPose> {
    let p7 = Grps7::params(&rows_array::<7>(corrs));
    let result = crate::start_systems::solve_grps7(&p7, &simhc::all_roots::AllRootsOptions::default());
    let p8 = (corrs.len() >= 8).then(|| Grps8::params(&rows_array::<8>(corrs)));
    let mut best: Option<(GrpsPose, Validation, f64)> = None;
    for root in &result.real {
        let x = match &p8 {
            Some(p8) => match solve_newton::<Grps8, f64, 8, 9, 96>(&root.x, p8, newton) {
                Ok(r) => r.x,
                Err(_) => root.x,
            },
            None => root.x,
        };
        let Some(pose) = GrpsPose::from_unknowns(&x) else { continue };
        let validation = Validation::of(&pose, corrs);
        // tie-break (7 correspondences: all residuals vanish): distance to the start rotation
        let distance = (pose.rotation - start.rotation).norm();
        let better = best.as_ref().is_none_or(|(_, v, d)| {
            let (k, kb) = (validation.key(), v.key());
            (k.0, if corrs.len() >= 8 { k.1 } else { distance }) < (kb.0, if corrs.len() >= 8 { kb.1 } else { *d })
        });
        if better {
            best = Some((pose, validation, distance));
        }
    }
    best.map(|(p, _, _)| p)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The order of the first attempts: by start hypothesis, or each method on every
    /// hypothesis before the next method (the default), with the restarts after both.
    #[test]
    fn the_schedule_runs_gauss_newton_on_every_start_before_any_path_by_default() {
        let solver = GrpsSolver::new().expect("shipped weights");
        let gn = pipeline::Method::GaussNewton;
        let (kinds, schedule) = solver.schedule(StartKind::Prediction, 1);
        // The prediction, its rotation with least-squares (t, s), and both swapped: 4 starts.
        let starts = kinds.iter().take_while(|k| !matches!(k, StartKind::Perturbed(_))).count();
        assert_eq!(starts, 4);
        let first: Vec<(usize, pipeline::Method)> = schedule.iter().take(3 * starts).map(|a| (a.provider, a.method)).collect();
        assert!(first[..starts].iter().enumerate().all(|(k, &(p, m))| p == k && m == gn), "{first:?}");
        assert!(first[starts..].iter().all(|&(_, m)| m != gn), "{first:?}");
        assert!(schedule[3 * starts..].iter().all(|a| a.provider >= starts && a.method == gn));

        let by_start = solver.clone().with_options(GrpsSolverOptions { by_method: false, ..GrpsSolverOptions::default() });
        let (_, schedule) = by_start.schedule(StartKind::Prediction, 1);
        let first: Vec<usize> = schedule.iter().take(3 * starts).map(|a| a.provider).collect();
        assert_eq!(first, [0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3]);
        let restarts = GrpsSolverOptions::default().restart_angles_deg.len() * RESTART_AXES.len();
        assert_eq!(schedule.len(), 3 * starts + restarts);
    }
}
