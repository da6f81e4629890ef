//! UPnP's correspondences for the one robust estimator: [`Correspondences`] for
//! [`UpnpProblem`], so that the library solver's [`simhc::solver::InstanceSolver::estimate`]
//! takes correspondences with outliers and returns `(pose, info)`, the shape of PoseLib's
//! `estimate_generalized_absolute_pose`:
//!
//! ```no_run
//! use simhc::ransac::RansacOptions;
//! use simhc_problems::upnp::instance::{UpnpLibrarySolver, UpnpProblem};
//! # let corrs: Vec<simhc_problems::upnp::scene::UpnpCorrespondence> = Vec::new();
//! let solver = UpnpLibrarySolver::new(UpnpProblem { max_angle: 0.01, ..UpnpProblem::default() })?;
//! let (pose, info) = solver.estimate(&corrs[..], &RansacOptions::poselib(3.0 / 800.0))?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```
//!
//! - **Samples** have [`UPNP_SAMPLE`] correspondences, one more than the minimal 3: three have
//!   up to 8 poses that explain them exactly, and a start near one of them reaches it, not
//!   necessarily the true one; a fourth leaves one, so every sample that is all inliers and
//!   near the truth gives it. A sample gets Gauss-Newton from the learned start (the
//!   estimator's default), validated on the sample by the solver's validator
//!   ([`UpnpProblem::max_angle`]: how far a sample's pose may miss its own correspondences).
//! - **Error**: the angle between a bearing and the direction from its ray origin to its point
//!   ([`angular_error`]), so the threshold is an angle in radians.
//! - **Local optimization**: Levenberg-Marquardt on the inliers' poses
//!   ([`super::refine::levenberg_marquardt`], 20 iterations).

use super::instance::{checked_pose, UpnpProblem};
use super::pose::UpnpPose;
use super::refine::{levenberg_marquardt, LmOptions};
use super::scene::UpnpCorrespondence;
use crate::metrics::quat_from_rotation;
use nalgebra::SVector;
use simhc::solver::{Correspondences, EstimateError, InstanceProblem};

/// The angle (radians) between the bearing of `c` and the direction from its ray origin to its
/// point under `pose`; `f64::INFINITY` for a point behind its ray origin or a NaN.
pub fn angular_error(pose: &UpnpPose, c: &UpnpCorrespondence) -> f64 {
    let d = pose.rotation * c.p + pose.translation - c.v;
    let cos = c.f.dot(&d);
    // Behind the ray origin, or a NaN.
    if cos.is_nan() || cos <= 0.0 {
        return f64::INFINITY;
    }
    let angle = c.f.cross(&d).norm().atan2(cos);
    if angle.is_nan() {
        f64::INFINITY
    } else {
        angle
    }
}

/// Correspondences in a UPnP RANSAC sample (module docs: one more than the minimal 3).
pub const UPNP_SAMPLE: usize = 4;

/// Iterations of the local optimization on the inliers.
const LO_ITERATIONS: usize = 20;

/// A sample held on the stack up to this size: a sample's solve allocates nothing.
const STACK: usize = 16;

impl Correspondences<4, 5, 66, 35, [UpnpCorrespondence]> for UpnpProblem {
    type Input<'a> = &'a [UpnpCorrespondence];
    type Model = UpnpPose;

    fn checked_count(&self, corrs: &[UpnpCorrespondence]) -> Result<usize, EstimateError> {
        self.check_data(corrs)?;
        Ok(corrs.len())
    }
    fn sample_size(&self) -> usize {
        UPNP_SAMPLE
    }
    fn with_instance<R>(&self, corrs: &[UpnpCorrespondence], indices: &[usize], run: impl FnOnce(&[UpnpCorrespondence]) -> R) -> R {
        match indices.first() {
            Some(&i0) if indices.len() <= STACK => {
                let mut held = [corrs[i0]; STACK];
                for (slot, &i) in held.iter_mut().zip(indices) {
                    *slot = corrs[i];
                }
                run(&held[..indices.len()])
            }
            _ => run(&indices.iter().map(|&i| corrs[i]).collect::<Vec<_>>()),
        }
    }
    fn model(&self, x: &SVector<f64, 4>, instance: &[UpnpCorrespondence]) -> Option<UpnpPose> {
        checked_pose(x, instance)
    }
    fn model_unknowns(&self, pose: &UpnpPose) -> SVector<f64, 4> {
        SVector::from(pose.quaternion)
    }
    fn model_error(&self, corrs: &[UpnpCorrespondence], pose: &UpnpPose, i: usize) -> f64 {
        angular_error(pose, &corrs[i])
    }
    fn refine_model(&self, corrs: &[UpnpCorrespondence], pose: &UpnpPose, inliers: &[usize], _threshold: f64) -> Option<UpnpPose> {
        let subset: Vec<UpnpCorrespondence> = inliers.iter().map(|&i| corrs[i]).collect();
        let options = LmOptions { max_iterations: LO_ITERATIONS, ..LmOptions::default() };
        let r = levenberg_marquardt(&pose.rotation, &pose.translation, &subset, &options);
        let finite = r.cost.is_finite() && r.rotation.iter().chain(r.translation.iter()).all(|v| v.is_finite());
        finite.then(|| UpnpPose { rotation: r.rotation, translation: r.translation, quaternion: quat_from_rotation(&r.rotation) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::rotation_error_deg;
    use crate::upnp::instance::UpnpLibrarySolver;
    use crate::upnp::scene::{UpnpScene, UpnpSceneConfig};
    use nalgebra::Vector3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;
    use simhc::ransac::RansacOptions;

    /// A sampled scene of `n` correspondences, a fraction `wrong` of them given a random world
    /// point (wrong matches), with their true-inlier flags.
    fn scene_with_outliers(seed: u64, n: usize, wrong: f64) -> (UpnpScene, Vec<bool>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let config = UpnpSceneConfig { points: n, noise_px: 0.0, ..UpnpSceneConfig::default() };
        let mut scene = config.sample(&mut rng).unwrap();
        let mut inlier = vec![true; n];
        for (c, keep) in scene.correspondences.iter_mut().zip(inlier.iter_mut()) {
            if rng.random::<f64>() < wrong {
                let shift = Vector3::new(rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0));
                c.p += shift;
                *keep = false;
            }
        }
        (scene, inlier)
    }

    /// The library solver whose samples validate within `max_angle` (radians).
    fn solver(max_angle: f64) -> UpnpLibrarySolver {
        UpnpLibrarySolver::new(UpnpProblem { max_angle, ..UpnpProblem::default() }).unwrap()
    }

    #[test]
    fn the_estimate_keeps_the_inliers_at_40_percent_outliers() {
        let (scene, inlier) = scene_with_outliers(7, 100, 0.4);
        let options = RansacOptions { max_iterations: 300, ..RansacOptions::poselib(1e-4) };
        let (pose, info) = solver(1e-6).estimate(&scene.correspondences, &options).unwrap();
        let er = rotation_error_deg(&pose.rotation, &scene.rotation);
        assert!(er < 1e-4, "rotation error {er} deg");
        let kept = info.inlier_mask.iter().zip(&inlier).filter(|(m, t)| **m && **t).count();
        let wrong = info.inlier_mask.iter().zip(&inlier).filter(|(m, t)| **m && !**t).count();
        let truth = inlier.iter().filter(|t| **t).count();
        assert_eq!(kept, truth, "true matches kept");
        assert_eq!(wrong, 0, "wrong matches taken");
        assert_eq!(info.inliers.len(), truth);
        // Certified on the UPnP system of its inliers (noise-free: an exact root).
        let bound = info.certified.expect("certified").expect("a certificate");
        assert!(bound < 1e-6, "certified within {bound}");
    }

    #[test]
    fn a_solver_sharing_the_library_network_estimates_the_same() {
        let (scene, _) = scene_with_outliers(9, 60, 0.3);
        let library = UpnpLibrarySolver::new(UpnpProblem::default()).unwrap();
        let problem = std::sync::Arc::new(UpnpProblem { max_angle: 1e-6, ..UpnpProblem::default() });
        let shared = UpnpLibrarySolver::with_learned(problem, library.learned_start().clone(), 0.0).unwrap();
        assert!(std::ptr::eq(shared.learned_start().network(), library.learned_start().network()), "one copy of the weights");
        let options = RansacOptions { max_iterations: 300, ..RansacOptions::poselib(1e-4) };
        let (a, info_a) = shared.estimate(&scene.correspondences, &options).unwrap();
        let (b, info_b) = solver(1e-6).estimate(&scene.correspondences, &options).unwrap();
        assert_eq!(a.rotation, b.rotation, "the same weights, samples and steps");
        assert_eq!(info_a.inlier_mask, info_b.inlier_mask);
        assert!(rotation_error_deg(&a.rotation, &scene.rotation) < 1e-4);
    }

    #[test]
    fn bad_input_names_the_correspondence_and_field() {
        let (mut scene, _) = scene_with_outliers(8, 20, 0.0);
        let solver = solver(1e-6);
        let options = RansacOptions::poselib(1e-4);
        scene.correspondences[13].f.y = f64::NAN;
        match solver.estimate(&scene.correspondences, &options).unwrap_err() {
            EstimateError::NonFinite(at) => assert_eq!((at.row, at.field), (Some(13), "f")),
            e => panic!("{e}"),
        }
        scene.correspondences[13].f.y = 0.1;
        let err = solver.estimate(&scene.correspondences[..3], &options).unwrap_err();
        assert_eq!(err, EstimateError::TooFew { rows: 3, needed: 4 });
        let mut one_origin = scene.correspondences.clone();
        one_origin.iter_mut().for_each(|c| c.f = nalgebra::Vector3::z());
        assert!(matches!(solver.estimate(&one_origin, &options).unwrap_err(), EstimateError::Degenerate(_)));
    }

    #[test]
    fn one_sample_of_correspondences_is_solved_once() {
        let (scene, _) = scene_with_outliers(10, UPNP_SAMPLE, 0.0);
        let (pose, info) = solver(1e-6).estimate(&scene.correspondences, &RansacOptions::poselib(1e-4)).unwrap();
        assert_eq!(info.iterations, 1);
        assert_eq!(info.inliers, (0..UPNP_SAMPLE).collect::<Vec<_>>());
        assert!(rotation_error_deg(&pose.rotation, &scene.rotation) < 1e-4);
    }
}
