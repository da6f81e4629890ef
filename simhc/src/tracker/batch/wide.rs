//! The arithmetic of path lanes: [`Wide`] holds one complex number per path, and the batch
//! operation's building blocks (the coefficient Horner, Gaussian elimination) work on it lane by
//! lane.
//!
//! Why a type of its own rather than [`crate::lanes::C64x4`]: the batch operation is the whole
//! cost of all-roots tracking, and two choices that row lanes cannot make pay here.
//! - **The width `W` follows the vector registers**: 8 paths with AVX-512 (one register per
//!   part), 4 with AVX2. Each broadcast coefficient and each loop step then serves a full
//!   register. (8 paths in two AVX2 registers per part run out of registers: slower than 4.)
//! - **Fused products** (`FMA = true`, chosen at run time when the CPU has FMA): a complex
//!   product is two multiplies and two fused multiply-adds instead of four multiplies and two
//!   additions, and an elimination update `r - m p` is four fused operations. Results differ
//!   from unfused arithmetic by rounding only; on one machine they do not depend on the batch.

use crate::lanes::Lanes;
use std::ops::{Add, Mul, Neg, Sub};

use crate::scalar::C;

/// `W` complex numbers, real and imaginary parts apart; products fused when `FMA`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
pub struct Wide<const W: usize, const FMA: bool> {
    /// Real parts.
    pub re: [f64; W],
    /// Imaginary parts.
    pub im: [f64; W],
}

impl<const W: usize, const FMA: bool> Default for Wide<W, FMA> {
    #[inline(always)]
    fn default() -> Self {
        Self { re: [0.0; W], im: [0.0; W] }
    }
}

/// `a * b + c`, fused when `FMA` (never a library call: without FMA hardware `FMA` is false).
#[inline(always)]
pub fn madd<const FMA: bool>(a: f64, b: f64, c: f64) -> f64 {
    if FMA {
        a.mul_add(b, c)
    } else {
        a * b + c
    }
}

/// Lane-wise `f(a, b)` on both parts.
macro_rules! lanewise {
    ($trait:ident, $method:ident, $op:tt) => {
        impl<const W: usize, const FMA: bool> $trait for Wide<W, FMA> {
            type Output = Self;
            #[inline(always)]
            fn $method(self, o: Self) -> Self {
                let mut out = self;
                for l in 0..W {
                    out.re[l] = self.re[l] $op o.re[l];
                    out.im[l] = self.im[l] $op o.im[l];
                }
                out
            }
        }
    };
}
lanewise!(Add, add, +);
lanewise!(Sub, sub, -);

impl<const W: usize, const FMA: bool> Mul for Wide<W, FMA> {
    type Output = Self;
    /// `(a + ib)(c + id) = (ac - bd) + i(ad + bc)`.
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        let mut out = self;
        for l in 0..W {
            let (a, b, c, d) = (self.re[l], self.im[l], o.re[l], o.im[l]);
            out.re[l] = madd::<FMA>(a, c, -(b * d));
            out.im[l] = madd::<FMA>(a, d, b * c);
        }
        out
    }
}

impl<const W: usize, const FMA: bool> Neg for Wide<W, FMA> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        let mut out = self;
        for l in 0..W {
            out.re[l] = -self.re[l];
            out.im[l] = -self.im[l];
        }
        out
    }
}

impl<const W: usize, const FMA: bool> Lanes for Wide<W, FMA> {
    type Scalar = C;
    #[inline(always)]
    fn from_real(c: f64) -> Self {
        Self { re: [c; W], im: [0.0; W] }
    }
    #[inline(always)]
    fn scale(self, c: f64) -> Self {
        let mut out = self;
        for l in 0..W {
            out.re[l] *= c;
            out.im[l] *= c;
        }
        out
    }
    #[inline(always)]
    fn splat(v: C) -> Self {
        Self { re: [v.re; W], im: [v.im; W] }
    }
    #[inline(always)]
    fn get(&self, i: usize) -> C {
        C::new(self.re[i], self.im[i])
    }
    #[inline(always)]
    fn set(&mut self, i: usize, v: C) {
        self.re[i] = v.re;
        self.im[i] = v.im;
    }
    #[inline(always)]
    fn mul_add(self, b: Self, c: Self) -> Self {
        if !FMA {
            // Unfused: the trait's order (what unfused generated code computes).
            return self * b + c;
        }
        let mut out = c;
        for l in 0..W {
            let (xr, xi, yr, yi) = (self.re[l], self.im[l], b.re[l], b.im[l]);
            out.re[l] = madd::<FMA>(xr, yr, madd::<FMA>(-xi, yi, c.re[l]));
            out.im[l] = madd::<FMA>(xr, yi, madd::<FMA>(xi, yr, c.im[l]));
        }
        out
    }
    #[inline(always)]
    fn mul_sub(self, b: Self, c: Self) -> Self {
        // `a b + (-c)`: negation is exact and `x - y == x + (-y)` in IEEE arithmetic, so this
        // is `mul_add`'s computation, fused or not.
        self.mul_add(b, -c)
    }
    #[inline(always)]
    fn neg_mul_add(self, b: Self, c: Self) -> Self {
        if !FMA {
            // Unfused: the trait's order (what unfused generated code computes).
            return c - self * b;
        }
        c.minus_product(self, b)
    }
    #[inline(always)]
    fn scale_add(self, k: f64, c: Self) -> Self {
        if !FMA {
            // Unfused: the trait's order (what unfused generated code computes).
            return self.scale(k) + c;
        }
        let mut out = c;
        for l in 0..W {
            out.re[l] = madd::<FMA>(self.re[l], k, c.re[l]);
            out.im[l] = madd::<FMA>(self.im[l], k, c.im[l]);
        }
        out
    }
}

impl<const W: usize, const FMA: bool> Wide<W, FMA> {
    /// `self - m * p` (the elimination update; four fused operations per lane with `FMA`).
    #[inline(always)]
    fn minus_product(self, m: Self, p: Self) -> Self {
        let mut out = self;
        for l in 0..W {
            let (mr, mi, pr, pi) = (m.re[l], m.im[l], p.re[l], p.im[l]);
            out.re[l] = madd::<FMA>(mi, pi, madd::<FMA>(-mr, pr, self.re[l]));
            out.im[l] = madd::<FMA>(-mi, pr, madd::<FMA>(-mr, pi, self.im[l]));
        }
        out
    }

    /// `|re| + |im|` per lane (the pivot measure of the scalar LUs).
    #[inline(always)]
    fn magnitude(self) -> [f64; W] {
        std::array::from_fn(|l| self.re[l].abs() + self.im[l].abs())
    }

    /// `1 / z` per lane.
    #[inline(always)]
    fn reciprocal(self) -> Self {
        let mut out = self;
        for l in 0..W {
            let (a, b) = (self.re[l], self.im[l]);
            let d = 1.0 / (a * a + b * b);
            out.re[l] = a * d;
            out.im[l] = -b * d;
        }
        out
    }

    /// Swaps lane `l` of `self` and `other`.
    #[inline(always)]
    fn swap_lane(&mut self, other: &mut Self, l: usize) {
        std::mem::swap(&mut self.re[l], &mut other.re[l]);
        std::mem::swap(&mut self.im[l], &mut other.im[l]);
    }
}

/// `a * t + b` per lane, `t` real.
#[inline(always)]
fn axpy_real<const W: usize, const FMA: bool>(a: Wide<W, FMA>, t: &[f64; W], b: Wide<W, FMA>) -> Wide<W, FMA> {
    let mut out = b;
    for l in 0..W {
        out.re[l] = madd::<FMA>(a.re[l], t[l], b.re[l]);
        out.im[l] = madd::<FMA>(a.im[l], t[l], b.im[l]);
    }
    out
}

/// `p(t) = sum_k t^k p[k]` and `p'(t)` in every lane, each lane at its own real `t` (Horner for
/// both at once). Unrolled for the usual lengths (GRPS: cubic coefficients).
#[inline(always)]
pub fn horner<const W: usize, const FMA: bool>(p: &[C], t: &[f64; W]) -> (Wide<W, FMA>, Wide<W, FMA>) {
    let s = Wide::<W, FMA>::splat;
    let zero = Wide::default();
    match *p {
        [a] => (s(a), zero),
        [a, b] => (axpy_real(s(b), t, s(a)), s(b)),
        [a, b, c] => {
            let (v, d) = (axpy_real(s(c), t, s(b)), s(c));
            (axpy_real(v, t, s(a)), axpy_real(d, t, v))
        }
        [a, b, c, e] => {
            let (v, d) = (axpy_real(s(e), t, s(c)), s(e));
            let (v, d) = (axpy_real(v, t, s(b)), axpy_real(d, t, v));
            (axpy_real(v, t, s(a)), axpy_real(d, t, v))
        }
        _ => {
            let n = p.len();
            let mut v = if n == 0 { zero } else { s(p[n - 1]) };
            let mut d = zero;
            for &pk in p[..n.saturating_sub(1)].iter().rev() {
                d = axpy_real(d, t, v);
                v = axpy_real(v, t, s(pk));
            }
            (v, d)
        }
    }
}

/// Per-lane outcome of the linear algebra.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Factor {
    /// Solved.
    Ok,
    /// A pivot at or below the singularity threshold.
    Singular,
    /// A non-finite matrix entry.
    NonFinite,
}

/// Threshold pivoting: the diagonal entry stays the pivot while its magnitude is at least this
/// fraction of the column's largest below it (partial pivoting is `1`).
///
/// Why: a row interchange moves one lane's data element by element, while the elimination runs
/// on all lanes at once; with `0.1` interchanges become rare, and the growth of the entries
/// stays bounded by `(1 + 1 / 0.1)` per step (the usual choice of sparse LU codes). Measured on
/// GRPS7: the same end points as with partial pivoting (tests of the batch tracker).
pub const PIVOT_THRESHOLD: f64 = 0.1;

/// Gaussian elimination with threshold pivoting ([`PIVOT_THRESHOLD`]), per lane, of `a`
/// (row-major, `N x N`) applied to two right-hand sides, then back substitution: `f <- a^-1 f`,
/// `d <- a^-1 d`. A lane is singular when every candidate pivot of a column is at most
/// `N * eps * |A|_1` (the scalar LUs' rule) and non-finite when `A` has a non-finite entry; its
/// outputs are then meaningless but finite.
#[inline(always)]
pub fn solve_lanes<const W: usize, const FMA: bool, const N: usize>(
    a: &mut [[Wide<W, FMA>; N]; N],
    f: &mut [Wide<W, FMA>; N],
    d: &mut [Wide<W, FMA>; N],
) -> [Factor; W] {
    let mut status = [Factor::Ok; W];
    // |A|_1 per lane (largest column sum of |re| + |im|) and finiteness.
    let mut norm = [0.0f64; W];
    for c in 0..N {
        let mut sum = [0.0f64; W];
        for row in a.iter() {
            let m = row[c].magnitude();
            for l in 0..W {
                sum[l] += m[l];
            }
        }
        for l in 0..W {
            // `max` drops NaN, so finiteness is checked per column.
            if !sum[l].is_finite() {
                status[l] = Factor::NonFinite;
            }
            norm[l] = norm[l].max(sum[l]);
        }
    }
    let threshold: [f64; W] = std::array::from_fn(|l| norm[l] * N as f64 * f64::EPSILON);
    let mut inv_diag = [Wide::<W, FMA>::default(); N];
    for k in 0..N {
        // The largest candidate below the diagonal, all lanes at once.
        let diag = a[k][k].magnitude();
        let mut best = [0.0f64; W];
        let mut best_row = [k as f64; W];
        for (i, row) in a.iter().enumerate().skip(k + 1) {
            let m = row[k].magnitude();
            for l in 0..W {
                let better = m[l] > best[l];
                best[l] = if better { m[l] } else { best[l] };
                best_row[l] = if better { i as f64 } else { best_row[l] };
            }
        }
        for l in 0..W {
            let keep = diag[l] >= PIVOT_THRESHOLD * best[l] && diag[l] > threshold[l];
            if keep {
                continue;
            }
            // Not above the threshold, NaN included.
            let pivot = diag[l].max(best[l]);
            if pivot.partial_cmp(&threshold[l]) != Some(std::cmp::Ordering::Greater) {
                if status[l] == Factor::Ok {
                    status[l] = Factor::Singular;
                }
                // Keep the lane's arithmetic finite; its results are discarded.
                a[k][k].set(l, C::new(1.0, 0.0));
                continue;
            }
            if best[l] > diag[l] {
                let r = best_row[l] as usize;
                let (top, below) = a.split_at_mut(r);
                for (x, y) in top[k][k..].iter_mut().zip(&mut below[0][k..]) {
                    x.swap_lane(y, l);
                }
                let (fk, fr) = f.split_at_mut(r);
                fk[k].swap_lane(&mut fr[0], l);
                let (dk, dr) = d.split_at_mut(r);
                dk[k].swap_lane(&mut dr[0], l);
            }
        }
        let inv = a[k][k].reciprocal();
        inv_diag[k] = inv;
        let (top, below) = a.split_at_mut(k + 1);
        let pivot_row = &top[k];
        for (i, row) in below.iter_mut().enumerate() {
            let i = i + k + 1;
            let m = row[k] * inv;
            for c in k + 1..N {
                row[c] = row[c].minus_product(m, pivot_row[c]);
            }
            f[i] = f[i].minus_product(m, f[k]);
            d[i] = d[i].minus_product(m, d[k]);
        }
    }
    for i in (0..N).rev() {
        let (mut sf, mut sd) = (f[i], d[i]);
        for c in i + 1..N {
            sf = sf.minus_product(a[i][c], f[c]);
            sd = sd.minus_product(a[i][c], d[c]);
        }
        f[i] = sf * inv_diag[i];
        d[i] = sd * inv_diag[i];
    }
    status
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{SMatrix, SVector};
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random_c(rng: &mut ChaCha8Rng) -> C {
        C::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0))
    }

    fn lane_of<const W: usize, const FMA: bool, const N: usize>(v: &[Wide<W, FMA>; N], l: usize) -> SVector<C, N> {
        SVector::from_fn(|i, _| v[i].get(l))
    }

    /// Lane 2 is rank deficient, lane 3 has a NaN entry, lane 5 needs interchanges (a tiny
    /// leading entry); the others are random.
    fn elimination_case<const W: usize, const FMA: bool>() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        const N: usize = 8;
        let mut mats: [SMatrix<C, N, N>; W] = std::array::from_fn(|_| SMatrix::from_fn(|_, _| random_c(&mut rng)));
        let f: [SVector<C, N>; W] = std::array::from_fn(|_| SVector::from_fn(|_, _| random_c(&mut rng)));
        let d: [SVector<C, N>; W] = std::array::from_fn(|_| SVector::from_fn(|_, _| random_c(&mut rng)));
        let row = mats[2].row(1).into_owned();
        mats[2].set_row(5, &row);
        mats[3][(4, 4)] = C::new(f64::NAN, 0.0);
        mats[5][(0, 0)] = C::new(1e-9, 0.0);
        let mut a = [[Wide::<W, FMA>::default(); N]; N];
        let (mut fl, mut dl) = ([Wide::<W, FMA>::default(); N], [Wide::<W, FMA>::default(); N]);
        for l in 0..W {
            for i in 0..N {
                for j in 0..N {
                    a[i][j].set(l, mats[l][(i, j)]);
                }
                fl[i].set(l, f[l][i]);
                dl[i].set(l, d[l][i]);
            }
        }
        let status = solve_lanes(&mut a, &mut fl, &mut dl);
        for l in 0..W {
            let expected = match l {
                2 => Factor::Singular,
                3 => Factor::NonFinite,
                _ => Factor::Ok,
            };
            assert_eq!(status[l], expected, "lane {l}");
            if expected != Factor::Ok {
                continue;
            }
            let lu = mats[l].lu();
            let (xf, xd) = (lu.solve(&f[l]).unwrap(), lu.solve(&d[l]).unwrap());
            let (gf, gd) = (lane_of(&fl, l), lane_of(&dl, l));
            assert!((gf - xf).camax() < 1e-11 * xf.camax(), "lane {l}: {:e}", (gf - xf).camax());
            assert!((gd - xd).camax() < 1e-11 * xd.camax(), "lane {l}: {:e}", (gd - xd).camax());
            // The residual of the lane's own solve, independent of nalgebra.
            assert!((mats[l] * gf - f[l]).camax() < 1e-12, "lane {l}");
        }
    }

    #[test]
    fn lane_elimination_matches_nalgebra_and_flags_singular_lanes() {
        elimination_case::<8, false>();
        elimination_case::<8, true>();
        elimination_case::<6, true>();
    }

    #[test]
    fn products_match_complex_arithmetic() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        const W: usize = 4;
        let (mut a, mut b) = (Wide::<W, true>::default(), Wide::<W, true>::default());
        let mut pairs = Vec::new();
        for l in 0..W {
            let (x, y) = (random_c(&mut rng), random_c(&mut rng));
            a.set(l, x);
            b.set(l, y);
            pairs.push((x, y));
        }
        let plain = |w: Wide<W, true>| Wide::<W, false> { re: w.re, im: w.im };
        let (fused, unfused) = (a * b, plain(a) * plain(b));
        for (l, (x, y)) in pairs.into_iter().enumerate() {
            // Unfused: the same operations as `Complex<f64>`'s product; fused: within rounding.
            assert_eq!(unfused.get(l), x * y);
            assert!((fused.get(l) - x * y).norm() <= 4.0 * f64::EPSILON * (x.norm() * y.norm()));
            assert_eq!((a + b).get(l), x + y);
            assert_eq!((a - b).get(l), x - y);
            assert_eq!((-a).get(l), -x);
            assert_eq!(a.scale(0.25).get(l), x * 0.25);
            let tol = 8.0 * f64::EPSILON * (x.norm() * y.norm() + x.norm() + y.norm());
            assert!((a.mul_add(b, a).get(l) - (x * y + x)).norm() <= tol);
            assert!((a.mul_sub(b, a).get(l) - (x * y - x)).norm() <= tol);
            assert!((a.neg_mul_add(b, a).get(l) - (x - x * y)).norm() <= tol);
            assert!((a.scale_add(-1.5, b).get(l) - (x * -1.5 + y)).norm() <= tol);
            let (pa, pb) = (plain(a), plain(b));
            assert_eq!(pa.mul_add(pb, pa).get(l), x * y + x);
            assert_eq!(pa.neg_mul_add(pb, pa).get(l), x - x * y);
        }
    }

    #[test]
    fn horner_gives_value_and_derivative_per_lane() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let t = [0.0, 0.3, -1.2, 1.0, 0.5, 2.0, -0.1, 0.9];
        for len in 1..=6 {
            let p: Vec<C> = (0..len).map(|_| random_c(&mut rng)).collect();
            let (v, d) = horner::<8, true>(&p, &t);
            let (v0, d0) = horner::<8, false>(&p, &t);
            for l in 0..8 {
                let tl = t[l];
                let value: C = p.iter().enumerate().map(|(k, c)| c * tl.powi(k as i32)).sum();
                let slope: C = p.iter().enumerate().skip(1).map(|(k, c)| c * (k as f64 * tl.powi(k as i32 - 1))).sum();
                for (vv, dd) in [(v.get(l), d.get(l)), (v0.get(l), d0.get(l))] {
                    assert!((vv - value).norm() < 1e-12, "len {len} lane {l}");
                    assert!((dd - slope).norm() < 1e-12, "len {len} lane {l}");
                }
            }
        }
    }
}
