//! A GRPS pose `(R, t, s)` and its unknown vector `[q, t, s]`.

use crate::metrics::rotation_from_quat;
use nalgebra::{Matrix3, SVector, Vector3};

/// A relative pose and scale: `alpha f + v = R (alpha' f' + s v') + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrpsPose {
    /// Rotation view 2 -> view 1.
    pub rotation: Matrix3<f64>,
    /// Translation.
    pub translation: Vector3<f64>,
    /// Scale (metric length of one view-2 unit).
    pub scale: f64,
}

impl GrpsPose {
    /// The unknown vector `[q, t, s]` of the polynomial system.
    pub fn unknowns(&self) -> SVector<f64, 8> {
        super::unknowns_of(&self.rotation, &self.translation, self.scale)
    }

    /// The pose of an unknown vector (the quaternion normalized), or `None` for a zero or
    /// non-finite quaternion.
    pub fn from_unknowns(x: &SVector<f64, 8>) -> Option<Self> {
        let n = (x[0] * x[0] + x[1] * x[1] + x[2] * x[2] + x[3] * x[3]).sqrt();
        if !(n > 1e-12 && x.iter().all(|v| v.is_finite())) {
            return None;
        }
        let q = [x[0] / n, x[1] / n, x[2] / n, x[3] / n];
        Some(Self { rotation: rotation_from_quat(q), translation: Vector3::new(x[4], x[5], x[6]), scale: x[7] })
    }

    /// Whether two poses are the same solution: rotations and translations within `1e-6`
    /// (relative for the translation). Unknown vectors of one pose can differ in the sign of
    /// the quaternion, so compare poses, not vectors.
    pub fn same(&self, other: &GrpsPose) -> bool {
        (self.rotation - other.rotation).norm() <= 1e-6
            && (self.translation - other.translation).norm() <= 1e-6 * (1.0 + self.translation.norm())
    }
}
