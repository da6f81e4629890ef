//! The UPnP regressor's input rows and output decoding, shared by training (`simhc-regressor`)
//! and inference ([`super::learned`]).
//!
//! # Canonical frames
//!
//! A user's correspondences come in whatever world and viewer frames their pipeline uses. Both
//! are moved to frames computed from the data alone, with the exact change of the pose, so that
//! the network sees the same rows in every frame:
//!
//! - world: centred on the mean point `p_m`, scaled by `1 / k` (`k` the RMS distance of the
//!   points to `p_m`), rotated by `W` onto the principal axes of the points (largest spread
//!   first, each axis signed so that the third moment along it is positive, right-handed);
//! - viewer: ray origins centred on their mean `v_m` and scaled by the same `1 / k`, rotated by
//!   `V` taking the mean bearing to `+z` and the principal axis of the bearings' spread about it
//!   to `+x` (signed by its third moment).
//!
//! With `p~ = W (p - p_m) / k`, `f~ = V f`, `v~ = V (v - v_m) / k` the relation
//! `alpha f + v = R p + t` holds in canonical coordinates with `R~ = V R W^T`, so
//! `R = V^T R~ W` ([`UpnpFrame::decode`]). The frames are equivariant: a rigid change of either
//! input frame changes `W` or `V` and leaves the rows unchanged, up to rounding and except where
//! the principal axes are not unique (isotropic spreads).
//!
//! # Rows ([`UPNP_ROW_WIDTH`] = 9 numbers per correspondence)
//!
//! `[p~, f~ / |f~|, v~]`. Output: the quaternion of `R~` (4 numbers, sign-invariant loss).

use super::scene::UpnpCorrespondence;
use crate::frames::{bearing_frame, principal_axes};
use crate::metrics::{quat_from_rotation, rotation_from_quat};
use nalgebra::{Matrix3, Vector3};

/// Numbers per input row of the UPnP regressor.
pub const UPNP_ROW_WIDTH: usize = 9;

/// Numbers the UPnP regressor outputs (a quaternion `[w, x, y, z]`).
pub const UPNP_OUTPUTS: usize = 4;

/// The canonical frames of a set of correspondences (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpnpFrame {
    /// Rotation of the world frame onto the points' principal axes (`W`).
    pub world: Matrix3<f64>,
    /// Mean world point.
    pub p_mean: Vector3<f64>,
    /// Rotation of the viewer frame (`V`).
    pub viewer: Matrix3<f64>,
    /// Mean ray origin.
    pub v_mean: Vector3<f64>,
    /// RMS distance of the points to their mean.
    pub scale: f64,
}

impl UpnpFrame {
    /// The frames of `corrs`; `None` for empty input, non-finite values, zero bearings, or
    /// coincident points.
    pub fn new(corrs: &[UpnpCorrespondence]) -> Option<Self> {
        if corrs.is_empty() {
            return None;
        }
        let inv_n = 1.0 / corrs.len() as f64;
        let p_mean = corrs.iter().map(|c| c.p).sum::<Vector3<f64>>() * inv_n;
        let v_mean = corrs.iter().map(|c| c.v).sum::<Vector3<f64>>() * inv_n;
        let mut cov = Matrix3::zeros();
        for c in corrs {
            let d = c.p - p_mean;
            cov += d * d.transpose();
        }
        let scale = (cov.trace() * inv_n).sqrt();
        if !(scale > 0.0 && scale.is_finite()) {
            return None;
        }
        let world = principal_axes(&cov, corrs.iter().map(|c| c.p - p_mean))?;

        let viewer = bearing_frame(corrs.iter().map(|c| c.f))?;
        Some(Self { world, p_mean, viewer, v_mean, scale })
    }

    /// Writes the canonical rows (module docs) into `out` (`UPNP_ROW_WIDTH * corrs.len()`
    /// numbers); `false` when `out` has the wrong length or a value is not finite.
    pub fn rows(&self, corrs: &[UpnpCorrespondence], out: &mut [f32]) -> bool {
        if out.len() != UPNP_ROW_WIDTH * corrs.len() {
            return false;
        }
        let inv_k = 1.0 / self.scale;
        for (c, row) in corrs.iter().zip(out.chunks_exact_mut(UPNP_ROW_WIDTH)) {
            let p = self.world * (c.p - self.p_mean) * inv_k;
            let f = self.viewer * c.f.normalize();
            let v = self.viewer * (c.v - self.v_mean) * inv_k;
            for k in 0..3 {
                row[k] = p[k] as f32;
                row[3 + k] = f[k] as f32;
                row[6 + k] = v[k] as f32;
            }
        }
        out.iter().all(|v| v.is_finite())
    }

    /// The quaternion of `R = V^T R~ W` from the network's canonical quaternion (normalized
    /// here); `None` when it is zero or not finite.
    pub fn decode(&self, q: &[f64; UPNP_OUTPUTS]) -> Option<[f64; 4]> {
        let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(n > 0.0 && n.is_finite()) {
            return None;
        }
        let r = self.viewer.transpose() * rotation_from_quat(q.map(|v| v / n)) * self.world;
        Some(quat_from_rotation(&r))
    }

    /// The canonical quaternion of a rotation `R` (the training target): that of `V R W^T`.
    pub fn encode(&self, r: &Matrix3<f64>) -> [f64; 4] {
        quat_from_rotation(&(self.viewer * r * self.world.transpose()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::rotation_error_deg;
    use crate::upnp::scene::{random_rotation, PointBox, UpnpSceneConfig};
    use rand::SeedableRng;

    #[test]
    fn frames_are_rotations_and_decode_inverts_encode() {
        let scene = UpnpSceneConfig::default().sample_seeded(3).unwrap();
        let frame = UpnpFrame::new(&scene.correspondences).unwrap();
        for m in [frame.world, frame.viewer] {
            assert!((m * m.transpose() - Matrix3::identity()).amax() < 1e-12);
            assert!((m.determinant() - 1.0).abs() < 1e-12);
        }
        let q = frame.decode(&frame.encode(&scene.rotation)).unwrap();
        assert!(rotation_error_deg(&rotation_from_quat(q), &scene.rotation) < 1e-9);
    }

    #[test]
    fn rows_do_not_depend_on_the_frames_or_the_order() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(8);
        for layout in [PointBox::Viewer, PointBox::World] {
            let scene = UpnpSceneConfig::default().sample_with(layout, false, &mut rng).unwrap();
            let (w, v) = (random_rotation(&mut rng), random_rotation(&mut rng));
            let moved = scene.transformed((&w, &Vector3::new(3.0, -1.0, 2.0)), (&v, &Vector3::new(-4.0, 0.5, 1.0)));
            let rows = |s: &crate::upnp::scene::UpnpScene| {
                let frame = UpnpFrame::new(&s.correspondences).unwrap();
                let mut out = vec![0.0f32; UPNP_ROW_WIDTH * s.correspondences.len()];
                assert!(frame.rows(&s.correspondences, &mut out));
                (out, frame.encode(&s.rotation))
            };
            let ((a, qa), (b, qb)) = (rows(&scene), rows(&moved));
            let diff = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
            assert!(diff < 1e-4, "{layout:?}: rows differ by {diff}");
            let dot: f64 = qa.iter().zip(&qb).map(|(x, y)| x * y).sum();
            assert!(dot.abs() > 1.0 - 1e-9, "{layout:?}: canonical targets differ");
            // Reversed order: the same rows, reversed.
            let mut rev = scene.clone();
            rev.correspondences.reverse();
            let (c, _) = rows(&rev);
            let n = scene.correspondences.len();
            for i in 0..n {
                let (x, y) = (&a[i * 9..i * 9 + 9], &c[(n - 1 - i) * 9..(n - i) * 9]);
                assert!(x.iter().zip(y).all(|(s, t)| (s - t).abs() < 1e-5));
            }
        }
    }

    #[test]
    fn bad_input_has_no_frame() {
        let scene = UpnpSceneConfig::default().sample_seeded(1).unwrap();
        assert!(UpnpFrame::new(&[]).is_none());
        let mut zero = scene.correspondences.clone();
        zero[2].f = Vector3::zeros();
        assert!(UpnpFrame::new(&zero).is_none());
        let mut same = scene.correspondences.clone();
        for c in &mut same {
            c.p = Vector3::new(1.0, 2.0, 3.0);
        }
        assert!(UpnpFrame::new(&same).is_none());
    }
}
