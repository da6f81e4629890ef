//! What the built-ins' robust estimators share: their error
//! ([`crate::upnp::ransac::UpnpEstimator::estimate`], [`crate::grps::ransac::GrpsEstimator::estimate`]).

use thiserror::Error;

/// Why a built-in robust estimator returned no model; `E` is the problem's input error.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum RobustError<E> {
    /// Bad input (names the correspondence and what is wrong with it), or fewer
    /// correspondences than a sample.
    #[error(transparent)]
    Input(#[from] E),
    /// No sample gave a validated pose.
    #[error("no model: none of {iterations} samples gave a validated pose")]
    NoModel {
        /// Samples drawn.
        iterations: usize,
    },
}
