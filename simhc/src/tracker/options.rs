//! Tracker settings with documented defaults.

/// The predictor that extrapolates along the path tangent `dx/dt = -J_x^+ dH/dt`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Predictor {
    /// Explicit Euler, order 1: one tangent per step (at the accepted point, reused from the
    /// corrector), so no extra factorization; good only for tiny steps.
    Euler,
    /// Heun (explicit trapezoid), order 2: one extra tangent per step.
    Heun,
    /// Classic Runge-Kutta, order 4: three extra tangents per step. The paper's predictor and the
    /// default; its `O(dt^5)` local error lets the adaptive controller take few, long steps.
    Rk4,
    /// Hermite extrapolation through the last accepted points and their tangents (a multistep
    /// predictor): cubic through two points (order 3), quintic through three (order 5). The
    /// tangents come from the correctors' last factorizations, so a step costs *no* extra
    /// factorization. The first step (no history yet) and the first after a path restart use
    /// Heun. Best where factorizations dominate and paths are smooth (all-roots tracking).
    Hermite {
        /// Accepted points used: `2` (cubic) or `3` (quintic); other values are clamped.
        points: u8,
    },
}

impl Predictor {
    /// The order `p` (local error `O(dt^(p+1))`), used by the step-size controller.
    #[inline]
    pub fn order(self) -> u32 {
        match self {
            Predictor::Euler => 1,
            Predictor::Heun => 2,
            Predictor::Rk4 => 4,
            Predictor::Hermite { points } => 2 * (points.clamp(2, 3) as u32) - 1,
        }
    }
}

/// Settings of the adaptive step-size controller.
///
/// The controller follows the idea of Timme (2019, "Mixed precision path tracking for polynomial
/// homotopy continuation") and HomotopyContinuation.jl: a step is good when the Newton corrector
/// *contracts fast* from the predicted point, because then it provably converges to the nearby
/// path point and not to another path. The contraction `theta = |dx_1| / |dx_0|` of the first two
/// Newton updates measures that (`theta ~ omega |dx_0| / 2`, `omega` a Lipschitz estimate of the
/// Jacobian), and `|dx_0|` is the predictor error, `~ dt^(p+1)`. So
/// - a step is rejected when an update contracts by less than `max_contraction`, or the corrector
///   needs more than `max_newton_iterations`, or the Jacobian is singular / values non-finite;
/// - the next step is scaled by `(target_contraction / theta)^(1/(p+1))`, clamped to
///   `[min_shrink, max_growth]` (and to at most `1` right after a rejection, which keeps the
///   controller from oscillating);
/// - a step is also rejected when the first Newton update exceeds `max_relative_correction`
///   times the predictor's move `|x_pred - x|`: a good step's predictor error is a small fraction
///   of the move (the ratio falls like `dt^p`), while a corrector that pulls the prediction back
///   by about the whole move is converging to a *different* path that passes nearby — the
///   classic path jump, which the contraction test alone does not see (Newton contracts fast
///   towards any regular root);
/// - for overdetermined systems (`NF > NX`, Gauss-Newton) the step follows the corrector's
///   iteration count instead (grow by 2 after at most two iterations, keep after three, shrink
///   otherwise), without the path-jump guard and the `omega` prediction: on an inconsistent
///   homotopy the predictor is only first order and `theta` has a step-independent floor, see
///   the `step_size` module;
/// - before a second Newton evaluation, `omega` from the previous step predicts `theta`; a
///   prediction above `max_contraction` rejects at once (saves one evaluation per rejection).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AdaptiveStep {
    /// First step size in `t`. Default `0.1`.
    pub initial: f64,
    /// Smallest step before the path is given up ([`super::TrackError::StepSizeTooSmall`], or
    /// [`super::TrackError::SingularJacobian`] if singular Jacobians caused the shrinking).
    /// Default `1e-12`: a real path at a fold shrinks its steps geometrically, so this bounds the
    /// time a doomed path costs (about 40 halvings from `0.1`).
    pub min: f64,
    /// Largest step. Default `0.5`: even an easy path is corrected at least twice on the way.
    pub max: f64,
    /// Reject when a Newton update is not smaller than this fraction of the previous one.
    /// Default `0.25`.
    pub max_contraction: f64,
    /// Reject when the first corrector update is larger than this fraction of the predicted move
    /// (path-jump guard, see above). Default `0.25`.
    pub max_relative_correction: f64,
    /// The contraction `theta` the controller aims at. Default `0.05`; with Newton's quadratic
    /// convergence that is about 2-3 corrector iterations per step at the default tolerances.
    pub target_contraction: f64,
    /// Largest growth factor of the step after an accepted step. Default `4`.
    pub max_growth: f64,
    /// Paper-style fallback over stalls; `None` (default) tracks faithfully and fails at folds.
    pub drag: Option<DragStep>,
    /// Smallest shrink factor after a rejection (the controller may shrink less when `theta`
    /// says the step was only slightly too long). Default `0.25`; singular or non-finite
    /// rejections shrink by `0.5`.
    pub min_shrink: f64,
}

impl Default for AdaptiveStep {
    fn default() -> Self {
        Self {
            initial: 0.1,
            min: 1e-12,
            max: 0.5,
            max_contraction: 0.25,
            max_relative_correction: 0.25,
            target_contraction: 0.05,
            max_growth: 4.0,
            drag: None,
            min_shrink: 0.25,
        }
    }
}

/// A paper-style step the adaptive tracker takes instead of shrinking below `below`.
///
/// Why: a real path that turns back (a fold) cannot be followed past the fold; the adaptive
/// controller shrinks its steps towards it and fails. The paper's fixed schedule instead
/// *drags* the point over: a step of fixed size whose Gauss-Newton corrector lands on whatever
/// branch is nearby, accepted whether it converged or not. On GRPS with a simulated start that
/// often recovers the right solution (the end point is corrected at `t = 1` anyway). With a
/// drag, the adaptive tracker behaves like the paper's at stalls and stays adaptive elsewhere;
/// it is no longer a faithful path tracker (so not for all-roots work), and
/// [`super::TrackStats::drag_steps`] counts the drags.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DragStep {
    /// Drag when the adaptive step would be smaller than this (e.g. `1e-3`).
    pub below: f64,
    /// Size of a drag step (e.g. the paper's `0.05`); adaptive stepping resumes from it.
    pub dt: f64,
    /// (Gauss-)Newton iterations of a drag step's corrector (the paper's `5`).
    pub max_newton_iterations: usize,
}

impl Default for DragStep {
    fn default() -> Self {
        Self { below: 1e-3, dt: 0.05, max_newton_iterations: 5 }
    }
}

/// How the tracker chooses its steps in `t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StepControl {
    /// The paper's fixed schedule `t_k = k dt` (`dt = 0.02` for UPnP, `0.05` for GRPS). Every
    /// step is accepted whether or not the corrector converged (as in the paper); only
    /// singular Jacobians, non-finite values and divergence stop the path.
    Fixed {
        /// Step in `t`.
        dt: f64,
    },
    /// Accept/reject with step growth and shrinking, see [`AdaptiveStep`].
    Adaptive(AdaptiveStep),
}

/// All tracker settings. `TrackerOptions::default()` is the adaptive tracker;
/// [`TrackerOptions::paper`] reproduces the paper's fixed schedule.
///
/// Tolerances are on Newton updates in the weighted max-norm
/// `|v|_w = max_i |v_i| / max(1, |x_i|)` (relative for large components, absolute for small
/// ones), with `x` the last accepted point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackerOptions {
    /// Step-size control. Default: [`StepControl::Adaptive`] with [`AdaptiveStep::default`].
    pub step: StepControl,
    /// Predictor. Default [`Predictor::Rk4`].
    pub predictor: Predictor,
    /// Newton (Gauss-Newton for `NF > NX`) iterations per step at most. Default `3` (the paper: 5).
    pub max_newton_iterations: usize,
    /// Corrector tolerance on intermediate steps: the step's point is accepted when the
    /// estimated remaining error `theta / (1 - theta) |dx_k|_w` (or `|dx_k|_w` itself) is below
    /// it. Intermediate points only need to stay well inside the basin of the path, so this is
    /// looser than `final_tolerance`. Default `1e-9`.
    pub path_tolerance: f64,
    /// Adaptive only: an intermediate step is also accepted when, after at least two Newton
    /// updates, the estimated remaining error is below `path_reduction * |dx_0|_w`, i.e. the
    /// corrector has removed all but this fraction of the predictor error. Intermediate points
    /// only need to stay close to the path (the next corrector removes what is left, it does not
    /// accumulate), so full convergence there is wasted work: this saves the last Newton
    /// iteration of most steps, and makes Gauss-Newton on least-squares paths (linear
    /// convergence) affordable. `0` demands `path_tolerance` on every step. Default `1e-2`.
    pub path_reduction: f64,
    /// Corrector tolerance at `t = 1`: the end point is refined until the estimated error is
    /// below it (fixed schedule: the last step's corrector already aims at it). Default `1e-12`.
    pub final_tolerance: f64,
    /// Newton iterations at `t = 1` after the last step, when its corrector did not already
    /// reach `final_tolerance`. Default `3` (one or two are usual: the last step leaves the point
    /// well inside the quadratic convergence region).
    pub final_newton_iterations: usize,
    /// Whether a final point that misses `final_tolerance` after the extra iterations is a
    /// failure ([`super::TrackError::CorrectorDidNotConverge`]). Default `true`. The paper
    /// preset sets `false`: the point is returned with its accuracy, as the paper did.
    pub require_final_convergence: bool,
    /// Steps (accepted plus rejected) at most, then [`super::TrackError::MaxSteps`].
    /// Default `1000`.
    pub max_steps: usize,
    /// An accepted point with `max_i |x_i|` above this is
    /// [`super::TrackError::DivergedToInfinity`]; corrector iterates beyond it reject the step.
    /// Default `1e8`.
    pub max_norm: f64,
}

impl Default for TrackerOptions {
    fn default() -> Self {
        Self {
            step: StepControl::Adaptive(AdaptiveStep::default()),
            predictor: Predictor::Rk4,
            max_newton_iterations: 3,
            path_tolerance: 1e-9,
            path_reduction: 1e-2,
            final_tolerance: 1e-12,
            final_newton_iterations: 3,
            require_final_convergence: true,
            max_steps: 1000,
            max_norm: 1e8,
        }
    }
}

impl TrackerOptions {
    /// The paper's tracker: fixed step `dt` (0.02 for UPnP, 0.05 for GRPS), RK4, at most 5
    /// (Gauss-)Newton iterations per step, stopping at `|dx| < 1e-10`; the end point is
    /// returned even when the last corrector did not converge.
    pub fn paper(dt: f64) -> Self {
        Self {
            step: StepControl::Fixed { dt },
            predictor: Predictor::Rk4,
            max_newton_iterations: 5,
            path_tolerance: 1e-10,
            path_reduction: 0.0,
            final_tolerance: 1e-10,
            final_newton_iterations: 0,
            require_final_convergence: false,
            max_steps: 1000,
            max_norm: 1e8,
        }
    }

    /// The adaptive tracker with drag steps ([`DragStep::default`]) and a first step of `0.25`:
    /// for *single-path* tracking from a simulated start (simulator HC), where reaching the right
    /// end point matters and a faithful path is not required. Calibration run on this machine,
    /// GRPS with 8 correspondences, generic simulator, parameter homotopy, 300 paths, start
    /// rotated by 5 (20) deg with 10 % translation/scale error: success 96.0 % (85.7 %) against
    /// the paper's fixed schedule's 96.0 % (85.0 %), median 15 us (16 us) against 109 us
    /// (121 us) per path; with [`Predictor::Heun`] 96.3 % (86.7 %) at 10 us. Failures come back
    /// as [`super::TrackError::CorrectorDidNotConverge`] where the paper returns a wrong point.
    /// Not for all-roots tracking (a drag may switch paths).
    pub fn single_path() -> Self {
        Self::adaptive(AdaptiveStep { initial: 0.25, drag: Some(DragStep::default()), ..AdaptiveStep::default() })
    }

    /// The adaptive tracker with the given controller settings, other fields at their defaults.
    pub fn adaptive(step: AdaptiveStep) -> Self {
        Self { step: StepControl::Adaptive(step), ..Self::default() }
    }
}

/// Settings of plain Newton / Gauss-Newton ([`super::newton`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NewtonOptions {
    /// Iterations at most. Default `10`.
    pub max_iterations: usize,
    /// Converged when the estimated error after the last update is below this, in the weighted
    /// max-norm of [`TrackerOptions`]. Default `1e-12`.
    pub tolerance: f64,
    /// An iterate with `max_i |x_i|` above this is [`super::TrackError::DivergedToInfinity`].
    /// Default `1e8`.
    pub max_norm: f64,
}

impl Default for NewtonOptions {
    fn default() -> Self {
        Self { max_iterations: 10, tolerance: 1e-12, max_norm: 1e8 }
    }
}
