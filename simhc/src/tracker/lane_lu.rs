//! LU with partial pivoting for small square matrices with the rows held as lanes of columns:
//! the eliminations `row_i -= l_ik u_k` and the triangular solves' dot products run
//! [`LANES`] columns at a time, and row interchanges move whole rows. Compiled with AVX2 where
//! available ([`crate::lanes::dispatch`]).
//!
//! Why: the tracker factorizes the `NX x NX` Jacobian at every corrector iteration and
//! predictor stage and solves with it one to three times; for GRPS7's complex 8 x 8 that is
//! about a quarter of the all-roots time. The scalar (column-oriented) LU of the `linalg` module
//! stays in use for the sizes where this one does not pay ([`pays`]).

use super::factor::FactorError;
use crate::lanes::{dispatch, Kernel, Lanes, LANES};
use crate::Scalar;
use nalgebra::{SMatrix, SVector};

/// Column blocks per row, at most.
const MAX_BLOCKS: usize = 2;
/// Largest size handled here.
pub(crate) const MAX_N: usize = LANES * MAX_BLOCKS;

/// Whether the lane LU serves size `n`. Measured (release, this machine): complex 8 x 8
/// factorization 0.28 us against 0.31 us scalar, solve 0.07 against 0.12 us; UPnP's 5 x 5
/// all-roots solve got slower with it (1.13 against 1.00 ms), so smaller sizes stay scalar.
#[inline(always)]
pub(crate) fn pays(n: usize) -> bool {
    (6..=MAX_N).contains(&n)
}

type Row<S> = [<S as crate::Ring>::Lanes; MAX_BLOCKS];

#[inline(always)]
fn get<S: Scalar>(r: &Row<S>, j: usize) -> S {
    r[j / LANES].get(j % LANES)
}

#[inline(always)]
fn set<S: Scalar>(r: &mut Row<S>, j: usize, v: S) {
    r[j / LANES].set(j % LANES, v)
}

/// `P A = L U` by rows: row `i` holds `L_ij` for `j < i` and `U_ij` for `j >= i`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LaneLu<S: Scalar, const N: usize> {
    rows: [Row<S>; N],
    /// `1 / U_ii`.
    inv_diag: [S; N],
    /// `perm[k]`: the row swapped with `k` at step `k`.
    perm: [usize; N],
}

impl<S: Scalar, const N: usize> LaneLu<S, N> {
    pub(crate) fn new() -> Self {
        let zero = <S::Lanes as Lanes>::from_real(0.0);
        Self { rows: [[zero; MAX_BLOCKS]; N], inv_diag: [S::zero(); N], perm: [0; N] }
    }

    /// Factorizes `a`; a pivot with `|re| + |im| <= threshold` is singular.
    pub(crate) fn factor(&mut self, a: &SMatrix<S, N, N>, threshold: f64) -> Result<(), FactorError> {
        struct Job<'a, S: Scalar, const N: usize> {
            lu: &'a mut LaneLu<S, N>,
            a: &'a SMatrix<S, N, N>,
            threshold: f64,
            out: &'a mut Result<(), FactorError>,
        }
        impl<S: Scalar, const N: usize> Kernel for Job<'_, S, N> {
            #[inline(always)]
            fn run(self) {
                *self.out = self.lu.factor_impl(self.a, self.threshold);
            }
        }
        let mut out = Err(FactorError::NonFinite);
        dispatch(Job { lu: self, a, threshold, out: &mut out });
        out
    }

    #[inline(always)]
    fn factor_impl(&mut self, a: &SMatrix<S, N, N>, threshold: f64) -> Result<(), FactorError> {
        if N > MAX_N {
            return Err(FactorError::NonFinite);
        }
        let nb = N.div_ceil(LANES);
        let zero = <S::Lanes as Lanes>::from_real(0.0);
        for (i, row) in self.rows.iter_mut().enumerate() {
            *row = [zero; MAX_BLOCKS];
            for j in 0..N {
                set::<S>(row, j, a[(i, j)]);
            }
        }
        for k in 0..N {
            let mut p = k;
            let mut best = -1.0f64;
            for i in k..N {
                let m = get::<S>(&self.rows[i], k).norm1();
                if m > best {
                    best = m;
                    p = i;
                }
            }
            if best <= threshold {
                return Err(FactorError::Singular);
            }
            self.perm[k] = p;
            self.rows.swap(k, p);
            let inv = S::one() / get::<S>(&self.rows[k], k);
            self.inv_diag[k] = inv;
            // U's row k right of the diagonal; the columns up to k are zero so that the
            // updates below leave the L entries of the other rows alone.
            let mut u = self.rows[k];
            for j in 0..=k {
                set::<S>(&mut u, j, S::zero());
            }
            for row in self.rows.iter_mut().skip(k + 1) {
                let l = get::<S>(row, k) * inv;
                let ll = <S::Lanes as Lanes>::splat(l);
                for b in 0..nb {
                    row[b] = row[b] - ll * u[b];
                }
                set::<S>(row, k, l);
            }
        }
        Ok(())
    }

    /// `x` with `A x = b`.
    pub(crate) fn solve(&self, b: &SVector<S, N>) -> SVector<S, N> {
        struct Job<'a, S: Scalar, const N: usize> {
            lu: &'a LaneLu<S, N>,
            b: &'a SVector<S, N>,
            x: &'a mut SVector<S, N>,
        }
        impl<S: Scalar, const N: usize> Kernel for Job<'_, S, N> {
            #[inline(always)]
            fn run(self) {
                self.lu.solve_impl(self.b, self.x);
            }
        }
        let mut x = SVector::<S, N>::zeros();
        dispatch(Job { lu: self, b, x: &mut x });
        x
    }

    #[inline(always)]
    fn solve_impl(&self, b: &SVector<S, N>, x: &mut SVector<S, N>) {
        *x = *b;
        for (k, &p) in self.perm.iter().enumerate() {
            if p != k && p < N {
                x.swap_rows(k, p);
            }
        }
        // L y = P b (unit diagonal): y_i -= sum_{j < i} L_ij y_j, row by row.
        for i in 1..N {
            let mut s = S::zero();
            for j in 0..i {
                s += get::<S>(&self.rows[i], j) * x[j];
            }
            x[i] -= s;
        }
        // U x = y.
        for i in (0..N).rev() {
            let mut s = x[i];
            for j in i + 1..N {
                s -= get::<S>(&self.rows[i], j) * x[j];
            }
            x[i] = s * self.inv_diag[i];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scalar::C;

    fn matrix(seed: u64) -> SMatrix<C, 8, 8> {
        // A deterministic, well-conditioned but pivot-needing matrix.
        SMatrix::from_fn(|i, j| {
            let k = (seed as usize * 31 + i * 7 + j * 3) % 17;
            C::new(k as f64 - 8.0 + 0.1 * j as f64, ((i * 5 + j + seed as usize) % 7) as f64 - 3.0)
        })
    }

    #[test]
    fn solves_like_nalgebra() {
        for seed in 0..20 {
            let a = matrix(seed);
            let b = SVector::<C, 8>::from_fn(|i, _| C::new(i as f64 - 2.0, 1.0 + seed as f64));
            let mut lu = LaneLu::<C, 8>::new();
            lu.factor(&a, 1e-12).unwrap();
            let x = lu.solve(&b);
            let reference = a.lu().solve(&b).unwrap();
            assert!((x - reference).norm() <= 1e-10 * reference.norm(), "seed {seed}");
            assert!((a * x - b).norm() <= 1e-10 * b.norm(), "seed {seed}");
        }
        // Real 6 x 6 (two column blocks, one partly used).
        let a = SMatrix::<f64, 6, 6>::from_fn(|i, j| ((i * 7 + j * 11) % 13) as f64 - 6.0 + if i == j { 0.5 } else { 0.0 });
        let b = SVector::<f64, 6>::from_fn(|i, _| i as f64 + 1.0);
        let mut lu = LaneLu::<f64, 6>::new();
        lu.factor(&a, 1e-12).unwrap();
        assert!((a * lu.solve(&b) - b).norm() <= 1e-10 * b.norm());
    }

    #[test]
    fn singular_matrix_is_reported() {
        let mut a = matrix(3);
        for i in 0..8 {
            a[(i, 5)] = a[(i, 2)] * C::new(2.0, -1.0);
        }
        let mut lu = LaneLu::<C, 8>::new();
        assert_eq!(lu.factor(&a, 1e-9), Err(FactorError::Singular));
    }
}
