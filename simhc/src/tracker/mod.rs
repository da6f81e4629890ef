//! The path tracker: follows one solution path of a [`Homotopy`] from `t = 0` to `t = 1` with a
//! predictor-corrector scheme, with no heap allocation.
//!
//! Layout after HomotopyContinuation.jl's `tracker.jl`: [`TrackerOptions`] (with the paper's
//! fixed schedule as [`TrackerOptions::paper`] and an adaptive controller as the default), a
//! [`Tracker`] holding a [`TrackerState`] that can be driven step by step ([`Tracker::step`]) or
//! to the end ([`Tracker::track`], or the free function [`track`]), and a typed result:
//! [`TrackResult`] or a [`TrackError`] code. Nothing here panics on bad input or bad numerics.
//!
//! One file per concern: `options` (settings), `path` (the algorithm, once: [`TrackerState`] is
//! a state machine that asks for evaluations and takes their results), this module (the scalar
//! driver, [`Tracker`]), [`batch`] (the lane driver: one path per SIMD lane), `corrector`
//! (one Newton run, fed update by update; [`newton`]), `predictor` (tangents, Hermite
//! extrapolation), `step_size` (the step rules), `result` (results and stop codes), `linalg`,
//! `lane_lu` and `factor` (the dense solves).
//!
//! One step from `(x, t)`:
//! 1. **Predictor** ([`Predictor`], default RK4) on `J_x dx/dt = -dH/dt`; the tangent at `(x, t)`
//!    comes for free from the previous corrector's factorization, the other stages factorize the
//!    Jacobian at their points. For `NF > NX` tangents are least-squares solutions (normal
//!    equations, see the tolerance note in the `linalg` module: fine up to `cond(J) ~ 1e6`).
//! 2. **Corrector**: Newton (Gauss-Newton for `NF > NX`) at `t + dt`, a fresh Jacobian per
//!    iteration, stopping as soon as the *estimated remaining error* is below the tolerance
//!    (`theta / (1 - theta) |dx_k|`, or `omega |dx_0|^2 / 2` after one iteration), so easy steps
//!    cost one or two evaluations.
//! 3. **Step size**: fixed (`t_k = k dt`, every step accepted, as in the paper) or adaptive
//!    (accept when the corrector contracts fast and converges within the iteration budget;
//!    rescale the step by `(target / theta)^(1/(p+1))`; see [`AdaptiveStep`]).
//!
//! At `t = 1` the point is corrected to `final_tolerance` and judged by
//! [`Homotopy::validation_residual`] (the full system for [`crate::homotopy::SquaredUp`]).
//!
//! Cost model (why it is fast): every Newton iteration and every RK4 stage is one evaluation of
//! `H`/`J_x` plus one `NX x NX` factorization; an adaptive RK4 step on an easy path costs 3 stage
//! factorizations plus 1-2 corrector iterations, and the controller aims at few, long steps.
//! [`TrackStats`] counts them.
//!
//! Overdetermined systems (`NF > NX`, e.g. GRPS with 8 correspondences, 9 x 8): Gauss-Newton
//! tracks the least-squares path, which for the straight line (or a parameter segment whose
//! inner points are inconsistent) is not a path of zeros; the tangent is then only first-order
//! accurate and the path may fold. [`TrackerOptions::single_path`] (adaptive with drag steps)
//! copes like the paper's schedule at a fraction of the cost; [`crate::homotopy::SquaredUp`]
//! gives a consistent square path instead (but can end at spurious roots, which its full
//! residual reveals).
//!
//! Usage with any [`crate::Problem`] (here `x^2 - a`, tracking `sqrt(a)` from `a = 1` to `4`):
//!
//! ```
//! use nalgebra::{SMatrix, SVector, Vector1};
//! use simhc::homotopy::StraightLine;
//! use simhc::tracker::{track, TrackerOptions};
//! use simhc::{Problem, ProblemInfo, Ring};
//!
//! struct Sqrt;
//! impl ProblemInfo for Sqrt {
//!     const NAME: &'static str = "sqrt";
//!     const UNKNOWN_NAMES: &'static [&'static str] = &["x"];
//!     const PARAM_NAMES: &'static [&'static str] = &["a"];
//! }
//! impl Problem<1, 1, 1> for Sqrt {
//!     fn residual<S: Ring>(x: &SVector<S, 1>, p: &SVector<S, 1>, f: &mut SVector<S, 1>) {
//!         f[0] = x[0] * x[0] - p[0];
//!     }
//!     fn jacobian<S: Ring>(x: &SVector<S, 1>, _p: &SVector<S, 1>, j: &mut SMatrix<S, 1, 1>) {
//!         j[(0, 0)] = x[0] + x[0];
//!     }
//!     fn residual_jacobian<S: Ring>(
//!         x: &SVector<S, 1>, p: &SVector<S, 1>, f: &mut SVector<S, 1>, j: &mut SMatrix<S, 1, 1>,
//!     ) {
//!         Self::residual(x, p, f);
//!         Self::jacobian(x, p, j);
//!     }
//! }
//!
//! let h = StraightLine::<Sqrt, f64, 1>::new(Vector1::new(1.0), Vector1::new(4.0));
//! let r = track(&h, &Vector1::new(1.0), &TrackerOptions::default()).unwrap();
//! assert!((r.x[0] - 2.0).abs() < 1e-12 && r.residual < 1e-12);
//! println!("{} steps, {} factorizations", r.stats.accepted_steps, r.stats.factorizations);
//! ```

pub mod batch;
mod corrector;
mod factor;
mod lane_lu;
pub(crate) mod linalg;
mod options;
mod path;
mod predictor;
mod result;
mod step_size;

pub use corrector::{newton, solve_newton, NewtonResult};
pub use options::{AdaptiveStep, DragStep, NewtonOptions, Predictor, StepControl, TrackerOptions};
pub use path::{TrackerState, TrackerStatus};
pub(crate) use result::Trouble;
pub use result::{TrackError, TrackResult, TrackStats};

use crate::homotopy::Homotopy;
use crate::Scalar;
use corrector::update;
use linalg::LinearSolver;
use nalgebra::SVector;
use path::{Eval, Next};
use predictor::{tangent, tangent_from_factor};

/// A path tracker for the homotopy `H` (borrowed), reusable for many start points: the scalar
/// driver of the path state machine ([`TrackerState`], module `path`), which evaluates `H` and
/// factorizes one Jacobian per request of the machine.
///
/// All storage is inline (fixed-size nalgebra types), so a `Tracker` lives on the stack and
/// `start`/`step`/`track` never allocate. `NF` is the number of equations of the *tracked*
/// homotopy (`NX` for a squared-up one).
#[derive(Debug, Clone)]
pub struct Tracker<'h, S: Scalar, H, const NX: usize, const NF: usize> {
    homotopy: &'h H,
    options: TrackerOptions,
    state: TrackerState<S, NX>,
    solver: LinearSolver<S, NX, NF>,
}

impl<'h, S, H, const NX: usize, const NF: usize> Tracker<'h, S, H, NX, NF>
where
    S: Scalar,
    H: Homotopy<S, NX, NF>,
{
    /// A tracker for `homotopy` with `options`.
    pub fn new(homotopy: &'h H, options: TrackerOptions) -> Self {
        Self { homotopy, options, state: TrackerState::new(false), solver: LinearSolver::new() }
    }

    /// The options.
    pub fn options(&self) -> &TrackerOptions {
        &self.options
    }

    /// The current state.
    pub fn state(&self) -> &TrackerState<S, NX> {
        &self.state
    }

    /// The current status.
    pub fn status(&self) -> TrackerStatus {
        self.state.status
    }

    /// Sets up tracking from `x0` at `t = 0`: checks the input and computes the first tangent.
    pub fn start(&mut self, x0: &SVector<S, NX>) -> Result<(), TrackError> {
        let next = self.state.start(x0, &self.options);
        match self.run(next) {
            TrackerStatus::Failed(e) => Err(e),
            _ => Ok(()),
        }
    }

    /// Tracks from `x0` to `t = 1`.
    pub fn track(&mut self, x0: &SVector<S, NX>) -> Result<TrackResult<S, NX>, TrackError> {
        self.start(x0)?;
        while self.step() == TrackerStatus::Tracking {}
        self.state.result().map(|mut r| {
            r.residual = self.homotopy.validation_residual(&r.x, r.t);
            r
        })
    }

    /// One predictor-corrector attempt; returns the new status.
    pub fn step(&mut self) -> TrackerStatus {
        if self.state.status != TrackerStatus::Tracking {
            return self.state.status;
        }
        let next = self.state.begin_step(&self.options, NF == NX);
        self.run(next)
    }

    /// Serves the machine's requests until the attempt (or tracking) is over.
    #[inline]
    fn run(&mut self, mut next: Next) -> TrackerStatus {
        while let Next::Eval(eval) = next {
            let (x, t) = self.state.at();
            let h = self.homotopy;
            let result = match eval {
                Eval::Tangent => tangent(h, x, t, &mut self.solver),
                Eval::Update => update(h, x, t, &mut self.solver),
                Eval::TangentAtAccepted => tangent_from_factor(h, x, t, &self.solver),
            };
            next = self.state.feed(&self.options, NF == NX, result);
        }
        self.state.status
    }
}

/// Tracks `x0` (a solution of `H(x, 0) = 0`) along `homotopy` to `t = 1`.
///
/// Generic over the scalar (`f64`, `Complex<f64>`), the homotopy and the sizes; allocation-free.
/// Equivalent to `Tracker::new(homotopy, *options).track(x0)`.
#[inline]
pub fn track<S, H, const NX: usize, const NF: usize>(
    homotopy: &H,
    x0: &SVector<S, NX>,
    options: &TrackerOptions,
) -> Result<TrackResult<S, NX>, TrackError>
where
    S: Scalar,
    H: Homotopy<S, NX, NF>,
{
    Tracker::new(homotopy, *options).track(x0)
}
