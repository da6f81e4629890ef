//! The path state machine: the tracking algorithm of one path — predictor stages, corrector
//! iterations, acceptance and rejection, the `omega` update, the step-size rules, the final
//! refinement at `t = 1` and the success checks — written once, as a machine that asks for
//! evaluations and takes their results (the shape of argmin's `Solver::next_iter` driven by an
//! `Executor`).
//!
//! The machine never evaluates anything itself. It says what it needs at [`TrackerState::at`]
//! ([`Eval`]), and a driver computes it and hands the result to [`TrackerState::feed`]:
//! - the scalar driver ([`super::Tracker`]) evaluates the homotopy and factorizes one Jacobian per
//!   request, and reuses the corrector's last factorization for the tangent at an accepted point;
//! - the lane driver ([`super::batch`]) runs one batch operation for a request of every lane
//!   (each a path of its own), which returns the Newton update and the tangent together; the
//!   tangent at an accepted point is the one that came with the last corrector update.
//!
//! Between step attempts the machine is [`Next::Ready`]: the scalar driver returns from
//! [`super::Tracker::step`] there (one attempt per call), the lane driver starts the next attempt
//! at once ([`TrackerState::begin_step`]). [`Next::Ended`] means success or a
//! [`TrackError`]; [`TrackerState::result`] has it.
//!
//! Everything here is fixed-size and allocation-free; the drivers pass `square` (`NF == NX`, a
//! constant in each monomorphized driver) for the Newton/Gauss-Newton branches.

use super::corrector::{max_abs, norm_weights, weighted_norm, Corrector, CorrectorSettings};
use super::options::{AdaptiveStep, DragStep, Predictor, StepControl, TrackerOptions};
use super::predictor::{all_finite, axpy, hermite, History};
use super::result::{TrackError, TrackResult, TrackStats, Trouble};
use super::step_size;
use crate::Scalar;
use nalgebra::SVector;

/// Second Newton updates below this (weighted norm) are at rounding level: no `omega` from them.
const OMEGA_NOISE_FLOOR: f64 = 1e-12;

/// What the machine needs at [`TrackerState::at`] (a point `x` and a time `t`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Eval {
    /// The tangent `-J_x^-1 dH/dt` (least squares for `NF > NX`), from a new factorization of
    /// `J_x(x, t)`: the start tangent and the predictor stages.
    Tangent,
    /// The Newton (Gauss-Newton) update `J_x^-1 H(x, t)`, from a new factorization.
    Update,
    /// The tangent at the just accepted point, from the last [`Eval::Update`]'s factorization
    /// (no new factorization; not counted).
    TangentAtAccepted,
}

/// What the machine does next.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Next {
    /// Evaluate this and [`TrackerState::feed`] the result.
    Eval(Eval),
    /// A step attempt is over (accepted or rejected); [`TrackerState::begin_step`] starts the
    /// next one.
    Ready,
    /// Tracking is over: [`TrackerState::result`].
    Ended,
}

/// What the machine waits for.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    /// Nothing (not started, between attempts, or ended).
    Idle,
    /// The tangent at the start point.
    Start,
    /// A predictor stage's tangent: Heun's one at the Euler point, or RK4's three.
    Stage(u8),
    /// A corrector update at `t1`.
    Correct,
    /// The tangent at the accepted point; then the step size is updated.
    Accepted { omega_before: Option<f64>, after_rejection: bool, dragged: bool },
    /// A final-refinement update at `t = 1`.
    Final,
}

/// Where the tracker is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TrackerStatus {
    /// Not started ([`super::Tracker::start`] not called yet).
    Idle,
    /// On the way; call [`super::Tracker::step`] again.
    Tracking,
    /// Reached `t = 1`.
    Success,
    /// Given up.
    Failed(TrackError),
}

/// The tracker's state, readable between steps (for diagnostics, plots and benchmarks; the
/// fields of a failed path show where it failed). It is also the path state machine (see the
/// module docs).
#[derive(Debug, Clone, Copy)]
pub struct TrackerState<S: Scalar, const NX: usize> {
    /// Current point (the last accepted one).
    pub x: SVector<S, NX>,
    /// Current `t`.
    pub t: f64,
    /// Step size of the next attempt (adaptive) or the fixed step.
    pub dt: f64,
    /// Estimated error of `x`.
    pub accuracy: f64,
    /// Estimate of the Newton contraction constant (`|dx_1| ~ omega |dx_0|^2 / 2`), once
    /// measured.
    pub omega: Option<f64>,
    /// Work counters.
    pub stats: TrackStats,
    /// Status.
    pub status: TrackerStatus,
    /// Whether the last attempt was rejected.
    pub last_rejected: bool,
    /// Tangent `dx/dt` at `(x, t)`.
    tangent: SVector<S, NX>,
    /// Weights of the weighted norm at `x`.
    weights: SVector<f64, NX>,
    /// Index `k` of `t_k = k dt` in the fixed schedule.
    fixed_index: usize,
    /// Accepted points before `x` (multistep predictor).
    history: History<S, NX>,
    /// What the machine waits for.
    phase: Phase,
    /// The attempt in progress: target time and step `t1 - t`.
    t1: f64,
    h: f64,
    /// Whether the attempt is accepted even when its corrector does not converge (the fixed
    /// schedule, and drag steps).
    fixed: bool,
    /// The drag step in progress, if it is one.
    drag: Option<DragStep>,
    /// RK4's second and third stage tangents.
    k2: SVector<S, NX>,
    k3: SVector<S, NX>,
    /// `|x_pred - x|_w`, the predicted move (the path-jump guard's reference).
    moved: f64,
    /// The corrector run in progress (or the last one).
    corrector: Corrector<S, NX>,
    /// The point and time of the next evaluation.
    at: SVector<S, NX>,
    at_t: f64,
    /// Evaluate the last predictor stage at `t1` itself (the lane driver's convention) rather
    /// than at `t + (t1 - t)` (the scalar driver's); the two differ by rounding, and each driver
    /// keeps its own so that its paths stay what they were.
    stage_at_target: bool,
}

impl<S: Scalar, const NX: usize> TrackerState<S, NX> {
    /// A machine that has not started (`stage_at_target`: see the field).
    pub(crate) fn new(stage_at_target: bool) -> Self {
        Self {
            x: SVector::zeros(),
            t: 0.0,
            dt: 0.0,
            accuracy: f64::NAN,
            omega: None,
            stats: TrackStats::default(),
            status: TrackerStatus::Idle,
            last_rejected: false,
            tangent: SVector::zeros(),
            weights: SVector::repeat(1.0),
            fixed_index: 0,
            history: History::new(),
            phase: Phase::Idle,
            t1: 0.0,
            h: 0.0,
            fixed: false,
            drag: None,
            k2: SVector::zeros(),
            k3: SVector::zeros(),
            moved: 0.0,
            corrector: Corrector::new(SVector::zeros(), CorrectorSettings::refine(0, 0.0, f64::INFINITY)),
            at: SVector::zeros(),
            at_t: 0.0,
            stage_at_target,
        }
    }

    /// The point and time of the requested evaluation.
    #[inline]
    pub(crate) fn at(&self) -> (&SVector<S, NX>, f64) {
        (&self.at, self.at_t)
    }

    /// The outcome once [`Next::Ended`]: the end point (with `residual` NaN: the driver fills in
    /// [`crate::homotopy::Homotopy::validation_residual`]) or the error.
    pub(crate) fn result(&self) -> Result<TrackResult<S, NX>, TrackError> {
        match self.status {
            TrackerStatus::Success => {
                Ok(TrackResult { x: self.x, t: self.t, stats: self.stats, accuracy: self.accuracy, residual: f64::NAN })
            }
            TrackerStatus::Failed(e) => Err(e),
            TrackerStatus::Idle | TrackerStatus::Tracking => Err(TrackError::NonFinite { t: self.t }),
        }
    }

    #[inline]
    fn fail(&mut self, e: TrackError) -> Next {
        self.status = TrackerStatus::Failed(e);
        self.phase = Phase::Idle;
        Next::Ended
    }

    #[inline]
    fn request(&mut self, phase: Phase, x: SVector<S, NX>, t: f64, eval: Eval) -> Next {
        self.phase = phase;
        self.at = x;
        self.at_t = t;
        Next::Eval(eval)
    }

    /// Starts from `x0` at `t = 0`: checks the input and asks for the start tangent.
    pub(crate) fn start(&mut self, x0: &SVector<S, NX>, o: &TrackerOptions) -> Next {
        *self = Self::new(self.stage_at_target);
        self.x = *x0;
        self.status = TrackerStatus::Tracking;
        let dt = match o.step {
            StepControl::Fixed { dt } => dt,
            StepControl::Adaptive(a) => a.initial.min(a.max),
        };
        if !(dt > 0.0 && dt.is_finite()) {
            return self.fail(TrackError::StepSizeTooSmall { t: 0.0 });
        }
        self.dt = dt;
        if !all_finite(x0) {
            return self.fail(TrackError::NonFinite { t: 0.0 });
        }
        if max_abs(x0) > o.max_norm {
            return self.fail(TrackError::DivergedToInfinity { t: 0.0 });
        }
        self.weights = norm_weights(x0);
        self.request(Phase::Start, *x0, 0.0, Eval::Tangent)
    }

    /// Starts the next predictor-corrector attempt (or fails on the step budget).
    pub(crate) fn begin_step(&mut self, o: &TrackerOptions, square: bool) -> Next {
        if self.status != TrackerStatus::Tracking {
            return Next::Ended;
        }
        let t0 = self.t;
        if self.stats.steps() >= o.max_steps {
            return self.fail(TrackError::MaxSteps { t: t0 });
        }
        // A "fixed" step is accepted whether or not its corrector converged: the paper's
        // schedule, and the adaptive tracker's drag steps over stalls.
        self.drag = match o.step {
            StepControl::Adaptive(AdaptiveStep { drag: Some(d), .. }) if self.dt < d.below => Some(d),
            _ => None,
        };
        let (t1, fixed) = match (o.step, self.drag) {
            (StepControl::Fixed { dt }, _) => {
                let k = self.fixed_index + 1;
                let t1 = (k as f64 * dt).min(1.0);
                (if 1.0 - t1 <= 1e-12 { 1.0 } else { t1 }, true)
            }
            (StepControl::Adaptive(_), Some(d)) => (if t0 + 1.05 * d.dt >= 1.0 { 1.0 } else { t0 + d.dt }, true),
            // Stretch the step to land on 1 rather than leave a sliver.
            (StepControl::Adaptive(_), None) => (if t0 + 1.05 * self.dt >= 1.0 { 1.0 } else { t0 + self.dt }, false),
        };
        self.t1 = t1;
        self.h = t1 - t0;
        self.fixed = fixed;
        let h = self.h;
        match o.predictor {
            Predictor::Euler => self.predicted(axpy(&self.x, h, &self.tangent), o, square),
            Predictor::Hermite { points } if self.history.len() >= 1 => {
                let m = (points.clamp(2, 3) as usize).min(self.history.len() + 1);
                let xp = hermite(&self.history, m, &self.x, t0, &self.tangent, h);
                self.predicted(xp, o, square)
            }
            // Hermite without enough history starts with Heun.
            Predictor::Heun | Predictor::Hermite { .. } => {
                let (x, t) = (axpy(&self.x, h, &self.tangent), self.stage_end());
                self.request(Phase::Stage(0), x, t, Eval::Tangent)
            }
            Predictor::Rk4 => {
                let half = 0.5 * h;
                let x = axpy(&self.x, half, &self.tangent);
                self.request(Phase::Stage(0), x, t0 + half, Eval::Tangent)
            }
        }
    }

    /// The time of the predictor's last stage (see `stage_at_target`).
    #[inline]
    fn stage_end(&self) -> f64 {
        if self.stage_at_target {
            self.t1
        } else {
            self.t + self.h
        }
    }

    /// Takes the result of the requested evaluation: a tangent, or a Newton update, or why
    /// there is none (singular or non-finite).
    pub(crate) fn feed(&mut self, o: &TrackerOptions, square: bool, result: Result<SVector<S, NX>, Trouble>) -> Next {
        match self.phase {
            Phase::Idle => Next::Ended,
            Phase::Start => {
                self.stats.factorizations += 1;
                match finite_tangent(result) {
                    Ok(v) => {
                        self.tangent = v;
                        self.phase = Phase::Idle;
                        Next::Ready
                    }
                    Err(trouble) => self.fail(trouble.into_error(0.0)),
                }
            }
            Phase::Stage(stage) => {
                self.stats.factorizations += 1;
                let v = match finite_tangent(result) {
                    Ok(v) => v,
                    Err(trouble) => return self.abandon(trouble, o, square),
                };
                let h = self.h;
                match (o.predictor, stage) {
                    (Predictor::Rk4, 0) => {
                        self.k2 = v;
                        let x = axpy(&self.x, 0.5 * h, &v);
                        self.request(Phase::Stage(1), x, self.t + 0.5 * h, Eval::Tangent)
                    }
                    (Predictor::Rk4, 1) => {
                        self.k3 = v;
                        let (x, t) = (axpy(&self.x, h, &v), self.stage_end());
                        self.request(Phase::Stage(2), x, t, Eval::Tangent)
                    }
                    (Predictor::Rk4, _) => {
                        let c = S::from_real(h / 6.0);
                        let two = S::from_real(2.0);
                        let (k1, k2, k3) = (&self.tangent, &self.k2, &self.k3);
                        let mut xp = self.x;
                        for i in 0..NX {
                            xp[i] += c * (k1[i] + two * (k2[i] + k3[i]) + v[i]);
                        }
                        self.predicted(xp, o, square)
                    }
                    // Heun (and Hermite's first steps).
                    _ => {
                        let c = S::from_real(0.5 * h);
                        let mut xp = self.x;
                        for i in 0..NX {
                            xp[i] += c * (self.tangent[i] + v[i]);
                        }
                        self.predicted(xp, o, square)
                    }
                }
            }
            Phase::Correct | Phase::Final => {
                self.stats.newton_iterations += 1;
                self.stats.factorizations += 1;
                if !self.corrector.feed(result, &self.weights, square) {
                    let x = self.corrector.x;
                    return self.request(self.phase, x, self.at_t, Eval::Update);
                }
                if self.phase == Phase::Final {
                    self.refined(o)
                } else {
                    self.corrected(o, square)
                }
            }
            Phase::Accepted { omega_before, after_rejection, dragged } => match finite_tangent(result) {
                Ok(v) => {
                    self.tangent = v;
                    if let (StepControl::Adaptive(a), false) = (o.step, dragged) {
                        let report = &self.corrector.report;
                        let f = if square {
                            step_size::grow_factor(&a, o.predictor.order(), report, omega_before, after_rejection)
                        } else {
                            step_size::iteration_factor(&a, report, after_rejection)
                        };
                        self.dt = (self.dt * f).min(a.max);
                    }
                    self.phase = Phase::Idle;
                    Next::Ready
                }
                Err(trouble) => self.fail(trouble.into_error(self.t)),
            },
        }
    }

    /// A predictor stage failed: a fixed step fails the path, an adaptive one is rejected.
    fn abandon(&mut self, trouble: Trouble, o: &TrackerOptions, square: bool) -> Next {
        if self.fixed {
            self.fail(trouble.into_error(self.t))
        } else {
            self.reject(trouble, false, o, square)
        }
    }

    /// The predicted point `xp` at `t1`: set up the corrector there.
    fn predicted(&mut self, xp: SVector<S, NX>, o: &TrackerOptions, square: bool) -> Next {
        if !all_finite(&xp) {
            return self.abandon(Trouble::NonFinite, o, square);
        }
        let at_end = self.t1 >= 1.0;
        // The predicted move, for the path-jump guard (square adaptive steps only).
        self.moved = weighted_norm(&(xp - self.x), &self.weights);
        let adaptive = |iterations| CorrectorSettings::adaptive_step(iterations, o.path_tolerance, o.path_reduction, o.max_norm);
        let settings = match (o.step, self.drag) {
            (StepControl::Fixed { .. }, _) => CorrectorSettings::fixed_step(
                o.max_newton_iterations,
                if at_end { o.final_tolerance } else { o.path_tolerance },
                o.max_norm,
            ),
            (StepControl::Adaptive(_), Some(d)) => adaptive(d.max_newton_iterations),
            (StepControl::Adaptive(a), None) => CorrectorSettings {
                // The last step is accepted like any other; `finish` then polishes the end
                // point to `final_tolerance` (demanding it here would reject good steps).
                max_contraction: a.max_contraction,
                omega: if square { self.omega } else { None },
                // The first update also removes what is left of the current point's error.
                // Not for Gauss-Newton (see `AdaptiveStep` on overdetermined systems).
                max_first_update: if square {
                    a.max_relative_correction * self.moved + 2.0 * self.accuracy.max(o.path_tolerance)
                } else {
                    f64::INFINITY
                },
                ..adaptive(o.max_newton_iterations)
            },
        };
        self.corrector = Corrector::new(xp, settings);
        if settings.max_iterations == 0 {
            return self.corrected(o, square);
        }
        let t1 = self.t1;
        self.request(Phase::Correct, xp, t1, Eval::Update)
    }

    /// The corrector at `t1` has stopped: accept or reject the attempt.
    fn corrected(&mut self, o: &TrackerOptions, square: bool) -> Next {
        let report = &mut self.corrector.report;
        if self.corrector.settings.max_first_update.is_finite() && self.moved > 0.0 {
            report.relative_correction = report.norm_dx0 / self.moved;
        }
        let outcome = report.outcome;
        if let Some(d) = self.drag {
            if matches!(outcome, Ok(()) | Err(Trouble::NotConverged)) {
                self.stats.drag_steps += 1;
                // Resume adaptive stepping from the drag step's size.
                self.dt = d.dt;
                self.omega = None;
            }
        }
        match outcome {
            Ok(()) => self.accept(o),
            Err(Trouble::NotConverged) if self.fixed => self.accept(o),
            Err(trouble) if self.fixed => self.fail(trouble.into_error(self.t)),
            Err(trouble) => self.reject(trouble, true, o, square),
        }
    }

    /// Moves to the corrected point at `t1`; asks for its tangent (or refines at `t = 1`).
    fn accept(&mut self, o: &TrackerOptions) -> Next {
        let after_rejection = self.last_rejected;
        let dragged = self.drag.is_some();
        if dragged {
            // A drag step may leave the path: extrapolating through it would mislead.
            self.history.clear();
        } else {
            self.history.push(self.t, &self.x, &self.tangent);
        }
        let report = self.corrector.report;
        let (x, t1) = (self.corrector.x, self.t1);
        self.x = x;
        self.t = t1;
        self.stats.accepted_steps += 1;
        self.fixed_index += 1;
        self.last_rejected = false;
        self.accuracy = report.accuracy;
        if max_abs(&x) > o.max_norm {
            return self.fail(TrackError::DivergedToInfinity { t: t1 });
        }
        let omega_before = self.omega;
        if dragged {
            // A drag step's corrector says nothing about the path's contraction.
        } else if report.norm_dx1 > OMEGA_NOISE_FLOOR && report.norm_dx0 > 0.0 {
            self.omega = Some(2.0 * step_size::step_theta(&report) / report.norm_dx0);
        } else if report.theta1.is_finite() {
            // A second update at rounding level says nothing about omega (it would be ~0 and
            // make the next corrector trust a single iteration blindly).
            self.omega = None;
        }
        self.weights = norm_weights(&x);
        if t1 >= 1.0 {
            return self.finish(o);
        }
        self.request(Phase::Accepted { omega_before, after_rejection, dragged }, x, t1, Eval::TangentAtAccepted)
    }

    /// Shrinks the step after a failed attempt (`measured`: the corrector's report applies).
    fn reject(&mut self, trouble: Trouble, measured: bool, o: &TrackerOptions, square: bool) -> Next {
        let StepControl::Adaptive(a) = o.step else {
            return self.fail(trouble.into_error(self.t));
        };
        self.stats.rejected_steps += 1;
        self.last_rejected = true;
        let f = if square {
            let report = measured.then_some(&self.corrector.report);
            step_size::shrink_factor(&a, o.predictor.order(), trouble, report, self.omega)
        } else {
            0.5
        };
        self.dt *= f;
        if self.dt < a.min {
            return self.fail(trouble.into_stall_error(self.t));
        }
        self.phase = Phase::Idle;
        Next::Ready
    }

    /// At `t = 1`: refine to `final_tolerance` if the last step did not get there.
    fn finish(&mut self, o: &TrackerOptions) -> Next {
        if !reached(self.accuracy, o.final_tolerance) && o.final_newton_iterations > 0 {
            let settings = CorrectorSettings::refine(o.final_newton_iterations, o.final_tolerance, o.max_norm);
            self.corrector = Corrector::new(self.x, settings);
            return self.request(Phase::Final, self.x, 1.0, Eval::Update);
        }
        self.success(o)
    }

    /// The final refinement has stopped.
    fn refined(&mut self, o: &TrackerOptions) -> Next {
        match self.corrector.report.outcome {
            Ok(()) | Err(Trouble::NotConverged) | Err(Trouble::Contraction) => {
                self.x = self.corrector.x;
                self.accuracy = self.corrector.report.accuracy;
                self.success(o)
            }
            Err(other) => self.fail(other.into_error(1.0)),
        }
    }

    /// The checks at the end point.
    fn success(&mut self, o: &TrackerOptions) -> Next {
        if o.require_final_convergence && !reached(self.accuracy, o.final_tolerance) {
            return self.fail(TrackError::CorrectorDidNotConverge { t: 1.0 });
        }
        if !all_finite(&self.x) {
            return self.fail(TrackError::NonFinite { t: 1.0 });
        }
        self.status = TrackerStatus::Success;
        self.phase = Phase::Idle;
        Next::Ended
    }
}

/// A tangent result with non-finite entries is a non-finite evaluation.
#[inline]
fn finite_tangent<S: Scalar, const NX: usize>(r: Result<SVector<S, NX>, Trouble>) -> Result<SVector<S, NX>, Trouble> {
    match r {
        Ok(v) if !all_finite(&v) => Err(Trouble::NonFinite),
        r => r,
    }
}

/// Whether the estimated error `accuracy` (NaN: unknown) is within `tolerance`.
#[inline]
fn reached(accuracy: f64, tolerance: f64) -> bool {
    accuracy <= tolerance
}
