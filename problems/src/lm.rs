//! Settings shared by the Levenberg-Marquardt refinements of the built-in problems
//! ([`crate::upnp::refine`], [`crate::grps::refine`]).

/// Settings of a Levenberg-Marquardt loop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LmOptions {
    /// Iterations at most.
    pub max_iterations: usize,
    /// Initial damping relative to the diagonal of `J^T J`.
    pub initial_lambda: f64,
    /// Stop when the step is below this (max-norm).
    pub step_tolerance: f64,
}

impl Default for LmOptions {
    fn default() -> Self {
        Self { max_iterations: 50, initial_lambda: 1e-3, step_tolerance: 1e-12 }
    }
}
