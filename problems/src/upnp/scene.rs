//! UPnP correspondences and the paper's scene sampler, plus the sampling helpers shared with
//! GRPS (Euler-angle rotations, boxes, the bearing noise model).
//!
//! # Convention
//!
//! A correspondence `(p, f, v)` is a world point `p`, a unit bearing `f` and the ray origin `v`
//! (camera centre), both in the generalized-camera ("viewer") frame. With the pose `(R, t)`
//! mapping world into viewer coordinates,
//!
//! ```text
//! alpha f + v = R p + t,   alpha > 0 (depth along the ray).
//! ```
//!
//! # Generative model ([`UpnpSceneConfig::sample`], paper section "Experiments")
//!
//! All draws are uniform, from the caller's RNG, in this order:
//! 1. rotation `R = Rz(yaw) Ry(pitch) Rx(roll)` with `roll, pitch, yaw` each in `[-pi/2, pi/2]`
//!    ([`sample_euler_rotation`], draws roll, pitch, yaw);
//! 2. translation `t` in `[-1, 1]³`;
//! 3. `cameras` ray origins `v_c` in `[-1, 1]³` (viewer frame);
//! 4. `points` viewer-frame points `X_i` in `[-1, 1]² x [4, 8]`; the world point is
//!    `p_i = R^T (X_i - t)`; point `i` is seen by camera `i mod cameras` (round robin),
//!    `v_i = v_(i mod cameras)`, and the noise-free bearing is `f_i = normalize(X_i - v_i)`
//!    (positive depth `alpha_i = |X_i - v_i| >= 3`);
//! 5. bearing noise ([`add_bearing_noise`]) on every `f_i`, in order, two draws each — always
//!    drawn, also for `noise_px == 0`, so the geometry of a seed does not depend on the noise
//!    level.
//!
//! # Noise model ([`add_bearing_noise`])
//!
//! OpenGV's `addNoise` (`opengv/test/random_generators.cpp`), which the paper's experiments use,
//! with the focal length as a parameter instead of the hard-coded 800 px: the bearing is seen
//! as a virtual pinhole image point at focal length `focal_px` with the optical axis along `f`;
//! an orthonormal tangent basis `(n1, n2)` at `f` is built (`n1` from the largest-magnitude
//! component of `f`, `n2 = f x n1`) and
//!
//! ```text
//! f_noisy = normalize(focal_px f + e1 n1 + e2 n2),  e1, e2 ~ U[-noise_px/sqrt2, noise_px/sqrt2]
//! ```
//!
//! independently. So the image-plane offset has per-axis uniform noise and magnitude at most
//! `noise_px` pixels (OpenGV divides the level by `1.4142`; we divide by `sqrt 2`). The paper's
//! "2 pixels" is `noise_px = 2`, `focal_px = 800`.

use nalgebra::{Matrix3, Rotation3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use thiserror::Error;

/// One generalized 2D-3D correspondence: `alpha f + v = R p + t` (module docs).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(from = "CorrespondenceRecord", into = "CorrespondenceRecord")]
pub struct UpnpCorrespondence {
    /// World point.
    pub p: Vector3<f64>,
    /// Bearing (unit for sampled data; the geometry normalizes it anyway), viewer frame.
    pub f: Vector3<f64>,
    /// Ray origin (camera centre), viewer frame.
    pub v: Vector3<f64>,
}

impl UpnpCorrespondence {
    /// The numbers of one correspondence as a row: `p`, `f`, `v`.
    pub const ROW_LEN: usize = 9;

    /// The correspondence of a row `[p, f, v]`: the first [`Self::ROW_LEN`] numbers of `row`,
    /// which must have that many (the callers check every row's length first: the CLI's
    /// trials reader names the row, Python the field). What those rows hold.
    pub fn from_row(row: &[f64]) -> Self {
        let v = |k: usize| Vector3::new(row[k], row[k + 1], row[k + 2]);
        Self { p: v(0), f: v(3), v: v(6) }
    }
}

/// A sampled UPnP problem with its ground truth pose (`alpha_i f_i + v_i = R p_i + t`).
///
/// Serialized (serde) as `{"correspondences": [{"p": [x,y,z], "f": [..], "v": [..]}, ..],
/// "rotation": [[r00,r01,r02],[r10,r11,r12],[r20,r21,r22]] (row-major), "translation": [x,y,z]}`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(from = "SceneRecord", into = "SceneRecord")]
pub struct UpnpScene {
    /// The correspondences, in sampling order.
    pub correspondences: Vec<UpnpCorrespondence>,
    /// Ground-truth rotation (world to viewer).
    pub rotation: Matrix3<f64>,
    /// Ground-truth translation (world to viewer).
    pub translation: Vector3<f64>,
}

/// Which frame the sampler's point box `[-1, 1]² x [4, 8]` is in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum PointBox {
    /// The viewer frame: every point is in front of the rig (simhc's training distribution).
    #[default]
    Viewer,
    /// The world frame: the paper's text read literally, the data of the peers' generators
    /// (points anywhere around the rig once the pose is applied).
    World,
}

impl UpnpScene {
    /// The same scene seen in other frames: world points `p' = W p + t_w`, viewer data
    /// `f' = V f`, `v' = V v + t_v`, and the ground truth changed to match,
    /// `R' = V R W^T`, `t' = V (t - R W^T t_w) + t_v`.
    pub fn transformed(&self, world: (&Matrix3<f64>, &Vector3<f64>), viewer: (&Matrix3<f64>, &Vector3<f64>)) -> UpnpScene {
        let ((w, tw), (v, tv)) = (world, viewer);
        let rw = self.rotation * w.transpose();
        UpnpScene {
            correspondences: self
                .correspondences
                .iter()
                .map(|c| UpnpCorrespondence { p: w * c.p + tw, f: v * c.f, v: v * c.v + tv })
                .collect(),
            rotation: v * rw,
            translation: v * (self.translation - rw * tw) + tv,
        }
    }

    /// [`UpnpScene::transformed`] with uniformly random rotations `W`, `V` and translations
    /// `t_w`, `t_v` in `[-10, 10]³`, drawn in that order.
    pub fn random_frames<R: Rng + ?Sized>(&self, rng: &mut R) -> UpnpScene {
        let w = random_rotation(rng);
        let tw = sample_in_box(rng, [-10.0; 3], [10.0; 3]);
        let v = random_rotation(rng);
        let tv = sample_in_box(rng, [-10.0; 3], [10.0; 3]);
        self.transformed((&w, &tw), (&v, &tv))
    }
}

/// A uniformly distributed rotation (a normalized Gaussian quaternion; four normal draws by
/// Box-Muller, eight uniform draws).
pub fn random_rotation<R: Rng + ?Sized>(rng: &mut R) -> Matrix3<f64> {
    let mut gauss = || {
        let u1: f64 = rng.random::<f64>().max(f64::MIN_POSITIVE);
        let u2: f64 = rng.random();
        (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
    };
    let q = nalgebra::Quaternion::new(gauss(), gauss(), gauss(), gauss());
    nalgebra::UnitQuaternion::from_quaternion(q).to_rotation_matrix().into_inner()
}

/// Settings of the UPnP scene sampler; the default is the paper's experiment.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct UpnpSceneConfig {
    /// Number of cameras (ray origins) of the generalized camera; paper: 4.
    pub cameras: usize,
    /// Number of correspondences; paper: 16.
    pub points: usize,
    /// Bearing noise level in pixels (see the module docs); paper: 2.
    pub noise_px: f64,
    /// Virtual focal length in pixels for the noise model; paper: 800.
    pub focal_px: f64,
}

impl Default for UpnpSceneConfig {
    fn default() -> Self {
        Self { cameras: 4, points: 16, noise_px: 2.0, focal_px: 800.0 }
    }
}

/// Invalid scene sampler settings (shared by the UPnP and GRPS samplers).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Error)]
pub enum SceneConfigError {
    /// At least one camera is needed.
    #[error("scene needs at least one camera")]
    NoCameras,
    /// At least one point is needed.
    #[error("scene needs at least one point")]
    NoPoints,
    /// `noise_px` must be finite and non-negative, `focal_px` finite and positive.
    #[error("noise level must be finite and >= 0 and focal length finite and > 0")]
    InvalidNoise,
}

/// Checks the noise settings shared by both samplers.
pub(crate) fn check_noise(noise_px: f64, focal_px: f64) -> Result<(), SceneConfigError> {
    if noise_px.is_finite() && noise_px >= 0.0 && focal_px.is_finite() && focal_px > 0.0 {
        Ok(())
    } else {
        Err(SceneConfigError::InvalidNoise)
    }
}

impl UpnpSceneConfig {
    /// Checks the settings.
    pub fn validate(&self) -> Result<(), SceneConfigError> {
        if self.cameras == 0 {
            return Err(SceneConfigError::NoCameras);
        }
        if self.points == 0 {
            return Err(SceneConfigError::NoPoints);
        }
        check_noise(self.noise_px, self.focal_px)
    }

    /// Samples a scene with the paper's generative model (module docs) from `rng`.
    pub fn sample<R: Rng + ?Sized>(&self, rng: &mut R) -> Result<UpnpScene, SceneConfigError> {
        self.sample_with(PointBox::Viewer, false, rng)
    }

    /// Samples a scene with the points drawn in the box of `layout`; with `random_frames`, the
    /// world and viewer frames are then changed by random rigid motions
    /// ([`UpnpScene::random_frames`], drawn last: the scene of a seed is otherwise the same).
    pub fn sample_with<R: Rng + ?Sized>(&self, layout: PointBox, random_frames: bool, rng: &mut R) -> Result<UpnpScene, SceneConfigError> {
        self.validate()?;
        let half_pi = std::f64::consts::FRAC_PI_2;
        let rotation = sample_euler_rotation(rng, half_pi);
        let translation = sample_in_box(rng, [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]);
        let centres: Vec<Vector3<f64>> = (0..self.cameras).map(|_| sample_in_box(rng, [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0])).collect();
        let mut correspondences: Vec<UpnpCorrespondence> = (0..self.points)
            .map(|i| {
                let drawn = sample_in_box(rng, [-1.0, -1.0, 4.0], [1.0, 1.0, 8.0]);
                let (p, x) = match layout {
                    // |x - v| >= 3 since x.z >= 4 and v.z <= 1.
                    PointBox::Viewer => (rotation.transpose() * (drawn - translation), drawn),
                    // |x - v| > 0 almost surely; the depth along f = (x - v)/|x - v| is positive.
                    PointBox::World => (drawn, rotation * drawn + translation),
                };
                let v = centres[i % self.cameras];
                UpnpCorrespondence { p, f: (x - v).normalize(), v }
            })
            .collect();
        for c in &mut correspondences {
            c.f = add_bearing_noise(&c.f, self.noise_px, self.focal_px, rng);
        }
        let scene = UpnpScene { correspondences, rotation, translation };
        Ok(if random_frames { scene.random_frames(rng) } else { scene })
    }

    /// [`Self::sample`] with `ChaCha8Rng::seed_from_u64(seed)`.
    pub fn sample_seeded(&self, seed: u64) -> Result<UpnpScene, SceneConfigError> {
        self.sample(&mut ChaCha8Rng::seed_from_u64(seed))
    }
}

/// `Rz(yaw) Ry(pitch) Rx(roll)` with `roll`, `pitch`, `yaw` drawn (in that order) uniformly in
/// `[-max_angle, max_angle]` (radians). The paper uses `max_angle = pi/2`.
pub fn sample_euler_rotation<R: Rng + ?Sized>(rng: &mut R, max_angle: f64) -> Matrix3<f64> {
    let roll = rng.random_range(-max_angle..=max_angle);
    let pitch = rng.random_range(-max_angle..=max_angle);
    let yaw = rng.random_range(-max_angle..=max_angle);
    // nalgebra applies roll, then pitch, then yaw: Rz(yaw) * Ry(pitch) * Rx(roll).
    Rotation3::from_euler_angles(roll, pitch, yaw).into_inner()
}

/// A point uniform in the axis-aligned box `[lo, hi]` (draws x, y, z in order).
pub fn sample_in_box<R: Rng + ?Sized>(rng: &mut R, lo: [f64; 3], hi: [f64; 3]) -> Vector3<f64> {
    Vector3::from_fn(|k, _| lo[k] + (hi[k] - lo[k]) * rng.random::<f64>())
}

/// OpenGV's bearing noise (module docs): `normalize(focal_px f + e1 n1 + e2 n2)` with
/// `e1, e2 ~ U[-noise_px/sqrt 2, noise_px/sqrt 2]`, `(n1, n2)` an orthonormal tangent basis at
/// `f`. `f` is normalized first. Always consumes two `f64` draws. A zero or non-finite `f` is
/// returned unchanged (after the draws).
pub fn add_bearing_noise<R: Rng + ?Sized>(f: &Vector3<f64>, noise_px: f64, focal_px: f64, rng: &mut R) -> Vector3<f64> {
    let u1: f64 = rng.random();
    let u2: f64 = rng.random();
    let n = f.norm();
    if n == 0.0 || !n.is_finite() {
        return *f;
    }
    let f = f / n;
    let (n1, n2) = tangent_basis(&f);
    let amp = noise_px / std::f64::consts::SQRT_2;
    let e1 = amp * (2.0 * u1 - 1.0);
    let e2 = amp * (2.0 * u2 - 1.0);
    (f * focal_px + n1 * e1 + n2 * e2).normalize()
}

/// OpenGV's orthonormal tangent basis at the unit vector `f`: `n1` sets the coordinate after the
/// largest-magnitude one to 1, `n2 = f x n1`. Ties go to the earlier coordinate (OpenGV divides
/// by zero for e.g. `f = (a, a, 0)`; otherwise identical).
fn tangent_basis(f: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let (x, y, z) = (f.x, f.y, f.z);
    let n1 = if x.abs() >= y.abs() && x.abs() >= z.abs() {
        Vector3::new(-y / x, 1.0, 0.0)
    } else if y.abs() >= z.abs() {
        Vector3::new(0.0, -z / y, 1.0)
    } else {
        Vector3::new(1.0, 0.0, -x / z)
    }
    .normalize();
    (n1, f.cross(&n1))
}

/// Plain serde form of a vector.
pub(crate) fn arr3(v: &Vector3<f64>) -> [f64; 3] {
    [v.x, v.y, v.z]
}

/// Row-major plain serde form of a matrix.
pub(crate) fn rows3(m: &Matrix3<f64>) -> [[f64; 3]; 3] {
    std::array::from_fn(|i| std::array::from_fn(|j| m[(i, j)]))
}

/// Matrix from row-major rows.
pub(crate) fn from_rows3(r: &[[f64; 3]; 3]) -> Matrix3<f64> {
    Matrix3::from_fn(|i, j| r[i][j])
}

impl crate::input::VectorFields for UpnpCorrespondence {
    const FIELDS: &'static [&'static str] = &["p", "f", "v"];
    fn from_fields(fields: &[[f64; 3]]) -> Self {
        Self { p: fields[0].into(), f: fields[1].into(), v: fields[2].into() }
    }
}

impl crate::input::TrialFields for UpnpScene {
    type Correspondence = UpnpCorrespondence;
    const HAS_SCALE: bool = false;
    fn from_parts(correspondences: Vec<UpnpCorrespondence>, rotation: [[f64; 3]; 3], translation: [f64; 3], _scale: f64) -> Self {
        Self { correspondences, rotation: from_rows3(&rotation), translation: translation.into() }
    }
}

#[derive(Serialize, Deserialize)]
struct CorrespondenceRecord {
    p: [f64; 3],
    f: [f64; 3],
    v: [f64; 3],
}

impl From<CorrespondenceRecord> for UpnpCorrespondence {
    fn from(r: CorrespondenceRecord) -> Self {
        Self { p: r.p.into(), f: r.f.into(), v: r.v.into() }
    }
}

impl From<UpnpCorrespondence> for CorrespondenceRecord {
    fn from(c: UpnpCorrespondence) -> Self {
        Self { p: arr3(&c.p), f: arr3(&c.f), v: arr3(&c.v) }
    }
}

#[derive(Serialize, Deserialize)]
struct SceneRecord {
    correspondences: Vec<UpnpCorrespondence>,
    rotation: [[f64; 3]; 3],
    translation: [f64; 3],
}

impl From<SceneRecord> for UpnpScene {
    fn from(r: SceneRecord) -> Self {
        Self { correspondences: r.correspondences, rotation: from_rows3(&r.rotation), translation: r.translation.into() }
    }
}

impl From<UpnpScene> for SceneRecord {
    fn from(s: UpnpScene) -> Self {
        Self { correspondences: s.correspondences, rotation: rows3(&s.rotation), translation: arr3(&s.translation) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serde_records_round_trip() {
        let scene = UpnpSceneConfig::default().sample_seeded(5).unwrap();
        let back = UpnpScene::from(SceneRecord::from(scene.clone()));
        assert_eq!(back, scene);
        let rec = SceneRecord::from(scene.clone());
        assert_eq!(rec.rotation[0][1], scene.rotation[(0, 1)]);
        assert_eq!(rec.rotation[1][0], scene.rotation[(1, 0)]);
    }

    #[test]
    fn every_variant_satisfies_its_ground_truth() {
        let config = UpnpSceneConfig { noise_px: 0.0, ..UpnpSceneConfig::default() };
        for layout in [PointBox::Viewer, PointBox::World] {
            for frames in [false, true] {
                let mut rng = ChaCha8Rng::seed_from_u64(9);
                for _ in 0..20 {
                    let s = config.sample_with(layout, frames, &mut rng).unwrap();
                    assert!((s.rotation.transpose() * s.rotation - Matrix3::identity()).amax() < 1e-12);
                    assert!((s.rotation.determinant() - 1.0).abs() < 1e-12);
                    for c in &s.correspondences {
                        let d = s.rotation * c.p + s.translation - c.v;
                        assert!(c.f.cross(&d).norm() < 1e-9 * d.norm(), "{layout:?} {frames}");
                        assert!(c.f.dot(&d) > 0.0);
                    }
                }
            }
        }
        // The frames are drawn last: the scene itself is the same.
        let a = config.sample_with(PointBox::World, false, &mut ChaCha8Rng::seed_from_u64(4)).unwrap();
        let b = config.sample_with(PointBox::World, true, &mut ChaCha8Rng::seed_from_u64(4)).unwrap();
        let ratio = |s: &UpnpScene| (s.correspondences[0].p - s.correspondences[1].p).norm();
        assert!((ratio(&a) - ratio(&b)).abs() < 1e-12);
        assert_ne!(a.correspondences[0].p, b.correspondences[0].p);
    }

    #[test]
    fn tangent_basis_is_orthonormal() {
        for f in [
            Vector3::x(),
            Vector3::y(),
            Vector3::z(),
            Vector3::new(1.0, 1.0, 1.0),
            Vector3::new(1.0, 1.0, 0.0),
            Vector3::new(0.0, -1.0, 1.0),
            Vector3::new(-0.2, 0.9, -0.9),
        ] {
            let f = f.normalize();
            let (a, b) = tangent_basis(&f);
            assert!(a.dot(&f).abs() < 1e-15 && b.dot(&f).abs() < 1e-15 && a.dot(&b).abs() < 1e-15);
            assert!((a.norm() - 1.0).abs() < 1e-15 && (b.norm() - 1.0).abs() < 1e-15);
        }
    }
}
