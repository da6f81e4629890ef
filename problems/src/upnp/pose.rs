//! A generalized camera pose and how well it explains the correspondences: what every UPnP
//! solve returns and validates, whichever start produced it.
//!
//! Pose convention: `alpha_i f_i + v_i = R p_i + t` (world point `p_i`, bearing `f_i` and ray
//! origin `v_i` in the viewer frame).

use super::geometry::UpnpSystem;
use super::params_of;
use super::scene::UpnpCorrespondence;
use crate::metrics::rotation_from_quat;
use crate::start_systems::solve_upnp;
use nalgebra::{Matrix3, Vector3};
use simhc::all_roots::AllRootsOptions;
use simhc::pipeline::Verdict;

/// A generalized camera pose: `alpha f + v = R p + t`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpnpPose {
    /// Rotation world -> viewer.
    pub rotation: Matrix3<f64>,
    /// Translation world -> viewer.
    pub translation: Vector3<f64>,
    /// The unit quaternion `[w, x, y, z]` of `rotation` as tracked.
    pub quaternion: [f64; 4],
}

impl UpnpPose {
    /// The pose of a (not necessarily unit) quaternion with the optimal translation of the
    /// system's cost (`None` for a zero or non-finite quaternion).
    pub fn of_quaternion(target: &UpnpSystem, q: [f64; 4]) -> Option<Self> {
        let n = q.iter().map(|v| v * v).sum::<f64>().sqrt();
        if !(n > 0.0 && n.is_finite()) {
            return None;
        }
        let q = q.map(|v| v / n);
        Some(Self { rotation: rotation_from_quat(q), translation: target.translation(q), quaternion: q })
    }
}

/// How well a pose explains the correspondences.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct UpnpValidation {
    /// Largest angle (radians) between a bearing `f_i` and `R p_i + t - v_i`.
    pub max_angle: f64,
    /// Correspondences whose point lies behind its ray origin (`f_i . (R p_i + t - v_i) <= 0`).
    pub behind: usize,
}

impl UpnpValidation {
    /// Validates `pose` on `corrs` (a NaN residual counts as an infinite angle).
    pub fn of(pose: &UpnpPose, corrs: &[UpnpCorrespondence]) -> Self {
        let mut max_angle = 0.0f64;
        let mut behind = 0;
        for c in corrs {
            let d = pose.rotation * c.p + pose.translation - c.v;
            let cos = c.f.dot(&d);
            let angle = c.f.cross(&d).norm().atan2(cos);
            max_angle = if angle.is_nan() { f64::INFINITY } else { max_angle.max(angle) };
            if cos.is_nan() || cos <= 0.0 {
                behind += 1;
            }
        }
        Self { max_angle, behind }
    }

    /// At most `max_behind` points behind their rays and every angle at most `max_angle`.
    pub fn passes(&self, max_angle: f64, max_behind: usize) -> bool {
        self.behind <= max_behind && self.max_angle <= max_angle
    }

    /// [`UpnpValidation::passes`] as the pipeline's verdict.
    pub fn verdict(&self, max_angle: f64, max_behind: usize) -> Verdict {
        Verdict::accept_if(self.passes(max_angle, max_behind))
    }

    /// Whether `self` explains the data better than `other` (ranks end points that do not
    /// pass): fewer points behind first, then the residual.
    pub fn better(&self, other: &Self) -> bool {
        (self.behind, self.max_angle) < (other.behind, other.max_angle)
    }
}

/// The pose of the smallest cost among all real critical points (`None` when the all-roots
/// solver finds no real one): the all-roots fallback of a UPnP solve.
pub fn global_minimum(target: &UpnpSystem) -> Option<UpnpPose> {
    let result = solve_upnp(&params_of(&target.m), &AllRootsOptions::default());
    result
        .real
        .iter()
        .filter_map(|s| UpnpPose::of_quaternion(target, [s.x[0], s.x[1], s.x[2], s.x[3]]))
        .min_by(|a, b| target.cost(a.quaternion).total_cmp(&target.cost(b.quaternion)))
}
