//! Online simulators: given a predicted solution `x0` and the target parameters `p`, build
//! start parameters `p0` near `p` that `x0` solves exactly, `F(x0; p0) = 0`.
//!
//! Every problem gets [`MinNormSimulator`] for free (it only needs `dF/dp`); a problem with a
//! geometric rule (reproject the points under the predicted pose) implements
//! [`OnlineSimulator`] itself. `#[simhc_problem(simulator = custom)]` turns the generated default
//! off so that the problem's own implementation is the only one.

use crate::{ParamDerivative, Scalar};
use nalgebra::{Cholesky, SMatrix, SVector};
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
    /// After the iteration budget the start problem is still inconsistent; this also happens when
    /// an equation that does not depend on the parameters (such as `q.q - 1`) fails at `x0`.
    #[error("simulated start problem not consistent: residual {residual:e}")]
    NotConsistent {
        /// Max-norm of `F(x0; p0)` at the end.
        residual: f64,
    },
}

/// Builds a start problem for a predicted solution.
pub trait OnlineSimulator<const NX: usize, const NF: usize, const NP: usize> {
    /// Returns `p0` with `F(x0; p0) = 0`, as close to `p` as the rule makes it.
    fn simulate(
        &self,
        x0: &SVector<f64, NX>,
        p: &SVector<f64, NP>,
    ) -> Result<SVector<f64, NP>, SimulatorError>;
}

/// The generic simulator: minimum-norm parameter correction by Gauss-Newton on `p`,
/// `p <- p - Jp^T (Jp Jp^T)^-1 F(x0; p)` with `Jp = dF/dp (x0; p)`.
///
/// Equations whose `dF/dp` row vanishes (they do not involve parameters) cannot be corrected;
/// they are left out of the step and must already hold at `x0`, otherwise the result is
/// [`SimulatorError::NotConsistent`].
#[derive(Debug, Clone, Copy)]
pub struct MinNormSimulator<P> {
    /// Gauss-Newton iterations at most (the correction is exact in one step when `F` is affine in
    /// `p`, as for the built-in problems).
    pub max_iterations: usize,
    /// Success when `max |F(x0; p0)| <= tolerance * (1 + max |p|)`.
    pub tolerance: f64,
    problem: PhantomData<fn() -> P>,
}

impl<P> Default for MinNormSimulator<P> {
    fn default() -> Self {
        Self { max_iterations: 8, tolerance: 1e-12, problem: PhantomData }
    }
}

impl<P> MinNormSimulator<P> {
    /// Default settings (8 iterations, tolerance 1e-12).
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
            let mut gram: SMatrix<f64, NF, NF> = jp * jp.transpose();
            let mut rhs = f;
            let scale = gram.diagonal().amax().max(1e-300);
            for k in 0..NF {
                // An equation free of parameters cannot be corrected: drop it from the step.
                if gram[(k, k)] <= 1e-24 * scale {
                    for c in 0..NF {
                        gram[(k, c)] = 0.0;
                        gram[(c, k)] = 0.0;
                    }
                    gram[(k, k)] = 1.0;
                    rhs[k] = 0.0;
                }
            }
            let chol = Cholesky::new(gram).ok_or(SimulatorError::Singular)?;
            let lambda = chol.solve(&rhs);
            p0 -= jp.transpose() * lambda;
            if !p0.iter().all(|v| v.is_finite_value()) {
                return Err(SimulatorError::NonFinite);
            }
        }
        P::residual(x0, &p0, &mut f);
        let residual = f.amax();
        if residual <= tol {
            Ok(p0)
        } else {
            Err(SimulatorError::NotConsistent { residual })
        }
    }
}

impl<P, const NX: usize, const NF: usize, const NP: usize> OnlineSimulator<NX, NF, NP>
    for MinNormSimulator<P>
where
    P: ParamDerivative<NX, NF, NP>,
{
    fn simulate(
        &self,
        x0: &SVector<f64, NX>,
        p: &SVector<f64, NP>,
    ) -> Result<SVector<f64, NP>, SimulatorError> {
        self.run::<NX, NF, NP>(x0, p)
    }
}
