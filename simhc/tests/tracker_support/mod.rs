//! Hand-written problems for the tracker tests (the code generator is developed in parallel).
//! Every problem is generic over the scalar, like generated code.
#![allow(dead_code)]

use nalgebra::{SMatrix, SVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use simhc::{ParamDerivative, Problem, ProblemInfo, Ring, Scalar};

/// A real constant in `S`.
#[inline]
pub fn k<S: Ring>(v: f64) -> S {
    S::constant(v)
}

pub fn rng(seed: u64) -> ChaCha8Rng {
    println!("seed = {seed}");
    ChaCha8Rng::seed_from_u64(seed)
}

pub fn uniform(rng: &mut ChaCha8Rng, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * rng.random::<f64>()
}

/// Implements `ProblemInfo` with placeholder names.
macro_rules! info {
    ($t:ty, $name:expr) => {
        impl ProblemInfo for $t {
            const NAME: &'static str = $name;
            const UNKNOWN_NAMES: &'static [&'static str] = &[];
            const PARAM_NAMES: &'static [&'static str] = &[];
        }
    };
}

// ---------------------------------------------------------------------------------------------

/// `F(x; a) = x^3 + a x - a^3 - a^2`: for `a > 0` the only real root is `x = a` (the other two
/// solve `x^2 + a x + a^2 + a = 0`, discriminant `-3a^2 - 4a < 0`).
pub struct Cubic;
info!(Cubic, "cubic");

impl Problem<1, 1, 1> for Cubic {
    fn residual<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 1>, f: &mut SVector<S, 1>) {
        let (x, a) = (x[0], p[0]);
        f[0] = x * x * x + a * x - a * a * a - a * a;
    }
    fn jacobian<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 1>, j: &mut SMatrix<S, 1, 1>) {
        j[(0, 0)] = k::<S>(3.0) * x[0] * x[0] + p[0];
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 1>, f: &mut SVector<S, 1>, j: &mut SMatrix<S, 1, 1>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

impl ParamDerivative<1, 1, 1> for Cubic {
    fn param_jacobian<S: Scalar>(x: &SVector<S, 1>, p: &SVector<S, 1>, jp: &mut SMatrix<S, 1, 1>) {
        let a = p[0];
        jp[(0, 0)] = x[0] - k::<S>(3.0) * a * a - k::<S>(2.0) * a;
    }
    fn param_directional<S: Scalar>(x: &SVector<S, 1>, p: &SVector<S, 1>, dp: &SVector<S, 1>, out: &mut SVector<S, 1>) {
        let mut jp = SMatrix::<S, 1, 1>::zeros();
        Self::param_jacobian(x, p, &mut jp);
        out[0] = jp[(0, 0)] * dp[0];
    }
}

// ---------------------------------------------------------------------------------------------

/// `F(x; a) = x^3 - 3x - a`: folds at `x = -1, a = 2` and `x = 1, a = -2`.
pub struct FoldCubic;
info!(FoldCubic, "fold_cubic");

impl Problem<1, 1, 1> for FoldCubic {
    fn residual<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 1>, f: &mut SVector<S, 1>) {
        let x = x[0];
        f[0] = x * x * x - k::<S>(3.0) * x - p[0];
    }
    fn jacobian<S: Ring>(x: &SVector<S, 1>, _p: &SVector<S, 1>, j: &mut SMatrix<S, 1, 1>) {
        j[(0, 0)] = k::<S>(3.0) * x[0] * x[0] - k::<S>(3.0);
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 1>, f: &mut SVector<S, 1>, j: &mut SMatrix<S, 1, 1>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

impl ParamDerivative<1, 1, 1> for FoldCubic {
    fn param_jacobian<S: Scalar>(_x: &SVector<S, 1>, _p: &SVector<S, 1>, jp: &mut SMatrix<S, 1, 1>) {
        jp[(0, 0)] = -S::one();
    }
    fn param_directional<S: Scalar>(_x: &SVector<S, 1>, _p: &SVector<S, 1>, dp: &SVector<S, 1>, out: &mut SVector<S, 1>) {
        out[0] = -dp[0];
    }
}

// ---------------------------------------------------------------------------------------------

/// `F(x; a, b, c) = a x^2 + b x + c`.
pub struct Quadratic;
info!(Quadratic, "quadratic");

impl Problem<1, 1, 3> for Quadratic {
    fn residual<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 3>, f: &mut SVector<S, 1>) {
        let x = x[0];
        f[0] = (p[0] * x + p[1]) * x + p[2];
    }
    fn jacobian<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 3>, j: &mut SMatrix<S, 1, 1>) {
        j[(0, 0)] = k::<S>(2.0) * p[0] * x[0] + p[1];
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 3>, f: &mut SVector<S, 1>, j: &mut SMatrix<S, 1, 1>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

impl ParamDerivative<1, 1, 3> for Quadratic {
    fn param_jacobian<S: Scalar>(x: &SVector<S, 1>, _p: &SVector<S, 3>, jp: &mut SMatrix<S, 1, 3>) {
        jp[(0, 0)] = x[0] * x[0];
        jp[(0, 1)] = x[0];
        jp[(0, 2)] = S::one();
    }
    fn param_directional<S: Scalar>(x: &SVector<S, 1>, _p: &SVector<S, 3>, dp: &SVector<S, 3>, out: &mut SVector<S, 1>) {
        out[0] = dp[0] * x[0] * x[0] + dp[1] * x[0] + dp[2];
    }
}

// ---------------------------------------------------------------------------------------------

/// Circle `(x - cx)^2 + (y - cy)^2 = r^2` and line `nx x + ny y = d`; `p = (cx, cy, r, nx, ny, d)`.
pub struct CircleLine;
info!(CircleLine, "circle_line");

impl Problem<2, 2, 6> for CircleLine {
    fn residual<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 6>, f: &mut SVector<S, 2>) {
        let (u, v) = (x[0] - p[0], x[1] - p[1]);
        f[0] = u * u + v * v - p[2] * p[2];
        f[1] = p[3] * x[0] + p[4] * x[1] - p[5];
    }
    fn jacobian<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 6>, j: &mut SMatrix<S, 2, 2>) {
        j[(0, 0)] = k::<S>(2.0) * (x[0] - p[0]);
        j[(0, 1)] = k::<S>(2.0) * (x[1] - p[1]);
        j[(1, 0)] = p[3];
        j[(1, 1)] = p[4];
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, 6>, f: &mut SVector<S, 2>, j: &mut SMatrix<S, 2, 2>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

impl ParamDerivative<2, 2, 6> for CircleLine {
    fn param_jacobian<S: Scalar>(x: &SVector<S, 2>, p: &SVector<S, 6>, jp: &mut SMatrix<S, 2, 6>) {
        jp.fill(S::zero());
        jp[(0, 0)] = k::<S>(-2.0) * (x[0] - p[0]);
        jp[(0, 1)] = k::<S>(-2.0) * (x[1] - p[1]);
        jp[(0, 2)] = k::<S>(-2.0) * p[2];
        jp[(1, 3)] = x[0];
        jp[(1, 4)] = x[1];
        jp[(1, 5)] = -S::one();
    }
    fn param_directional<S: Scalar>(x: &SVector<S, 2>, p: &SVector<S, 6>, dp: &SVector<S, 6>, out: &mut SVector<S, 2>) {
        let mut jp = SMatrix::<S, 2, 6>::zeros();
        Self::param_jacobian(x, p, &mut jp);
        jp.mul_to(dp, out);
    }
}

/// The two intersections of circle and line in closed form, ordered along the line direction
/// `(-ny, nx)`; `None` if the line misses the circle.
pub fn circle_line_intersections(p: &SVector<f64, 6>) -> Option<[SVector<f64, 2>; 2]> {
    let (cx, cy, r, nx, ny, d) = (p[0], p[1], p[2], p[3], p[4], p[5]);
    let nn = (nx * nx + ny * ny).sqrt();
    let (ux, uy) = (nx / nn, ny / nn);
    let dist = (d / nn) - (ux * cx + uy * cy); // signed distance from the centre to the line
    let h2 = r * r - dist * dist;
    if h2 <= 0.0 {
        return None;
    }
    let h = h2.sqrt();
    let (fx, fy) = (cx + dist * ux, cy + dist * uy); // foot of the perpendicular
    let (tx, ty) = (-uy, ux);
    Some([SVector::<f64, 2>::new(fx - h * tx, fy - h * ty), SVector::<f64, 2>::new(fx + h * tx, fy + h * ty)])
}

// ---------------------------------------------------------------------------------------------

/// A random square quadratic system in 4 unknowns whose solution is known by construction:
/// `F_i(x; p) = sum_j A_ij e_j + sum_{j<=l} B_ijl e_j e_l`, `e_j = x_j - u_j^3`, so `x = u^3`
/// (component-wise) solves it for every `p = (A, B, u)`. Along a parameter segment `u` is linear
/// in `t` and the solution path `x(t) = u(t)^3` is a cubic curve.
pub struct Quad4;
info!(Quad4, "quad4");

pub const Q4_NA: usize = 16;
pub const Q4_NB: usize = 40;
pub const Q4_NP: usize = Q4_NA + Q4_NB + 4;

/// Index of `B_ijl` (`j <= l`) in `p`.
#[inline]
fn q4_b(i: usize, j: usize, l: usize) -> usize {
    // pairs (j, l), j <= l, in row-major order: 10 per equation
    let mut idx = 0;
    for a in 0..4 {
        for b in a..4 {
            if a == j && b == l {
                return Q4_NA + 10 * i + idx;
            }
            idx += 1;
        }
    }
    unreachable!()
}

#[inline]
fn q4_e<S: Ring>(x: &SVector<S, 4>, p: &SVector<S, Q4_NP>) -> SVector<S, 4> {
    let mut e = SVector::<S, 4>::from_element(S::constant(0.0));
    for j in 0..4 {
        let u = p[Q4_NA + Q4_NB + j];
        e[j] = x[j] - u * u * u;
    }
    e
}

impl Problem<4, 4, Q4_NP> for Quad4 {
    fn residual<S: Ring>(x: &SVector<S, 4>, p: &SVector<S, Q4_NP>, f: &mut SVector<S, 4>) {
        let e = q4_e(x, p);
        for i in 0..4 {
            let mut s = S::constant(0.0);
            for j in 0..4 {
                s = s + p[4 * i + j] * e[j];
                for l in j..4 {
                    s = s + p[q4_b(i, j, l)] * e[j] * e[l];
                }
            }
            f[i] = s;
        }
    }
    fn jacobian<S: Ring>(x: &SVector<S, 4>, p: &SVector<S, Q4_NP>, jac: &mut SMatrix<S, 4, 4>) {
        let e = q4_e(x, p);
        for i in 0..4 {
            for m in 0..4 {
                jac[(i, m)] = p[4 * i + m];
            }
            for j in 0..4 {
                for l in j..4 {
                    let b = p[q4_b(i, j, l)];
                    jac[(i, j)] = jac[(i, j)] + b * e[l];
                    jac[(i, l)] = jac[(i, l)] + b * e[j];
                }
            }
        }
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 4>, p: &SVector<S, Q4_NP>, f: &mut SVector<S, 4>, j: &mut SMatrix<S, 4, 4>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

impl ParamDerivative<4, 4, Q4_NP> for Quad4 {
    fn param_jacobian<S: Scalar>(x: &SVector<S, 4>, p: &SVector<S, Q4_NP>, jp: &mut SMatrix<S, 4, Q4_NP>) {
        let e = q4_e(x, p);
        let mut jx = SMatrix::<S, 4, 4>::zeros();
        Self::jacobian(x, p, &mut jx);
        jp.fill(S::zero());
        for i in 0..4 {
            for j in 0..4 {
                jp[(i, 4 * i + j)] = e[j];
                for l in j..4 {
                    jp[(i, q4_b(i, j, l))] = e[j] * e[l];
                }
                // d e_j / d u_j = -3 u_j^2
                let u = p[Q4_NA + Q4_NB + j];
                jp[(i, Q4_NA + Q4_NB + j)] = -jx[(i, j)] * k::<S>(3.0) * u * u;
            }
        }
    }
    fn param_directional<S: Scalar>(x: &SVector<S, 4>, p: &SVector<S, Q4_NP>, dp: &SVector<S, Q4_NP>, out: &mut SVector<S, 4>) {
        let mut jp = SMatrix::<S, 4, Q4_NP>::zeros();
        Self::param_jacobian(x, p, &mut jp);
        jp.mul_to(dp, out);
    }
}

/// Random `Quad4` parameters: `A = 3 I + U(-0.5, 0.5)` (strictly diagonally dominant, so every
/// convex combination of two such `A` is regular), `B ~ U(-0.3, 0.3)`, `u ~ U(-1.2, 1.2)`.
pub fn quad4_params(rng: &mut ChaCha8Rng) -> SVector<f64, Q4_NP> {
    let mut p = SVector::<f64, Q4_NP>::zeros();
    for i in 0..4 {
        for j in 0..4 {
            p[4 * i + j] = uniform(rng, -0.5, 0.5) + if i == j { 3.0 } else { 0.0 };
        }
    }
    for b in 0..Q4_NB {
        p[Q4_NA + b] = uniform(rng, -0.3, 0.3);
    }
    for j in 0..4 {
        p[Q4_NA + Q4_NB + j] = uniform(rng, -1.2, 1.2);
    }
    p
}

/// The solution `u^3` of `Quad4` at `p`.
pub fn quad4_solution(p: &SVector<f64, Q4_NP>) -> SVector<f64, 4> {
    SVector::<f64, 4>::from_fn(|j, _| p[Q4_NA + Q4_NB + j].powi(3))
}

// ---------------------------------------------------------------------------------------------

/// Three quadratic equations in two unknowns with the exact common root `(u, v)`:
/// `F_k = a_k e1 + b_k e2 + c_k e1^2 + d_k e1 e2 + g_k e2^2`, `e = (x - u, y - v)`,
/// `p = (a_k, b_k, c_k, d_k, g_k for k = 0..3, u, v)`.
pub struct Over3x2;
info!(Over3x2, "over3x2");

pub const O_NP: usize = 17;

impl Problem<2, 3, O_NP> for Over3x2 {
    fn residual<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, O_NP>, f: &mut SVector<S, 3>) {
        let (e1, e2) = (x[0] - p[15], x[1] - p[16]);
        for kk in 0..3 {
            let c = 5 * kk;
            f[kk] = p[c] * e1 + p[c + 1] * e2 + p[c + 2] * e1 * e1 + p[c + 3] * e1 * e2 + p[c + 4] * e2 * e2;
        }
    }
    fn jacobian<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, O_NP>, j: &mut SMatrix<S, 3, 2>) {
        let (e1, e2) = (x[0] - p[15], x[1] - p[16]);
        let two = k::<S>(2.0);
        for kk in 0..3 {
            let c = 5 * kk;
            j[(kk, 0)] = p[c] + two * p[c + 2] * e1 + p[c + 3] * e2;
            j[(kk, 1)] = p[c + 1] + p[c + 3] * e1 + two * p[c + 4] * e2;
        }
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 2>, p: &SVector<S, O_NP>, f: &mut SVector<S, 3>, j: &mut SMatrix<S, 3, 2>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

impl ParamDerivative<2, 3, O_NP> for Over3x2 {
    fn param_jacobian<S: Scalar>(x: &SVector<S, 2>, p: &SVector<S, O_NP>, jp: &mut SMatrix<S, 3, O_NP>) {
        let (e1, e2) = (x[0] - p[15], x[1] - p[16]);
        let mut jx = SMatrix::<S, 3, 2>::zeros();
        Self::jacobian(x, p, &mut jx);
        jp.fill(S::zero());
        for kk in 0..3 {
            let c = 5 * kk;
            jp[(kk, c)] = e1;
            jp[(kk, c + 1)] = e2;
            jp[(kk, c + 2)] = e1 * e1;
            jp[(kk, c + 3)] = e1 * e2;
            jp[(kk, c + 4)] = e2 * e2;
            jp[(kk, 15)] = -jx[(kk, 0)];
            jp[(kk, 16)] = -jx[(kk, 1)];
        }
    }
    fn param_directional<S: Scalar>(x: &SVector<S, 2>, p: &SVector<S, O_NP>, dp: &SVector<S, O_NP>, out: &mut SVector<S, 3>) {
        let mut jp = SMatrix::<S, 3, O_NP>::zeros();
        Self::param_jacobian(x, p, &mut jp);
        jp.mul_to(dp, out);
    }
}

/// Random `Over3x2` parameters: linear parts of rank 2 with margin, small quadratic parts.
pub fn over_params(rng: &mut ChaCha8Rng) -> SVector<f64, O_NP> {
    let mut p = SVector::<f64, O_NP>::zeros();
    for kk in 0..3 {
        let c = 5 * kk;
        p[c] = uniform(rng, -1.0, 1.0);
        p[c + 1] = uniform(rng, -1.0, 1.0);
        for q in 2..5 {
            p[c + q] = uniform(rng, -0.3, 0.3);
        }
    }
    // Make the linear part well conditioned: add identity-like rows.
    p[0] += 2.0;
    p[6] += 2.0;
    p[15] = uniform(rng, -1.0, 1.0);
    p[16] = uniform(rng, -1.0, 1.0);
    p
}

// ---------------------------------------------------------------------------------------------

/// `F(x; c) = sum_k c_k x^k`, degree 6.
pub struct Poly6;
info!(Poly6, "poly6");

impl Problem<1, 1, 7> for Poly6 {
    fn residual<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 7>, f: &mut SVector<S, 1>) {
        let x = x[0];
        let mut acc = p[6];
        for kk in (0..6).rev() {
            acc = acc * x + p[kk];
        }
        f[0] = acc;
    }
    fn jacobian<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 7>, j: &mut SMatrix<S, 1, 1>) {
        let x = x[0];
        let mut acc = p[6] * k::<S>(6.0);
        for kk in (1..6).rev() {
            acc = acc * x + p[kk] * k::<S>(kk as f64);
        }
        j[(0, 0)] = acc;
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 7>, f: &mut SVector<S, 1>, j: &mut SMatrix<S, 1, 1>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}

/// The total-degree start system `x^6 - 1` (no parameters).
pub struct Start6;
info!(Start6, "start6");

impl Problem<1, 1, 0> for Start6 {
    fn residual<S: Ring>(x: &SVector<S, 1>, _p: &SVector<S, 0>, f: &mut SVector<S, 1>) {
        let x2 = x[0] * x[0];
        f[0] = x2 * x2 * x2 - S::constant(1.0);
    }
    fn jacobian<S: Ring>(x: &SVector<S, 1>, _p: &SVector<S, 0>, j: &mut SMatrix<S, 1, 1>) {
        let x = x[0];
        let x2 = x * x;
        j[(0, 0)] = k::<S>(6.0) * x2 * x2 * x;
    }
    fn residual_jacobian<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 0>, f: &mut SVector<S, 1>, j: &mut SMatrix<S, 1, 1>) {
        Self::residual(x, p, f);
        Self::jacobian(x, p, j);
    }
}
