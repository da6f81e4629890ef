//! Canonical frames computed from the data alone, for a problem's learned-start features and
//! its canonical frame (the built-ins' `features` modules use them). A frame computed this way moves
//! with the data: a rigid change of the user's frame changes the canonical rotation and
//! leaves the canonical coordinates the same, so a regressor never sees the user's choice of
//! frame (up to rounding, and except where a spread is isotropic and its axes are not unique).

use nalgebra::{Matrix2, Matrix3, SymmetricEigen, Vector2, Vector3};

/// The rotation `V` (rows: the canonical axes) taking the mean of the unit `bearings` to `+z`
/// and the principal axis of their spread about it to `+x`, signed so that the third moment
/// along it is positive.
///
/// `None` for no bearings or a zero or non-finite bearing. The identity when the bearings
/// cancel out (an omnidirectional rig can do that): still an exact frame, only not one that
/// moves with the data.
pub fn bearing_frame(bearings: impl Iterator<Item = Vector3<f64>> + Clone) -> Option<Matrix3<f64>> {
    let mut count = 0usize;
    let mut mean_f = Vector3::zeros();
    for f in bearings.clone() {
        let n = f.norm();
        if !(n > 0.0 && n.is_finite()) {
            return None;
        }
        mean_f += f / n;
        count += 1;
    }
    let nf = mean_f.norm();
    if count == 0 {
        return None;
    }
    // Finite here (every bearing was), so `<=` also means "cancel out".
    if nf <= 1e-9 * count as f64 {
        return Some(Matrix3::identity());
    }
    let inv_n = 1.0 / count as f64;
    let z = mean_f / nf;
    // The spread of the bearings about z, in a basis (a, b) of the plane orthogonal to z.
    let a = if z.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
    let a = (a - z * z.dot(&a)).normalize();
    let b = z.cross(&a);
    let tangent = |f: Vector3<f64>| {
        let f = f.normalize();
        Vector2::new(f.dot(&a), f.dot(&b))
    };
    let mean2 = bearings.clone().map(tangent).sum::<Vector2<f64>>() * inv_n;
    let mut cov2 = Matrix2::zeros();
    for f in bearings.clone() {
        let g = tangent(f) - mean2;
        cov2 += g * g.transpose();
    }
    let eig = SymmetricEigen::new(cov2);
    let k = if eig.eigenvalues[0] >= eig.eigenvalues[1] { 0 } else { 1 };
    let mut e = eig.eigenvectors.column(k).into_owned();
    let third: f64 = bearings.map(|f| (tangent(f) - mean2).dot(&e).powi(3)).sum();
    if third < 0.0 {
        e = -e;
    }
    let x = a * e.x + b * e.y;
    let y = z.cross(&x);
    let v = Matrix3::from_rows(&[x.transpose(), y.transpose(), z.transpose()]);
    v.iter().all(|c| c.is_finite()).then_some(v)
}

/// Rows = the eigenvectors of the PSD `cov`, largest eigenvalue first, each signed so that the
/// third moment of `points` along it is positive, the third made right-handed.
pub fn principal_axes(cov: &Matrix3<f64>, points: impl Iterator<Item = Vector3<f64>> + Clone) -> Option<Matrix3<f64>> {
    let eig = SymmetricEigen::new(*cov);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&i, &j| eig.eigenvalues[j].total_cmp(&eig.eigenvalues[i]));
    let mut axes = order.map(|k| eig.eigenvectors.column(k).into_owned());
    for axis in axes.iter_mut().take(2) {
        let third: f64 = points.clone().map(|d| d.dot(axis).powi(3)).sum();
        if third < 0.0 {
            *axis = -*axis;
        }
    }
    axes[2] = axes[0].cross(&axes[1]);
    let w = Matrix3::from_rows(&[axes[0].transpose(), axes[1].transpose(), axes[2].transpose()]);
    w.iter().all(|v| v.is_finite()).then_some(w)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::{random_unit_quaternion, rotation_from_quat};
    use rand::{Rng, SeedableRng};

    #[test]
    fn bearing_frame_moves_with_the_bearings() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(5);
        for _ in 0..50 {
            let bearings: Vec<Vector3<f64>> = (0..8)
                .map(|_| Vector3::new(rng.random_range(-1.0..1.0), rng.random_range(-1.0..1.0), rng.random_range(1.0..4.0)))
                .collect();
            let q = rotation_from_quat(random_unit_quaternion(&mut rng));
            let v = bearing_frame(bearings.iter().copied()).unwrap();
            let w = bearing_frame(bearings.iter().map(|f| q * f)).unwrap();
            assert!((v * v.transpose() - Matrix3::identity()).amax() < 1e-12 && (v.determinant() - 1.0).abs() < 1e-12);
            // The canonical bearings agree: W q = V.
            assert!((w * q - v).amax() < 1e-9, "frames differ by {:e}", (w * q - v).amax());
        }
    }

    #[test]
    fn bearing_frame_rejects_bad_bearings() {
        let good = [Vector3::new(0.1, 0.0, 1.0), Vector3::new(0.0, 0.2, 1.0)];
        assert!(bearing_frame(good.iter().copied()).is_some());
        assert!(bearing_frame(std::iter::empty()).is_none());
        assert!(bearing_frame([good[0], Vector3::zeros()].into_iter()).is_none());
        assert!(bearing_frame([good[0], Vector3::new(f64::NAN, 0.0, 1.0)].into_iter()).is_none());
        assert_eq!(bearing_frame([Vector3::z(), -Vector3::z()].into_iter()), Some(Matrix3::identity()));
    }
}
