//! The Newton / Gauss-Newton corrector, and plain Newton refinement on a fixed system.

use super::linalg::LinearSolver;
use super::options::NewtonOptions;
use super::predictor::all_finite;
use super::result::{TrackError, Trouble};
use crate::homotopy::Homotopy;
use crate::Scalar;
use nalgebra::{SMatrix, SVector};

/// Weights `1 / max(1, |x_i|)` of the weighted max-norm.
#[inline]
pub(crate) fn norm_weights<S: Scalar, const N: usize>(x: &SVector<S, N>) -> SVector<f64, N> {
    // `sqrt(|e|^2)`, not `modulus` (a `hypot` call, which showed in profiles).
    x.map(|e| 1.0 / e.modulus_squared().sqrt().max(1.0))
}

/// `max_i |v_i| w_i` (NaN if any entry is NaN).
#[inline]
pub(crate) fn weighted_norm<S: Scalar, const N: usize>(v: &SVector<S, N>, w: &SVector<f64, N>) -> f64 {
    let mut m = 0.0f64;
    for (e, wi) in v.iter().zip(w.iter()) {
        let a = e.modulus_squared() * wi * wi;
        if a.is_nan() {
            return f64::NAN;
        }
        m = m.max(a);
    }
    m.sqrt()
}

/// `max_i |x_i|`.
#[inline]
pub(crate) fn max_abs<S: Scalar, const N: usize>(x: &SVector<S, N>) -> f64 {
    crate::homotopy::max_modulus(x)
}

/// How one corrector run is configured.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CorrectorSettings {
    /// Evaluations at most.
    pub max_iterations: usize,
    /// Target on the estimated error after the last update (weighted norm).
    pub tolerance: f64,
    /// Also converged when the estimated error is below `reduction * |dx_0|` (after at least two
    /// updates); `0` disables.
    pub reduction: f64,
    /// Reject when an update contracts by less than this (infinite: never).
    pub max_contraction: f64,
    /// `omega` of the previous step: predicts the contraction before the second evaluation and
    /// estimates the error after the first one. `None`: no prediction.
    pub omega: Option<f64>,
    /// Use the error estimates (`theta / (1 - theta) |dx|`, `omega |dx|^2 / 2`); otherwise the
    /// plain test `|dx| <= tolerance` (the paper's).
    pub estimate_error: bool,
    /// Iterates with `max |x_i|` above this stop the corrector.
    pub max_norm: f64,
    /// Reject when the first update `|dx_0|_w` exceeds this (and the tolerance): a predictor
    /// error comparable to the predicted move means the corrector may be pulled to another path.
    pub max_first_update: f64,
}

impl CorrectorSettings {
    /// Newton to `tolerance` within `max_iterations` evaluations, judged by the error estimates,
    /// with no other stop: plain Newton, the final refinement at `t = 1`. The step presets
    /// below start from it.
    pub fn refine(max_iterations: usize, tolerance: f64, max_norm: f64) -> Self {
        Self {
            max_iterations,
            tolerance,
            reduction: 0.0,
            max_contraction: f64::INFINITY,
            omega: None,
            estimate_error: true,
            max_norm,
            max_first_update: f64::INFINITY,
        }
    }

    /// A step of the paper's fixed schedule: the plain test `|dx| <= tolerance`, no estimates.
    pub fn fixed_step(max_iterations: usize, tolerance: f64, max_norm: f64) -> Self {
        Self { estimate_error: false, ..Self::refine(max_iterations, tolerance, max_norm) }
    }

    /// A step of the adaptive tracker: also converged at `reduction * |dx_0|`; rejected when
    /// an update contracts by less than `max_contraction` or the first update exceeds
    /// `max_first_update`; `omega` predicts the contraction. A drag step is this with no
    /// contraction, first-update or `omega` test.
    pub fn adaptive_step(max_iterations: usize, tolerance: f64, reduction: f64, max_norm: f64) -> Self {
        Self { reduction, ..Self::refine(max_iterations, tolerance, max_norm) }
    }
}

/// Result of a corrector run; `x` has been updated in place to the last iterate.
#[derive(Debug, Clone, Copy)]
pub(crate) struct CorrectorReport {
    /// `Ok(())` converged; otherwise why not.
    pub outcome: Result<(), Trouble>,
    /// Evaluations done.
    pub iterations: usize,
    /// `|dx_0|_w`, the first update (the predictor error).
    pub norm_dx0: f64,
    /// Measured `|dx_1| / |dx_0|` if a second update was computed, else NaN.
    pub theta1: f64,
    /// Measured `|dx_2| / |dx_1|` if a third update was computed, else NaN. For Newton it is
    /// tiny; for Gauss-Newton on a non-zero-residual path it is the linear rate of convergence,
    /// which does not depend on the step size.
    pub theta2: f64,
    /// `|dx_1|_w`, NaN if not computed.
    pub norm_dx1: f64,
    /// Predicted contraction `omega |dx_0| / 2` when the run stopped on the prediction, else NaN.
    pub theta_predicted: f64,
    /// Estimated error of the final iterate.
    pub accuracy: f64,
    /// `|dx_0|_w / |x_pred - x|_w`, the first update relative to the predicted move (the
    /// path-jump guard's ratio), when the tracker set a guard; else NaN.
    pub relative_correction: f64,
}

/// One corrector run as a state machine: fed one Newton update at a time (the drivers compute
/// them, see [`super::path`]), it applies each and decides when to stop.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Corrector<S: Scalar, const NX: usize> {
    /// The current iterate.
    pub x: SVector<S, NX>,
    pub settings: CorrectorSettings,
    /// The run so far; final once [`Corrector::feed`] returned `true`.
    pub report: CorrectorReport,
    /// `|dx|_w` of the previous update.
    prev: f64,
}

impl<S: Scalar, const NX: usize> Corrector<S, NX> {
    /// A run from `x` (no update yet).
    #[inline]
    pub(crate) fn new(x: SVector<S, NX>, settings: CorrectorSettings) -> Self {
        Self { x, settings, report: CorrectorReport::new(), prev: f64::NAN }
    }

    /// Applies the next update `dx` (or records why there is none) in the weighted norm `w`;
    /// `square`: Newton, not Gauss-Newton. `true` when the run has stopped: converged, failed, or
    /// out of iterations (`report.outcome` says which).
    #[inline]
    pub(crate) fn feed(&mut self, dx: Result<SVector<S, NX>, Trouble>, w: &SVector<f64, NX>, square: bool) -> bool {
        self.report.iterations += 1;
        let stop = match dx {
            Err(trouble) => {
                self.report.outcome = Err(trouble);
                true
            }
            Ok(dx) => apply_update(&mut self.x, &dx, w, &self.settings, &mut self.report, &mut self.prev, square),
        };
        // Out of iterations: `outcome` is still `NotConverged`.
        stop || self.report.iterations >= self.settings.max_iterations
    }
}

/// Newton (`NF = NX`) or Gauss-Newton (`NF > NX`) on `H(., t) = 0` from `x` (a [`Corrector`]
/// driven to its end), with a fresh Jacobian in every iteration: [`newton`]'s loop.
///
/// Stops as soon as the estimated remaining error is below the tolerance: after update `k >= 1`
/// that is `theta / (1 - theta) |dx_k|` with `theta = |dx_k| / |dx_(k-1)|` (the standard bound for
/// a contraction), after the first update `omega |dx_0|^2 / 2` when `omega` is known from the
/// previous step (Newton's quadratic convergence) — which often saves the second evaluation.
#[inline]
fn correct<S, H, const NX: usize, const NF: usize>(
    h: &H,
    x: &mut SVector<S, NX>,
    t: f64,
    w: &SVector<f64, NX>,
    s: &CorrectorSettings,
) -> CorrectorReport
where
    S: Scalar,
    H: Homotopy<S, NX, NF>,
{
    let mut solver = LinearSolver::<S, NX, NF>::new();
    let mut corrector = Corrector::new(*x, *s);
    if s.max_iterations > 0 {
        while !corrector.feed(update(h, &corrector.x, t, &mut solver), w, NF == NX) {}
    }
    *x = corrector.x;
    corrector.report
}

/// The Newton (Gauss-Newton) update `J_x^-1 H` at `(x, t)`; the factorization stays in `solver`.
#[inline]
pub(crate) fn update<S, H, const NX: usize, const NF: usize>(
    h: &H,
    x: &SVector<S, NX>,
    t: f64,
    solver: &mut LinearSolver<S, NX, NF>,
) -> Result<SVector<S, NX>, Trouble>
where
    S: Scalar,
    H: Homotopy<S, NX, NF>,
{
    let mut r = SVector::<S, NF>::zeros();
    let mut j = SMatrix::<S, NF, NX>::zeros();
    h.evaluate(x, t, &mut r, &mut j);
    solver.factor(&j)?;
    Ok(solver.solve(&r))
}

impl CorrectorReport {
    /// Before the first update: not converged, nothing measured.
    pub(crate) fn new() -> Self {
        CorrectorReport {
            outcome: Err(Trouble::NotConverged),
            iterations: 0,
            norm_dx0: f64::NAN,
            theta1: f64::NAN,
            theta2: f64::NAN,
            norm_dx1: f64::NAN,
            theta_predicted: f64::NAN,
            accuracy: f64::INFINITY,
            relative_correction: f64::NAN,
        }
    }
}

/// Applies Newton update number `report.iterations - 1` (`x -= dx`) and decides: `true` when
/// the corrector stops (`report.outcome` says why: converged, contraction, non-finite,
/// diverged), `false` to go on (the caller stops after `max_iterations` with
/// `NotConverged`). `prev` carries `|dx|_w` of the previous update; `square`: Newton (not
/// Gauss-Newton). [`Corrector::feed`]'s step.
#[inline]
fn apply_update<S: Scalar, const NX: usize>(
    x: &mut SVector<S, NX>,
    dx: &SVector<S, NX>,
    w: &SVector<f64, NX>,
    s: &CorrectorSettings,
    report: &mut CorrectorReport,
    prev: &mut f64,
    square: bool,
) -> bool {
    let k = report.iterations.saturating_sub(1);
    let n = weighted_norm(dx, w);
    if !n.is_finite() {
        report.outcome = Err(Trouble::NonFinite);
        return true;
    }
    *x -= dx;
    if !all_finite(x) {
        report.outcome = Err(Trouble::NonFinite);
        return true;
    }
    if max_abs(x) > s.max_norm {
        report.outcome = Err(Trouble::Diverged);
        return true;
    }
    let accuracy = if k == 0 {
        report.norm_dx0 = n;
        if n > s.max_first_update && n > s.tolerance {
            report.accuracy = n;
            report.outcome = Err(Trouble::Contraction);
            return true;
        }
        match s.omega {
            Some(omega) if s.estimate_error => {
                let predicted = 0.5 * omega * n;
                if predicted > s.max_contraction {
                    report.theta_predicted = predicted;
                    report.accuracy = n;
                    report.outcome = Err(Trouble::Contraction);
                    return true;
                }
                // Quadratic convergence: error after the update ~ omega/2 |dx_0|^2; a
                // factor 2 of safety on the estimate of omega. Not for Gauss-Newton, whose
                // error after one update has a linear part too.
                if square {
                    (2.0 * predicted * n).min(n)
                } else {
                    n
                }
            }
            _ => n,
        }
    } else {
        let theta = n / *prev;
        if k == 1 {
            report.theta1 = theta;
            report.norm_dx1 = n;
        } else if k == 2 {
            report.theta2 = theta;
        }
        if theta > s.max_contraction {
            report.accuracy = n;
            report.outcome = Err(Trouble::Contraction);
            return true;
        }
        if s.estimate_error && theta < 1.0 {
            (theta / (1.0 - theta) * n).min(n)
        } else {
            n
        }
    };
    report.accuracy = if s.estimate_error { accuracy } else { n };
    if report.accuracy <= s.tolerance || (k >= 1 && report.accuracy <= s.reduction * report.norm_dx0) {
        report.outcome = Ok(());
        return true;
    }
    *prev = n;
    false
}

/// Result of [`newton`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonResult<S: Scalar, const NX: usize> {
    /// The last iterate.
    pub x: SVector<S, NX>,
    /// Whether the estimated error reached the tolerance within the iteration budget. A
    /// non-converged result is not an error, so that a fixed-budget Gauss-Newton baseline still
    /// gets its last iterate.
    pub converged: bool,
    /// Iterations (residual + Jacobian evaluations and factorizations) done.
    pub iterations: usize,
    /// Estimated error of `x` (weighted max-norm of the last update, or the contraction bound).
    pub accuracy: f64,
    /// [`Homotopy::validation_residual`] at `x`.
    pub residual: f64,
}

/// Plain Newton (square) or Gauss-Newton (`NF > NX`) on `H(., t) = 0` from `x0`: the final
/// refinement of a tracked point, and the "Gauss-Newton only" baseline (use
/// [`crate::homotopy::FixedSystem`] to run it on `F(x; p)` directly).
///
/// Errors: [`TrackError::NonFinite`] (input or iterates), [`TrackError::SingularJacobian`],
/// [`TrackError::DivergedToInfinity`] (iterate above `max_norm`). Running out of iterations is
/// reported by `converged == false`. No heap allocation.
pub fn newton<S, H, const NX: usize, const NF: usize>(
    h: &H,
    x0: &SVector<S, NX>,
    t: f64,
    options: &NewtonOptions,
) -> Result<NewtonResult<S, NX>, TrackError>
where
    S: Scalar,
    H: Homotopy<S, NX, NF>,
{
    if !all_finite(x0) || !t.is_finite() {
        return Err(TrackError::NonFinite { t });
    }
    let mut x = *x0;
    let w = norm_weights(&x);
    let settings = CorrectorSettings::refine(options.max_iterations, options.tolerance, options.max_norm);
    let report = correct::<S, H, NX, NF>(h, &mut x, t, &w, &settings);
    let converged = match report.outcome {
        Ok(()) => true,
        Err(Trouble::NotConverged) | Err(Trouble::Contraction) => false,
        Err(other) => return Err(other.into_error(t)),
    };
    let residual = h.validation_residual(&x, t);
    Ok(NewtonResult { x, converged, iterations: report.iterations, accuracy: report.accuracy, residual })
}

/// Plain (Gauss-)Newton on `F(x; p) = 0` directly: [`newton`] on
/// [`crate::homotopy::FixedSystem`]. This is the "Gauss-Newton only" baseline (refine the
/// predicted start on the target, no homotopy); call it as
/// `solve_newton::<MyProblem, f64, NX, NF, NP>(&x0, &p, &options)`.
pub fn solve_newton<P, S, const NX: usize, const NF: usize, const NP: usize>(
    x0: &SVector<S, NX>,
    p: &SVector<S, NP>,
    options: &NewtonOptions,
) -> Result<NewtonResult<S, NX>, TrackError>
where
    P: crate::Problem<NX, NF, NP>,
    S: Scalar,
{
    newton::<S, _, NX, NF>(&crate::homotopy::FixedSystem::<P, S, NP>::new(*p), x0, 1.0, options)
}
