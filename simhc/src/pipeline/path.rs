//! One attempt from a start: Simulator HC (the simulated start problem, the straight line in
//! coefficient form to the target, the adaptive tracker: stage 3 of the paper), or plain
//! Gauss-Newton on the target system (the paper's "Pred + LM" baseline, and a cheap first try
//! when starts are good).

use super::{AttemptError, PipelineOptions, StageTimes, StartSimulator};
use crate::homotopy::CoefficientLine;
use crate::interval::Interval;
use crate::tracker::{solve_newton, track, NewtonOptions, TrackError, TrackResult, TrackStats};
use crate::{onto_parameter_free, CoefficientForm, ProblemLayout};
use nalgebra::{SMatrix, SVector};
use std::time::Instant;

/// A start meets the parameter-free equations when their residual is at most this (relative to
/// `1 + max |x|`); the minimum-norm simulator asks `1e-12` of the others.
const PARAMETER_FREE_TOLERANCE: f64 = 1e-12;
/// Gauss-Newton steps on the parameter-free equations that are not norms (norms are exact).
const PARAMETER_FREE_ITERATIONS: usize = 8;

/// Tracks `x0` from the simulated start problem to the target parameters `p`; adds the
/// simulator's and the tracker's time to `times`. `x0` is first put on the equations without
/// parameters ([`onto_parameter_free`]: `q.q - 1`, `t.t - 1`), which no simulator can make
/// hold; the path starts from that point. With [`PipelineOptions::polish`], an end point
/// that a tracker without `require_final_convergence` returned short of its final tolerance is
/// polished by [`gauss_newton`] with `options.newton` (on noisy overdetermined systems
/// Gauss-Newton converges only linearly at the least-squares point); validation decides.
pub fn simulator_hc<P, D, S, const NX: usize, const NF: usize, const NP: usize, const NC: usize>(
    data: &D,
    simulator: &S,
    x0: &SVector<f64, NX>,
    p: &SVector<f64, NP>,
    options: &PipelineOptions,
    times: &mut StageTimes,
) -> Result<(SVector<f64, NX>, TrackStats), AttemptError>
where
    P: CoefficientForm<NX, NF, NP, NC> + ProblemLayout,
    D: ?Sized,
    S: StartSimulator<D, NX, NF, NP> + ?Sized,
{
    let ts = Instant::now();
    let simulated = onto_parameter_free::<P, NX, NF, NP>(x0, PARAMETER_FREE_TOLERANCE, PARAMETER_FREE_ITERATIONS)
        .and_then(|x0| simulator.simulate(data, &x0, p).map(|p0| (x0, p0)));
    times.simulator += ts.elapsed();
    let (x0, p0) = simulated?;
    let tt = Instant::now();
    let h = CoefficientLine::<P, f64, NP, NC>::new::<NX, NF>(&p0, p);
    let result = track(&h, &x0, &options.tracker).and_then(|r| polish::<P, NX, NF, NP>(r, p, options));
    times.tracking += tt.elapsed();
    Ok(result?)
}

/// The end point of a path, polished by [`gauss_newton`] when [`PipelineOptions::polish`] asks
/// and the tracker returned it short of the accuracy `1e-7` (only a tracker without
/// `require_final_convergence` does).
fn polish<P, const NX: usize, const NF: usize, const NP: usize>(
    r: TrackResult<f64, NX>,
    p: &SVector<f64, NP>,
    options: &PipelineOptions,
) -> Result<(SVector<f64, NX>, TrackStats), TrackError>
where
    P: crate::Problem<NX, NF, NP>,
{
    if !options.polish || options.tracker.require_final_convergence || r.accuracy <= 1e-7 {
        return Ok((r.x, r.stats));
    }
    let (x, polish) = gauss_newton::<P, NX, NF, NP>(&r.x, p, &options.newton)?;
    let mut stats = r.stats;
    stats.newton_iterations += polish.newton_iterations;
    Ok((x, stats))
}

/// Gauss-Newton from `x0` on the target parameters `p`. Accepted when it converged, or its last
/// update is below `1e-7` (on noisy overdetermined systems Gauss-Newton converges linearly at
/// the least-squares point), *and* the end point is stationary within the error Newton was
/// asked for ([`stationary_within`]): small updates alone also happen where Gauss-Newton
/// stalls at a point that is no root, near a real local minimum of `|F|²` where the Jacobian
/// is nearly singular. Such a point is [`TrackError::Stalled`]. Validation decides the rest.
/// The caller times it.
pub fn gauss_newton<P, const NX: usize, const NF: usize, const NP: usize>(
    x0: &SVector<f64, NX>,
    p: &SVector<f64, NP>,
    options: &NewtonOptions,
) -> Result<(SVector<f64, NX>, TrackStats), TrackError>
where
    P: crate::Problem<NX, NF, NP>,
{
    let r = solve_newton::<P, f64, NX, NF, NP>(x0, p, options)?;
    if !r.converged && (r.accuracy.is_nan() || r.accuracy > 1e-7) {
        return Err(TrackError::CorrectorDidNotConverge { t: 1.0 });
    }
    // The box the end point must be stationary within: the error Newton was asked for (in its
    // weighted max-norm, `|e_j| <= tolerance max(|x_j|, 1)`; or the smaller error it
    // estimates), times 4 because the estimate is an estimate, plus 16 ulps for the rounding of
    // `x` itself. Not the `1e-7` accepted above: updates of 1e-8 that stopped shrinking leave
    // a point stationary only if its residual (square) or gradient (least squares) is what an
    // error of `tolerance` explains; a stall's is not.
    let claimed = 4.0 * r.accuracy.clamp(0.0, options.tolerance) + 16.0 * f64::EPSILON;
    let radius = r.x.map(|v| claimed * v.abs().max(1.0));
    if !stationary_within::<P, NX, NF, NP>(&r.x, p, &radius) {
        return Err(TrackError::Stalled { t: 1.0 });
    }
    Ok((r.x, TrackStats { newton_iterations: r.iterations, ..TrackStats::default() }))
}

/// Whether `x` may be within `radius` of a root (`NF == NX`) or of a stationary point of
/// `|F|²` (`NF > NX`).
///
/// First in `f64`, to first order: a point at distance `e` from a root has `|F| <= |J| |e|`,
/// from a stationary point `|Jᵀ F| <= |J|ᵀ |J| |e|` (componentwise); a point that meets this
/// is accepted. A point that does not is given the benefit of the doubt once more, in
/// outward-rounded interval arithmetic over the box `X = x ± radius`: `0 ∈ F(X)` in every
/// component, or `0 ∈ J(X)ᵀ F(X)`. The interval width bounds both the round-off of evaluating
/// `F` (relative to the size of the terms it adds, which `|F(x)|` alone does not show) and the
/// second-order terms; `false` is then a proof that the box holds no root (stationary point).
/// The interval evaluation (a few times the cost of the `f64` one) runs only for points the
/// first-order test rejects.
pub fn stationary_within<P, const NX: usize, const NF: usize, const NP: usize>(
    x: &SVector<f64, NX>,
    p: &SVector<f64, NP>,
    radius: &SVector<f64, NX>,
) -> bool
where
    P: crate::Problem<NX, NF, NP>,
{
    let mut f = SVector::<f64, NF>::zeros();
    let mut j = SMatrix::<f64, NF, NX>::zeros();
    P::residual_jacobian(x, p, &mut f, &mut j);
    let explained = j.abs() * radius;
    let first_order = if NF == NX {
        (0..NF).all(|i| f[i].abs() <= explained[i])
    } else {
        let gradient = j.transpose() * f;
        let bound = j.abs().transpose() * explained;
        (0..NX).all(|k| gradient[k].abs() <= bound[k])
    };
    if first_order {
        return true;
    }

    let boxed = SVector::<Interval, NX>::from_fn(|i, _| Interval::around(x[i], radius[i]));
    let pi = p.map(Interval::point);
    let zero = Interval::point(0.0);
    let mut f = SVector::<Interval, NF>::from_element(zero);
    if NF == NX {
        P::residual(&boxed, &pi, &mut f);
        return f.iter().all(|v| v.contains(0.0));
    }
    let mut j = SMatrix::<Interval, NF, NX>::from_element(zero);
    P::residual_jacobian(&boxed, &pi, &mut f, &mut j);
    (0..NX).all(|k| {
        let mut g = zero;
        for i in 0..NF {
            g = g + j[(i, k)] * f[i];
        }
        g.contains(0.0)
    })
}
