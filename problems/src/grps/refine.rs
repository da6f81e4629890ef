//! Local refinement of a GRPS pose: the baselines of the benchmark ("Pred + LM" and
//! "Pred + Gauss-Newton" on the polynomial system) and the non-minimal refinement on many
//! correspondences (RANSAC inliers).
//!
//! - [`lm_polynomial`]: Levenberg-Marquardt on a compiled system `F(x; p) = 0` (any
//!   [`Problem`], here GRPS7/GRPS8: the paper's "Pred Initial + LM" with the residuals of the
//!   polynomial system, `q` unnormalized with `q.q - 1` as an equation).
//! - [`refine_pose`]: Levenberg-Marquardt on `N >= 7` correspondences of the *angular*
//!   residual `r_i = f_i . n_i`, `n_i = (R f'_i x c_i) / |R f'_i x c_i|`,
//!   `c_i = t + s R v'_i - v_i`: the sine of the angle between `f_i` and the plane that contains
//!   the second ray and the first ray's origin (the plane's normal is held fixed within one
//!   linearization, so the Jacobian is that of the triple product divided by `|n_i|`). On the
//!   manifold: `R <- exp([w]x) R`, `t <- t + dt`, `s <- s + ds` (7 parameters).

use super::geometry::grps_residual_direct;
use super::scene::GrpsCorrespondence;
use nalgebra::{Matrix3, Rotation3, SMatrix, SVector, Vector3};
use simhc::Problem;

pub use crate::lm::LmOptions;

/// Result of [`lm_polynomial`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmPolynomialResult {
    /// The last accepted point.
    pub x: SVector<f64, 8>,
    /// `|F(x; p)|²`.
    pub cost: f64,
    /// Iterations run.
    pub iterations: usize,
}

/// Levenberg-Marquardt (multiplicative damping of the diagonal) on `F(x; p) = 0` from `x0`.
/// Never fails: a non-finite step ends the loop with the last accepted point.
pub fn lm_polynomial<P, const NF: usize, const NP: usize>(
    x0: &SVector<f64, 8>,
    p: &SVector<f64, NP>,
    options: &LmOptions,
) -> LmPolynomialResult
where
    P: Problem<8, NF, NP>,
{
    let mut x = *x0;
    let mut f = SVector::<f64, NF>::zeros();
    let mut j = SMatrix::<f64, NF, 8>::zeros();
    P::residual_jacobian(&x, p, &mut f, &mut j);
    let mut cost = f.norm_squared();
    let mut lambda = options.initial_lambda;
    let mut iterations = 0;
    while iterations < options.max_iterations && cost.is_finite() {
        iterations += 1;
        let a = j.transpose() * j;
        let g = j.transpose() * f;
        let mut improved = false;
        for _ in 0..10 {
            let mut damped = a;
            for k in 0..8 {
                damped[(k, k)] += lambda * a[(k, k)].max(1e-12);
            }
            let Some(step) = damped.cholesky().map(|c| -c.solve(&g)) else {
                lambda *= 10.0;
                continue;
            };
            if !step.iter().all(|v| v.is_finite()) {
                break;
            }
            let xn = x + step;
            let mut fnew = SVector::<f64, NF>::zeros();
            P::residual(&xn, p, &mut fnew);
            let cn = fnew.norm_squared();
            if cn < cost {
                x = xn;
                cost = cn;
                lambda = (lambda * 0.1).max(1e-15);
                improved = true;
                if step.amax() < options.step_tolerance {
                    return LmPolynomialResult { x, cost, iterations };
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
        P::residual_jacobian(&x, p, &mut f, &mut j);
    }
    LmPolynomialResult { x, cost, iterations }
}

/// The angular residual of one correspondence (module docs): the sine of the angle between
/// `f` and the plane of `R f'` and `c = t + s R v' - v`; `0` when that plane is undefined.
pub fn angular_residual(r: &Matrix3<f64>, t: &Vector3<f64>, s: f64, c: &GrpsCorrespondence) -> f64 {
    let g = r * c.fp;
    let off = t + r * c.vp * s - c.v;
    let n = g.cross(&off).norm() * c.f.norm();
    if n > 0.0 {
        grps_residual_direct(r, t, s, c) / n
    } else {
        0.0
    }
}

/// A refined pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RefinedPose {
    /// Rotation.
    pub rotation: Matrix3<f64>,
    /// Translation.
    pub translation: Vector3<f64>,
    /// Scale.
    pub scale: f64,
    /// Sum of squared angular residuals.
    pub cost: f64,
    /// Iterations run.
    pub iterations: usize,
}

fn angular_cost(r: &Matrix3<f64>, t: &Vector3<f64>, s: f64, corrs: &[GrpsCorrespondence]) -> f64 {
    corrs.iter().map(|c| angular_residual(r, t, s, c).powi(2)).sum()
}

/// Levenberg-Marquardt on the angular residuals of `corrs` (module docs) from `(r, t, s)`.
/// Never fails: a non-finite step ends the loop with the last accepted pose.
pub fn refine_pose(r: &Matrix3<f64>, t: &Vector3<f64>, s: f64, corrs: &[GrpsCorrespondence], options: &LmOptions) -> RefinedPose {
    let (mut r, mut t, mut s) = (*r, *t, s);
    let mut cost = angular_cost(&r, &t, s, corrs);
    let mut lambda = options.initial_lambda;
    let mut iterations = 0;
    while iterations < options.max_iterations && cost.is_finite() {
        iterations += 1;
        let mut a = SMatrix::<f64, 7, 7>::zeros();
        let mut b = SVector::<f64, 7>::zeros();
        for c in corrs {
            let f = c.f;
            let g = r * c.fp;
            let rw = r * c.vp.cross(&c.fp);
            let off = t + r * c.vp * s - c.v;
            let norm = g.cross(&off).norm() * f.norm();
            if norm.is_nan() || norm <= 1e-300 {
                continue;
            }
            let res = grps_residual_direct(&r, &t, s, c) / norm;
            // d(triple)/dw, /dt, /ds (R <- exp([w]x) R)
            let dw = g.cross(&t.cross(&f)) - rw.cross(&f) * s + g.cross(&f.cross(&c.v));
            let dt = f.cross(&g);
            let ds = -f.dot(&rw);
            let jrow = SVector::<f64, 7>::from([dw.x, dw.y, dw.z, dt.x, dt.y, dt.z, ds]) / norm;
            a += jrow * jrow.transpose();
            b += jrow * res;
        }
        let mut improved = false;
        for _ in 0..10 {
            let mut damped = a;
            for k in 0..7 {
                damped[(k, k)] += lambda * a[(k, k)].max(1e-12);
            }
            let Some(step) = damped.cholesky().map(|ch| -ch.solve(&b)) else {
                lambda *= 10.0;
                continue;
            };
            if !step.iter().all(|v| v.is_finite()) {
                break;
            }
            let rn = Rotation3::new(Vector3::new(step[0], step[1], step[2])).into_inner() * r;
            let tn = t + Vector3::new(step[3], step[4], step[5]);
            let sn = s + step[6];
            let cn = angular_cost(&rn, &tn, sn, corrs);
            if cn < cost {
                (r, t, s, cost) = (rn, tn, sn, cn);
                lambda = (lambda * 0.1).max(1e-15);
                improved = true;
                if step.amax() < options.step_tolerance {
                    return RefinedPose { rotation: r, translation: t, scale: s, cost, iterations };
                }
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    RefinedPose { rotation: r, translation: t, scale: s, cost, iterations }
}

/// The least-squares translation and scale for a given rotation: the constraint is linear in
/// `(t, s)`, `(f x R f') . t - (f . R (v' x f')) s = -f . (v x R f')`; each row is divided by
/// `|f| |R f'|`. `None` if the 4x4 normal equations are singular.
pub fn translation_scale_for_rotation(r: &Matrix3<f64>, corrs: &[GrpsCorrespondence]) -> Option<(Vector3<f64>, f64)> {
    let mut a = SMatrix::<f64, 4, 4>::zeros();
    let mut b = SVector::<f64, 4>::zeros();
    for c in corrs {
        let g = r * c.fp;
        let w = 1.0 / (c.f.norm() * g.norm());
        if !w.is_finite() {
            return None;
        }
        let ft = c.f.cross(&g);
        let row = SVector::<f64, 4>::from([ft.x, ft.y, ft.z, -c.f.dot(&(r * c.vp.cross(&c.fp)))]) * w;
        let rhs = -c.f.dot(&c.v.cross(&g)) * w;
        a += row * row.transpose();
        b += row * rhs;
    }
    let x = a.cholesky()?.solve(&b);
    x.iter().all(|v| v.is_finite()).then(|| (Vector3::new(x[0], x[1], x[2]), x[3]))
}

/// How well a rotation alone explains the data: the summed squared angular residuals
/// ([`angular_residual`]) at the rotation's least-squares `(t, s)`
/// ([`translation_scale_for_rotation`]); `f64::INFINITY` when `(t, s)` is undetermined or the
/// cost is not finite. It ranks a regressor's start hypotheses on one problem: the true rotation
/// scores 0 on exact data, and the translation and scale need not be predicted well for the
/// rank to hold. Measured (2026-12-03, 2,000 validation scenes, 4 hypotheses): the first-ranked
/// rotation has a median error of 11.6 deg by this cost, 12.6 by the linear residual alone,
/// 14.2 by the angular cost of the predicted `(t, s)`, 14.7 by the network's own scores.
pub fn rotation_residual(r: &Matrix3<f64>, corrs: &[GrpsCorrespondence]) -> f64 {
    match translation_scale_for_rotation(r, corrs) {
        Some((t, s)) => {
            let cost = angular_cost(r, &t, s, corrs);
            if cost.is_finite() {
                cost
            } else {
                f64::INFINITY
            }
        }
        None => f64::INFINITY,
    }
}
