//! The GRPS Simulator HC solver: regressor -> online simulator (geometric or generic) ->
//! single-path homotopy continuation on the compiled GRPS7 / GRPS8 system, with failure
//! detection and retries.
//!
//! # Pipeline ([`GrpsSolver::solve_report`])
//!
//! 1. Input checks ([`super::geometry::validate`]): at least 7 correspondences, finite values,
//!    non-zero bearings, neither view central (scale observable); typed [`GrpsSolveError`].
//! 2. Regressor ([`GrpsSolver::predict`]): canonical rows ([`super::features`]), the folded
//!    network, `(R, t, s)` decoded from the 6D rotation, canonical translation and log scale.
//! 3. Attempts, in order, until one is *validated* (below):
//!    for each start hypothesis — the prediction; its rotation with the least-squares `(t, s)`
//!    ([`super::refine::translation_scale_for_rotation`]); the prediction of the swapped
//!    problem (view 2 first, [`super::features::swap_views`]); the prediction rotated by
//!    `perturbation_deg` about fixed axes — run the [`Method`]s of
//!    [`GrpsSolverOptions::methods`]: Simulator HC with the geometric or the generic
//!    simulator (straight-line homotopy in coefficient form, the adaptive single-path tracker),
//!    or plain Gauss-Newton on the target. `max_attempts = 1` is the paper's single path.
//! 4. Validation of an end point ([`Validation`]): the rotation is proper and `s > 0`; every
//!    correspondence's triangulated point is in front of both cameras (cheirality); and the
//!    largest angular residual ([`super::refine::angular_residual`]) is at most
//!    `accept_angle`. With 8 or more correspondences the system is overdetermined, so a wrong
//!    end point (a least-squares point of a failed path, or a root of a 7-subset) has a large
//!    residual; with 7 only cheirality can reject a wrong exact root.
//! 5. With more than 8 correspondences the system is built from the first 8; the validated
//!    pose is then refined on all of them ([`super::refine::refine_pose`]).
//!
//! If no attempt validates, [`GrpsSolveError::NotValidated`] carries the best end point (the
//! smallest residual among those with the fewest cheirality violations): a flagged result,
//! never a silent one. All attempts are counted in the reported times.

use super::features::{swap_pose, swap_views, GrpsFrame, GRPS_OUTPUTS, GRPS_ROW_WIDTH};
use super::geometry::{simulate_ray, triangulate_depths, validate, GrpsError};
use super::refine::{angular_residual, refine_pose, translation_scale_for_rotation, LmOptions};
use super::scene::GrpsCorrespondence;
use super::{Grps7, Grps8, Row};
use crate::metrics::rotation_from_quat;
use nalgebra::{Matrix3, Rotation3, SVector, Unit, Vector3};
use simhc::homotopy::CoefficientLine;
use simhc::regressor::{FoldedNetwork, RegressorError};
use simhc::tracker::{solve_newton, track, NewtonOptions, TrackError, TrackStats, TrackerOptions};
use simhc::{CoefficientForm, MinNormSimulator, ParamDerivative, SimulatorError};
use std::time::{Duration, Instant};
use thiserror::Error;

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
        Some(Self {
            rotation: rotation_from_quat(q),
            translation: Vector3::new(x[4], x[5], x[6]),
            scale: x[7],
        })
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
    /// The prediction rotated about one of six fixed axes (index).
    Perturbed(u8),
    /// A start given by the caller.
    Given,
}

/// Solver settings; the default is the shipped configuration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrpsSolverOptions {
    /// Methods tried on every start hypothesis, in order.
    pub methods: [Option<Method>; 3],
    /// Attempts (start hypothesis x method) at most; `1` is the paper's single path.
    pub max_attempts: usize,
    /// Rotation of the perturbed starts (degrees).
    pub perturbation_deg: f64,
    /// Largest angular residual (sine of the angle) of a validated end point.
    pub accept_angle: f64,
    /// Tracker settings of the homotopy paths.
    pub tracker: TrackerOptions,
    /// Gauss-Newton settings (the Gauss-Newton method and the end-point polish).
    pub newton: NewtonOptions,
}

impl Default for GrpsSolverOptions {
    fn default() -> Self {
        Self {
            methods: [Some(Method::Hc(SimulatorKind::Geometric)), Some(Method::GaussNewton), Some(Method::Hc(SimulatorKind::Generic))],
            max_attempts: 24,
            perturbation_deg: 20.0,
            accept_angle: 1e-3,
            tracker: TrackerOptions::single_path(),
            newton: NewtonOptions { max_iterations: 20, ..NewtonOptions::default() },
        }
    }
}

impl GrpsSolverOptions {
    /// The paper's Simulator HC: one path with `simulator`, no retries.
    pub fn single_path(simulator: SimulatorKind) -> Self {
        Self { methods: [Some(Method::Hc(simulator)), None, None], max_attempts: 1, ..Self::default() }
    }

    /// The default retries with `accept_angle` scaled for bearing noise of `noise_px` pixels at
    /// focal length `focal_px`: `max(1e-3, 6 noise_px / focal_px)` (the largest angular residual of
    /// the true pose on 8 noisy correspondences is a few times the per-bearing noise).
    pub fn for_noise(noise_px: f64, focal_px: f64) -> Self {
        Self { accept_angle: (6.0 * noise_px / focal_px).max(1e-3), ..Self::default() }
    }

    /// The minimal solver inside RANSAC: few attempts per sample (the prediction with the
    /// geometric simulator, then Gauss-Newton, then the predicted rotation with least-squares
    /// `(t, s)`), validation by cheirality and a loose residual (consensus decides the rest).
    pub fn for_ransac() -> Self {
        Self {
            methods: [Some(Method::Hc(SimulatorKind::Geometric)), Some(Method::GaussNewton), None],
            max_attempts: 3,
            accept_angle: 0.02,
            ..Self::default()
        }
    }

    /// Default retries with `simulator` first (then Gauss-Newton, then the other simulator).
    pub fn with_simulator(simulator: SimulatorKind) -> Self {
        let other = match simulator {
            SimulatorKind::Geometric => SimulatorKind::Generic,
            SimulatorKind::Generic => SimulatorKind::Geometric,
        };
        Self { methods: [Some(Method::Hc(simulator)), Some(Method::GaussNewton), Some(Method::Hc(other))], ..Self::default() }
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
    /// Every attempt failed to track.
    #[error("all {attempts} attempts failed; last: {last}")]
    NoEndPoint {
        /// Attempts made.
        attempts: usize,
        /// The last failure.
        last: AttemptError,
    },
    /// End points were found but none passed validation; the best one is attached (flagged
    /// result).
    #[error("no end point passed validation (best: max angular residual {:e}, {} behind a camera)", .0.validation.max_angle, .0.validation.behind)]
    NotValidated(Box<GrpsSolveReport>),
}

/// Why one attempt produced no end point.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum AttemptError {
    /// The simulator failed (degenerate simulated ray or inconsistent generic correction).
    #[error("simulator: {0}")]
    Simulator(#[from] SimulatorError),
    /// The path (or Gauss-Newton) failed.
    #[error("tracker: {0}")]
    Tracker(#[from] TrackError),
    /// The end point is not a pose (zero quaternion, non-finite values).
    #[error("end point is not a pose")]
    NotAPose,
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

    /// Whether the end point is accepted with `accept_angle`.
    pub fn passes(&self, accept_angle: f64) -> bool {
        self.positive_scale && self.behind == 0 && self.max_angle <= accept_angle
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

/// Six fixed unit axes for the perturbed starts (spread over the sphere).
const AXES: [[f64; 3]; 6] = [
    [0.577, 0.577, 0.577],
    [-0.577, -0.577, 0.577],
    [0.577, -0.577, -0.577],
    [-0.577, 0.577, -0.577],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
];

impl GrpsSolver {
    /// The solver with the shipped regressor and default options.
    pub fn new() -> Result<Self, RegressorError> {
        Ok(Self::with_network(FoldedNetwork::from_bytes(GRPS_WEIGHTS)?))
    }

    /// The solver with a given network (rows of width [`GRPS_ROW_WIDTH`], 10 outputs).
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
    pub fn solve(&self, corrs: &[GrpsCorrespondence]) -> Result<GrpsPose, GrpsSolveError> {
        self.solve_report(corrs).map(|r| r.pose)
    }

    /// The regressor's pose for `corrs` (checked input, at least one correspondence).
    pub fn predict(&self, corrs: &[GrpsCorrespondence]) -> Result<GrpsPose, GrpsSolveError> {
        validate(corrs)?;
        self.predict_unchecked(corrs)
    }

    fn predict_unchecked(&self, corrs: &[GrpsCorrespondence]) -> Result<GrpsPose, GrpsSolveError> {
        let frame = GrpsFrame::new(corrs).ok_or(GrpsSolveError::BadPrediction)?;
        let mut rows = vec![0.0f32; GRPS_ROW_WIDTH * corrs.len()];
        if !frame.rows(corrs, &mut rows) {
            return Err(GrpsSolveError::Input(GrpsError::NonFinite { index: 0 }));
        }
        let mut out = [0.0f64; GRPS_OUTPUTS];
        self.network.forward(&rows, &mut out)?;
        let (rotation, translation, scale) = frame.decode(&out).ok_or(GrpsSolveError::BadPrediction)?;
        Ok(GrpsPose { rotation, translation, scale })
    }

    /// Solves with the regressor's start and the retries of the options.
    pub fn solve_report(&self, corrs: &[GrpsCorrespondence]) -> Result<GrpsSolveReport, GrpsSolveError> {
        validate(corrs)?;
        let t0 = Instant::now();
        let prediction = self.predict_unchecked(corrs)?;
        let mut times = StageTimes { regressor: t0.elapsed(), ..StageTimes::default() };
        self.run(corrs, Some(prediction), None, &mut times)
    }

    /// Solves from a given start (no regressor; the perturbed starts are built around it).
    pub fn solve_from(&self, corrs: &[GrpsCorrespondence], start: &GrpsPose) -> Result<GrpsSolveReport, GrpsSolveError> {
        validate(corrs)?;
        let mut times = StageTimes::default();
        self.run(corrs, None, Some(*start), &mut times)
    }

    fn run(
        &self,
        corrs: &[GrpsCorrespondence],
        prediction: Option<GrpsPose>,
        given: Option<GrpsPose>,
        times: &mut StageTimes,
    ) -> Result<GrpsSolveReport, GrpsSolveError> {
        let o = &self.options;
        let methods: Vec<Method> = o.methods.iter().flatten().copied().collect();
        let base = given.or(prediction).ok_or(GrpsSolveError::BadPrediction)?;
        let base_kind = if given.is_some() { StartKind::Given } else { StartKind::Prediction };
        let mut attempts = 0;
        let mut best: Option<GrpsSolveReport> = None;
        let mut last_error = AttemptError::NotAPose;
        let mut kinds: Vec<StartKind> = vec![base_kind];
        if given.is_none() {
            kinds.extend([StartKind::PredictedRotation, StartKind::Swapped]);
        }
        kinds.extend((0..AXES.len() as u8).map(StartKind::Perturbed));
        'starts: for kind in kinds {
            if attempts >= o.max_attempts || methods.is_empty() {
                break;
            }
            let ts = Instant::now();
            let start = match self.start_hypothesis(kind, &base, corrs, times) {
                Some(s) => s,
                None => continue,
            };
            times.simulator += ts.elapsed();
            for &method in &methods {
                if attempts >= o.max_attempts {
                    break 'starts;
                }
                attempts += 1;
                match self.attempt(corrs, &start, method, times) {
                    Ok((pose, stats)) => {
                        let tv = Instant::now();
                        let validation = Validation::of(&pose, corrs);
                        times.tracking += tv.elapsed();
                        let report = GrpsSolveReport {
                            pose,
                            prediction,
                            validation,
                            attempts,
                            start: kind,
                            method,
                            stats,
                            times: *times,
                        };
                        if validation.passes(o.accept_angle) {
                            return Ok(self.finish(corrs, report, times));
                        }
                        if best.as_ref().is_none_or(|b| validation.key() < b.validation.key()) {
                            best = Some(report);
                        }
                    }
                    Err(e) => last_error = e,
                }
            }
        }
        match best {
            Some(mut b) => {
                b.attempts = attempts;
                b.times = *times;
                Err(GrpsSolveError::NotValidated(Box::new(b)))
            }
            None => Err(GrpsSolveError::NoEndPoint { attempts, last: last_error }),
        }
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

    fn start_hypothesis(
        &self,
        kind: StartKind,
        base: &GrpsPose,
        corrs: &[GrpsCorrespondence],
        times: &mut StageTimes,
    ) -> Option<GrpsPose> {
        match kind {
            StartKind::Prediction | StartKind::Given => Some(*base),
            StartKind::PredictedRotation => {
                let (t, s) = translation_scale_for_rotation(&base.rotation, corrs)?;
                (s > 0.0).then_some(GrpsPose { rotation: base.rotation, translation: t, scale: s })
            }
            StartKind::Swapped => {
                let tr = Instant::now();
                let swapped = swap_views(corrs);
                let p = self.predict_unchecked(&swapped).ok();
                times.regressor += tr.elapsed();
                let p = p?;
                let (rotation, translation, scale) = swap_pose(&p.rotation, &p.translation, p.scale);
                Some(GrpsPose { rotation, translation, scale })
            }
            StartKind::Perturbed(k) => {
                let axis = Unit::new_normalize(Vector3::from(AXES[k as usize % AXES.len()]));
                let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
                let rot = Rotation3::from_axis_angle(&axis, sign * self.options.perturbation_deg.to_radians()).into_inner();
                Some(GrpsPose { rotation: rot * base.rotation, ..*base })
            }
        }
    }

    /// One attempt from `start` with `method` on the first 7 or 8 correspondences.
    fn attempt(
        &self,
        corrs: &[GrpsCorrespondence],
        start: &GrpsPose,
        method: Method,
        times: &mut StageTimes,
    ) -> Result<(GrpsPose, TrackStats), AttemptError> {
        if corrs.len() == 7 {
            attempt_n::<Grps7, 7, 8, 84, 266>(corrs, start, method, &self.options, Grps7::params, times)
        } else {
            attempt_n::<Grps8, 8, 9, 96, 304>(&corrs[..8], start, method, &self.options, Grps8::params, times)
        }
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

/// The start parameters of the geometric simulator for `x0 = start`.
pub fn geometric_start_params<const N: usize, const NP: usize>(
    corrs: &[GrpsCorrespondence],
    start: &GrpsPose,
    params: fn(&[Row; N]) -> SVector<f64, NP>,
) -> Result<SVector<f64, NP>, SimulatorError> {
    let mut rows = rows_array::<N>(corrs);
    for (row, c) in rows.iter_mut().zip(corrs) {
        let (f, _) = simulate_ray(&start.rotation, &start.translation, start.scale, c).ok_or(SimulatorError::Singular)?;
        row.f = f.into();
    }
    Ok(params(&rows))
}

fn attempt_n<P, const N: usize, const NF: usize, const NP: usize, const NC: usize>(
    corrs: &[GrpsCorrespondence],
    start: &GrpsPose,
    method: Method,
    options: &GrpsSolverOptions,
    params: fn(&[Row; N]) -> SVector<f64, NP>,
    times: &mut StageTimes,
) -> Result<(GrpsPose, TrackStats), AttemptError>
where
    P: CoefficientForm<8, NF, NP, NC> + ParamDerivative<8, NF, NP>,
{
    let ts = Instant::now();
    let p1 = params(&rows_array::<N>(corrs));
    let x0 = start.unknowns();
    let (x, stats) = match method {
        Method::GaussNewton => {
            let r = solve_newton::<P, f64, 8, NF, NP>(&x0, &p1, &options.newton);
            times.tracking += ts.elapsed();
            let r = r?;
            if !r.converged {
                return Err(TrackError::CorrectorDidNotConverge { t: 1.0 }.into());
            }
            (r.x, TrackStats { newton_iterations: r.iterations, ..TrackStats::default() })
        }
        Method::Hc(kind) => {
            let p0 = match kind {
                SimulatorKind::Geometric => geometric_start_params::<N, NP>(corrs, start, params),
                SimulatorKind::Generic => MinNormSimulator::<P>::new().run::<8, NF, NP>(&x0, &p1),
            };
            times.simulator += ts.elapsed();
            let p0 = p0?;
            let tt = Instant::now();
            let h = CoefficientLine::<P, f64, NP, NC>::new::<8, NF>(&p0, &p1);
            let r = track(&h, &x0, &options.tracker);
            times.tracking += tt.elapsed();
            let r = r?;
            (r.x, r.stats)
        }
    };
    let pose = GrpsPose::from_unknowns(&x).ok_or(AttemptError::NotAPose)?;
    Ok((pose, stats))
}
