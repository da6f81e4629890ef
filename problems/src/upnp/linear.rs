//! A closed-form start for UPnP: the linear (DLT) relaxation of the object-space cost.
//!
//! With `V_i = I - f_i f_i^T` the cost `sum_i |V_i (R p_i + t - v_i)|^2` is a quadratic form in
//! the twelve entries of `(R, t)` when `R` is not constrained to be a rotation. Its minimizer
//! solves the 12x12 normal equations `sum_i B_i^T V_i B_i y = sum_i B_i^T V_i v_i` with
//! `B_i y = R p_i + t`; the rotation nearest to the `R` block (SVD) is the start.
//!
//! Why it is a good start provider: it transforms exactly with the frames. A rigid change of
//! the world (`p' = W p + t_w`) or of the viewer (`f' = V f`, `v' = V v + t_v`) maps the
//! least-squares problem onto itself, so the estimate follows the transform up to rounding,
//! whatever distribution the data comes from. It needs at least 6 correspondences with
//! non-coplanar world points and non-central rays (the inhomogeneous term comes from the ray
//! origins); otherwise it reports [`LinearStartError`] and the solver moves on to its next
//! start.

use super::scene::UpnpCorrespondence;
use nalgebra::{Matrix3, SMatrix, SVector, Vector3};
use thiserror::Error;

/// Fewest correspondences for which the linear relaxation is determined (two equations each,
/// twelve unknowns).
pub const LINEAR_MIN_CORRESPONDENCES: usize = 6;

/// Why the linear start is not available for an input.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum LinearStartError {
    /// Fewer than [`LINEAR_MIN_CORRESPONDENCES`] correspondences.
    #[error("the linear start needs at least {LINEAR_MIN_CORRESPONDENCES} correspondences, got {0}")]
    TooFew(usize),
    /// The normal equations are singular: coplanar world points, central rays, or non-finite
    /// input.
    #[error("the linear start is degenerate for this input (coplanar points or central rays)")]
    Degenerate,
}

/// The rotation of the linear relaxation (world to viewer, `alpha f + v = R p + t`).
pub fn linear_rotation(corrs: &[UpnpCorrespondence]) -> Result<Matrix3<f64>, LinearStartError> {
    let n = corrs.len();
    if n < LINEAR_MIN_CORRESPONDENCES {
        return Err(LinearStartError::TooFew(n));
    }
    // Centre and scale the world points and centre the ray origins: the estimate is
    // unchanged in exact arithmetic (t absorbs the shifts, the SVD the scale), and the normal
    // equations are far better conditioned.
    let inv_n = 1.0 / n as f64;
    let p_mean = corrs.iter().map(|c| c.p).sum::<Vector3<f64>>() * inv_n;
    let v_mean = corrs.iter().map(|c| c.v).sum::<Vector3<f64>>() * inv_n;
    let spread = (corrs.iter().map(|c| (c.p - p_mean).norm_squared()).sum::<f64>() * inv_n).sqrt();
    if !(spread > 0.0 && spread.is_finite()) {
        return Err(LinearStartError::Degenerate);
    }
    let mut normal = SMatrix::<f64, 12, 12>::zeros();
    let mut rhs = SVector::<f64, 12>::zeros();
    for c in corrs {
        let f = c.f / c.f.norm();
        let proj = Matrix3::identity() - f * f.transpose();
        let p = (c.p - p_mean) / spread;
        let v = proj * (c.v - v_mean);
        // B = [p^T (x) I_3 | I_3] acting on y = [R row-major (9); t (3)]: (B y)_k = R_k . p + t_k.
        let mut b = SMatrix::<f64, 3, 12>::zeros();
        for k in 0..3 {
            for j in 0..3 {
                b[(k, 3 * k + j)] = p[j];
            }
            b[(k, 9 + k)] = 1.0;
        }
        let pb = proj * b;
        normal += b.transpose() * pb;
        rhs += b.transpose() * v;
    }
    let y = normal.cholesky().ok_or(LinearStartError::Degenerate)?.solve(&rhs);
    let mut r = Matrix3::from_fn(|i, j| y[3 * i + j]);
    if !r.iter().all(|x| x.is_finite()) {
        return Err(LinearStartError::Degenerate);
    }
    // The relaxation's R block is a positive multiple of a rotation for exact data; a negative
    // determinant means the sign of the whole solution is off (nearly central rays).
    if r.determinant() < 0.0 {
        r = -r;
    }
    nearest_rotation(&r).ok_or(LinearStartError::Degenerate)
}

/// The rotation nearest to `m` in the Frobenius norm, or `None` when `m` is (near) zero.
pub fn nearest_rotation(m: &Matrix3<f64>) -> Option<Matrix3<f64>> {
    let svd = m.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    if svd.singular_values[0] <= 0.0 || !svd.singular_values[0].is_finite() {
        return None;
    }
    let d = (u * v_t).determinant().signum();
    Some(u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::rotation_error_deg;
    use crate::upnp::scene::UpnpSceneConfig;

    #[test]
    fn exact_on_noise_free_scenes() {
        let config = UpnpSceneConfig { noise_px: 0.0, ..UpnpSceneConfig::default() };
        for seed in 0..50 {
            let scene = config.sample_seeded(seed).unwrap();
            let r = linear_rotation(&scene.correspondences).unwrap();
            assert!(rotation_error_deg(&r, &scene.rotation) < 1e-6, "seed {seed}");
        }
    }

    #[test]
    fn close_on_noisy_scenes() {
        let config = UpnpSceneConfig::default();
        for seed in 0..50 {
            let scene = config.sample_seeded(seed).unwrap();
            let r = linear_rotation(&scene.correspondences).unwrap();
            // 2 px noise: the relaxation is within a few degrees (median 0.7 deg).
            assert!(rotation_error_deg(&r, &scene.rotation) < 10.0, "seed {seed}");
        }
    }

    #[test]
    fn degenerate_inputs_are_reported() {
        let scene = UpnpSceneConfig::default().sample_seeded(1).unwrap();
        assert_eq!(linear_rotation(&scene.correspondences[..5]), Err(LinearStartError::TooFew(5)));
        // Coplanar world points: the column of R along the plane normal is not observed.
        let mut planar = scene.correspondences.clone();
        for c in &mut planar {
            c.p.z = 1.0;
        }
        assert_eq!(linear_rotation(&planar), Err(LinearStartError::Degenerate));
        // All world points equal.
        let mut same = scene.correspondences.clone();
        for c in &mut same {
            c.p = Vector3::new(1.0, 2.0, 3.0);
        }
        assert_eq!(linear_rotation(&same), Err(LinearStartError::Degenerate));
    }
}
