//! The path tracker: follows one solution path of a [`Homotopy`] from `t = 0` to `t = 1` with a
//! predictor-corrector scheme, with no heap allocation.
//!
//! Layout after HomotopyContinuation.jl's `tracker.jl`: [`TrackerOptions`] (with the paper's
//! fixed schedule as [`TrackerOptions::paper`] and an adaptive controller as the default), a
//! [`Tracker`] holding a [`TrackerState`] that can be driven step by step ([`Tracker::step`]) or
//! to the end ([`Tracker::track`], or the free function [`track`]), and a typed result:
//! [`TrackResult`] or a [`TrackError`] code. Nothing here panics on bad input or bad numerics.
//!
//! One step from `(x, t)`:
//! 1. **Predictor** ([`Predictor`], default RK4) on `J_x dx/dt = -dH/dt`; the tangent at `(x, t)`
//!    comes for free from the previous corrector's factorization, the other stages factorize the
//!    Jacobian at their points. For `NF > NX` tangents are least-squares solutions (normal
//!    equations, see the tolerance note in the `linalg` module: fine up to `cond(J) ~ 1e6`).
//! 2. **Corrector**: Newton (Gauss-Newton for `NF > NX`) at `t + dt`, a fresh Jacobian per
//!    iteration, stopping as soon as the *estimated remaining error* is below the tolerance
//!    (`theta / (1 - theta) |dx_k|`, or `omega |dx_0|^2 / 2` after one iteration), so easy steps
//!    cost one or two evaluations.
//! 3. **Step size**: fixed (`t_k = k dt`, every step accepted, as in the paper) or adaptive
//!    (accept when the corrector contracts fast and converges within the iteration budget;
//!    rescale the step by `(target / theta)^(1/(p+1))`; see [`AdaptiveStep`]).
//!
//! At `t = 1` the point is corrected to `final_tolerance` and judged by
//! [`Homotopy::validation_residual`] (the full system for [`crate::homotopy::SquaredUp`]).
//!
//! Cost model (why it is fast): every Newton iteration and every RK4 stage is one evaluation of
//! `H`/`J_x` plus one `NX x NX` factorization; an adaptive RK4 step on an easy path costs 3 stage
//! factorizations plus 1-2 corrector iterations, and the controller aims at few, long steps.
//! [`TrackStats`] counts them.
//!
//! Overdetermined systems (`NF > NX`, e.g. GRPS with 8 correspondences, 9 x 8): Gauss-Newton
//! tracks the least-squares path, which for the straight line (or a parameter segment whose
//! inner points are inconsistent) is not a path of zeros; the tangent is then only first-order
//! accurate and the path may fold. [`TrackerOptions::single_path`] (adaptive with drag steps)
//! copes like the paper's schedule at a fraction of the cost; [`crate::homotopy::SquaredUp`]
//! gives a consistent square path instead (but can end at spurious roots, which its full
//! residual reveals).
//!
//! Usage with any [`crate::Problem`] (here `x^2 - a`, tracking `sqrt(a)` from `a = 1` to `4`):
//!
//! ```
//! use nalgebra::{SMatrix, SVector, Vector1};
//! use simhc::homotopy::StraightLine;
//! use simhc::tracker::{track, TrackerOptions};
//! use simhc::{Problem, ProblemInfo, Scalar};
//!
//! struct Sqrt;
//! impl ProblemInfo for Sqrt {
//!     const NAME: &'static str = "sqrt";
//!     const UNKNOWN_NAMES: &'static [&'static str] = &["x"];
//!     const PARAM_NAMES: &'static [&'static str] = &["a"];
//! }
//! impl Problem<1, 1, 1> for Sqrt {
//!     fn residual<S: Scalar>(x: &SVector<S, 1>, p: &SVector<S, 1>, f: &mut SVector<S, 1>) {
//!         f[0] = x[0] * x[0] - p[0];
//!     }
//!     fn jacobian<S: Scalar>(x: &SVector<S, 1>, _p: &SVector<S, 1>, j: &mut SMatrix<S, 1, 1>) {
//!         j[(0, 0)] = x[0] + x[0];
//!     }
//!     fn residual_jacobian<S: Scalar>(
//!         x: &SVector<S, 1>, p: &SVector<S, 1>, f: &mut SVector<S, 1>, j: &mut SMatrix<S, 1, 1>,
//!     ) {
//!         Self::residual(x, p, f);
//!         Self::jacobian(x, p, j);
//!     }
//! }
//!
//! let h = StraightLine::<Sqrt, f64, 1>::new(Vector1::new(1.0), Vector1::new(4.0));
//! let r = track(&h, &Vector1::new(1.0), &TrackerOptions::default()).unwrap();
//! assert!((r.x[0] - 2.0).abs() < 1e-12 && r.residual < 1e-12);
//! println!("{} steps, {} factorizations", r.stats.accepted_steps, r.stats.factorizations);
//! ```

pub mod batch;
mod corrector;
mod lane_lu;
mod linalg;
mod options;
mod predictor;
mod step_size;

pub use corrector::{newton, solve_newton, NewtonResult};
pub use options::{AdaptiveStep, DragStep, NewtonOptions, Predictor, StepControl, TrackerOptions};

use crate::homotopy::Homotopy;
use crate::Scalar;
use corrector::{
    correct, max_abs, norm_weights, weighted_norm, CorrectorReport, CorrectorSettings,
};
use linalg::LinearSolver;
use nalgebra::SVector;
use predictor::{all_finite, predict, tangent, tangent_from_factor, History};
use thiserror::Error;

/// Second Newton updates below this (weighted norm) are at rounding level: no `omega` from them.
const OMEGA_NOISE_FLOOR: f64 = 1e-12;

/// Why a path was given up. Each carries the `t` the tracker had reached.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum TrackError {
    /// The adaptive step fell below `AdaptiveStep::min` because correctors kept failing:
    /// typically a real path at a fold (it turns back in `t`), or near-collision of paths.
    /// Also returned for invalid step settings (non-positive or non-finite `dt`).
    #[error("step size too small at t = {t}")]
    StepSizeTooSmall {
        /// Last accepted `t`.
        t: f64,
    },
    /// The Jacobian is singular at the start point or on the path (fixed schedule), or singular
    /// Jacobians made the adaptive step shrink below its minimum.
    #[error("singular Jacobian at t = {t}")]
    SingularJacobian {
        /// Last accepted `t`.
        t: f64,
    },
    /// An accepted point (or a Newton iterate in [`newton`] / the fixed schedule) exceeded
    /// `max_norm`, or the adaptive step shrank to its minimum with corrector iterates beyond it:
    /// the path goes to infinity.
    #[error("path diverged to infinity at t = {t}")]
    DivergedToInfinity {
        /// Last accepted `t`.
        t: f64,
    },
    /// `max_steps` steps (accepted plus rejected) without reaching `t = 1`.
    #[error("maximum number of steps reached at t = {t}")]
    MaxSteps {
        /// Last accepted `t`.
        t: f64,
    },
    /// At `t = 1` the corrector (plus `final_newton_iterations`) did not reach
    /// `final_tolerance` (only with `require_final_convergence`).
    #[error("corrector did not converge at t = {t}")]
    CorrectorDidNotConverge {
        /// `t` of the failed correction.
        t: f64,
    },
    /// NaN or infinity in the input or in an evaluation.
    #[error("non-finite value at t = {t}")]
    NonFinite {
        /// Last accepted `t`.
        t: f64,
    },
    /// A batch request named a start point that does not exist
    /// ([`batch::track_batch`]'s `indices` beyond its `starts`).
    #[error("no start point with index {index} ({available} given)")]
    NoStartPoint {
        /// The requested index.
        index: usize,
        /// How many start points there are.
        available: usize,
    },
    /// A batch job named tracker settings that do not exist ([`batch::PathJob::settings`]
    /// beyond the settings given to [`batch::track_batch_queue`]).
    #[error("no tracker settings with index {index} ({available} given)")]
    NoTrackerSettings {
        /// The requested index.
        index: usize,
        /// How many settings there are.
        available: usize,
    },
}

impl TrackError {
    /// The `t` the tracker had reached.
    pub fn t(&self) -> f64 {
        match *self {
            TrackError::StepSizeTooSmall { t }
            | TrackError::SingularJacobian { t }
            | TrackError::DivergedToInfinity { t }
            | TrackError::MaxSteps { t }
            | TrackError::CorrectorDidNotConverge { t }
            | TrackError::NonFinite { t } => t,
            TrackError::NoStartPoint { .. } | TrackError::NoTrackerSettings { .. } => 0.0,
        }
    }
}

/// Internal reason a step attempt failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Trouble {
    Singular,
    NonFinite,
    Diverged,
    Contraction,
    NotConverged,
}

impl Trouble {
    /// The public code when steps shrank below the smallest step because of `self`.
    #[inline]
    pub(crate) fn into_stall_error(self, t: f64) -> TrackError {
        match self {
            Trouble::Singular => TrackError::SingularJacobian { t },
            Trouble::NonFinite => TrackError::NonFinite { t },
            // Steps of every size leave the max-norm ball: the path goes to infinity.
            Trouble::Diverged => TrackError::DivergedToInfinity { t },
            _ => TrackError::StepSizeTooSmall { t },
        }
    }

    /// The public code for a failure at `t`.
    #[inline]
    pub(crate) fn into_error(self, t: f64) -> TrackError {
        match self {
            Trouble::Singular => TrackError::SingularJacobian { t },
            Trouble::NonFinite => TrackError::NonFinite { t },
            Trouble::Diverged => TrackError::DivergedToInfinity { t },
            Trouble::Contraction | Trouble::NotConverged => {
                TrackError::CorrectorDidNotConverge { t }
            }
        }
    }
}

/// Work counters of one path.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TrackStats {
    /// Accepted steps.
    pub accepted_steps: usize,
    /// Rejected steps (adaptive only).
    pub rejected_steps: usize,
    /// Corrector iterations (each one `H` + `J_x` evaluation and one factorization), including
    /// the final refinement.
    pub newton_iterations: usize,
    /// All Jacobian factorizations: corrector iterations plus predictor stages.
    pub factorizations: usize,
    /// Drag steps taken by the adaptive tracker (see [`DragStep`]).
    pub drag_steps: usize,
}

impl TrackStats {
    /// Accepted plus rejected steps.
    #[inline]
    pub fn steps(&self) -> usize {
        self.accepted_steps + self.rejected_steps
    }
}

/// A successfully tracked path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackResult<S: Scalar, const NX: usize> {
    /// The end point, a solution of `H(x, 1) = 0`.
    pub x: SVector<S, NX>,
    /// Always `1.0`.
    pub t: f64,
    /// Work counters.
    pub stats: TrackStats,
    /// Estimated error of `x` (weighted max-norm, see [`TrackerOptions`]).
    pub accuracy: f64,
    /// Max-norm of [`Homotopy::validation_residual`] at `(x, 1)`: for a squared-up system the
    /// full system's residual.
    pub residual: f64,
}

/// Where the tracker is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum TrackerStatus {
    /// Not started ([`Tracker::start`] not called yet).
    Idle,
    /// On the way; call [`Tracker::step`] again.
    Tracking,
    /// Reached `t = 1`.
    Success,
    /// Given up.
    Failed(TrackError),
}

/// The tracker's state, readable between steps (for diagnostics, plots and benchmarks; the
/// fields of a failed path show where it failed).
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
}

impl<S: Scalar, const NX: usize> TrackerState<S, NX> {
    fn new() -> Self {
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
        }
    }
}

/// A path tracker for the homotopy `H` (borrowed), reusable for many start points.
///
/// All storage is inline (fixed-size nalgebra types), so a `Tracker` lives on the stack and
/// `start`/`step`/`track` never allocate. `NF` is the number of equations of the *tracked*
/// homotopy (`NX` for a squared-up one).
#[derive(Debug, Clone)]
pub struct Tracker<'h, S: Scalar, H, const NX: usize, const NF: usize> {
    homotopy: &'h H,
    options: TrackerOptions,
    state: TrackerState<S, NX>,
    solver: LinearSolver<S, NX, NF>,
}

impl<'h, S, H, const NX: usize, const NF: usize> Tracker<'h, S, H, NX, NF>
where
    S: Scalar,
    H: Homotopy<S, NX, NF>,
{
    /// A tracker for `homotopy` with `options`.
    pub fn new(homotopy: &'h H, options: TrackerOptions) -> Self {
        Self { homotopy, options, state: TrackerState::new(), solver: LinearSolver::new() }
    }

    /// The options.
    pub fn options(&self) -> &TrackerOptions {
        &self.options
    }

    /// The current state.
    pub fn state(&self) -> &TrackerState<S, NX> {
        &self.state
    }

    /// The current status.
    pub fn status(&self) -> TrackerStatus {
        self.state.status
    }

    /// Sets up tracking from `x0` at `t = 0`: checks the input and computes the first tangent.
    pub fn start(&mut self, x0: &SVector<S, NX>) -> Result<(), TrackError> {
        self.state = TrackerState::new();
        self.state.x = *x0;
        self.state.status = TrackerStatus::Tracking;
        let dt = match self.options.step {
            StepControl::Fixed { dt } => dt,
            StepControl::Adaptive(a) => a.initial.min(a.max),
        };
        if !(dt > 0.0 && dt.is_finite()) {
            return self.fail(TrackError::StepSizeTooSmall { t: 0.0 });
        }
        self.state.dt = dt;
        if !all_finite(x0) {
            return self.fail(TrackError::NonFinite { t: 0.0 });
        }
        if max_abs(x0) > self.options.max_norm {
            return self.fail(TrackError::DivergedToInfinity { t: 0.0 });
        }
        self.state.weights = norm_weights(x0);
        match tangent(self.homotopy, x0, 0.0, &mut self.solver, &mut self.state.stats) {
            Ok(v) => self.state.tangent = v,
            Err(e) => return self.fail(e.into_error(0.0)),
        }
        Ok(())
    }

    /// Tracks from `x0` to `t = 1`.
    pub fn track(&mut self, x0: &SVector<S, NX>) -> Result<TrackResult<S, NX>, TrackError> {
        self.start(x0)?;
        loop {
            match self.step() {
                TrackerStatus::Tracking => {}
                TrackerStatus::Success => {
                    return Ok(TrackResult {
                        x: self.state.x,
                        t: self.state.t,
                        stats: self.state.stats,
                        accuracy: self.state.accuracy,
                        residual: self.homotopy.validation_residual(&self.state.x, self.state.t),
                    })
                }
                TrackerStatus::Failed(e) => return Err(e),
                TrackerStatus::Idle => return Err(TrackError::NonFinite { t: 0.0 }),
            }
        }
    }

    #[inline]
    fn fail<T>(&mut self, e: TrackError) -> Result<T, TrackError> {
        self.state.status = TrackerStatus::Failed(e);
        Err(e)
    }

    #[inline]
    fn set_failed(&mut self, e: TrackError) -> TrackerStatus {
        self.state.status = TrackerStatus::Failed(e);
        self.state.status
    }

    /// One predictor-corrector attempt; returns the new status.
    pub fn step(&mut self) -> TrackerStatus {
        if self.state.status != TrackerStatus::Tracking {
            return self.state.status;
        }
        let t0 = self.state.t;
        if self.state.stats.steps() >= self.options.max_steps {
            return self.set_failed(TrackError::MaxSteps { t: t0 });
        }
        // A "fixed" step is accepted whether or not its corrector converged: the paper's
        // schedule, and the adaptive tracker's drag steps over stalls.
        let drag = match self.options.step {
            StepControl::Adaptive(AdaptiveStep { drag: Some(d), .. }) if self.state.dt < d.below => {
                Some(d)
            }
            _ => None,
        };
        let (t1, fixed) = match (self.options.step, drag) {
            (StepControl::Fixed { dt }, _) => {
                let k = self.state.fixed_index + 1;
                let t1 = (k as f64 * dt).min(1.0);
                (if 1.0 - t1 <= 1e-12 { 1.0 } else { t1 }, true)
            }
            (StepControl::Adaptive(_), Some(d)) => {
                (if t0 + 1.05 * d.dt >= 1.0 { 1.0 } else { t0 + d.dt }, true)
            }
            (StepControl::Adaptive(_), None) => {
                let dt = self.state.dt;
                // Stretch the step to land on 1 rather than leave a sliver.
                (if t0 + 1.05 * dt >= 1.0 { 1.0 } else { t0 + dt }, false)
            }
        };
        let dt = t1 - t0;
        let h = self.homotopy;
        let opts = self.options;

        let xp = predict(
            opts.predictor,
            h,
            &self.state.x,
            t0,
            dt,
            &self.state.tangent,
            &self.state.history,
            &mut self.solver,
            &mut self.state.stats,
        );
        let mut x = match xp {
            Ok(x) => x,
            Err(trouble) => {
                return if fixed {
                    self.set_failed(trouble.into_error(t0))
                } else {
                    self.reject(trouble, None)
                }
            }
        };

        let at_end = t1 >= 1.0;
        // The predicted move, for the path-jump guard (square adaptive steps only).
        let moved = weighted_norm(&(x - self.state.x), &self.state.weights);
        let settings = match (opts.step, drag) {
            (StepControl::Fixed { .. }, _) => {
                CorrectorSettings::fixed_step(opts.max_newton_iterations, if at_end { opts.final_tolerance } else { opts.path_tolerance }, opts.max_norm)
            }
            (StepControl::Adaptive(_), Some(d)) => CorrectorSettings::adaptive_step(d.max_newton_iterations, opts.path_tolerance, opts.path_reduction, opts.max_norm),
            (StepControl::Adaptive(a), None) => CorrectorSettings {
                // The last step is accepted like any other; `finish` then polishes the end
                // point to `final_tolerance` (demanding it here would reject good steps).
                max_contraction: a.max_contraction,
                omega: if NF == NX { self.state.omega } else { None },
                // The first update also removes what is left of the current point's error.
                // Not for Gauss-Newton (see `AdaptiveStep` on overdetermined systems).
                max_first_update: if NF == NX {
                    a.max_relative_correction * moved
                        + 2.0 * self.state.accuracy.max(opts.path_tolerance)
                } else {
                    f64::INFINITY
                },
                ..CorrectorSettings::adaptive_step(opts.max_newton_iterations, opts.path_tolerance, opts.path_reduction, opts.max_norm)
            },
        };
        let mut report = correct(
            h,
            &mut x,
            t1,
            &self.state.weights,
            &mut self.solver,
            &settings,
            &mut self.state.stats,
        );
        if settings.max_first_update.is_finite() && moved > 0.0 {
            report.relative_correction = report.norm_dx0 / moved;
        }
        if let Some(d) = drag {
            if matches!(report.outcome, Ok(()) | Err(Trouble::NotConverged)) {
                self.state.stats.drag_steps += 1;
                // Resume adaptive stepping from the drag step's size.
                self.state.dt = d.dt;
                self.state.omega = None;
            }
        }
        match report.outcome {
            Ok(()) => self.accept(x, t1, &report, drag.is_some()),
            Err(Trouble::NotConverged) if fixed => self.accept(x, t1, &report, drag.is_some()),
            Err(trouble) if fixed => self.set_failed(trouble.into_error(t0)),
            Err(trouble) => self.reject(trouble, Some(&report)),
        }
    }

    fn accept(
        &mut self,
        x: SVector<S, NX>,
        t1: f64,
        report: &CorrectorReport,
        dragged: bool,
    ) -> TrackerStatus {
        let after_rejection = self.state.last_rejected;
        let st = &mut self.state;
        if dragged {
            // A drag step may leave the path: extrapolating through it would mislead.
            st.history.clear();
        } else {
            st.history.push(st.t, &st.x, &st.tangent);
        }
        st.x = x;
        st.t = t1;
        st.stats.accepted_steps += 1;
        st.fixed_index += 1;
        st.last_rejected = false;
        st.accuracy = report.accuracy;
        if max_abs(&x) > self.options.max_norm {
            return self.set_failed(TrackError::DivergedToInfinity { t: t1 });
        }
        let omega_before = st.omega;
        if dragged {
            // A drag step's corrector says nothing about the path's contraction.
        } else if report.norm_dx1 > OMEGA_NOISE_FLOOR && report.norm_dx0 > 0.0 {
            st.omega = Some(2.0 * step_size::step_theta(report) / report.norm_dx0);
        } else if report.theta1.is_finite() {
            // A second update at rounding level says nothing about omega (it would be ~0 and
            // make the next corrector trust a single iteration blindly).
            st.omega = None;
        }
        st.weights = norm_weights(&x);
        if t1 >= 1.0 {
            return self.finish();
        }
        // Tangent at the new point from the corrector's last factorization.
        match tangent_from_factor(self.homotopy, &x, t1, &self.solver) {
            Ok(v) => self.state.tangent = v,
            Err(e) => return self.set_failed(e.into_error(t1)),
        }
        if let (StepControl::Adaptive(a), false) = (self.options.step, dragged) {
            let f = if NF == NX {
                step_size::grow_factor(
                    &a,
                    self.options.predictor.order(),
                    report,
                    omega_before,
                    after_rejection,
                )
            } else {
                step_size::iteration_factor(&a, report, after_rejection)
            };
            self.state.dt = (self.state.dt * f).min(a.max);
        }
        self.state.status
    }

    fn reject(&mut self, trouble: Trouble, report: Option<&CorrectorReport>) -> TrackerStatus {
        let StepControl::Adaptive(a) = self.options.step else {
            return self.set_failed(trouble.into_error(self.state.t));
        };
        let st = &mut self.state;
        st.stats.rejected_steps += 1;
        st.last_rejected = true;
        let f = if NF == NX {
            step_size::shrink_factor(&a, self.options.predictor.order(), trouble, report, st.omega)
        } else {
            0.5
        };
        st.dt *= f;
        if st.dt < a.min {
            let t = st.t;
            return self.set_failed(trouble.into_stall_error(t));
        }
        self.state.status
    }

    /// At `t = 1`: refine to `final_tolerance` if the last step did not get there.
    fn finish(&mut self) -> TrackerStatus {
        let opts = self.options;
        let reached = |accuracy: f64| accuracy <= opts.final_tolerance;
        if !reached(self.state.accuracy) && opts.final_newton_iterations > 0 {
            let mut x = self.state.x;
            let settings = CorrectorSettings::refine(opts.final_newton_iterations, opts.final_tolerance, opts.max_norm);
            let report = correct(
                self.homotopy,
                &mut x,
                1.0,
                &self.state.weights,
                &mut self.solver,
                &settings,
                &mut self.state.stats,
            );
            match report.outcome {
                Ok(()) | Err(Trouble::NotConverged) | Err(Trouble::Contraction) => {
                    self.state.x = x;
                    self.state.accuracy = report.accuracy;
                }
                Err(other) => return self.set_failed(other.into_error(1.0)),
            }
        }
        if opts.require_final_convergence && !reached(self.state.accuracy) {
            return self.set_failed(TrackError::CorrectorDidNotConverge { t: 1.0 });
        }
        if !all_finite(&self.state.x) {
            return self.set_failed(TrackError::NonFinite { t: 1.0 });
        }
        self.state.status = TrackerStatus::Success;
        self.state.status
    }
}

/// Tracks `x0` (a solution of `H(x, 0) = 0`) along `homotopy` to `t = 1`.
///
/// Generic over the scalar (`f64`, `Complex<f64>`), the homotopy and the sizes; allocation-free.
/// Equivalent to `Tracker::new(homotopy, *options).track(x0)`.
#[inline]
pub fn track<S, H, const NX: usize, const NF: usize>(
    homotopy: &H,
    x0: &SVector<S, NX>,
    options: &TrackerOptions,
) -> Result<TrackResult<S, NX>, TrackError>
where
    S: Scalar,
    H: Homotopy<S, NX, NF>,
{
    Tracker::new(homotopy, *options).track(x0)
}
