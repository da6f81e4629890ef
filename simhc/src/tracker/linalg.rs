//! Small dense solves on the stack for the tracker: LU with partial pivoting for square Jacobians,
//! Cholesky on the normal equations for overdetermined ones.
//!
//! Why not nalgebra's `LU`/`QR`: for sizes that are const generics of the caller, nalgebra's
//! decompositions need `Const<N>: DimMin<Const<N>>` bounds (typenum) that would leak into every
//! generic signature of the tracker. These are a few dozen lines, allocation-free, with the
//! singularity test the tracker needs (a pivot threshold relative to the matrix norm), and the factorization is kept
//! so that one Jacobian serves several right-hand sides (Newton update and path tangent).
//!
//! Least squares (`NF > NX`): `J^H J dx = J^H b` by Cholesky. This squares the condition
//! number, so the update has relative error about `kappa(J)^2 * eps`: fine for the Gauss-Newton
//! corrector and tangent up to `kappa(J) ~ 1e6` (the GRPS Jacobian is ~1e3 at the truth), and
//! the factorization reports singularity when a pivot of `J^H J` falls below
//! `NX * eps * max diag(J^H J)`, i.e. `kappa(J) >~ 1e7`. Square-up
//! ([`crate::homotopy::SquaredUp`]) avoids the squaring when that matters.

use super::factor::FactorError;
use super::lane_lu::{self, LaneLu};
use crate::Scalar;
use nalgebra::{SMatrix, SVector};

/// Solver for `J dx = b` (square) or `min |J dx - b|` (`NF > NX`), factorized once, solved many
/// times.
#[derive(Debug, Clone, Copy)]
pub(crate) struct LinearSolver<S: Scalar, const NX: usize, const NF: usize> {
    /// LU factors (square) or the Cholesky factor `L` of `J^H J` (lower triangle).
    m: SMatrix<S, NX, NX>,
    /// Row interchanges of the LU (`perm[k]` swapped with `k` at step `k`).
    perm: [usize; NX],
    /// Copy of `J` for forming `J^H b` (least squares only).
    j: SMatrix<S, NF, NX>,
    /// Whether `m` holds a valid factorization.
    valid: bool,
    /// The square factorization on lanes (used when [`lane_lu::pays`]).
    lanes: LaneLu<S, NX>,
}

impl<S: Scalar, const NX: usize, const NF: usize> LinearSolver<S, NX, NF> {
    pub(crate) fn new() -> Self {
        Self { m: SMatrix::zeros(), perm: [0; NX], j: SMatrix::zeros(), valid: false, lanes: LaneLu::new() }
    }

    /// Factorizes `j` (square: LU of `j`; overdetermined: Cholesky of `j^H j`).
    #[inline]
    pub(crate) fn factor(&mut self, j: &SMatrix<S, NF, NX>) -> Result<(), FactorError> {
        self.valid = false;
        if NF == NX && lane_lu::pays(NX) {
            let threshold = pivot_threshold::<S, NX>(j.as_slice())?;
            let a = SMatrix::<S, NX, NX>::from_column_slice(j.as_slice());
            self.lanes.factor(&a, threshold)?;
        } else if NF == NX {
            // Same column-major layout: copy straight through.
            for (d, s) in self.m.as_mut_slice().iter_mut().zip(j.as_slice()) {
                *d = *s;
            }
            lu_in_place::<S, NX>(self.m.as_mut_slice(), &mut self.perm)?;
        } else {
            self.j = *j;
            gram_lower::<S, NX, NF>(j.as_slice(), self.m.as_mut_slice());
            cholesky_in_place::<S, NX>(self.m.as_mut_slice())?;
        }
        self.valid = true;
        Ok(())
    }

    /// `dx` with `J dx = b` (least-squares solution when `NF > NX`). Requires a successful
    /// [`LinearSolver::factor`]; with an invalid factorization the result is NaN, which the
    /// caller's finiteness check turns into an error instead of a panic.
    #[inline]
    pub(crate) fn solve(&self, b: &SVector<S, NF>) -> SVector<S, NX> {
        let mut x = SVector::<S, NX>::zeros();
        if !self.valid {
            x.fill(S::from_real(f64::NAN));
            return x;
        }
        if NF == NX && lane_lu::pays(NX) {
            let b = SVector::<S, NX>::from_column_slice(b.as_slice());
            return self.lanes.solve(&b);
        }
        if NF == NX {
            for (d, s) in x.as_mut_slice().iter_mut().zip(b.as_slice()) {
                *d = *s;
            }
            lu_solve::<S, NX>(self.m.as_slice(), &self.perm, x.as_mut_slice());
        } else {
            // J^H b, column by column.
            for (xc, col) in x.iter_mut().zip(self.j.as_slice().chunks_exact(NF)) {
                *xc = dotc(col, b.as_slice());
            }
            cholesky_solve::<S, NX>(self.m.as_slice(), x.as_mut_slice());
        }
        x
    }
}

/// `sum_i conj(a_i) b_i`, with four partial sums so that the additions do not form one long
/// dependency chain (these dot products are short, 8-10 terms, and latency-bound).
#[inline(always)]
fn dotc<S: Scalar>(a: &[S], b: &[S]) -> S {
    let mut acc = [S::zero(); 4];
    let mut ac = a.chunks_exact(4);
    let mut bc = b.chunks_exact(4);
    for (x, y) in (&mut ac).zip(&mut bc) {
        for ((s, &xi), &yi) in acc.iter_mut().zip(x).zip(y) {
            *s += xi.conjugate() * yi;
        }
    }
    for ((s, &xi), &yi) in acc.iter_mut().zip(ac.remainder()).zip(bc.remainder()) {
        *s += xi.conjugate() * yi;
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// `sum_i conj(a_i) b_i` for the short, varying-length sums of the triangular solves.
#[inline(always)]
fn dotc_short<S: Scalar>(a: &[S], b: &[S]) -> S {
    let mut s = S::zero();
    for (&ai, &bi) in a.iter().zip(b) {
        s += ai.conjugate() * bi;
    }
    s
}

/// Lower triangle of `J^H J` (`J` column-major `NF x NX`) into `g` (column-major `NX x NX`).
#[inline]
fn gram_lower<S: Scalar, const NX: usize, const NF: usize>(j: &[S], g: &mut [S]) {
    for (c, gc) in g.chunks_exact_mut(NX).enumerate() {
        let Some(jc) = j.get(c * NF..(c + 1) * NF) else { return };
        for (r, gr) in gc.iter_mut().enumerate().skip(c) {
            if let Some(jr) = j.get(r * NF..(r + 1) * NF) {
                *gr = dotc(jr, jc);
            }
        }
    }
}

/// The matrix 1-norm `max_c sum_r |a_rc|_1` of the column-major `N x N` matrix `a`, and whether
/// all entries are finite. Column sums are independent dependency chains (a running `max` over
/// all entries would serialize on its latency), and a non-finite entry makes its column sum
/// non-finite, so one pass answers both.
#[inline]
fn norm1_finite<S: Scalar, const N: usize>(a: &[S]) -> (f64, bool) {
    let mut sums = [0.0f64; N];
    for (sum, col) in sums.iter_mut().zip(a.chunks_exact(N)) {
        *sum = col.iter().map(|e| e.norm1()).sum();
    }
    let finite = sums.iter().all(|v| v.is_finite());
    (sums.iter().fold(0.0f64, |m, &v| m.max(v)), finite)
}

/// The LU's singularity threshold `N * eps * |A|_1` of the column-major `N x N` matrix `a`
/// (both LUs use it), or `NonFinite`.
#[inline]
fn pivot_threshold<S: Scalar, const N: usize>(a: &[S]) -> Result<f64, FactorError> {
    let (scale, finite) = norm1_finite::<S, N>(a);
    if !finite {
        return Err(FactorError::NonFinite);
    }
    Ok(scale * (N as f64) * f64::EPSILON)
}

/// In-place LU with partial pivoting of the column-major `N x N` matrix `a`, `P A = L U`, `L`
/// unit lower (below the diagonal), `U` on and above. Singular when a pivot is at most
/// `N * eps * |A|_1` (matrix 1-norm, complex entries measured by `|re| + |im|` as in the pivot
/// search; an all-zero matrix is singular): such a pivot means `cond(A) >~ 1 / (N eps)`. Column-oriented (right-looking) on slices, so the
/// inner loops run over contiguous memory without index arithmetic.
#[inline]
fn lu_in_place<S: Scalar, const N: usize>(a: &mut [S], perm: &mut [usize; N]) -> Result<(), FactorError> {
    if a.len() != N * N {
        return Err(FactorError::NonFinite);
    }
    let threshold = pivot_threshold::<S, N>(a)?;
    for k in 0..N {
        // Pivot search in column k, rows k..N.
        let col_k = &a[k * N..(k + 1) * N];
        let mut p = k;
        let mut best = -1.0f64;
        for (i, v) in col_k.iter().enumerate().skip(k) {
            let m = v.norm1();
            if m > best {
                best = m;
                p = i;
            }
        }
        if best <= threshold {
            return Err(FactorError::Singular);
        }
        perm[k] = p;
        if p != k {
            for col in a.chunks_exact_mut(N) {
                col.swap(k, p);
            }
        }
        let (left, right) = a.split_at_mut((k + 1) * N);
        let col_k = &mut left[k * N..];
        let inv = S::one() / col_k[k];
        for l in &mut col_k[k + 1..] {
            *l *= inv;
        }
        let lk = &col_k[k + 1..];
        for col_c in right.chunks_exact_mut(N) {
            let akc = col_c[k];
            for (x, &l) in col_c[k + 1..].iter_mut().zip(lk) {
                *x -= l * akc;
            }
        }
    }
    Ok(())
}

/// Solves `A x = b` in place from the factors of [`lu_in_place`].
#[inline]
fn lu_solve<S: Scalar, const N: usize>(lu: &[S], perm: &[usize; N], x: &mut [S]) {
    if lu.len() != N * N || x.len() != N {
        return;
    }
    for (k, &p) in perm.iter().enumerate() {
        if p != k && p < N {
            x.swap(k, p);
        }
    }
    // L y = P b, unit diagonal, column-oriented.
    for (k, col) in lu.chunks_exact(N).enumerate() {
        let xk = x[k];
        for (xi, &l) in x[k + 1..].iter_mut().zip(&col[k + 1..]) {
            *xi -= l * xk;
        }
    }
    // U x = y, column-oriented.
    for (k, col) in lu.chunks_exact(N).enumerate().rev() {
        let xk = x[k] / col[k];
        x[k] = xk;
        for (xi, &u) in x[..k].iter_mut().zip(&col[..k]) {
            *xi -= u * xk;
        }
    }
}

/// In-place Cholesky `A = L L^H` of the column-major Hermitian positive definite `N x N` matrix
/// given by its lower triangle (left-looking, column by column). Singular when a pivot `d_k` is
/// at most `N * eps * max_k a_kk`.
#[inline]
fn cholesky_in_place<S: Scalar, const N: usize>(a: &mut [S]) -> Result<(), FactorError> {
    if a.len() != N * N {
        return Err(FactorError::NonFinite);
    }
    let mut scale = 0.0f64;
    for k in 0..N {
        let d = a[k * N + k];
        if !d.is_finite_value() {
            return Err(FactorError::NonFinite);
        }
        scale = scale.max(d.real());
    }
    let threshold = scale * (N as f64) * f64::EPSILON;
    for c in 0..N {
        let (left, right) = a.split_at_mut(c * N);
        let col_c = &mut right[..N];
        // col_c[c..] -= sum_k L[c..][k] * conj(L[c][k]) over the finished columns k < c.
        for col_k in left.chunks_exact(N) {
            let lck = col_k[c].conjugate();
            for (x, &l) in col_c[c..].iter_mut().zip(&col_k[c..]) {
                *x -= l * lck;
            }
        }
        let d = col_c[c].real();
        if d.is_nan() {
            return Err(FactorError::NonFinite);
        }
        if d <= threshold {
            return Err(FactorError::Singular);
        }
        let lcc = d.sqrt();
        col_c[c] = S::from_real(lcc);
        let inv = S::from_real(1.0 / lcc);
        for x in &mut col_c[c + 1..] {
            *x *= inv;
            if !x.is_finite_value() {
                return Err(FactorError::NonFinite);
            }
        }
    }
    Ok(())
}

/// Solves `L L^H x = b` in place (`L` column-major lower triangle).
#[inline]
fn cholesky_solve<S: Scalar, const N: usize>(l: &[S], x: &mut [S]) {
    if l.len() != N * N || x.len() != N {
        return;
    }
    // L y = b, column-oriented.
    for (k, col) in l.chunks_exact(N).enumerate() {
        let yk = x[k] / col[k];
        x[k] = yk;
        for (xi, &lik) in x[k + 1..].iter_mut().zip(&col[k + 1..]) {
            *xi -= lik * yk;
        }
    }
    // L^H x = y: row k of L^H is column k of L conjugated.
    for (k, col) in l.chunks_exact(N).enumerate().rev() {
        let s = x[k] - dotc_short(&col[k + 1..], &x[k + 1..]);
        x[k] = s / col[k];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Matrix3, Vector3};
    use num_complex::Complex;

    #[test]
    fn lu_solves_square() {
        let a = Matrix3::new(0.0, 2.0, 1.0, 1.0, 1.0, 0.0, 3.0, 0.0, 1.0);
        let b = Vector3::new(1.0, 2.0, 3.0);
        let mut s = LinearSolver::<f64, 3, 3>::new();
        s.factor(&a).unwrap();
        let x = s.solve(&b);
        assert!((a * x - b).amax() < 1e-14);
    }

    #[test]
    fn lu_detects_singular() {
        let a = Matrix3::new(1.0, 2.0, 3.0, 2.0, 4.0, 6.0, 0.0, 1.0, 1.0);
        let mut s = LinearSolver::<f64, 3, 3>::new();
        assert_eq!(s.factor(&a), Err(FactorError::Singular));
        assert!(!s.solve(&Vector3::zeros()).iter().all(|v| v.is_finite()));
        let z = Matrix3::<f64>::zeros();
        assert_eq!(s.factor(&z), Err(FactorError::Singular));
        let n = Matrix3::new(f64::NAN, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0);
        assert_eq!(s.factor(&n), Err(FactorError::NonFinite));
    }

    #[test]
    fn normal_equations_least_squares_complex() {
        let c = |re: f64, im: f64| Complex::new(re, im);
        let j = nalgebra::SMatrix::<Complex<f64>, 3, 2>::new(c(1.0, 0.5), c(0.0, 1.0), c(2.0, 0.0), c(1.0, -1.0), c(0.5, 0.0), c(3.0, 0.2));
        let b = nalgebra::SVector::<Complex<f64>, 3>::new(c(1.0, 0.0), c(0.0, 2.0), c(-1.0, 1.0));
        let mut s = LinearSolver::<Complex<f64>, 2, 3>::new();
        s.factor(&j).unwrap();
        let x = s.solve(&b);
        // Normal equations hold: J^H (J x - b) = 0.
        let r = j.adjoint() * (j * x - b);
        assert!(r.iter().all(|v| v.norm() < 1e-13));
    }
}
