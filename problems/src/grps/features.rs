//! The GRPS regressor's input rows and output decoding, shared by training (`simhc-regressor`)
//! and inference ([`super::learned`]).
//!
//! # Canonical frames
//!
//! Both views are moved to a canonical frame before the network sees them, with the exact
//! change of the pose, so that the network never has to learn these nuisances:
//!
//! - rotation `Q_k` of view `k` taking the mean bearing of that view to `+z` and the principal
//!   axis of the bearings' spread about it to `+x` ([`crate::frames::bearing_frame`]; the
//!   points are in front of the cameras, so the mean bearing is well defined). Both axes move
//!   with the view, so a rigid change of either view's frame leaves the rows unchanged;
//! - centring of the ray origins on their mean `m_k` (a translation of the view frame);
//! - scaling by `1 / k_k`, with `k_k` the RMS distance of the origins to their mean.
//!
//! With `f = Q1^T f~`, `v = m1 + k1 Q1^T v~` and `f' = Q2^T f~'`, `v' = m2 + k2 Q2^T v~'`, the
//! relation `alpha f + v = R (alpha' f' + s v') + t` becomes the same relation in canonical
//! coordinates with
//!
//! ```text
//! R~ = Q1 R Q2^T,   s~ = s k2 / k1,   t~ = Q1 (t + s R m2 - m1) / k1,
//! R  = Q1^T R~ Q2,  s  = s~ k1 / k2,  t  = k1 Q1^T t~ - s R m2 + m1.
//! ```
//!
//! # Rows ([`GRPS_ROW_WIDTH`] = 18 numbers per correspondence)
//!
//! `[f~, v~, v~ x f~, f~', v~', v~' x f~']`: bearing, origin and Plücker moment of the ray in
//! each canonical view (the constraint is bilinear in the two rays' Plücker coordinates).
//!
//! # Outputs ([`GRPS_OUTPUTS`] = 10 numbers)
//!
//! `[a1 (3), a2 (3), t~ (3), ln s~]`: the rotation `R~` in the continuous 6D representation of
//! Zhou et al. (2019) (its first two columns before Gram-Schmidt: `b1 = a1 / |a1|`,
//! `b2 = normalize(a2 - (b1 . a2) b1)`, `b3 = b1 x b2`, `R~ = [b1 b2 b3]`), the canonical
//! translation, and the log of the canonical scale. [`GrpsFrame::decode`] maps them back.

use super::scene::GrpsCorrespondence;
use crate::frames::bearing_frame;
use nalgebra::{Matrix3, Vector3};

/// Numbers per input row of the GRPS regressor.
pub const GRPS_ROW_WIDTH: usize = 18;

/// Numbers the GRPS regressor outputs (6D rotation, translation, log scale).
pub const GRPS_OUTPUTS: usize = 10;

/// The canonical frames of a set of correspondences (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GrpsFrame {
    /// Rotation of view 1 into its canonical frame.
    pub q1: Matrix3<f64>,
    /// Mean ray origin of view 1 (original coordinates).
    pub m1: Vector3<f64>,
    /// RMS spread of the view-1 origins (`1` if they coincide).
    pub k1: f64,
    /// Rotation of view 2 into its canonical frame.
    pub q2: Matrix3<f64>,
    /// Mean ray origin of view 2.
    pub m2: Vector3<f64>,
    /// RMS spread of the view-2 origins.
    pub k2: f64,
}

fn view_frame<'a>(
    bearings: impl Iterator<Item = &'a Vector3<f64>> + Clone,
    origins: impl Iterator<Item = &'a Vector3<f64>> + Clone,
) -> Option<(Matrix3<f64>, Vector3<f64>, f64)> {
    let q = bearing_frame(bearings.copied())?;
    let count = origins.clone().count() as f64;
    let m = origins.clone().fold(Vector3::zeros(), |a, v| a + v) / count;
    let k = (origins.map(|v| (v - m).norm_squared()).sum::<f64>() / count).sqrt();
    let k = if k > 1e-12 * (1.0 + m.amax()) && k.is_finite() { k } else { 1.0 };
    m.iter().all(|x| x.is_finite()).then_some((q, m, k))
}

impl GrpsFrame {
    /// The frame of data that is already canonical: no rotation, no shift, unit spreads.
    pub const IDENTITY: GrpsFrame = GrpsFrame {
        q1: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        m1: Vector3::new(0.0, 0.0, 0.0),
        k1: 1.0,
        q2: Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0),
        m2: Vector3::new(0.0, 0.0, 0.0),
        k2: 1.0,
    };

    /// The canonical frames of `corrs`, or `None` for an empty set, a non-finite value, a zero
    /// bearing, or bearings that cancel out.
    pub fn new(corrs: &[GrpsCorrespondence]) -> Option<Self> {
        if corrs.is_empty() {
            return None;
        }
        let (q1, m1, k1) = view_frame(corrs.iter().map(|c| &c.f), corrs.iter().map(|c| &c.v))?;
        let (q2, m2, k2) = view_frame(corrs.iter().map(|c| &c.fp), corrs.iter().map(|c| &c.vp))?;
        Some(Self { q1, m1, k1, q2, m2, k2 })
    }

    /// The canonical rows of `corrs` (module docs) into `out` (`GRPS_ROW_WIDTH * corrs.len()` numbers).
    /// Returns `false` (and leaves `out` partly written) for a length mismatch or non-finite
    /// values.
    pub fn rows(&self, corrs: &[GrpsCorrespondence], out: &mut [f32]) -> bool {
        if out.len() != GRPS_ROW_WIDTH * corrs.len() {
            return false;
        }
        for (c, row) in corrs.iter().zip(out.chunks_exact_mut(GRPS_ROW_WIDTH)) {
            let f = self.q1 * c.f.normalize();
            let v = self.q1 * (c.v - self.m1) / self.k1;
            let fp = self.q2 * c.fp.normalize();
            let vp = self.q2 * (c.vp - self.m2) / self.k2;
            let m = v.cross(&f);
            let mp = vp.cross(&fp);
            for (k, x) in f.iter().chain(&v).chain(&m).chain(&fp).chain(&vp).chain(&mp).enumerate() {
                if !x.is_finite() {
                    return false;
                }
                row[k] = *x as f32;
            }
        }
        true
    }

    /// The correspondences in the canonical frames (module docs): `f~ = Q1 f`,
    /// `v~ = Q1 (v - m1) / k1`, and the same for view 2. Bearings keep their length.
    pub fn canonical(&self, corrs: &[GrpsCorrespondence]) -> Vec<GrpsCorrespondence> {
        corrs.iter().map(|c| self.canonical_one(c)).collect()
    }

    /// One correspondence in the canonical frames ([`Self::canonical`], without a `Vec`).
    pub fn canonical_one(&self, c: &GrpsCorrespondence) -> GrpsCorrespondence {
        GrpsCorrespondence {
            f: self.q1 * c.f,
            v: self.q1 * (c.v - self.m1) / self.k1,
            fp: self.q2 * c.fp,
            vp: self.q2 * (c.vp - self.m2) / self.k2,
        }
    }

    /// The canonical pose `(R~, t~, s~)` of a pose (module docs).
    pub fn to_canonical(&self, r: &Matrix3<f64>, t: &Vector3<f64>, s: f64) -> (Matrix3<f64>, Vector3<f64>, f64) {
        let rc = self.q1 * r * self.q2.transpose();
        let sc = s * self.k2 / self.k1;
        let tc = self.q1 * (t + r * self.m2 * s - self.m1) / self.k1;
        (rc, tc, sc)
    }

    /// The pose of a canonical pose (inverse of [`Self::to_canonical`]).
    pub fn from_canonical(&self, rc: &Matrix3<f64>, tc: &Vector3<f64>, sc: f64) -> (Matrix3<f64>, Vector3<f64>, f64) {
        let r = self.q1.transpose() * rc * self.q2;
        let s = sc * self.k1 / self.k2;
        let t = self.q1.transpose() * tc * self.k1 - r * self.m2 * s + self.m1;
        (r, t, s)
    }

    /// The training target of a pose: `[R~ column 0, R~ column 1, t~, ln s~]`.
    pub fn target(&self, r: &Matrix3<f64>, t: &Vector3<f64>, s: f64) -> [f64; GRPS_OUTPUTS] {
        let (rc, tc, sc) = self.to_canonical(r, t, s);
        [rc[(0, 0)], rc[(1, 0)], rc[(2, 0)], rc[(0, 1)], rc[(1, 1)], rc[(2, 1)], tc.x, tc.y, tc.z, sc.ln()]
    }

    /// The pose `(R, t, s)` of the network's outputs (module docs), or `None` if the 6D
    /// rotation is degenerate or a value is not finite.
    pub fn decode(&self, out: &[f64; GRPS_OUTPUTS]) -> Option<(Matrix3<f64>, Vector3<f64>, f64)> {
        let rc = rotation_from_6d(&[out[0], out[1], out[2], out[3], out[4], out[5]])?;
        let tc = Vector3::new(out[6], out[7], out[8]);
        let sc = out[9].clamp(-30.0, 30.0).exp();
        let (r, t, s) = self.from_canonical(&rc, &tc, sc);
        (r.iter().chain(t.iter()).all(|x| x.is_finite()) && s.is_finite()).then_some((r, t, s))
    }
}

/// The rotation of a 6D representation `[a1, a2]` by Gram-Schmidt (module docs), or `None`
/// when `a1` vanishes or `a2` is parallel to it.
pub fn rotation_from_6d(a: &[f64; 6]) -> Option<Matrix3<f64>> {
    let a1 = Vector3::new(a[0], a[1], a[2]);
    let a2 = Vector3::new(a[3], a[4], a[5]);
    let n1 = a1.norm();
    if !(n1 > 1e-12 && n1.is_finite()) {
        return None;
    }
    let b1 = a1 / n1;
    let p = a2 - b1 * b1.dot(&a2);
    let n2 = p.norm();
    if !(n2 > 1e-12 * a2.norm().max(1e-300) && n2.is_finite()) {
        return None;
    }
    let b2 = p / n2;
    let b3 = b1.cross(&b2);
    Some(Matrix3::from_columns(&[b1, b2, b3]))
}

/// The correspondences of the swapped problem, view 2 as the first view. From
/// `alpha f + v = R (alpha' f' + s v') + t`: `(alpha'/s) f' + v' = R^T ((alpha/s) f + v / s) - R^T t / s`,
/// so the swapped problem `(f', v') - (f, v)` has the pose `R_sw = R^T`, `t_sw = -R^T t / s`,
/// `s_sw = 1 / s` ([`swap_pose`]). A second, different input for the regressor.
pub fn swap_views(corrs: &[GrpsCorrespondence]) -> Vec<GrpsCorrespondence> {
    corrs.iter().map(|c| GrpsCorrespondence { f: c.fp, v: c.vp, fp: c.f, vp: c.v }).collect()
}

/// `(R, t, s) -> (R^T, -R^T t / s, 1 / s)`: the pose of the swapped problem ([`swap_views`]);
/// its own inverse.
pub fn swap_pose(r: &Matrix3<f64>, t: &Vector3<f64>, s: f64) -> (Matrix3<f64>, Vector3<f64>, f64) {
    let rt = r.transpose();
    (rt, -(rt * t) / s, 1.0 / s)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grps::geometry::grps_residual_direct;
    use crate::grps::scene::GrpsSceneConfig;
    use crate::metrics::rotation_error_deg;

    #[test]
    fn canonical_pose_solves_canonical_correspondences() {
        for seed in 0..20 {
            let scene = GrpsSceneConfig::default().sample_seeded(seed).unwrap();
            let frame = GrpsFrame::new(&scene.correspondences).unwrap();
            let (rc, tc, sc) = frame.to_canonical(&scene.rotation, &scene.translation, scene.scale);
            let mut rows = vec![0.0f32; GRPS_ROW_WIDTH * 8];
            assert!(frame.rows(&scene.correspondences, &mut rows));
            let canonical = frame.canonical(&scene.correspondences);
            for cc in &canonical {
                assert!(grps_residual_direct(&rc, &tc, sc, cc).abs() < 1e-10);
            }
            // Canonical data is its own canonical frame, up to rounding.
            let again = GrpsFrame::new(&canonical).unwrap();
            assert!((again.q1 - Matrix3::identity()).amax() < 1e-9 && (again.q2 - Matrix3::identity()).amax() < 1e-9);
            assert!(again.m1.amax() < 1e-12 && again.m2.amax() < 1e-12);
            assert!((again.k1 - 1.0).abs() < 1e-12 && (again.k2 - 1.0).abs() < 1e-12);
            let (r, t, s) = frame.from_canonical(&rc, &tc, sc);
            assert!((r - scene.rotation).norm() < 1e-12 && (t - scene.translation).norm() < 1e-10);
            assert!((s - scene.scale).abs() < 1e-12);
            let target = frame.target(&scene.rotation, &scene.translation, scene.scale);
            let (r2, t2, s2) = frame.decode(&target).unwrap();
            assert!(rotation_error_deg(&r2, &scene.rotation) < 1e-6);
            assert!((t2 - scene.translation).norm() < 1e-9 && (s2 - scene.scale).abs() < 1e-9);
        }
    }

    #[test]
    fn rows_do_not_depend_on_the_frames_or_the_units() {
        use rand::SeedableRng;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(11);
        for seed in 0..20 {
            let scene = GrpsSceneConfig::default().sample_seeded(seed).unwrap();
            let moved = scene.random_frames(&mut rng);
            let rows = |s: &crate::grps::scene::GrpsScene| {
                let frame = GrpsFrame::new(&s.correspondences).unwrap();
                let mut out = vec![0.0f32; GRPS_ROW_WIDTH * s.correspondences.len()];
                assert!(frame.rows(&s.correspondences, &mut out));
                (out, frame.target(&s.rotation, &s.translation, s.scale))
            };
            let ((a, ta), (b, tb)) = (rows(&scene), rows(&moved));
            let diff = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0f32, f32::max);
            assert!(diff < 1e-4, "seed {seed}: rows differ by {diff}");
            let tdiff = ta.iter().zip(&tb).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
            assert!(tdiff < 1e-8, "seed {seed}: canonical targets differ by {tdiff:e}");
        }
    }

    #[test]
    fn swapped_pose_solves_swapped_problem() {
        let scene = GrpsSceneConfig::default().sample_seeded(3).unwrap();
        let swapped = swap_views(&scene.correspondences);
        let (r, t, s) = swap_pose(&scene.rotation, &scene.translation, scene.scale);
        // The swapped relation holds with view-1 origins scaled: check the constraint with
        // v' of the swapped problem (= original v) in the swapped view-2 units.
        for c in &swapped {
            assert!(grps_residual_direct(&r, &t, s, c).abs() < 1e-10);
        }
        let (r0, t0, s0) = swap_pose(&r, &t, s);
        assert!((r0 - scene.rotation).norm() < 1e-12 && (t0 - scene.translation).norm() < 1e-10 && (s0 - scene.scale).abs() < 1e-12);
    }
}
