//! What tracking ends with: a [`TrackResult`] with its [`TrackStats`], or a [`TrackError`] stop
//! code; and the internal reason a step attempt failed ([`Trouble`]).

use crate::Scalar;
use nalgebra::SVector;
use thiserror::Error;

/// Why a path was given up. Each carries the `t` the tracker had reached.
#[derive(Debug, Clone, Copy, PartialEq, Error)]
pub enum TrackError {
    /// The adaptive step fell below `AdaptiveStep::min` because correctors kept failing:
    /// typically a real path at a fold (it turns back in `t`), or near-collision of paths.
    /// Also returned for invalid step settings (non-positive or non-finite `dt`).
    #[error("step size too small at t = {t}")]
    StepSizeTooSmall {
        /// Last accepted `t`.
        t: f64,
    },
    /// The Jacobian is singular at the start point or on the path (fixed schedule), or singular
    /// Jacobians made the adaptive step shrink below its minimum.
    #[error("singular Jacobian at t = {t}")]
    SingularJacobian {
        /// Last accepted `t`.
        t: f64,
    },
    /// An accepted point (or a Newton iterate in [`super::newton`] / the fixed schedule) exceeded
    /// `max_norm`, or the adaptive step shrank to its minimum with corrector iterates beyond it:
    /// the path goes to infinity.
    #[error("path diverged to infinity at t = {t}")]
    DivergedToInfinity {
        /// Last accepted `t`.
        t: f64,
    },
    /// `max_steps` steps (accepted plus rejected) without reaching `t = 1`.
    #[error("maximum number of steps reached at t = {t}")]
    MaxSteps {
        /// Last accepted `t`.
        t: f64,
    },
    /// At `t = 1` the corrector (plus `final_newton_iterations`) did not reach
    /// `final_tolerance` (only with `require_final_convergence`).
    #[error("corrector did not converge at t = {t}")]
    CorrectorDidNotConverge {
        /// `t` of the failed correction.
        t: f64,
    },
    /// NaN or infinity in the input or in an evaluation.
    #[error("non-finite value at t = {t}")]
    NonFinite {
        /// Last accepted `t`.
        t: f64,
    },
    /// (Gauss-)Newton's updates became small at a point that provably has no root (square
    /// system) or no stationary point of `|F|²` (more equations than unknowns) within the error
    /// Newton was asked for ([`crate::pipeline::path::gauss_newton`]): it stalled.
    #[error("Gauss-Newton stalled at a non-stationary point at t = {t}")]
    Stalled {
        /// `t` of the system it ran on.
        t: f64,
    },
}

impl TrackError {
    /// The `t` the tracker had reached.
    pub fn t(&self) -> f64 {
        match *self {
            TrackError::StepSizeTooSmall { t }
            | TrackError::SingularJacobian { t }
            | TrackError::DivergedToInfinity { t }
            | TrackError::MaxSteps { t }
            | TrackError::CorrectorDidNotConverge { t }
            | TrackError::NonFinite { t }
            | TrackError::Stalled { t } => t,
        }
    }
}

/// Internal reason a step attempt failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Trouble {
    Singular,
    NonFinite,
    Diverged,
    Contraction,
    NotConverged,
}

impl Trouble {
    /// The public code when steps shrank below the smallest step because of `self`.
    #[inline]
    pub(crate) fn into_stall_error(self, t: f64) -> TrackError {
        match self {
            Trouble::Singular => TrackError::SingularJacobian { t },
            Trouble::NonFinite => TrackError::NonFinite { t },
            // Steps of every size leave the max-norm ball: the path goes to infinity.
            Trouble::Diverged => TrackError::DivergedToInfinity { t },
            _ => TrackError::StepSizeTooSmall { t },
        }
    }

    /// The public code for a failure at `t`.
    #[inline]
    pub(crate) fn into_error(self, t: f64) -> TrackError {
        match self {
            Trouble::Singular => TrackError::SingularJacobian { t },
            Trouble::NonFinite => TrackError::NonFinite { t },
            Trouble::Diverged => TrackError::DivergedToInfinity { t },
            Trouble::Contraction | Trouble::NotConverged => TrackError::CorrectorDidNotConverge { t },
        }
    }
}

/// Work counters of one path.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TrackStats {
    /// Accepted steps.
    pub accepted_steps: usize,
    /// Rejected steps (adaptive only).
    pub rejected_steps: usize,
    /// Corrector iterations (each one `H` + `J_x` evaluation and one factorization), including
    /// the final refinement.
    pub newton_iterations: usize,
    /// All Jacobian factorizations: corrector iterations plus predictor stages.
    pub factorizations: usize,
    /// Drag steps taken by the adaptive tracker (see [`super::DragStep`]).
    pub drag_steps: usize,
}

impl TrackStats {
    /// Accepted plus rejected steps.
    #[inline]
    pub fn steps(&self) -> usize {
        self.accepted_steps + self.rejected_steps
    }
}

/// A successfully tracked path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackResult<S: Scalar, const NX: usize> {
    /// The end point, a solution of `H(x, 1) = 0`.
    pub x: SVector<S, NX>,
    /// Always `1.0`.
    pub t: f64,
    /// Work counters.
    pub stats: TrackStats,
    /// Estimated error of `x` (weighted max-norm, see [`super::TrackerOptions`]).
    pub accuracy: f64,
    /// Max-norm of [`crate::homotopy::Homotopy::validation_residual`] at `(x, 1)`: for a squared-up system the
    /// full system's residual.
    pub residual: f64,
}
