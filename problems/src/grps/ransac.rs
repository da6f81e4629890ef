//! GRPS inside RANSAC: the Simulator HC solver as the minimal solver of
//! [`simhc::ransac::ransac`], the normalized reprojection error as the residual, and
//! Levenberg-Marquardt on the inliers ([`super::refine::refine_pose`]) as the non-minimal
//! refinement.
//!
//! # Residual ([`reprojection_error`])
//!
//! The point is triangulated as the midpoint of the closest points of the two rays
//! (least-squares depths, [`super::geometry::triangulate_depths`]) and reprojected into both
//! views; the residual is the larger of the two reprojection errors in normalized image units,
//! measured as the sine of the angle between the observed bearing and the direction from the
//! ray origin to the point (the tangent-plane distance at unit focal length, to first order).
//! A point behind either camera, or rays that are parallel, gives `f64::INFINITY`. The paper's
//! inlier threshold is `0.01` (8 px at `f = 800`).

use super::geometry::{triangulate_depths, validate, GrpsError};
use super::refine::{refine_pose, LmOptions};
use super::scene::GrpsCorrespondence;
use super::solver::{GrpsPose, GrpsSolveError, GrpsSolver};
use crate::robust::{self, RobustError};
use simhc::ransac::{Estimator, RansacOptions};
use simhc::solver::EstimateInfo;

/// Why there is no robust GRPS estimate.
pub type GrpsEstimateError = RobustError<GrpsError>;

/// The normalized reprojection error of one correspondence under `pose` (module docs).
pub fn reprojection_error(pose: &GrpsPose, c: &GrpsCorrespondence) -> f64 {
    let (r, t, s) = (&pose.rotation, &pose.translation, pose.scale);
    let Some((a1, a2)) = triangulate_depths(r, t, s, c) else { return f64::INFINITY };
    if !(a1 > 0.0 && a2 > 0.0) {
        return f64::INFINITY;
    }
    let f = c.f.normalize();
    let g = (r * c.fp).normalize();
    let o2 = r * c.vp * s + t;
    // `triangulate_depths` solves with the raw bearings; rescale to unit ones.
    let x1 = c.v + c.f * a1;
    let x2 = o2 + r * c.fp * a2;
    let m = (x1 + x2) * 0.5;
    let sin_angle = |dir: &nalgebra::Vector3<f64>, d: nalgebra::Vector3<f64>| {
        let n = d.norm();
        if n > 0.0 {
            dir.cross(&d).norm() / n
        } else {
            f64::INFINITY
        }
    };
    let e1 = sin_angle(&f, m - c.v);
    let e2 = sin_angle(&g, m - o2);
    let e = e1.max(e2);
    if e.is_nan() {
        f64::INFINITY
    } else {
        e
    }
}

/// The GRPS solver as a RANSAC estimator over correspondences.
#[derive(Debug, Clone)]
pub struct GrpsEstimator {
    /// The minimal solver (its options decide the retries per sample).
    pub solver: GrpsSolver,
    /// Correspondences per sample: 7 (minimal, square system) or 8 (overdetermined).
    pub sample_size: usize,
    /// Settings of the non-minimal refinement.
    pub refine: LmOptions,
    /// Hypotheses per sample: `1` returns the solver's answer; more returns up to that many
    /// distinct plausible end points ([`GrpsSolver::candidates`]), each scored by consensus.
    pub hypotheses: usize,
}

impl GrpsEstimator {
    /// An estimator with samples of `sample_size` (7 or 8) correspondences and up to 4
    /// hypotheses per sample. Measured (`simhc bench grps --experiment ransac`, 300 runs, 40 %
    /// outliers, 7-point samples, local optimization): 99.7 % with 4 hypotheses and 8 attempts
    /// per sample, 97 % with the solver's single answer.
    pub fn new(solver: GrpsSolver, sample_size: usize) -> Self {
        Self {
            solver,
            sample_size: sample_size.clamp(7, 8),
            refine: LmOptions { max_iterations: 20, ..LmOptions::default() },
            hypotheses: 4,
        }
    }

    /// A robust estimate from `corrs` (any number, at least a sample; checked as the solver
    /// checks its input): LO-RANSAC with `options` ([`RansacOptions::poselib`] for PoseLib's
    /// defaults), `options.threshold` in the units of [`reprojection_error`].
    pub fn estimate(&self, corrs: &[GrpsCorrespondence], options: &RansacOptions) -> Result<(GrpsPose, EstimateInfo), GrpsEstimateError> {
        robust::estimate(self, corrs, options, validate, |got, need| GrpsError::TooFewCorrespondences { got, need })
    }
}

impl Estimator for GrpsEstimator {
    type Datum = GrpsCorrespondence;
    type Model = GrpsPose;

    fn sample_size(&self) -> usize {
        self.sample_size
    }

    fn solve(&self, data: &[GrpsCorrespondence], indices: &[usize], out: &mut Vec<GrpsPose>) {
        let sample: Vec<GrpsCorrespondence> = indices.iter().map(|&i| data[i]).collect();
        if self.hypotheses > 1 {
            if let Ok(c) = self.solver.candidates(&sample, self.hypotheses) {
                out.extend(c);
            }
            return;
        }
        match self.solver.solve_report(&sample) {
            Ok(r) => out.push(r.pose),
            // An end point that missed validation is still a hypothesis: consensus decides.
            Err(GrpsSolveError::NotValidated(b)) if b.validation.positive_scale => out.push(b.pose),
            Err(_) => {}
        }
    }

    fn residual(&self, model: &GrpsPose, datum: &GrpsCorrespondence) -> f64 {
        reprojection_error(model, datum)
    }

    fn refine(&self, model: &GrpsPose, data: &[GrpsCorrespondence], inliers: &[usize]) -> Option<GrpsPose> {
        let subset: Vec<GrpsCorrespondence> = inliers.iter().map(|&i| data[i]).collect();
        let r = refine_pose(&model.rotation, &model.translation, model.scale, &subset, &self.refine);
        (r.cost.is_finite() && r.scale > 0.0).then_some(GrpsPose { rotation: r.rotation, translation: r.translation, scale: r.scale })
    }
}
