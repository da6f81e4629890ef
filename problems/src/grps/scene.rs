//! GRPS correspondences and the paper's scene sampler.
//!
//! # Convention
//!
//! A correspondence `(f, v) - (f', v')` (fields `f, v` and `fp, vp`) pairs a ray of the first
//! generalized camera (view 1: bearing `f`, origin `v`, view-1 frame) with a ray of the second
//! (view 2: `f'`, `v'`, view-2 frame, in view 2's own units). The relative pose and scale
//! `(R, t, s)` maps view-2 coordinates into view 1: a point `Y2` of view 2 is
//! `Y1 = R (s Y2) + t` in view 1. Hence, with latent depths `alpha, alpha' > 0`,
//!
//! ```text
//! alpha f + v = R (alpha' f' + s v') + t,
//! ```
//!
//! where `alpha'` is measured in view-1 (metric) units, i.e. `s` times the depth in view 2's
//! units. Eliminating the depths gives the paper's constraint
//! `t.(f x R f') - s f^T R [v']x f' + f^T [v]x R f' = 0`
//! ([`super::geometry::grps_residual_direct`]).
//!
//! # Generative model ([`GrpsSceneConfig::sample`])
//!
//! All draws uniform, from the caller's RNG, in this order:
//! 1. view 1: rotation `R1` ([`sample_euler_rotation`], roll/pitch/yaw in `[-pi/2, pi/2]`), then
//!    origin `o1` in `[-1, 1]³`; the view frame is placed in the world by `X = R1 Y1 + o1`;
//! 2. view 2 likewise: `R2`, then `o2` in `[-1, 1]³`, `X = R2 Y2m + o2` (`Y2m` metric);
//! 3. scale `s` in `[0.1, 5]`; view 2's own coordinates are `Y2 = Y2m / s`;
//! 4. `cameras_per_view` ray origins `v_c` in `[-1, 1]³` of view 1 (metric), then as many `v'_c`
//!    in `[-1, 1]³` of view 2 (view 2's own units, i.e. `s v'_c` metric);
//! 5. `points` world points `X_i` in `[-1, 1]² x [2, 20]`; point `i` is seen by camera
//!    `c = i mod cameras_per_view` in both views: `v = v_c`, `f = normalize(R1^T (X - o1) - v_c)`,
//!    `v' = v'_c`, `f' = normalize(R2^T (X - o2) / s - v'_c)`. (A point closer than `1e-6` to one
//!    of its ray origins is redrawn; this has probability ~0.)
//! 6. bearing noise ([`add_bearing_noise`], the UPnP noise model) on every `f`, then on every
//!    `f'` — always drawn, so a seed's geometry does not depend on the noise level.
//!
//! Ground truth: `R = R1^T R2`, `t = R1^T (o2 - o1)`, `s`; the noise-free depths are
//! `alpha = |Y1 - v|` and `alpha' = s |Y2 - v'|`, both positive.
//!
//! Note: the paper's text samples offsets in `[-1, 1]³` without saying in which units the second
//! view's offsets are; its released code multiplies the second view's offsets by the scale, as
//! here.

use crate::upnp::scene::{
    add_bearing_noise, arr3, check_noise, from_rows3, random_rotation, rows3, sample_euler_rotation, sample_in_box, SceneConfigError,
};
use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// One 2D-2D generalized correspondence: `alpha f + v = R (alpha' fp + s vp) + t`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
#[serde(from = "CorrespondenceRecord", into = "CorrespondenceRecord")]
pub struct GrpsCorrespondence {
    /// Bearing `f` in view 1.
    pub f: Vector3<f64>,
    /// Ray origin `v` in view 1.
    pub v: Vector3<f64>,
    /// Bearing `f'` in view 2.
    pub fp: Vector3<f64>,
    /// Ray origin `v'` in view 2 (view 2's units).
    pub vp: Vector3<f64>,
}

/// A sampled GRPS problem with its ground truth (view 1 `= R (s view 2) + t`).
///
/// Serialized (serde) as `{"correspondences": [{"f": [x,y,z], "v": [..], "fp": [..],
/// "vp": [..]}, ..], "rotation": [[..],[..],[..]] (row-major), "translation": [x,y,z],
/// "scale": s}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(from = "SceneRecord", into = "SceneRecord")]
pub struct GrpsScene {
    /// The correspondences, in sampling order.
    pub correspondences: Vec<GrpsCorrespondence>,
    /// Ground-truth relative rotation `R = R1^T R2`.
    pub rotation: Matrix3<f64>,
    /// Ground-truth relative translation `t = R1^T (o2 - o1)`.
    pub translation: Vector3<f64>,
    /// Ground-truth scale `s` (metric length of one view-2 unit).
    pub scale: f64,
}

impl GrpsScene {
    /// The same scene in other frames: view 1 `f' = V1 f`, `v' = V1 v + t1`; view 2
    /// `fp' = V2 fp`, `vp' = c V2 vp + t2` (`c` new view-2 units per old one). The ground truth
    /// changes to match: `R' = V1 R V2^T`, `s' = s / c`, `t' = V1 t + t1 - s' R' t2`.
    pub fn transformed(&self, view1: (&Matrix3<f64>, &Vector3<f64>), view2: (&Matrix3<f64>, &Vector3<f64>), units2: f64) -> GrpsScene {
        let ((v1, t1), (v2, t2)) = (view1, view2);
        let rotation = v1 * self.rotation * v2.transpose();
        let scale = self.scale / units2;
        GrpsScene {
            correspondences: self
                .correspondences
                .iter()
                .map(|c| GrpsCorrespondence { f: v1 * c.f, v: v1 * c.v + t1, fp: v2 * c.fp, vp: v2 * c.vp * units2 + t2 })
                .collect(),
            rotation,
            translation: v1 * self.translation + t1 - rotation * t2 * scale,
            scale,
        }
    }

    /// [`GrpsScene::transformed`] with uniformly random rotations `V1`, `V2`, translations
    /// `t1`, `t2` in `[-10, 10]³` and units `c` log-uniform in `[1/4, 4]`, drawn in that order.
    pub fn random_frames<R: Rng + ?Sized>(&self, rng: &mut R) -> GrpsScene {
        let v1 = random_rotation(rng);
        let t1 = sample_in_box(rng, [-10.0; 3], [10.0; 3]);
        let v2 = random_rotation(rng);
        let t2 = sample_in_box(rng, [-10.0; 3], [10.0; 3]);
        let units = rng.random_range(-4f64.ln()..=4f64.ln()).exp();
        self.transformed((&v1, &t1), (&v2, &t2), units)
    }
}

/// Settings of the GRPS scene sampler; the default is the paper's 8-point noise-free experiment.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GrpsSceneConfig {
    /// Number of correspondences (paper: 7 minimal, 8 overdetermined, 200 for RANSAC).
    pub points: usize,
    /// Cameras per view (paper: 3; 1, 3, 5 in the noise experiment).
    pub cameras_per_view: usize,
    /// Bearing noise level in pixels ([`crate::upnp::scene`] noise model).
    pub noise_px: f64,
    /// Virtual focal length in pixels for the noise model.
    pub focal_px: f64,
}

impl Default for GrpsSceneConfig {
    fn default() -> Self {
        Self { points: 8, cameras_per_view: 3, noise_px: 0.0, focal_px: 800.0 }
    }
}

impl GrpsSceneConfig {
    /// Checks the settings.
    pub fn validate(&self) -> Result<(), SceneConfigError> {
        if self.cameras_per_view == 0 {
            return Err(SceneConfigError::NoCameras);
        }
        if self.points == 0 {
            return Err(SceneConfigError::NoPoints);
        }
        check_noise(self.noise_px, self.focal_px)
    }

    /// Samples a scene with the generative model of the module docs from `rng`.
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Result<GrpsScene, SceneConfigError> {
        self.validate()?;
        let half_pi = std::f64::consts::FRAC_PI_2;
        let unit_lo = [-1.0; 3];
        let unit_hi = [1.0; 3];
        let r1 = sample_euler_rotation(rng, half_pi);
        let o1 = sample_in_box(rng, unit_lo, unit_hi);
        let r2 = sample_euler_rotation(rng, half_pi);
        let o2 = sample_in_box(rng, unit_lo, unit_hi);
        let scale = rng.random_range(0.1..=5.0);
        let cams1: Vec<Vector3<f64>> = (0..self.cameras_per_view).map(|_| sample_in_box(rng, unit_lo, unit_hi)).collect();
        let cams2: Vec<Vector3<f64>> = (0..self.cameras_per_view).map(|_| sample_in_box(rng, unit_lo, unit_hi)).collect();
        let mut correspondences = Vec::with_capacity(self.points);
        for i in 0..self.points {
            let (v1, v2) = (cams1[i % self.cameras_per_view], cams2[i % self.cameras_per_view]);
            loop {
                let x = sample_in_box(rng, [-1.0, -1.0, 2.0], [1.0, 1.0, 20.0]);
                let d1 = r1.transpose() * (x - o1) - v1;
                let d2 = r2.transpose() * (x - o2) / scale - v2;
                if d1.norm() >= 1e-6 && d2.norm() >= 1e-6 {
                    correspondences.push(GrpsCorrespondence { f: d1.normalize(), v: v1, fp: d2.normalize(), vp: v2 });
                    break;
                }
            }
        }
        for c in &mut correspondences {
            c.f = add_bearing_noise(&c.f, self.noise_px, self.focal_px, rng);
        }
        for c in &mut correspondences {
            c.fp = add_bearing_noise(&c.fp, self.noise_px, self.focal_px, rng);
        }
        Ok(GrpsScene { correspondences, rotation: r1.transpose() * r2, translation: r1.transpose() * (o2 - o1), scale })
    }

    /// [`Self::sample`] with `ChaCha8Rng::seed_from_u64(seed)`.
    pub fn sample_seeded(&self, seed: u64) -> Result<GrpsScene, SceneConfigError> {
        self.sample(&mut ChaCha8Rng::seed_from_u64(seed))
    }
}

impl crate::input::VectorFields for GrpsCorrespondence {
    const FIELDS: &'static [&'static str] = &["f", "v", "fp", "vp"];
    fn from_fields(fields: &[[f64; 3]]) -> Self {
        Self { f: fields[0].into(), v: fields[1].into(), fp: fields[2].into(), vp: fields[3].into() }
    }
}

impl crate::input::TrialFields for GrpsScene {
    type Correspondence = GrpsCorrespondence;
    const HAS_SCALE: bool = true;
    fn from_parts(correspondences: Vec<GrpsCorrespondence>, rotation: [[f64; 3]; 3], translation: [f64; 3], scale: f64) -> Self {
        Self { correspondences, rotation: from_rows3(&rotation), translation: translation.into(), scale }
    }
}

#[derive(Serialize, Deserialize)]
struct CorrespondenceRecord {
    f: [f64; 3],
    v: [f64; 3],
    fp: [f64; 3],
    vp: [f64; 3],
}

impl From<CorrespondenceRecord> for GrpsCorrespondence {
    fn from(r: CorrespondenceRecord) -> Self {
        Self { f: r.f.into(), v: r.v.into(), fp: r.fp.into(), vp: r.vp.into() }
    }
}

impl From<GrpsCorrespondence> for CorrespondenceRecord {
    fn from(c: GrpsCorrespondence) -> Self {
        Self { f: arr3(&c.f), v: arr3(&c.v), fp: arr3(&c.fp), vp: arr3(&c.vp) }
    }
}

#[derive(Serialize, Deserialize)]
struct SceneRecord {
    correspondences: Vec<GrpsCorrespondence>,
    rotation: [[f64; 3]; 3],
    translation: [f64; 3],
    scale: f64,
}

impl From<SceneRecord> for GrpsScene {
    fn from(r: SceneRecord) -> Self {
        Self { correspondences: r.correspondences, rotation: from_rows3(&r.rotation), translation: r.translation.into(), scale: r.scale }
    }
}

impl From<GrpsScene> for SceneRecord {
    fn from(s: GrpsScene) -> Self {
        Self { correspondences: s.correspondences, rotation: rows3(&s.rotation), translation: arr3(&s.translation), scale: s.scale }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serde_records_round_trip() {
        let scene = GrpsSceneConfig::default().sample_seeded(9).unwrap();
        assert_eq!(GrpsScene::from(SceneRecord::from(scene.clone())), scene);
    }
}
