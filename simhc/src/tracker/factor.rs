//! Why a factorization failed: shared by the dense solves (`linalg`) and the lane LU
//! (`lane_lu`), which `linalg` calls, so it lives below both.

use super::result::Trouble;

/// The factorization met a (numerically) singular matrix or non-finite entries.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FactorError {
    /// Pivot below the relative threshold.
    Singular,
    /// NaN or infinity in the matrix.
    NonFinite,
}

impl From<FactorError> for Trouble {
    #[inline]
    fn from(e: FactorError) -> Self {
        match e {
            FactorError::Singular => Trouble::Singular,
            FactorError::NonFinite => Trouble::NonFinite,
        }
    }
}
