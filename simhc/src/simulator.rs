//! Online simulators: given a predicted solution `x0` and the target parameters `p`, build
//! start parameters `p0` near `p` that `x0` solves exactly, `F(x0; p0) = 0`.
//!
//! Every problem gets [`MinNormSimulator`] for free (it only needs `dF/dp`); a problem with a
//! geometric rule (reproject the points under the predicted pose) implements
//! [`OnlineSimulator`] itself. `#[simhc_problem(simulator = custom)]` turns the generated default
//! off so that the problem's own implementation is the only one.

use crate::{ParamDerivative, Scalar};
use nalgebra::{SMatrix, SVector};
use std::marker::PhantomData;
use thiserror::Error;

/// Why a simulator could not produce a consistent start problem.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum SimulatorError {
    /// Input or intermediate values were NaN or infinite.
    #[error("non-finite value in simulator input or output")]
    NonFinite,
    /// The linear system of the correction was singular (degenerate geometry).
    #[error("singular system in the simulator (degenerate input)")]
    Singular,
    /// After the iteration budget the start problem is still inconsistent.
    #[error("simulated start problem not consistent: equation {equation} has residual {residual:e}")]
    NotConsistent {
        /// Max-norm of `F(x0; p0)` at the end.
        residual: f64,
        /// The equation of that residual (index into `F`; [`crate::Layout::equation_name`]).
        equation: usize,
    },
    /// An equation in which no parameter occurs (`t.dot(t) - 1`) does not hold at the start and
    /// could not be made to: no simulator can change it, so the start must meet it
    /// ([`onto_parameter_free`]).
    #[error("equation {equation} has no parameters and the start misses it by {residual:e}; the start must satisfy it (a zero vector where a unit one is needed?)")]
    ParameterFree {
        /// The equation (index into `F`; [`crate::Layout::equation_name`]).
        equation: usize,
        /// Its residual at the start.
        residual: f64,
    },
}

/// Builds a start problem for a predicted solution.
#[diagnostic::on_unimplemented(
    message = "`{Self}` has no online simulator with NX = {NX}, NF = {NF}, NP = {NP}",
    label = "no `simhc::OnlineSimulator<{NX}, {NF}, {NP}>` for this instance",
    note = "`#[simhc_problem]` implements it for every instance, with its own sizes (`Foo::NX`, `Foo::NF`, `Foo::NP`), unless declared with `simulator = custom`; then implement it yourself"
)]
pub trait OnlineSimulator<const NX: usize, const NF: usize, const NP: usize> {
    /// Returns `p0` with `F(x0; p0) = 0`, as close to `p` as the rule makes it.
    fn simulate(&self, x0: &SVector<f64, NX>, p: &SVector<f64, NP>) -> Result<SVector<f64, NP>, SimulatorError>;
}

/// The generic simulator: minimum-norm parameter correction by Gauss-Newton on `p`,
/// `p <- p - Jp^+ F(x0; p)` with `Jp = dF/dp (x0; p)` and `Jp^+` its pseudo-inverse.
///
/// The step is computed by a rank-revealing QR factorization of `Jp^T` with column pivoting
/// ([`min_norm_step`]), not by the normal equations: equations that are dependent at `x0`, such
/// as the three components of a cross product `f x d` (of rank two, since `f . (f x d) = 0`), make
/// `Jp Jp^T` singular or, as `F -> 0`, ill-conditioned, and a Cholesky factorization of it fails.
/// Equations whose `dF/dp` row vanishes (they do not involve parameters) or depends on the
/// others cannot be corrected independently; they are left out of the step and must hold at the
/// end, otherwise the result is [`SimulatorError::NotConsistent`] naming the worst equation.
/// The pipeline puts a start on the parameter-free equations first ([`onto_parameter_free`]).
#[derive(Debug, Clone, Copy)]
pub struct MinNormSimulator<P> {
    /// Gauss-Newton iterations at most (the correction is exact in one step when `F` is affine in
    /// `p`, as for the built-in problems).
    pub max_iterations: usize,
    /// Success when `max |F(x0; p0)| <= tolerance * (1 + max |p|)`.
    pub tolerance: f64,
    /// Pivots of the QR factorization below `rank_tolerance` times the largest count as zero:
    /// their equations depend on the others. Default `1e-10`.
    pub rank_tolerance: f64,
    problem: PhantomData<fn() -> P>,
}

impl<P> Default for MinNormSimulator<P> {
    fn default() -> Self {
        Self { max_iterations: 8, tolerance: 1e-12, rank_tolerance: 1e-10, problem: PhantomData }
    }
}

impl<P> MinNormSimulator<P> {
    /// Default settings (8 iterations, tolerance 1e-12, rank tolerance 1e-10).
    pub fn new() -> Self {
        Self::default()
    }

    /// The simulator with explicit sizes, for callers that hold `P` only.
    pub fn run<const NX: usize, const NF: usize, const NP: usize>(
        &self,
        x0: &SVector<f64, NX>,
        p: &SVector<f64, NP>,
    ) -> Result<SVector<f64, NP>, SimulatorError>
    where
        P: ParamDerivative<NX, NF, NP>,
    {
        if !x0.iter().chain(p.iter()).all(|v| v.is_finite()) {
            return Err(SimulatorError::NonFinite);
        }
        let tol = self.tolerance * (1.0 + p.amax());
        let mut p0 = *p;
        let mut f = SVector::<f64, NF>::zeros();
        let mut jp = SMatrix::<f64, NF, NP>::zeros();
        for _ in 0..self.max_iterations {
            P::residual(x0, &p0, &mut f);
            if f.amax() <= tol {
                return Ok(p0);
            }
            P::param_jacobian(x0, &p0, &mut jp);
            let step = min_norm_step(&jp, &f, self.rank_tolerance).ok_or(SimulatorError::Singular)?;
            p0 -= step;
            if !p0.iter().all(|v| v.is_finite_value()) {
                return Err(SimulatorError::NonFinite);
            }
        }
        P::residual(x0, &p0, &mut f);
        let equation = f.iamax();
        let residual = f[equation].abs();
        if residual <= tol {
            Ok(p0)
        } else {
            Err(SimulatorError::NotConsistent { residual, equation })
        }
    }
}

/// `x0` moved onto the equations without parameters ([`crate::Layout::parameter_free`]), which
/// no online simulator can make hold: first every field whose norm such an equation fixes (and
/// every quaternion) is put on its sphere ([`crate::Layout::normalize_unknowns`]), which
/// settles `q.q - 1` and `t.t - 1` exactly; any other parameter-free equation still above
/// `tolerance` then gets minimum-norm Gauss-Newton steps on those equations alone, at most
/// `max_iterations`. Returns `x0` unchanged when the problem has no such equation.
/// [`SimulatorError::ParameterFree`] names the equation that could not be met. No allocation.
pub fn onto_parameter_free<P, const NX: usize, const NF: usize, const NP: usize>(
    x0: &SVector<f64, NX>,
    tolerance: f64,
    max_iterations: usize,
) -> Result<SVector<f64, NX>, SimulatorError>
where
    P: crate::Problem<NX, NF, NP> + crate::ProblemLayout,
{
    let layout = P::LAYOUT;
    if layout.parameter_free.is_empty() {
        return Ok(*x0);
    }
    if !x0.iter().all(|v| v.is_finite()) {
        return Err(SimulatorError::NonFinite);
    }
    let mut x = *x0;
    if !layout.normalize_unknowns(x.as_mut_slice()) {
        // A zero field cannot be put on its sphere: name the first norm equation it misses.
        let missed = layout.norms.iter().find(|n| {
            let f = &layout.unknowns[n.field];
            x0.as_slice()[f.offset..f.offset + f.kind.len()].iter().all(|v| *v == 0.0)
        });
        let equation = missed.map_or(layout.parameter_free[0], |n| n.equation);
        return Err(SimulatorError::ParameterFree { equation, residual: missed.map_or(f64::NAN, |n| n.norm * n.norm) });
    }
    // Norm equations hold after normalization up to rounding; other parameter-free equations
    // need the residual. `p` is irrelevant to them: zeros.
    if layout.parameter_free.iter().all(|e| layout.norms.iter().any(|n| n.equation == *e)) {
        return Ok(x);
    }
    let p = SVector::<f64, NP>::zeros();
    let (mut f, mut j) = (SVector::<f64, NF>::zeros(), SMatrix::<f64, NF, NX>::zeros());
    let mut worst = (0, f64::INFINITY);
    for iteration in 0..=max_iterations {
        P::residual_jacobian(&x, &p, &mut f, &mut j);
        // Only the parameter-free equations: zero the others' rows.
        let mut keep = SVector::<f64, NF>::zeros();
        layout.parameter_free.iter().for_each(|&e| keep[e] = 1.0);
        f.component_mul_assign(&keep);
        for (r, k) in keep.iter().enumerate() {
            if *k == 0.0 {
                j.row_mut(r).fill(0.0);
            }
        }
        let e = f.iamax();
        worst = (e, f[e].abs());
        if worst.1 <= tolerance * (1.0 + x.amax()) {
            return Ok(x);
        }
        if iteration == max_iterations {
            break;
        }
        let Some(step) = min_norm_step(&j, &f, 1e-12) else { break };
        x -= step;
        if !x.iter().all(|v| v.is_finite()) {
            return Err(SimulatorError::NonFinite);
        }
    }
    Err(SimulatorError::ParameterFree { equation: worst.0, residual: worst.1 })
}

/// The minimum-norm solution `d` of `J d = f` over a maximal set of independent equations:
/// Householder QR of `J^T` (columns = equations) with column pivoting, stopped at the first pivot
/// below `rank_tolerance` times the largest column norm; the remaining equations are left out.
/// For a consistent system this is `J^+ f`. `None` when `J` is zero or not finite (no equation
/// can be corrected). No allocation.
pub fn min_norm_step<const NF: usize, const NP: usize>(
    j: &SMatrix<f64, NF, NP>,
    f: &SVector<f64, NF>,
    rank_tolerance: f64,
) -> Option<SVector<f64, NP>> {
    let mut a: SMatrix<f64, NP, NF> = j.transpose();
    let mut rhs = *f;
    let mut norms = SVector::<f64, NF>::from_fn(|c, _| a.column(c).norm_squared());
    let largest = norms.amax().sqrt();
    if !(largest > 0.0 && largest.is_finite()) {
        return None;
    }
    let mut betas = SVector::<f64, NF>::zeros();
    let mut rank = 0;
    for k in 0..NF.min(NP) {
        // Pivot: the remaining column of largest norm below row k (norms kept exact by
        // recomputation; NF is small).
        let (pivot, _) = (k..NF).map(|c| (c, norms[c])).fold((k, -1.0), |best, c| if c.1 > best.1 { c } else { best });
        a.swap_columns(k, pivot);
        norms.swap_rows(k, pivot);
        rhs.swap_rows(k, pivot);
        let alpha = a.view((k, k), (NP - k, 1)).norm();
        if alpha <= rank_tolerance * largest {
            break;
        }
        // Householder reflector I - beta u u^T mapping a[k.., k] onto -sign(a_kk) alpha e_1;
        // u is stored in a[k.., k] with u_0 = a_kk + sign alpha.
        let sign = if a[(k, k)] >= 0.0 { 1.0 } else { -1.0 };
        let u0 = a[(k, k)] + sign * alpha;
        a[(k, k)] = u0;
        let beta = 1.0 / (alpha * u0.abs());
        betas[k] = beta;
        for c in k + 1..NF {
            let dot: f64 = (k..NP).map(|r| a[(r, k)] * a[(r, c)]).sum();
            let s = beta * dot;
            for r in k..NP {
                a[(r, c)] -= s * a[(r, k)];
            }
            norms[c] = (k + 1..NP).map(|r| a[(r, c)] * a[(r, c)]).sum();
        }
        rank = k + 1;
        // R_kk = -sign alpha, kept beside the reflector.
        norms[k] = -sign * alpha;
    }
    // J^T P = Q R, so the kept equations read R_11^T y = (P^T f)_1 with y = (Q^T d)_1; the
    // minimum-norm d is Q [y; 0].
    let mut d = SVector::<f64, NP>::zeros();
    for k in 0..rank {
        let mut s = rhs[k];
        for i in 0..k {
            s -= a[(i, k)] * d[i];
        }
        d[k] = s / norms[k];
    }
    for k in (0..rank).rev() {
        // Apply reflector k: d <- d - beta u (u^T d), u = a[k.., k] (its diagonal entry u0).
        let dot: f64 = (k..NP).map(|r| a[(r, k)] * d[r]).sum();
        let s = betas[k] * dot;
        for r in k..NP {
            d[r] -= s * a[(r, k)];
        }
    }
    d.iter().all(|v| v.is_finite()).then_some(d)
}

impl<P, const NX: usize, const NF: usize, const NP: usize> OnlineSimulator<NX, NF, NP> for MinNormSimulator<P>
where
    P: ParamDerivative<NX, NF, NP>,
{
    fn simulate(&self, x0: &SVector<f64, NX>, p: &SVector<f64, NP>) -> Result<SVector<f64, NP>, SimulatorError> {
        self.run::<NX, NF, NP>(x0, p)
    }
}

#[cfg(test)]
mod tests {
    use super::min_norm_step;
    use nalgebra::{SMatrix, SVector};

    #[test]
    fn full_rank_step_is_the_pseudo_inverse() {
        let j = SMatrix::<f64, 3, 5>::from_fn(|r, c| ((r * 5 + c) as f64 * 0.7).sin() + if r == c { 2.0 } else { 0.0 });
        let f = SVector::<f64, 3>::new(0.3, -1.2, 0.5);
        let d = min_norm_step(&j, &f, 1e-12).unwrap();
        let expected = j.transpose() * (j * j.transpose()).try_inverse().unwrap() * f;
        assert!((d - expected).amax() < 1e-12, "{d} vs {expected}");
    }

    #[test]
    fn dependent_equations_are_dropped_and_still_hold() {
        // Row 2 = row 0 + 2 row 1, with a consistent right-hand side; row 3 has no parameters.
        let mut j = SMatrix::<f64, 4, 6>::from_fn(|r, c| ((r * 6 + c) as f64 * 1.3).cos());
        let (r0, r1) = (j.row(0).into_owned(), j.row(1).into_owned());
        j.set_row(2, &(r0 + r1 * 2.0));
        j.set_row(3, &nalgebra::RowSVector::<f64, 6>::zeros());
        let f = SVector::<f64, 4>::new(0.5, -0.25, 0.0, 0.0);
        let d = min_norm_step(&j, &f, 1e-10).unwrap();
        assert!((j * d - f).amax() < 1e-12, "residual {}", (j * d - f).amax());
        // Minimum norm: for a consistent system, the pseudo-inverse's solution.
        let pinv = j.pseudo_inverse(1e-10).unwrap();
        assert!((d - pinv * f).amax() < 1e-12, "{d} vs {}", pinv * f);
        assert!(min_norm_step(&SMatrix::<f64, 2, 3>::zeros(), &SVector::<f64, 2>::new(1.0, 0.0), 1e-10).is_none());
    }
}
