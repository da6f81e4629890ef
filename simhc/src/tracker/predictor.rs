//! Predictors: explicit Runge-Kutta steps on the path ODE `J_x dx/dt = -dH/dt`.

use super::linalg::{FactorError, LinearSolver};
use super::options::Predictor;
use super::{Trouble, TrackStats};
use crate::homotopy::Homotopy;
use crate::Scalar;
use nalgebra::{SMatrix, SVector};

impl From<FactorError> for Trouble {
    #[inline]
    fn from(e: FactorError) -> Self {
        match e {
            FactorError::Singular => Trouble::Singular,
            FactorError::NonFinite => Trouble::NonFinite,
        }
    }
}

/// Whether every entry is finite.
#[inline]
pub(crate) fn all_finite<S: Scalar, const N: usize>(v: &SVector<S, N>) -> bool {
    v.iter().all(|e| e.is_finite_value())
}

/// The path tangent `dx/dt` at `(x, t)`: factorizes `J_x(x, t)` into `solver` (kept for reuse)
/// and solves `J_x v = -dH/dt` (least squares for `NF > NX`).
#[inline]
pub(crate) fn tangent<S, H, const NX: usize, const NF: usize>(
    h: &H,
    x: &SVector<S, NX>,
    t: f64,
    solver: &mut LinearSolver<S, NX, NF>,
    stats: &mut TrackStats,
) -> Result<SVector<S, NX>, Trouble>
where
    S: Scalar,
    H: Homotopy<S, NX, NF>,
{
    let mut j = SMatrix::<S, NF, NX>::zeros();
    let mut dh = SVector::<S, NF>::zeros();
    h.jacobian_dt(x, t, &mut j, &mut dh);
    stats.factorizations += 1;
    solver.factor(&j)?;
    tangent_from_factor(h, x, t, solver)
}

/// The tangent at `(x, t)` with the Jacobian factorization already in `solver` (the corrector's
/// last one, taken within the corrector tolerance of `x`): only `dH/dt` is evaluated.
#[inline]
pub(crate) fn tangent_from_factor<S, H, const NX: usize, const NF: usize>(
    h: &H,
    x: &SVector<S, NX>,
    t: f64,
    solver: &LinearSolver<S, NX, NF>,
) -> Result<SVector<S, NX>, Trouble>
where
    S: Scalar,
    H: Homotopy<S, NX, NF>,
{
    let mut dh = SVector::<S, NF>::zeros();
    h.dt(x, t, &mut dh);
    let mut v = solver.solve(&dh);
    v.neg_mut();
    if all_finite(&v) {
        Ok(v)
    } else {
        Err(Trouble::NonFinite)
    }
}

/// `x + c v` without temporaries.
#[inline]
fn axpy<S: Scalar, const N: usize>(x: &SVector<S, N>, c: f64, v: &SVector<S, N>) -> SVector<S, N> {
    let c = S::from_real(c);
    let mut out = *x;
    for (o, &vi) in out.iter_mut().zip(v.iter()) {
        *o += c * vi;
    }
    out
}

/// The predicted point at `t + dt` from `(x, t)` with tangent `k1` at `(x, t)`.
#[inline]
pub(crate) fn predict<S, H, const NX: usize, const NF: usize>(
    kind: Predictor,
    h: &H,
    x: &SVector<S, NX>,
    t: f64,
    dt: f64,
    k1: &SVector<S, NX>,
    solver: &mut LinearSolver<S, NX, NF>,
    stats: &mut TrackStats,
) -> Result<SVector<S, NX>, Trouble>
where
    S: Scalar,
    H: Homotopy<S, NX, NF>,
{
    let xp = match kind {
        Predictor::Euler => axpy(x, dt, k1),
        Predictor::Heun => {
            let k2 = tangent(h, &axpy(x, dt, k1), t + dt, solver, stats)?;
            let c = S::from_real(0.5 * dt);
            let mut out = *x;
            for i in 0..NX {
                out[i] += c * (k1[i] + k2[i]);
            }
            out
        }
        Predictor::Rk4 => {
            let half = 0.5 * dt;
            let k2 = tangent(h, &axpy(x, half, k1), t + half, solver, stats)?;
            let k3 = tangent(h, &axpy(x, half, &k2), t + half, solver, stats)?;
            let k4 = tangent(h, &axpy(x, dt, &k3), t + dt, solver, stats)?;
            let c = S::from_real(dt / 6.0);
            let two = S::from_real(2.0);
            let mut out = *x;
            for i in 0..NX {
                out[i] += c * (k1[i] + two * (k2[i] + k3[i]) + k4[i]);
            }
            out
        }
    };
    if all_finite(&xp) {
        Ok(xp)
    } else {
        Err(Trouble::NonFinite)
    }
}
