//! A proof that a point approximates a true root: the interval Krawczyk test, as
//! HomotopyContinuation.jl's `certify` applies it.
//!
//! For `n` equations `G` in `n` unknowns (the whole square system, or `n` chosen rows of an
//! overdetermined one), a point `x̃` and a box `X = x̃ ± ε`, let `C ≈ G'(x̃)⁻¹` (any matrix
//! works: `C` only steers the test) and
//!
//! `K = x̃ − C G(x̃) + (I − C G'(X)) (X − x̃)`,
//!
//! evaluated in outward-rounded interval arithmetic ([`crate::interval`]), with `G'(X)` the
//! generated Jacobian run over the box. If `K` lies in the interior of `X`, then `X` contains
//! exactly one root of `G` (Krawczyk 1969, Moore 1977; Rump's form), the root lies in `K`, and
//! every matrix in `G'(X)` is nonsingular. A real box holds a real root.
//!
//! What is certified is the system *as compiled*: parameters are the given `f64` values
//! (degenerate intervals) and the generated code's constants are `f64` (a declared `x / 3`
//! is the product with the `f64` nearest to `1/3`). The certified point is the one given: no
//! Newton step moves it.
//!
//! Everything lives in nalgebra static matrices on the stack: no allocation.

use crate::interval::Interval;
use crate::tracker::linalg::LinearSolver;
use crate::Problem;
use nalgebra::{SMatrix, SVector};

/// How far the box reaches beyond the Newton step `|C G(x̃)|`: HomotopyContinuation.jl's
/// inflation. Large enough that round-off and the Jacobian's variation over the box rarely
/// break the contraction, small enough that the box stays in the root's basin.
pub const INFLATION: f64 = 512.0;

/// The factor the box radius is multiplied by for the one retry (divided by when the
/// Jacobian varies too much over the box, multiplied by when round-off in `G(x̃)` dominates).
pub const RETRY_FACTOR: f64 = 32.0;

/// A proof that the box `center ± radius` holds exactly one root of the equations `rows`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Certificate<const NX: usize> {
    /// The point certified (the one given, unchanged).
    pub center: SVector<f64, NX>,
    /// Per-unknown half-widths of the box `X` in which the root is unique (the box is rounded
    /// outward from `center ± radius`).
    pub radius: SVector<f64, NX>,
    /// The Krawczyk image `K ⊂ X`: it contains the root, and is usually much tighter than `X`.
    pub enclosure: SVector<Interval, NX>,
    /// The equations (indices into the residual vector) of the square system certified.
    pub rows: [usize; NX],
}

impl<const NX: usize> Certificate<NX> {
    /// Whether `x` lies in the certified box `X` (then it is the certified root's box; a root
    /// of the equations outside `X` is a different root).
    pub fn box_contains(&self, x: &SVector<f64, NX>) -> bool {
        (0..NX).all(|i| Interval::around(self.center[i], self.radius[i]).contains(x[i]))
    }

    /// Whether `x` lies in the enclosure `K` of the root.
    pub fn encloses(&self, x: &SVector<f64, NX>) -> bool {
        (0..NX).all(|i| self.enclosure[i].contains(x[i]))
    }

    /// The largest distance, per unknown, from the center to the root's enclosure: an upper
    /// bound of the error `|x̃ - x*|∞`.
    pub fn error_bound(&self) -> f64 {
        (0..NX)
            .map(|i| (self.enclosure[i].lo() - self.center[i]).abs().max((self.enclosure[i].hi() - self.center[i]).abs()))
            .fold(0.0, f64::max)
    }
}

/// Why a point was not certified. None of these says the point is not a root; they say the
/// proof did not go through.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum CertifyError {
    /// [`certify`] was called on a system with more equations than unknowns: choose the rows
    /// with [`certify_rows`].
    #[error("the system has {nf} equations in {nx} unknowns: choose {nx} rows (certify_rows)")]
    NotSquare { nx: usize, nf: usize },
    /// A chosen row is not an equation of the system, or appears twice.
    #[error("row {row} is out of range (0..{nf}) or chosen twice")]
    BadRow { row: usize, nf: usize },
    /// The point, the parameters, the residual, the Jacobian or the box is not finite.
    #[error("a non-finite value (point, parameters, residual or Jacobian)")]
    NonFinite,
    /// The Jacobian at the point is numerically singular (no `C` to steer by), or the box
    /// radius is zero.
    #[error("the Jacobian at the point is singular")]
    Singular,
    /// `K` is not inside `X` at either radius tried: no proof (the point may be far from a
    /// root, near a singular or a second root, or the system badly scaled).
    #[error("the Krawczyk image is not inside the box (contraction {contraction:.3e})")]
    NotContracting {
        /// The largest row sum of `|I - C G'(X)|` at the last radius tried: at or above 1 the
        /// Jacobian varies too much over the box for any radius to work.
        contraction: f64,
    },
}

/// Certifies `x` as an approximate root of the square system `P` (`NF == NX`) at parameters
/// `p`: [`certify_rows`] with all rows.
pub fn certify<P: Problem<NX, NF, NP>, const NX: usize, const NF: usize, const NP: usize>(
    x: &SVector<f64, NX>,
    p: &SVector<f64, NP>,
) -> Result<Certificate<NX>, CertifyError> {
    if NF != NX {
        return Err(CertifyError::NotSquare { nx: NX, nf: NF });
    }
    let mut rows = [0; NX];
    for (i, r) in rows.iter_mut().enumerate() {
        *r = i;
    }
    certify_rows::<P, NX, NF, NP>(x, p, &rows)
}

/// Certifies `x` as an approximate root of the `NX` equations `rows` of `P` at `p`.
///
/// The box radius is [`INFLATION`] times `max(|C G(x̃)|ᵢ, eps ‖x̃‖∞)`; if that box does not
/// contract, one retry at a radius [`RETRY_FACTOR`] times smaller (when `|I - C G'(X)|` has a
/// row sum at least 1/2: the box is too large for the Jacobian's variation) or larger
/// (otherwise: the box is too small for the round-off in `G(x̃)`).
pub fn certify_rows<P: Problem<NX, NF, NP>, const NX: usize, const NF: usize, const NP: usize>(
    x: &SVector<f64, NX>,
    p: &SVector<f64, NP>,
    rows: &[usize; NX],
) -> Result<Certificate<NX>, CertifyError> {
    let setup = Setup::new::<P, NF, NP>(x, p, rows)?;
    // The floor of the radius: round-off relative to the point's size (absolute at 0, where a
    // zero Newton step would otherwise give a zero box).
    let scale = f64::EPSILON * if x.amax() > 0.0 { x.amax() } else { 1.0 };
    let mut radius = SVector::<f64, NX>::zeros();
    for i in 0..NX {
        radius[i] = INFLATION * setup.newton_step[i].mag().max(scale);
    }
    let contraction = match setup.krawczyk::<P, NF, NP>(p, &radius)? {
        Ok(cert) => return Ok(cert),
        Err(contraction) => contraction,
    };
    let factor = if contraction >= 0.5 { 1.0 / RETRY_FACTOR } else { RETRY_FACTOR };
    radius *= factor;
    setup.krawczyk::<P, NF, NP>(p, &radius)?.map_err(|contraction| CertifyError::NotContracting { contraction })
}

/// The Krawczyk test of `x` on the box `x ± radius` exactly (no inflation, no retry): the
/// building block of [`certify_rows`], public so that a caller with its own box (and the tests)
/// can ask about that box.
pub fn certify_box<P: Problem<NX, NF, NP>, const NX: usize, const NF: usize, const NP: usize>(
    x: &SVector<f64, NX>,
    p: &SVector<f64, NP>,
    rows: &[usize; NX],
    radius: &SVector<f64, NX>,
) -> Result<Certificate<NX>, CertifyError> {
    let setup = Setup::new::<P, NF, NP>(x, p, rows)?;
    setup.krawczyk::<P, NF, NP>(p, radius)?.map_err(|contraction| CertifyError::NotContracting { contraction })
}

/// `NX` rows of an overdetermined system to certify at `x`: greedily the best conditioned, by
/// Gram-Schmidt with pivoting on the rows of `J(x)` each scaled to unit length (so an
/// equation's scale does not decide; a row that is nearly a combination of the chosen ones is
/// left out). A square system gets `0..NX` in order of choice. `Singular` when fewer than `NX`
/// independent rows are left (relative residual below `sqrt(eps)`), `NonFinite` for a
/// non-finite Jacobian.
pub fn choose_rows<P: Problem<NX, NF, NP>, const NX: usize, const NF: usize, const NP: usize>(
    x: &SVector<f64, NX>,
    p: &SVector<f64, NP>,
) -> Result<[usize; NX], CertifyError> {
    let mut j = SMatrix::<f64, NF, NX>::zeros();
    P::jacobian(x, p, &mut j);
    if !j.iter().all(|v| v.is_finite()) {
        return Err(CertifyError::NonFinite);
    }
    let mut taken = [false; NF];
    let mut basis = SMatrix::<f64, NX, NX>::zeros();
    let mut rows = [0; NX];
    for k in 0..NX {
        let mut best: Option<(usize, f64, SVector<f64, NX>)> = None;
        for r in (0..NF).filter(|&r| !taken[r]) {
            let norm = j.row(r).norm();
            if norm == 0.0 {
                continue;
            }
            let mut v: SVector<f64, NX> = j.row(r).transpose() / norm;
            for b in 0..k {
                let e = basis.column(b);
                v -= e * e.dot(&v);
            }
            let left = v.norm();
            if best.as_ref().is_none_or(|(_, l, _)| left > *l) {
                best = Some((r, left, v));
            }
        }
        match best {
            Some((r, left, v)) if left > f64::EPSILON.sqrt() => {
                taken[r] = true;
                rows[k] = r;
                basis.set_column(k, &(v / left));
            }
            _ => return Err(CertifyError::Singular),
        }
    }
    Ok(rows)
}

/// What every radius shares: the point, the rows, `C` and the interval `C G(x̃)`.
struct Setup<const NX: usize> {
    x: SVector<f64, NX>,
    rows: [usize; NX],
    c: SMatrix<f64, NX, NX>,
    /// `C G(x̃)` in interval arithmetic (the exact Newton step of `C` lies inside).
    newton_step: SVector<Interval, NX>,
}

impl<const NX: usize> Setup<NX> {
    fn new<P: Problem<NX, NF, NP>, const NF: usize, const NP: usize>(
        x: &SVector<f64, NX>,
        p: &SVector<f64, NP>,
        rows: &[usize; NX],
    ) -> Result<Self, CertifyError> {
        for (k, &r) in rows.iter().enumerate() {
            if r >= NF || rows[..k].contains(&r) {
                return Err(CertifyError::BadRow { row: r, nf: NF });
            }
        }
        if !x.iter().chain(p.iter()).all(|v| v.is_finite()) {
            return Err(CertifyError::NonFinite);
        }
        let mut j = SMatrix::<f64, NF, NX>::zeros();
        P::jacobian(x, p, &mut j);
        let mut g = SMatrix::<f64, NX, NX>::zeros();
        for (k, &r) in rows.iter().enumerate() {
            g.set_row(k, &j.row(r));
        }
        if !g.iter().all(|v| v.is_finite()) {
            return Err(CertifyError::NonFinite);
        }
        // C = G'(x̃)⁻¹ column by column, from the tracker's LU (its pivot threshold relative to
        // the matrix norm is the singularity test).
        let mut lu = LinearSolver::<f64, NX, NX>::new();
        lu.factor(&g).map_err(|_| CertifyError::Singular)?;
        let mut c = SMatrix::<f64, NX, NX>::zeros();
        for col in 0..NX {
            let unit = SVector::<f64, NX>::from_fn(|i, _| if i == col { 1.0 } else { 0.0 });
            c.set_column(col, &lu.solve(&unit));
        }
        if !c.iter().all(|v| v.is_finite()) {
            return Err(CertifyError::Singular);
        }

        let xi = x.map(Interval::point);
        let pi = p.map(Interval::point);
        let mut f = SVector::<Interval, NF>::from_element(Interval::point(0.0));
        P::residual(&xi, &pi, &mut f);
        let mut newton_step = SVector::<Interval, NX>::from_element(Interval::point(0.0));
        for i in 0..NX {
            let mut s = Interval::point(0.0);
            for (k, &r) in rows.iter().enumerate() {
                s = s + Interval::point(c[(i, k)]) * f[r];
            }
            if !s.is_finite() {
                return Err(CertifyError::NonFinite);
            }
            newton_step[i] = s;
        }
        Ok(Self { x: *x, rows: *rows, c, newton_step })
    }

    /// The test on `x ± radius`: the certificate, `Err(contraction)` when `K ⊄ int X`, or a
    /// typed error when the box cannot be evaluated.
    fn krawczyk<P: Problem<NX, NF, NP>, const NF: usize, const NP: usize>(
        &self,
        p: &SVector<f64, NP>,
        radius: &SVector<f64, NX>,
    ) -> Result<Result<Certificate<NX>, f64>, CertifyError> {
        if !radius.iter().all(|r| r.is_finite() && *r >= 0.0) {
            return Err(CertifyError::NonFinite);
        }
        if radius.iter().any(|r| *r == 0.0) {
            return Err(CertifyError::Singular);
        }
        let boxed = SVector::<Interval, NX>::from_fn(|i, _| Interval::around(self.x[i], radius[i]));
        let pi = p.map(Interval::point);
        let mut j = SMatrix::<Interval, NF, NX>::from_element(Interval::point(0.0));
        P::jacobian(&boxed, &pi, &mut j);

        // M = I - C G'(X), and its largest row sum of magnitudes (the contraction).
        let mut m = SMatrix::<Interval, NX, NX>::from_element(Interval::point(0.0));
        let mut contraction = 0.0f64;
        for i in 0..NX {
            let mut row_sum = 0.0;
            for col in 0..NX {
                let mut s = Interval::point(if i == col { 1.0 } else { 0.0 });
                for (k, &r) in self.rows.iter().enumerate() {
                    s = s - Interval::point(self.c[(i, k)]) * j[(r, col)];
                }
                if !s.is_finite() {
                    return Err(CertifyError::NonFinite);
                }
                row_sum += s.mag();
                m[(i, col)] = s;
            }
            contraction = contraction.max(row_sum);
        }

        // K = x̃ - C G(x̃) + M (X - x̃), all in interval arithmetic.
        let mut enclosure = SVector::<Interval, NX>::from_element(Interval::point(0.0));
        let mut inside = true;
        for i in 0..NX {
            let mut k = Interval::point(self.x[i]) - self.newton_step[i];
            for col in 0..NX {
                k = k + m[(i, col)] * (boxed[col] - Interval::point(self.x[col]));
            }
            if !k.is_finite() {
                return Err(CertifyError::NonFinite);
            }
            inside &= k.strictly_inside(boxed[i]);
            enclosure[i] = k;
        }
        Ok(if inside { Ok(Certificate { center: self.x, radius: *radius, enclosure, rows: self.rows }) } else { Err(contraction) })
    }
}
