//! Small dense solves on the stack for the tracker: LU with partial pivoting for square Jacobians,
//! Cholesky on the normal equations for overdetermined ones.
//!
//! Why not nalgebra's `LU`/`QR`: for sizes that are const generics of the caller, nalgebra's
//! decompositions need `Const<N>: DimMin<Const<N>>` bounds (typenum) that would leak into every
//! generic signature of the tracker. These are a few dozen lines, allocation-free, with the
//! singularity test the tracker needs (a relative pivot threshold), and the factorization is kept
//! so that one Jacobian serves several right-hand sides (Newton update and path tangent).
//!
//! Least squares (`NF > NX`): `J^H J dx = J^H b` by Cholesky. This squares the condition
//! number, so the update has relative error about `kappa(J)^2 * eps`: fine for the Gauss-Newton
//! corrector and tangent up to `kappa(J) ~ 1e6` (the GRPS Jacobian is ~1e3 at the truth), and
//! the factorization reports singularity when a pivot of `J^H J` falls below
//! `NX * eps * max diag(J^H J)`, i.e. `kappa(J) >~ 1e7`. Square-up
//! ([`crate::homotopy::SquaredUp`]) avoids the squaring when that matters.

use crate::Scalar;
use nalgebra::{SMatrix, SVector};

/// The factorization met a (numerically) singular matrix or non-finite entries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FactorError {
    /// Pivot below the relative threshold.
    Singular,
    /// NaN or infinity in the matrix.
    NonFinite,
}

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
}

impl<S: Scalar, const NX: usize, const NF: usize> LinearSolver<S, NX, NF> {
    pub(crate) fn new() -> Self {
        Self { m: SMatrix::zeros(), perm: [0; NX], j: SMatrix::zeros(), valid: false }
    }

    /// Factorizes `j` (square: LU of `j`; overdetermined: Cholesky of `j^H j`).
    #[inline]
    pub(crate) fn factor(&mut self, j: &SMatrix<S, NF, NX>) -> Result<(), FactorError> {
        self.valid = false;
        if NF == NX {
            for c in 0..NX {
                for r in 0..NX {
                    self.m[(r, c)] = j[(r, c)];
                }
            }
            lu_in_place(&mut self.m, &mut self.perm)?;
        } else {
            self.j = *j;
            // Lower triangle of the Gram matrix; columns are contiguous in nalgebra.
            for c in 0..NX {
                for r in c..NX {
                    self.m[(r, c)] = j.column(r).dotc(&j.column(c));
                }
            }
            cholesky_in_place(&mut self.m)?;
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
        if NF == NX {
            for i in 0..NX {
                x[i] = b[i];
            }
            lu_solve(&self.m, &self.perm, &mut x);
        } else {
            for c in 0..NX {
                x[c] = self.j.column(c).dotc(b);
            }
            cholesky_solve(&self.m, &mut x);
        }
        x
    }
}

/// Largest `|a_ij|_1` and whether all entries are finite.
#[inline]
fn max_entry<S: Scalar, const R: usize, const C: usize>(a: &SMatrix<S, R, C>) -> (f64, bool) {
    let mut m = 0.0f64;
    let mut finite = true;
    for e in a.iter() {
        finite &= e.is_finite_value();
        m = m.max(e.norm1());
    }
    (m, finite)
}

/// In-place LU with partial pivoting, `P A = L U`, `L` unit lower (below the diagonal), `U` on
/// and above. Singular when a pivot is at most `N * eps * max |a_ij|` (in the 1-norm of complex
/// entries, which is what the pivot search compares; an all-zero matrix is singular).
#[inline]
fn lu_in_place<S: Scalar, const N: usize>(
    a: &mut SMatrix<S, N, N>,
    perm: &mut [usize; N],
) -> Result<(), FactorError> {
    let (scale, finite) = max_entry(a);
    if !finite {
        return Err(FactorError::NonFinite);
    }
    let threshold = scale * (N as f64) * f64::EPSILON;
    for k in 0..N {
        let mut p = k;
        let mut best = a[(k, k)].norm1();
        for i in k + 1..N {
            let v = a[(i, k)].norm1();
            if v > best {
                best = v;
                p = i;
            }
        }
        if best <= threshold {
            return Err(FactorError::Singular);
        }
        perm[k] = p;
        if p != k {
            a.swap_rows(k, p);
        }
        let inv = S::one() / a[(k, k)];
        for i in k + 1..N {
            a[(i, k)] *= inv;
        }
        for c in k + 1..N {
            let akc = a[(k, c)];
            for i in k + 1..N {
                let l = a[(i, k)];
                a[(i, c)] -= l * akc;
            }
        }
    }
    Ok(())
}

/// Solves `A x = b` in place from the factors of [`lu_in_place`].
#[inline]
fn lu_solve<S: Scalar, const N: usize>(
    lu: &SMatrix<S, N, N>,
    perm: &[usize; N],
    x: &mut SVector<S, N>,
) {
    for k in 0..N {
        let p = perm[k];
        if p != k && p < N {
            x.swap_rows(k, p);
        }
    }
    // L y = P b, unit diagonal, column-oriented.
    for k in 0..N {
        let xk = x[k];
        for i in k + 1..N {
            x[i] -= lu[(i, k)] * xk;
        }
    }
    // U x = y, column-oriented.
    for k in (0..N).rev() {
        let xk = x[k] / lu[(k, k)];
        x[k] = xk;
        for i in 0..k {
            x[i] -= lu[(i, k)] * xk;
        }
    }
}

/// In-place Cholesky `A = L L^H` of a Hermitian positive definite matrix given by its lower
/// triangle. Singular when a pivot `d_k` is at most `N * eps * max_k a_kk`.
#[inline]
fn cholesky_in_place<S: Scalar, const N: usize>(a: &mut SMatrix<S, N, N>) -> Result<(), FactorError> {
    let mut scale = 0.0f64;
    for k in 0..N {
        let d = a[(k, k)];
        if !d.is_finite_value() {
            return Err(FactorError::NonFinite);
        }
        scale = scale.max(d.real());
    }
    let threshold = scale * (N as f64) * f64::EPSILON;
    for c in 0..N {
        let mut d = a[(c, c)].real();
        for k in 0..c {
            d -= a[(c, k)].modulus_squared();
        }
        if d.is_nan() {
            return Err(FactorError::NonFinite);
        }
        if d <= threshold {
            return Err(FactorError::Singular);
        }
        let lcc = d.sqrt();
        a[(c, c)] = S::from_real(lcc);
        let inv = S::from_real(1.0 / lcc);
        for r in c + 1..N {
            let mut s = a[(r, c)];
            for k in 0..c {
                s -= a[(r, k)] * a[(c, k)].conjugate();
            }
            if !s.is_finite_value() {
                return Err(FactorError::NonFinite);
            }
            a[(r, c)] = s * inv;
        }
    }
    Ok(())
}

/// Solves `L L^H x = b` in place.
#[inline]
fn cholesky_solve<S: Scalar, const N: usize>(l: &SMatrix<S, N, N>, x: &mut SVector<S, N>) {
    // L y = b, column-oriented.
    for k in 0..N {
        let yk = x[k] / l[(k, k)];
        x[k] = yk;
        for i in k + 1..N {
            x[i] -= l[(i, k)] * yk;
        }
    }
    // L^H x = y, row i of L^H is column i of L conjugated.
    for k in (0..N).rev() {
        let mut s = x[k];
        for i in k + 1..N {
            s -= l[(i, k)].conjugate() * x[i];
        }
        x[k] = s / l[(k, k)];
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
        let j = nalgebra::SMatrix::<Complex<f64>, 3, 2>::new(
            c(1.0, 0.5),
            c(0.0, 1.0),
            c(2.0, 0.0),
            c(1.0, -1.0),
            c(0.5, 0.0),
            c(3.0, 0.2),
        );
        let b = nalgebra::SVector::<Complex<f64>, 3>::new(c(1.0, 0.0), c(0.0, 2.0), c(-1.0, 1.0));
        let mut s = LinearSolver::<Complex<f64>, 2, 3>::new();
        s.factor(&j).unwrap();
        let x = s.solve(&b);
        // Normal equations hold: J^H (J x - b) = 0.
        let r = j.adjoint() * (j * x - b);
        assert!(r.iter().all(|v| v.norm() < 1e-13));
    }
}
