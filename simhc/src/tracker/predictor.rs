//! Predictor pieces on the path ODE `J_x dx/dt = -dH/dt`: the tangent (one factorization, or
//! the corrector's last), and Hermite extrapolation through accepted points (none). The
//! Runge-Kutta stages are steps of the path state machine (`super::path`).

use super::linalg::LinearSolver;
use super::result::Trouble;
use crate::homotopy::Homotopy;
use crate::Scalar;
use nalgebra::{SMatrix, SVector};

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
) -> Result<SVector<S, NX>, Trouble>
where
    S: Scalar,
    H: Homotopy<S, NX, NF>,
{
    let mut j = SMatrix::<S, NF, NX>::zeros();
    let mut dh = SVector::<S, NF>::zeros();
    h.jacobian_dt(x, t, &mut j, &mut dh);
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
pub(crate) fn axpy<S: Scalar, const N: usize>(x: &SVector<S, N>, c: f64, v: &SVector<S, N>) -> SVector<S, N> {
    let c = S::from_real(c);
    let mut out = *x;
    for (o, &vi) in out.iter_mut().zip(v.iter()) {
        *o += c * vi;
    }
    out
}

/// Accepted points before the current one, with their tangents (oldest first), for the
/// multistep [`Predictor::Hermite`]. Fixed-size: no allocation.
#[derive(Debug, Clone, Copy)]
pub(crate) struct History<S: Scalar, const NX: usize> {
    t: [f64; 2],
    x: [SVector<S, NX>; 2],
    v: [SVector<S, NX>; 2],
    len: usize,
}

impl<S: Scalar, const NX: usize> History<S, NX> {
    pub(crate) fn new() -> Self {
        Self { t: [0.0; 2], x: [SVector::zeros(); 2], v: [SVector::zeros(); 2], len: 0 }
    }

    /// How many points there are.
    #[inline]
    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// Forgets every point (start, or a drag step that left the path).
    #[inline]
    pub(crate) fn clear(&mut self) {
        self.len = 0;
    }

    /// Appends a point, dropping the oldest beyond two.
    #[inline]
    pub(crate) fn push(&mut self, t: f64, x: &SVector<S, NX>, v: &SVector<S, NX>) {
        if self.len == 2 {
            self.t[0] = self.t[1];
            self.x[0] = self.x[1];
            self.v[0] = self.v[1];
            self.len = 1;
        }
        self.t[self.len] = t;
        self.x[self.len] = *x;
        self.v[self.len] = *v;
        self.len += 1;
    }
}

/// Hermite extrapolation to `t + dt` through the last `m - 1` history points and `(t, x, v)`,
/// each with its value and tangent (confluent divided differences, Newton form, times relative
/// to `t`): the polynomial of degree `2m - 1`.
#[inline]
pub(crate) fn hermite<S: Scalar, const NX: usize>(
    history: &History<S, NX>,
    m: usize,
    x: &SVector<S, NX>,
    t: f64,
    v: &SVector<S, NX>,
    dt: f64,
) -> SVector<S, NX> {
    const MAX: usize = 6;
    let n = 2 * m;
    let first = history.len + 1 - m;
    let point = |i: usize| -> (f64, &SVector<S, NX>, &SVector<S, NX>) {
        let k = first + i;
        if k < history.len {
            (history.t[k] - t, &history.x[k], &history.v[k])
        } else {
            (0.0, x, v)
        }
    };
    let mut z = [0.0; MAX];
    let mut d = [SVector::<S, NX>::zeros(); MAX];
    for j in 0..n {
        let (tj, xj, _) = point(j / 2);
        z[j] = tj;
        d[j] = *xj;
    }
    // First differences: the tangent at a repeated node, else the slope.
    for j in (1..n).rev() {
        if j % 2 == 1 {
            d[j] = *point(j / 2).2;
        } else {
            let inv = S::from_real(1.0 / (z[j] - z[j - 1]));
            d[j] = (d[j] - d[j - 1]) * inv;
        }
    }
    for k in 2..n {
        for j in (k..n).rev() {
            let inv = S::from_real(1.0 / (z[j] - z[j - k]));
            d[j] = (d[j] - d[j - 1]) * inv;
        }
    }
    let mut p = d[n - 1];
    for j in (0..n - 1).rev() {
        let c = S::from_real(dt - z[j]);
        for i in 0..NX {
            p[i] = p[i] * c + d[j][i];
        }
    }
    p
}
