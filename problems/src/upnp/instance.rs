//! UPnP through the runtime's problem trait: [`UpnpProblem`] implements
//! [`simhc::solver::InstanceProblem`] for any number of correspondences
//! (`D = [UpnpCorrespondence]`), so the library solver, [`simhc::solver::InstanceSolver`],
//! solves generalized absolute pose with the same assembly as every declared problem
//! (Gauss-Newton from each start, then one path from each, then the all-roots fallback, each
//! end point validated on all correspondences; UPnP puts its linear start before the learned
//! one, [`Plan::other_starts_first`]):
//!
//! ```no_run
//! use simhc_problems::upnp::instance::{UpnpLibrarySolver, UpnpProblem};
//! # let corrs: Vec<simhc_problems::upnp::scene::UpnpCorrespondence> = Vec::new();
//! let solver = UpnpLibrarySolver::new(UpnpProblem::default())?;   // shipped weights
//! match solver.solve(&corrs[..]) {
//!     Ok(s) => println!("rotation quaternion {}", s.x),          // validated on all rows
//!     Err(e) => eprintln!("{e}"),                                // typed, flagged
//! }
//! # Ok::<(), simhc::solver::SolverError>(())
//! ```
//!
//! Why UPnP implements the general trait and not [`simhc::solver::DeclaredProblem`]: its
//! data is a list of any length, and its tracked parameters are the 66 entries of the cost
//! matrix `M` *derived* from all correspondences, not the first rows of the data.
//!
//! The translation of a solution is the least-squares one of its rotation
//! ([`upnp_pose`]); the unknowns are the quaternion `[w, x, y, z]`.

use super::geometry::{check_rays, check_spread, checked_translation, upnp_system, validate, UpnpError, UPNP_MIN_CORRESPONDENCES};
use super::learned::{UpnpLearned, UPNP_WEIGHTS};
use super::linear::linear_rotation;
use super::pose::{global_minimum, UpnpPose, UpnpValidation};
use super::scene::UpnpCorrespondence;
use super::simulator::reprojected_cost;
use super::{params_of, Upnp};
use crate::metrics::{quat_from_rotation, rotation_from_quat};
use nalgebra::SVector;
use simhc::pipeline::learned::NonFiniteParameter;
use simhc::pipeline::{PipelineOptions, StartError, StartProvider, Validator, Verdict};
use simhc::regressor::{FoldedNetwork, RegressorError};
use simhc::solver::{DegenerateInput, FirstRowsError, InstanceProblem, InstanceSolver, Plan, Refinement};
use simhc::tracker::TrackerOptions;
use simhc::SimulatorError;
use std::sync::Arc;

/// The library solver of UPnP.
pub type UpnpLibrarySolver = InstanceSolver<UpnpProblem, 4, 5, 66, 35, [UpnpCorrespondence]>;

/// Generalized absolute pose (UPnP) as an instance problem.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpnpProblem {
    /// Largest angle (radians) between a bearing and its point under an accepted pose, for
    /// noise-free data; with noise `sigma` (radians) the validator accepts up to
    /// `max(max_angle, 8 sigma)`. Default `0.02` (16 px at 800 px focal length): eight times the largest residual at the
    /// ground truth at the paper's 2 px (at most 0.0025 rad over 1000 trials of the peers harness).
    pub max_angle: f64,
    /// Points allowed behind their rays in an accepted pose. Default `0`.
    pub max_behind: usize,
    /// Whether to try the linear relaxation ([`super::linear`]) as a start beside the learned
    /// one. Default `true`.
    pub linear_start: bool,
    /// Whether the all-roots fallback (the global minimum of the cost) may run. Default `true`.
    pub fallback: bool,
}

impl Default for UpnpProblem {
    fn default() -> Self {
        Self { max_angle: 0.02, max_behind: 0, linear_start: true, fallback: true }
    }
}

/// The pose of a quaternion with the least-squares translation of its rotation (`None` for
/// a zero or non-finite quaternion, or correspondences that are not valid input).
pub fn upnp_pose(x: &SVector<f64, 4>, corrs: &[UpnpCorrespondence]) -> Option<UpnpPose> {
    validate(corrs).ok()?;
    checked_pose(x, corrs)
}

/// [`upnp_pose`] of correspondences already checked (inside a solve, after
/// [`InstanceProblem::check_data`]): the validator's and the simulator's, on every attempt.
pub(super) fn checked_pose(x: &SVector<f64, 4>, corrs: &[UpnpCorrespondence]) -> Option<UpnpPose> {
    let n = x.norm();
    if !(n > 0.0 && n.is_finite()) {
        return None;
    }
    let q = [x[0] / n, x[1] / n, x[2] / n, x[3] / n];
    let rotation = rotation_from_quat(q);
    let translation = checked_translation(&rotation, corrs).ok()?;
    Some(UpnpPose { rotation, translation, quaternion: q })
}

/// Accepts a quaternion whose pose puts every point within `max_angle` of its bearing, at most
/// `max_behind` behind.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct UpnpPoseValidator {
    /// Largest accepted angle (radians).
    pub max_angle: f64,
    /// Points allowed behind their rays.
    pub max_behind: usize,
}

impl Validator<[UpnpCorrespondence], 4> for UpnpPoseValidator {
    type Check = UpnpValidation;
    fn check(&self, corrs: &[UpnpCorrespondence], x: &SVector<f64, 4>) -> UpnpValidation {
        match checked_pose(x, corrs) {
            Some(pose) => UpnpValidation::of(&pose, corrs),
            None => UpnpValidation { max_angle: f64::INFINITY, behind: corrs.len() },
        }
    }
    fn verdict(&self, check: &UpnpValidation) -> Verdict {
        check.verdict(self.max_angle, self.max_behind)
    }
    fn better(&self, a: &UpnpValidation, b: &UpnpValidation) -> bool {
        a.better(b)
    }
}

/// The closed-form linear relaxation as a start ([`super::linear::linear_rotation`]): exactly
/// equivariant under rigid changes of the world and viewer frames, so it does not depend on the
/// distribution the regressor was trained on.
#[derive(Debug, Clone, Copy, Default)]
pub struct LinearStart;

impl StartProvider<[UpnpCorrespondence], 4> for LinearStart {
    fn name(&self) -> &'static str {
        "linear"
    }
    fn start(&self, corrs: &[UpnpCorrespondence]) -> Result<SVector<f64, 4>, StartError> {
        let r = linear_rotation(corrs).map_err(|e| StartError { provider: "linear", reason: e.to_string().into() })?;
        Ok(SVector::from(quat_from_rotation(&r)))
    }
}

/// A UPnP input error as the solver's: the correspondence (and field) at fault.
fn input_error(e: UpnpError) -> FirstRowsError {
    let degenerate = |row, reason| FirstRowsError::Degenerate(DegenerateInput { row, reason });
    match e {
        UpnpError::TooFewCorrespondences { got, need } => FirstRowsError::TooFew { got, need },
        // Not reached from a solve: `check_data` names the field first.
        UpnpError::NonFinite { index } => {
            FirstRowsError::NonFinite(NonFiniteParameter { row: Some(index), field: "p, f or v", index: 9 * index })
        }
        UpnpError::ZeroBearing { index } => degenerate(Some(index), "zero-length bearing `f`"),
        UpnpError::Degenerate => degenerate(None, "all bearings parallel: the translation is not determined"),
        UpnpError::CollinearPoints => degenerate(None, "all world points on one line: the rotation about it is not determined"),
    }
}

impl InstanceProblem<4, 5, 66, 35, [UpnpCorrespondence]> for UpnpProblem {
    type Tracked = Upnp;
    type Validator = UpnpPoseValidator;
    type Learned = UpnpLearned;
    type Canonical = Vec<UpnpCorrespondence>;

    fn name(&self) -> &'static str {
        "upnp"
    }
    fn weights(&self) -> Option<&'static [u8]> {
        Some(UPNP_WEIGHTS)
    }
    fn learned(_problem: &Arc<Self>, weights: &[u8]) -> Result<UpnpLearned, RegressorError> {
        UpnpLearned::new(FoldedNetwork::from_bytes(weights)?)
    }
    fn validator(&self, noise: f64) -> UpnpPoseValidator {
        UpnpPoseValidator { max_angle: self.max_angle.max(8.0 * noise), max_behind: self.max_behind }
    }
    fn plan(&self) -> Plan<[UpnpCorrespondence], 4, 5, 66> {
        Plan {
            // The paper's single-path tracker, the first validated end point.
            options: PipelineOptions { tracker: TrackerOptions::single_path(), extra_attempts: 0, ..PipelineOptions::default() },
            other_starts: if self.linear_start { vec![Box::new(LinearStart)] } else { Vec::new() },
            // The linear start costs about 3 us against the network's 10 us and is exact
            // without noise.
            other_starts_first: true,
            ..Plan::default()
        }
    }
    fn check_data(&self, corrs: &[UpnpCorrespondence]) -> Result<(), FirstRowsError> {
        if corrs.len() < UPNP_MIN_CORRESPONDENCES {
            return Err(FirstRowsError::TooFew { got: corrs.len(), need: UPNP_MIN_CORRESPONDENCES });
        }
        for (row, c) in corrs.iter().enumerate() {
            for (k, (field, v)) in [("p", &c.p), ("f", &c.f), ("v", &c.v)].into_iter().enumerate() {
                if let Some(j) = v.iter().position(|x| !x.is_finite()) {
                    return Err(FirstRowsError::NonFinite(NonFiniteParameter { row: Some(row), field, index: 9 * row + 3 * k + j }));
                }
            }
        }
        check_rays(corrs).and_then(|()| check_spread(corrs)).map_err(input_error)
    }
    fn tracked_params(&self, corrs: &[UpnpCorrespondence]) -> Result<SVector<f64, 66>, FirstRowsError> {
        Ok(params_of(&upnp_system(corrs).map_err(input_error)?.m))
    }
    fn simulate_start(
        &self,
        corrs: &[UpnpCorrespondence],
        x0: &SVector<f64, 4>,
        _p: &SVector<f64, 66>,
    ) -> Result<SVector<f64, 66>, SimulatorError> {
        // The paper's geometric simulator: the points reprojected under the start's pose.
        let pose = checked_pose(x0, corrs).ok_or(SimulatorError::Singular)?;
        let m = reprojected_cost(&pose.rotation, &pose.translation, corrs).map_err(|_| SimulatorError::Singular)?;
        Ok(params_of(&m))
    }
    fn refine(&self, _corrs: &[UpnpCorrespondence], _x0: &SVector<f64, 4>) -> Refinement<4> {
        Refinement::Unsupported
    }
    fn has_fallback(&self) -> bool {
        self.fallback
    }
    fn fallback_candidates(&self, corrs: &[UpnpCorrespondence], _p: &SVector<f64, 66>) -> Vec<SVector<f64, 4>> {
        upnp_system(corrs).ok().and_then(|s| global_minimum(&s)).map(|pose| SVector::from(pose.quaternion)).into_iter().collect()
    }
}
