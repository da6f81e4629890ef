//! The UPnP Simulator HC solver: start -> geometric online simulator -> single-path homotopy
//! continuation on the compiled UPnP system -> validation -> next start -> all-roots fallback.
//!
//! Pose convention: `alpha_i f_i + v_i = R p_i + t` (world point `p_i`, bearing `f_i` and ray
//! origin `v_i` in the viewer frame); [`UpnpPose`] holds that `R` and `t`.
//!
//! # Why validation
//!
//! A homotopy path ends on a stationary point of the UPnP cost, and from a far start that can
//! be the wrong one. Every end point is therefore checked on all correspondences
//! ([`UpnpValidation`]: the largest angle between a bearing and the direction to its point under
//! the pose, and cheirality). The solver returns the first end point that passes; when none
//! does, not even the global minimum of the all-roots fallback, the best one comes back inside
//! [`SolveError::NotValidated`], never as a plain `Ok`.
//!
//! # Starts
//!
//! [`StartKind::Linear`] is the closed-form linear relaxation ([`super::linear`]): exactly
//! equivariant under rigid changes of the world and viewer frames, so it does not depend on the
//! distribution the regressor was trained on. [`StartKind::Regressor`] is the learned start.
//! [`UpnpSolverOptions::starts`] sets their order.

use super::features::{UpnpFrame, UPNP_OUTPUTS, UPNP_ROW_WIDTH};
use super::geometry::{check_spread, reproject_in_place, upnp_system, validate, UpnpError, UpnpSystem};
use super::linear::{linear_rotation, LinearStartError};
use super::scene::UpnpCorrespondence;
use super::{params_of, Upnp};
use crate::metrics::{quat_from_rotation, rotation_from_quat};
use crate::start_systems::solve_upnp;
use nalgebra::{Matrix3, SVector, Vector3};
use simhc::all_roots::AllRootsOptions;
use simhc::pipeline::{
    AttemptError, Fallback, Origin, Pipeline, PipelineError, PipelineOptions, Solved, StartError, StartProvider, StartSimulator,
    TargetParameters, Validator, Verdict,
};
use simhc::regressor::{FoldedNetwork, RegressorError};
use simhc::tracker::{TrackError, TrackStats, TrackerOptions};
use simhc::SimulatorError;
use std::time::Instant;
use thiserror::Error;

/// The shipped UPnP regressor (trained by `simhc train upnp`).
pub static UPNP_WEIGHTS: &[u8] = include_bytes!("../../weights/upnp.folded");

/// A generalized camera pose: `alpha f + v = R p + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpnpPose {
    /// Rotation world -> viewer.
    pub rotation: Matrix3<f64>,
    /// Translation world -> viewer.
    pub translation: Vector3<f64>,
    /// The unit quaternion `[w, x, y, z]` of `rotation` as tracked.
    pub quaternion: [f64; 4],
}

impl UpnpPose {
    /// The pose of a (not necessarily unit) quaternion with its optimal translation.
    fn of_quaternion(target: &UpnpSystem, q: [f64; 4]) -> Option<Self> {
        let q = normalized(q)?;
        Some(Self { rotation: rotation_from_quat(q), translation: target.translation(q), quaternion: q })
    }
}

/// Where the start of an attempt came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StartKind {
    /// The linear relaxation ([`super::linear::linear_rotation`]).
    Linear,
    /// The learned regressor.
    Regressor,
    /// A start given by the caller ([`UpnpSolver::solve_from`]).
    Given,
}

/// What produced an end point.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// One homotopy path from the start (the paper's Simulator HC).
    SimulatorHc,
    /// The global minimum among all 40 critical points ([`crate::start_systems::solve_upnp`]).
    AllRoots,
}

/// How well a pose explains the correspondences.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpnpValidation {
    /// Largest angle (radians) between a bearing `f_i` and `R p_i + t - v_i`.
    pub max_angle: f64,
    /// Correspondences whose point lies behind its ray origin (`f_i . (R p_i + t - v_i) <= 0`).
    pub behind: usize,
}

impl UpnpValidation {
    /// Validates `pose` on `corrs` (a NaN residual counts as an infinite angle).
    pub fn of(pose: &UpnpPose, corrs: &[UpnpCorrespondence]) -> Self {
        let mut max_angle = 0.0f64;
        let mut behind = 0;
        for c in corrs {
            let d = pose.rotation * c.p + pose.translation - c.v;
            let cos = c.f.dot(&d);
            let angle = c.f.cross(&d).norm().atan2(cos);
            max_angle = if angle.is_nan() { f64::INFINITY } else { max_angle.max(angle) };
            if cos.is_nan() || cos <= 0.0 {
                behind += 1;
            }
        }
        Self { max_angle, behind }
    }

    /// At most `max_behind` points behind their rays and every angle at most `max_angle`.
    pub fn passes(&self, max_angle: f64, max_behind: usize) -> bool {
        self.behind <= max_behind && self.max_angle <= max_angle
    }

    /// [`UpnpValidation::passes`] as the pipeline's verdict.
    pub fn verdict(&self, max_angle: f64, max_behind: usize) -> Verdict {
        if self.passes(max_angle, max_behind) {
            Verdict::Accept
        } else {
            Verdict::Reject
        }
    }

    /// Whether `self` explains the data better than `other` (ranks end points that do not
    /// pass): fewer points behind first, then the residual.
    pub fn better(&self, other: &Self) -> bool {
        (self.behind, self.max_angle) < (other.behind, other.max_angle)
    }
}

/// Solver settings; the default is the shipped configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpnpSolverOptions {
    /// Starts tried in order, one homotopy path each, until an end point validates.
    /// Default: the linear relaxation, then the regressor.
    pub starts: [Option<StartKind>; 2],
    /// Tracker settings of every path. Default: [`TrackerOptions::single_path`].
    pub tracker: TrackerOptions,
    /// Largest angle (radians) between a bearing and its point under an accepted pose. Default
    /// `0.02` (16 px at 800 px focal length): eight times the largest residual at the ground
    /// truth at the paper's 2 px (at most 0.0025 rad over 1000 trials of the peers harness);
    /// [`UpnpSolverOptions::for_noise`] sets it from the noise.
    pub max_angle: f64,
    /// Points allowed behind their rays in an accepted pose. Default `0`.
    pub max_behind: usize,
    /// When no path validates: all 40 critical points of the cost (about 1 ms), the global
    /// minimum validated like any end point. Default `true`.
    pub all_roots_fallback: bool,
}

impl Default for UpnpSolverOptions {
    fn default() -> Self {
        Self {
            starts: [Some(StartKind::Linear), Some(StartKind::Regressor)],
            tracker: TrackerOptions::single_path(),
            max_angle: 0.02,
            max_behind: 0,
            all_roots_fallback: true,
        }
    }
}

impl UpnpSolverOptions {
    /// The paper's Simulator HC: one path from `start`, no fallback; the end point is still
    /// validated (flagged by [`SolveError::NotValidated`] when it fails).
    pub fn single_path(start: StartKind) -> Self {
        Self { starts: [Some(start), None], all_roots_fallback: false, ..Self::default() }
    }

    /// For bearing noise of `noise_px` pixels at focal length `focal_px`: accepted residuals up to
    /// `max(8 noise_px / focal_px, 1e-6)` radians.
    pub fn for_noise(noise_px: f64, focal_px: f64) -> Self {
        Self { max_angle: (8.0 * noise_px / focal_px).max(1e-6), ..Self::default() }
    }
}

/// Why a solve failed.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum SolveError {
    /// Bad input: too few correspondences, non-finite values, zero bearings, degenerate rays.
    #[error(transparent)]
    Input(#[from] UpnpError),
    /// The regressor could not run on the input.
    #[error("regressor: {0}")]
    Regressor(#[from] RegressorError),
    /// The linear start is not available for this input.
    #[error("linear start: {0}")]
    Linear(#[from] LinearStartError),
    /// The simulator could not build a start problem (a reprojected point on its ray origin).
    #[error("simulator: {0}")]
    Simulator(#[from] SimulatorError),
    /// No start provider had a start.
    #[error(transparent)]
    Start(#[from] StartError),
    /// The homotopy path failed; the code says how.
    #[error("tracking failed: {0}")]
    Tracker(#[from] TrackError),
    /// Every attempt ended, but no end point passed validation. The best one (fewest points
    /// behind, then the smallest residual) is inside, flagged: do not use it as a pose.
    #[error(
        "no pose validated after {} attempts (best: largest angular residual {:.3e} rad, {} points behind)",
        .0.attempts, .0.validation.max_angle, .0.validation.behind
    )]
    NotValidated(Box<UpnpSolveReport>),
}

pub use simhc::pipeline::StageTimes;

/// A solve with its diagnostics.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpnpSolveReport {
    /// The pose.
    pub pose: UpnpPose,
    /// The start quaternion of the attempt that produced the pose.
    pub start: [f64; 4],
    /// Where that start came from.
    pub start_kind: StartKind,
    /// What produced the pose.
    pub method: Method,
    /// Attempts made, the fallback included (1 when the first path validated).
    pub attempts: usize,
    /// Validation of the pose on all correspondences.
    pub validation: UpnpValidation,
    /// Path statistics of the attempt that produced the pose (zero for the fallback).
    pub stats: TrackStats,
    /// Stage timings.
    pub times: StageTimes,
}

/// Simulator HC for generalized absolute pose.
#[derive(Debug, Clone)]
pub struct UpnpSolver {
    network: FoldedNetwork,
    /// Settings.
    pub options: UpnpSolverOptions,
}

impl UpnpSolver {
    /// The solver with the shipped regressor weights and default options.
    pub fn new() -> Result<Self, RegressorError> {
        Ok(Self::with_network(FoldedNetwork::from_bytes(UPNP_WEIGHTS)?))
    }

    /// The solver with a given network (input rows of width [`UPNP_ROW_WIDTH`], 4 outputs).
    pub fn with_network(network: FoldedNetwork) -> Self {
        Self { network, options: UpnpSolverOptions::default() }
    }

    /// The network of the learned start.
    pub fn network(&self) -> &FoldedNetwork {
        &self.network
    }

    /// The same solver with other options.
    pub fn with_options(mut self, options: UpnpSolverOptions) -> Self {
        self.options = options;
        self
    }

    /// Solves for the pose.
    pub fn solve(&self, corrs: &[UpnpCorrespondence]) -> Result<UpnpPose, SolveError> {
        self.solve_report(corrs).map(|r| r.pose)
    }

    /// The regressor's quaternion for the correspondences (unit, `[w, x, y, z]`).
    pub fn predict(&self, corrs: &[UpnpCorrespondence]) -> Result<[f64; 4], SolveError> {
        validate(corrs)?;
        self.predict_unchecked(corrs)
    }

    /// The regressor on the canonical rows ([`super::features`]), decoded to the input frames.
    fn predict_unchecked(&self, corrs: &[UpnpCorrespondence]) -> Result<[f64; 4], SolveError> {
        predict(&self.network, corrs)
    }

    /// The start quaternion of the linear relaxation.
    pub fn linear_start(&self, corrs: &[UpnpCorrespondence]) -> Result<[f64; 4], SolveError> {
        validate(corrs)?;
        Ok(quat_from_rotation(&linear_rotation(corrs)?))
    }

    /// Solves with the starts of the options, validation and the fallback.
    pub fn solve_report(&self, corrs: &[UpnpCorrespondence]) -> Result<UpnpSolveReport, SolveError> {
        let starts: Vec<StartKind> = self.options.starts.iter().flatten().copied().collect();
        self.run(corrs, &starts, None, self.options.all_roots_fallback)
    }

    /// One path from a given start quaternion (e.g. a random one, for the ablation), validated,
    /// no fallback.
    pub fn solve_from(&self, corrs: &[UpnpCorrespondence], q0: [f64; 4]) -> Result<UpnpSolveReport, SolveError> {
        let q0 = normalized(q0).ok_or(UpnpError::NonFinite { index: usize::MAX })?;
        self.run(corrs, &[StartKind::Given], Some(q0), false)
    }

    /// The input checks, then [`simhc::pipeline`] with the UPnP pieces ([`UpnpInstance`]).
    fn run(
        &self,
        corrs: &[UpnpCorrespondence],
        kinds: &[StartKind],
        given: Option<[f64; 4]>,
        fallback: bool,
    ) -> Result<UpnpSolveReport, SolveError> {
        let o = &self.options;
        let t0 = Instant::now();
        let system = upnp_system(corrs)?;
        check_spread(corrs)?;
        let checks = t0.elapsed();
        let instance = UpnpInstance { corrs, system };
        let given = GivenStart(given.map(SVector::from));
        let (linear, regressor) = (LinearStart, RegressorStart(self));
        let starts: Vec<&dyn StartProvider<UpnpInstance, 4>> = kinds
            .iter()
            .map(|k| -> &dyn StartProvider<UpnpInstance, 4> {
                match k {
                    StartKind::Linear => &linear,
                    StartKind::Regressor => &regressor,
                    StartKind::Given => &given,
                }
            })
            .collect();
        let validator = UpnpValidator { max_angle: o.max_angle, max_behind: o.max_behind };
        let options = PipelineOptions { tracker: o.tracker, extra_attempts: 0, fallback, ..PipelineOptions::default() };
        let pipeline = Pipeline::<Upnp, _, _, _, _, 4, 5, 66, 35>::new(&TargetOfSystem, &starts, &GeometricSimulator, &validator)
            .with_fallback(&GlobalMinimum)
            .with_options(options);
        let report = |solved: Solved<UpnpValidation, 4>| -> Result<UpnpSolveReport, SolveError> {
            let q = [solved.x[0], solved.x[1], solved.x[2], solved.x[3]];
            let pose = UpnpPose::of_quaternion(&instance.system, q).ok_or(TrackError::NonFinite { t: 1.0 })?;
            let (start_kind, method) = match solved.origin {
                Origin::Path { provider, .. } => (kinds[provider], Method::SimulatorHc),
                // The fallback is credited to the first start, as before the pipeline.
                Origin::Fallback { .. } => (kinds.first().copied().unwrap_or(StartKind::Linear), Method::AllRoots),
            };
            let mut times = solved.times;
            times.target += checks;
            let start = [solved.start[0], solved.start[1], solved.start[2], solved.start[3]];
            Ok(UpnpSolveReport {
                pose,
                start,
                start_kind,
                method,
                attempts: solved.attempts,
                validation: solved.check,
                stats: solved.stats,
                times,
            })
        };
        match pipeline.solve(&instance) {
            Ok(solved) => report(solved),
            Err(PipelineError::NotValidated(best)) => Err(SolveError::NotValidated(Box::new(report(best)?))),
            Err(PipelineError::NoEndPoint { last, .. }) => Err(match last {
                Some(AttemptError::Start(e)) => SolveError::Start(e),
                Some(AttemptError::Simulator(e)) => SolveError::Simulator(e),
                Some(AttemptError::Tracker(e)) => SolveError::Tracker(e),
                None => SolveError::Tracker(TrackError::NonFinite { t: 0.0 }),
            }),
            Err(PipelineError::Input(never)) => match never {},
        }
    }
}

/// The data of one UPnP solve: the checked correspondences and their cost matrices.
pub struct UpnpInstance<'a> {
    /// The correspondences.
    pub corrs: &'a [UpnpCorrespondence],
    /// Their cost and translation matrices.
    pub system: UpnpSystem,
}

/// The target parameters: the entries of `M`.
struct TargetOfSystem;

impl TargetParameters<UpnpInstance<'_>, 66> for TargetOfSystem {
    type Error = std::convert::Infallible;
    fn params(&self, data: &UpnpInstance<'_>) -> Result<SVector<f64, 66>, Self::Error> {
        Ok(params_of(&data.system.m))
    }
}

/// [`StartKind::Linear`].
struct LinearStart;

impl StartProvider<UpnpInstance<'_>, 4> for LinearStart {
    fn name(&self) -> &'static str {
        "linear"
    }
    fn start(&self, data: &UpnpInstance<'_>) -> Result<SVector<f64, 4>, StartError> {
        let r = linear_rotation(data.corrs).map_err(|e| StartError { provider: "linear", reason: e.to_string().into() })?;
        Ok(SVector::from(quat_from_rotation(&r)))
    }
}

/// [`StartKind::Regressor`].
struct RegressorStart<'s>(&'s UpnpSolver);

impl StartProvider<UpnpInstance<'_>, 4> for RegressorStart<'_> {
    fn name(&self) -> &'static str {
        "regressor"
    }
    fn start(&self, data: &UpnpInstance<'_>) -> Result<SVector<f64, 4>, StartError> {
        let q = self.0.predict_unchecked(data.corrs).map_err(|e| StartError { provider: "regressor", reason: e.to_string().into() })?;
        Ok(SVector::from(q))
    }
}

/// [`StartKind::Given`].
struct GivenStart(Option<SVector<f64, 4>>);

impl StartProvider<UpnpInstance<'_>, 4> for GivenStart {
    fn name(&self) -> &'static str {
        "given"
    }
    fn start(&self, _data: &UpnpInstance<'_>) -> Result<SVector<f64, 4>, StartError> {
        self.0.ok_or(StartError { provider: "given", reason: "no start quaternion".into() })
    }
}

/// The paper's geometric simulator ([`simulate`]).
struct GeometricSimulator;

impl StartSimulator<UpnpInstance<'_>, 4, 5, 66> for GeometricSimulator {
    fn simulate(&self, data: &UpnpInstance<'_>, x0: &SVector<f64, 4>, _p: &SVector<f64, 66>) -> Result<SVector<f64, 66>, SimulatorError> {
        let m = simulate(&data.system, data.corrs, [x0[0], x0[1], x0[2], x0[3]]).map_err(|_| SimulatorError::Singular)?;
        Ok(params_of(&m))
    }
}

/// [`UpnpValidation`] with the options' thresholds.
struct UpnpValidator {
    max_angle: f64,
    max_behind: usize,
}

impl Validator<UpnpInstance<'_>, 4> for UpnpValidator {
    type Check = UpnpValidation;
    fn check(&self, data: &UpnpInstance<'_>, x: &SVector<f64, 4>) -> UpnpValidation {
        match UpnpPose::of_quaternion(&data.system, [x[0], x[1], x[2], x[3]]) {
            Some(pose) => UpnpValidation::of(&pose, data.corrs),
            None => UpnpValidation { max_angle: f64::INFINITY, behind: data.corrs.len() },
        }
    }
    fn verdict(&self, check: &UpnpValidation) -> Verdict {
        check.verdict(self.max_angle, self.max_behind)
    }
    fn better(&self, a: &UpnpValidation, b: &UpnpValidation) -> bool {
        a.better(b)
    }
}

/// The all-roots fallback: the global minimum of the cost ([`global_minimum`]), one candidate.
struct GlobalMinimum;

impl Fallback<UpnpInstance<'_>, 4, 66> for GlobalMinimum {
    fn candidates(&self, data: &UpnpInstance<'_>, _p: &SVector<f64, 66>) -> Vec<SVector<f64, 4>> {
        global_minimum(&data.system).map(|pose| SVector::from(pose.quaternion)).into_iter().collect()
    }
}

/// The regressor's unit quaternion for the correspondences: `network` on their canonical rows
/// ([`super::features`]), decoded to the input frames. The correspondences are not checked.
pub fn predict(network: &FoldedNetwork, corrs: &[UpnpCorrespondence]) -> Result<[f64; 4], SolveError> {
    /// Correspondences whose input rows are held on the stack (a RANSAC sample, a usual
    /// solve): no heap allocation for them.
    const STACK: usize = 32;
    let frame = UpnpFrame::new(corrs).ok_or(UpnpError::CollinearPoints)?;
    let mut stack = [0.0f32; UPNP_ROW_WIDTH * STACK];
    let mut heap = Vec::new();
    let rows = if corrs.len() <= STACK {
        &mut stack[..UPNP_ROW_WIDTH * corrs.len()]
    } else {
        heap.resize(UPNP_ROW_WIDTH * corrs.len(), 0.0f32);
        &mut heap[..]
    };
    if !frame.rows(corrs, rows) {
        return Err(RegressorError::NonFinite.into());
    }
    let mut out = [0.0f64; UPNP_OUTPUTS];
    network.forward(rows, &mut out)?;
    Ok(frame.decode(&out).ok_or(RegressorError::NonFinite)?)
}

/// The pose of the smallest cost among all real critical points (`None` when the all-roots
/// solver finds no real one).
pub fn global_minimum(target: &UpnpSystem) -> Option<UpnpPose> {
    let result = solve_upnp(&params_of(&target.m), &AllRootsOptions::default());
    result
        .real
        .iter()
        .filter_map(|s| UpnpPose::of_quaternion(target, [s.x[0], s.x[1], s.x[2], s.x[3]]))
        .min_by(|a, b| target.cost(a.quaternion).total_cmp(&target.cost(b.quaternion)))
}

/// The paper's geometric simulator: reproject the points under `(R(q0), t*(q0))` and rebuild
/// `M`; `q0` then solves the start system exactly (its simulated cost is zero).
pub fn simulate(target: &UpnpSystem, corrs: &[UpnpCorrespondence], q0: [f64; 4]) -> Result<nalgebra::SMatrix<f64, 11, 11>, UpnpError> {
    reprojected_cost(&rotation_from_quat(q0), &target.translation(q0), corrs)
}

/// The cost matrix of the correspondences with their bearings reprojected under `(r, t)`,
/// which `(r, t)` then solves exactly.
pub fn reprojected_cost(
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
    corrs: &[UpnpCorrespondence],
) -> Result<nalgebra::SMatrix<f64, 11, 11>, UpnpError> {
    let mut simulated = corrs.to_vec();
    reproject_in_place(r, t, &mut simulated)?;
    Ok(upnp_system(&simulated)?.m)
}

fn normalized(q: [f64; 4]) -> Option<[f64; 4]> {
    let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    (n > 0.0 && n.is_finite()).then(|| q.map(|v| v / n))
}
