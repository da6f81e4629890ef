//! UPnP inside RANSAC: the UPnP library solver ([`super::instance::UpnpLibrarySolver`]) on
//! samples of a few correspondences as the minimal solver of [`simhc::ransac::ransac`], the
//! angle between a bearing and the direction to its point as the per-correspondence error, and
//! Levenberg-Marquardt on the inliers ([`super::refine::levenberg_marquardt`]) as the local
//! optimization. The shape is PoseLib's `estimate_generalized_absolute_pose`: correspondences
//! with outliers in, `(pose, info)` out.
//!
//! # Samples
//!
//! A sample has [`UpnpEstimator::sample_size`] correspondences (default 4, one more than the
//! minimal 3). Three correspondences have up to 8 poses that explain them exactly, and a start
//! near one of them reaches it, not necessarily the true one; a fourth leaves one, so every
//! sample that is all inliers and near the truth gives it. A sample is solved by the attempts
//! of [`SAMPLE_ATTEMPTS`] (Gauss-Newton from the learned start), without the all-roots
//! fallback (about 1 ms, and most samples hold an outlier) and without the linear start (it
//! needs 6 correspondences), validated on the sample.

use super::geometry::{validate, UpnpError};
use super::instance::{upnp_pose, UpnpLibrarySolver, UpnpProblem};
use super::learned::UpnpLearned;
use super::pose::UpnpPose;
use super::refine::{levenberg_marquardt, LmOptions};
use super::scene::UpnpCorrespondence;
use crate::metrics::quat_from_rotation;
use crate::robust::{self, RobustError};
use simhc::pipeline::Method;
use simhc::ransac::{Estimator, RansacOptions};
use simhc::solver::{EstimateInfo, SolverAttempt, SolverError, StartId};
use std::sync::Arc;

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

/// Why there is no robust UPnP estimate.
pub type UpnpEstimateError = RobustError<UpnpError>;

/// The UPnP solver as a RANSAC estimator over correspondences.
#[derive(Clone)]
pub struct UpnpEstimator {
    /// The solver of a sample (module docs: learned start only, no fallback).
    pub solver: Arc<UpnpLibrarySolver>,
    /// The attempts on a sample, each naming its start.
    pub attempts: Vec<SolverAttempt>,
    /// Correspondences per sample (at least 3).
    pub sample_size: usize,
    /// Settings of the local optimization on the inliers.
    pub refine: LmOptions,
}

impl std::fmt::Debug for UpnpEstimator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("UpnpEstimator")
            .field("problem", self.solver.problem())
            .field("attempts", &self.attempts)
            .field("sample_size", &self.sample_size)
            .field("refine", &self.refine)
            .finish()
    }
}

/// The attempts on a sample: Gauss-Newton from the learned start, nothing more. Why no path
/// after it: most samples hold an outlier and no attempt validates them, so a path after a
/// failed Gauss-Newton mostly costs its 20 us for nothing, and among the many samples one that
/// is all inliers and in Gauss-Newton's basin comes soon. Measured with `simhc ransac upnp
/// --threshold 0.00375 --trials 30 --rows 100 --noise 1 --seed 1` (2026-12-04, BENCHMARKS.md):
/// one path per sample 18.8-29.4 ms per call, Gauss-Newton then a path 28.4-33.4 ms,
/// Gauss-Newton alone 7.5-9.5 ms, all at 100 % success and recall.
pub const SAMPLE_ATTEMPTS: [SolverAttempt; 1] = [SolverAttempt::new(StartId::LEARNED, Method::GaussNewton)];

impl UpnpEstimator {
    /// An estimator whose samples are solved from `network` with the attempts of
    /// [`SAMPLE_ATTEMPTS`]; samples of 4 correspondences. `max_angle` is how far a sample's
    /// pose may miss its own correspondences (radians), as [`UpnpProblem::max_angle`]. An
    /// error when the network does not have UPnP's input rows and outputs.
    pub fn new(network: simhc::regressor::FoldedNetwork, max_angle: f64) -> Result<Self, SolverError> {
        Self::from_learned(UpnpLearned::new(network)?, max_angle)
    }

    /// [`UpnpEstimator::new`] around a learned start already built, e.g. a library solver's
    /// ([`UpnpLibrarySolver::learned_start`], cloned: the clone shares the network).
    pub fn from_learned(learned: UpnpLearned, max_angle: f64) -> Result<Self, SolverError> {
        let problem = Arc::new(UpnpProblem { max_angle, max_behind: 0, linear_start: false, fallback: false });
        let solver = UpnpLibrarySolver::with_learned(problem, learned, 0.0)?;
        Ok(Self {
            solver: Arc::new(solver),
            attempts: SAMPLE_ATTEMPTS.to_vec(),
            sample_size: 4,
            refine: LmOptions { max_iterations: 20, ..LmOptions::default() },
        })
    }

    /// A robust estimate from `corrs` (any number, at least a sample): LO-RANSAC with
    /// `options` ([`RansacOptions::poselib`] for PoseLib's defaults), `options.threshold` an
    /// angle in radians ([`angular_error`]).
    pub fn estimate(&self, corrs: &[UpnpCorrespondence], options: &RansacOptions) -> Result<(UpnpPose, EstimateInfo), UpnpEstimateError> {
        let (pose, mut info) =
            robust::estimate(self, corrs, options, validate, |got, need| UpnpError::TooFewCorrespondences { got, need })?;
        // The certificate of the final pose on the UPnP system of its inliers (the cost it
        // was refined on): a stationary point of that cost, so a root of the tracked system.
        let inliers: Vec<UpnpCorrespondence> = info.inliers.iter().map(|&i| corrs[i]).collect();
        info.certified = Some(self.solver.certify(&inliers[..], &nalgebra::SVector::from(pose.quaternion)).map(|c| c.error_bound()));
        Ok((pose, info))
    }
}

impl UpnpEstimator {
    /// The pose of one sample, if it validates on the sample.
    fn solve_sample(&self, sample: &[UpnpCorrespondence], out: &mut Vec<UpnpPose>) {
        // A sample that does not validate holds an outlier or missed its basin: dropped.
        if let Ok(s) = self.solver.run_pipeline(sample, &self.attempts, false, None) {
            out.extend(upnp_pose(&s.x, sample));
        }
    }
}

impl Estimator for UpnpEstimator {
    type Datum = UpnpCorrespondence;
    type Model = UpnpPose;

    fn sample_size(&self) -> usize {
        self.sample_size
    }

    fn solve(&self, data: &[UpnpCorrespondence], indices: &[usize], out: &mut Vec<UpnpPose>) {
        // Samples of up to 16 on the stack: a sample's solve allocates nothing.
        const STACK: usize = 16;
        match indices.first() {
            Some(&i0) if indices.len() <= STACK => {
                let mut held = [data[i0]; STACK];
                for (slot, &i) in held.iter_mut().zip(indices) {
                    *slot = data[i];
                }
                self.solve_sample(&held[..indices.len()], out);
            }
            _ => {
                let sample: Vec<UpnpCorrespondence> = indices.iter().map(|&i| data[i]).collect();
                self.solve_sample(&sample, out);
            }
        }
    }

    fn residual(&self, model: &UpnpPose, datum: &UpnpCorrespondence) -> f64 {
        angular_error(model, datum)
    }

    fn refine(&self, model: &UpnpPose, data: &[UpnpCorrespondence], inliers: &[usize]) -> Option<UpnpPose> {
        let subset: Vec<UpnpCorrespondence> = inliers.iter().map(|&i| data[i]).collect();
        let r = levenberg_marquardt(&model.rotation, &model.translation, &subset, &self.refine);
        let finite = r.cost.is_finite() && r.rotation.iter().chain(r.translation.iter()).all(|v| v.is_finite());
        finite.then(|| UpnpPose { rotation: r.rotation, translation: r.translation, quaternion: quat_from_rotation(&r.rotation) })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::rotation_error_deg;
    use crate::upnp::scene::{UpnpScene, UpnpSceneConfig};
    use nalgebra::Vector3;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

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

    #[test]
    fn the_estimate_keeps_the_inliers_at_40_percent_outliers() {
        let (scene, inlier) = scene_with_outliers(7, 100, 0.4);
        let estimator = UpnpEstimator::from_learned(UpnpLearned::shipped().unwrap(), 1e-6).unwrap();
        let options = RansacOptions { max_iterations: 300, ..RansacOptions::poselib(1e-4) };
        let (pose, info) = estimator.estimate(&scene.correspondences, &options).unwrap();
        let er = rotation_error_deg(&pose.rotation, &scene.rotation);
        assert!(er < 1e-4, "rotation error {er} deg");
        let kept = info.inlier_mask.iter().zip(&inlier).filter(|(m, t)| **m && **t).count();
        let wrong = info.inlier_mask.iter().zip(&inlier).filter(|(m, t)| **m && !**t).count();
        let truth = inlier.iter().filter(|t| **t).count();
        assert_eq!(kept, truth, "true matches kept");
        assert_eq!(wrong, 0, "wrong matches taken");
        assert_eq!(info.inliers.len(), truth);
    }

    #[test]
    fn an_estimator_from_a_library_solver_shares_its_network_and_estimates_the_same() {
        let (scene, _) = scene_with_outliers(9, 60, 0.3);
        let library = UpnpLibrarySolver::new(UpnpProblem::default()).unwrap();
        let shared = UpnpEstimator::from_learned(library.learned_start().clone(), 1e-6).unwrap();
        assert!(std::ptr::eq(shared.solver.learned_start().network(), library.learned_start().network()), "one copy of the weights");
        let own = UpnpEstimator::from_learned(UpnpLearned::shipped().unwrap(), 1e-6).unwrap();
        let options = RansacOptions { max_iterations: 300, ..RansacOptions::poselib(1e-4) };
        let (a, info_a) = shared.estimate(&scene.correspondences, &options).unwrap();
        let (b, info_b) = own.estimate(&scene.correspondences, &options).unwrap();
        assert_eq!(a.rotation, b.rotation, "the same weights, samples and steps");
        assert_eq!(info_a.inlier_mask, info_b.inlier_mask);
        assert!(rotation_error_deg(&a.rotation, &scene.rotation) < 1e-4);
    }

    #[test]
    fn bad_input_names_the_correspondence() {
        let (mut scene, _) = scene_with_outliers(8, 20, 0.0);
        let estimator = UpnpEstimator::from_learned(UpnpLearned::shipped().unwrap(), 1e-6).unwrap();
        let options = RansacOptions::poselib(1e-4);
        scene.correspondences[13].f.y = f64::NAN;
        assert_eq!(estimator.estimate(&scene.correspondences, &options).unwrap_err(), UpnpError::NonFinite { index: 13 }.into());
        let err = estimator.estimate(&scene.correspondences[..3], &options).unwrap_err();
        assert_eq!(err, UpnpError::TooFewCorrespondences { got: 3, need: 4 }.into());
    }
}
