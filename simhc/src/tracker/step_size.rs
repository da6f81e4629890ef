//! The adaptive step-size rule (see [`super::AdaptiveStep`] for the reasoning).

use super::corrector::CorrectorReport;
use super::options::AdaptiveStep;
use super::Trouble;

/// `x^(1/n)` for `x >= 0` (square and cube roots without `powf`, which showed in profiles of
/// the batch tracker).
#[inline]
fn root(x: f64, n: u32) -> f64 {
    match n {
        1 => x,
        2 => x.sqrt(),
        3 => x.cbrt(),
        4 => x.sqrt().sqrt(),
        _ => x.powf(1.0 / n as f64),
    }
}

/// The contraction the step achieved or would have: measured `theta1` if there was a second
/// update, else `omega |dx_0| / 2` from the previous `omega`, else unknown (NaN).
#[inline]
fn observed_theta(report: &CorrectorReport, omega: Option<f64>) -> f64 {
    if report.theta1.is_finite() {
        step_theta(report)
    } else if report.theta_predicted.is_finite() {
        report.theta_predicted
    } else if let Some(omega) = omega {
        0.5 * omega * report.norm_dx0
    } else {
        f64::NAN
    }
}

/// The step-dependent part of the measured contraction: `theta1 - theta2` when a third update
/// showed a step-independent linear rate (Gauss-Newton on a least-squares path:
/// `theta1 ~ rate + omega |dx_0| / 2`, `theta2 ~ rate`), else `theta1`.
#[inline]
pub(crate) fn step_theta(report: &CorrectorReport) -> f64 {
    let (t1, t2) = (report.theta1, report.theta2);
    if t2.is_finite() && t2 < t1 {
        (t1 - t2).max(0.1 * t1)
    } else {
        t1
    }
}

/// Step factor after an accepted step of a predictor of order `order`.
#[inline]
pub(crate) fn grow_factor(a: &AdaptiveStep, order: u32, report: &CorrectorReport, omega: Option<f64>, after_rejection: bool) -> f64 {
    let theta = observed_theta(report, omega);
    let f = if theta.is_finite() && theta > 0.0 { root(a.target_contraction / theta, order + 1) } else { a.max_growth };
    let f = f.min(guard_factor(a, order, report));
    let upper = if after_rejection { 1.0 } else { a.max_growth };
    // Accepted steps never shrink by more than the rejection rule would.
    f.clamp(a.min_shrink, upper)
}

/// Where the controller aims the path-jump guard's ratio, as a fraction of its limit.
const GUARD_TARGET: f64 = 0.5;

/// Step factor that brings the path-jump guard's ratio `|dx_0| / |move|` to `GUARD_TARGET`
/// times its limit ([`AdaptiveStep::max_relative_correction`]); infinite when there is no guard.
///
/// Why: the ratio falls like `dt^p` (predictor error `~ dt^(p+1)` over a move `~ dt`), another
/// law than the contraction's, and near a close path it binds first. Steered by the contraction
/// alone, the controller kept growing steps that the guard then rejected.
#[inline]
fn guard_factor(a: &AdaptiveStep, order: u32, report: &CorrectorReport) -> f64 {
    let r = report.relative_correction;
    if r.is_finite() && r > 0.0 && a.max_relative_correction.is_finite() {
        root(GUARD_TARGET * a.max_relative_correction / r, order.max(1))
    } else {
        f64::INFINITY
    }
}

/// Step factor after a rejected step.
#[inline]
pub(crate) fn shrink_factor(a: &AdaptiveStep, order: u32, trouble: Trouble, report: Option<&CorrectorReport>, omega: Option<f64>) -> f64 {
    match (trouble, report) {
        (Trouble::Contraction | Trouble::NotConverged, Some(r)) => {
            let theta = observed_theta(r, omega);
            let f = if theta.is_finite() && theta > 0.0 { root(a.target_contraction / theta, order + 1) } else { 0.5 };
            f.min(guard_factor(a, order, r)).clamp(a.min_shrink, 0.5)
        }
        _ => 0.5,
    }
}

/// Step factor after an accepted Gauss-Newton step (`NF > NX`), from the number of corrector
/// iterations: grow after an easy step (at most two), keep after three, shrink after more.
///
/// Why not the contraction rule: on an inconsistent homotopy (the straight line of an
/// overdetermined system) the tangent `-J^+ dH/dt` is the tangent of the least-squares path only
/// where the residual vanishes, so the predictor error is first order whatever the predictor, and
/// `theta` contains Gauss-Newton's step-independent linear rate. Neither scales like
/// `dt^(p+1)`; the iteration count is the robust signal.
#[inline]
pub(crate) fn iteration_factor(a: &AdaptiveStep, report: &CorrectorReport, after_rejection: bool) -> f64 {
    let f = match report.iterations {
        0..=2 => a.max_growth.min(2.0),
        3 => 1.0,
        _ => 0.7,
    };
    if after_rejection {
        f.min(1.0)
    } else {
        f
    }
}
