//! What the built-ins' robust estimators share: their error
//! ([`crate::upnp::ransac::UpnpEstimator::estimate`]).

use simhc::ransac::{ransac, Estimator, RansacOptions};
use simhc::solver::EstimateInfo;
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

/// The estimate of a built-in: `check` on the data (the solver's own input checks),
/// `too_few(got, need)` below a sample, then LO-RANSAC with `options`.
pub fn estimate<E, Err>(
    estimator: &E,
    data: &[E::Datum],
    options: &RansacOptions,
    check: impl FnOnce(&[E::Datum]) -> Result<(), Err>,
    too_few: impl FnOnce(usize, usize) -> Err,
) -> Result<(E::Model, EstimateInfo), RobustError<Err>>
where
    E: Estimator,
{
    check(data)?;
    if data.len() < estimator.sample_size() {
        return Err(too_few(data.len(), estimator.sample_size()).into());
    }
    let result = ransac(estimator, data, options).ok_or(RobustError::NoModel { iterations: options.max_iterations })?;
    Ok(EstimateInfo::split(result))
}
