//! The built-in problems, UPnP and GRPS, registered as problems like any other
//! ([`simhc_pymodule::register`]): each says what its correspondences and its pose are
//! ([`DynSolver`]), and the one class, `simhc_pymodule::ProblemSolver`, does the rest.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};
use simhc::ransac::RansacOptions;
use simhc::solver::{Certification, EstimateInfo};
use simhc_problems::grps::declared::{GrpsSolvers, GrpsSolversError, RANSAC_NOISE_PX};
use simhc_problems::grps::geometry::validate;
use simhc_problems::grps::pose::GrpsPose;
use simhc_problems::grps::{correspondence_of_row, ROW_LEN};
use simhc_problems::upnp::instance::{upnp_pose, UpnpLibrarySolver, UpnpProblem};
use simhc_problems::upnp::learned::UpnpLearned;
use simhc_problems::upnp::scene::UpnpCorrespondence;
use simhc_pymodule::{estimate_failure, solve_failure, DynSolver, Failure, Field, Fields};
use std::sync::{Arc, OnceLock};

/// The focal length (pixels) the built-ins' pixel units refer to.
const FOCAL_PX: f64 = 800.0;

/// A pose's numbers as the solution fields `R` (row-major), `t`, then `s` where there is a
/// scale, then `q` (the unit quaternion `[w, x, y, z]` of `R`, `w >= 0`).
fn pose_numbers(r: &Matrix3<f64>, t: &Vector3<f64>, s: Option<f64>) -> Vec<f64> {
    let q = UnitQuaternion::from_matrix(r);
    let sign = if q.w < 0.0 { -1.0 } else { 1.0 };
    let mut x: Vec<f64> = (0..3).flat_map(|i| (0..3).map(move |j| r[(i, j)])).collect();
    x.extend(t.iter());
    x.extend(s);
    x.extend([q.w, q.i, q.j, q.k].map(|v| sign * v));
    x
}

/// The solution fields of a pose (`scale`: with `s`).
fn pose_fields(scale: bool) -> Vec<Field> {
    let mut fields = vec![Field::new("R", &[3, 3]), Field::new("t", &[3])];
    if scale {
        fields.push(Field::new("s", &[]));
    }
    fields.push(Field::new("q", &[4]));
    fields
}

/// The shipped UPnP learned start, loaded once and shared by every UPnP solver of the process.
fn upnp_learned() -> Result<&'static UpnpLearned, String> {
    static LEARNED: OnceLock<Result<UpnpLearned, String>> = OnceLock::new();
    LEARNED.get_or_init(|| UpnpLearned::shipped().map_err(|e| format!("the shipped UPnP weights: {e}"))).as_ref().map_err(Clone::clone)
}

/// Generalized absolute pose (UPnP) of a multi-camera rig.
struct Upnp {
    solver: UpnpLibrarySolver,
}

/// `simhc.upnp`: UPnP for data with noise `noise` (pixels at [`FOCAL_PX`]): a validated pose puts
/// every point within eight times the noise of its bearing (`0`: the problem's default, 16 px).
pub fn upnp(noise: f64) -> Result<Arc<dyn DynSolver>, String> {
    let problem = if noise == 0.0 {
        UpnpProblem::default()
    } else {
        UpnpProblem { max_angle: (8.0 * noise / FOCAL_PX).max(1e-6), ..UpnpProblem::default() }
    };
    let learned = upnp_learned()?.clone();
    let solver = UpnpLibrarySolver::with_learned(Arc::new(problem), learned, 0.0).map_err(|e| format!("the shipped UPnP weights: {e}"))?;
    Ok(Arc::new(Upnp { solver: solver.certifying(Certification::Report) }))
}

/// The correspondences of UPnP's rows `[points, bearings, origins]`.
fn upnp_correspondences(rows: &[f64]) -> Vec<UpnpCorrespondence> {
    rows.chunks_exact(UpnpCorrespondence::ROW_LEN).map(UpnpCorrespondence::from_row).collect()
}

impl DynSolver for Upnp {
    fn name(&self) -> &'static str {
        "upnp"
    }

    fn fields(&self) -> Fields {
        Fields {
            row: vec![Field::new("points", &[3]), Field::new("bearings", &[3]), Field::optional("origins", &[3])],
            globals: vec![],
            solution: pose_fields(false),
            rows: 3,
            more_rows: true,
            threshold: Some(3.0 / FOCAL_PX),
            estimate_noise: 1.0,
            about: "`upnp`: generalized absolute pose of a multi-camera rig from N >= 3 correspondences, \
                    `alpha_i * bearings[i] + origins[i] = R @ points[i] + t` (world to rig). `points` are in the world \
                    frame, `bearings` (any length, not zero) and `origins` (the ray's camera centre, default zeros: one \
                    central camera) in the rig frame; (N, 3) arrays each. Returns R, t and q. `noise` is in pixels at a \
                    focal length of 800 px (estimate's default 1: a sample's pose may miss its own correspondences by \
                    eight times it); estimate's `threshold` is the largest angle (radians) between a bearing and the \
                    direction to its point, default three pixels (3 / 800)."
                .into(),
        }
    }

    fn solve(&self, _: usize, rows: &[f64], _: &[f64]) -> Result<(Vec<f64>, Option<f64>), Failure> {
        let corrs = upnp_correspondences(rows);
        let solution = self.solver.solve(&corrs[..]).map_err(solve_failure)?;
        // A validated quaternion has a pose: the rays were checked before the solve.
        let pose = upnp_pose(&solution.x, &corrs).ok_or_else(|| Failure::NoSolution("the validated rotation has no translation".into()))?;
        Ok((pose_numbers(&pose.rotation, &pose.translation, None), solution.certified.and_then(|c| c.ok()).map(|c| c.error_bound())))
    }

    fn estimate(&self, rows: &[f64], _: &[f64], options: &RansacOptions) -> Result<(Vec<f64>, EstimateInfo), Failure> {
        let corrs = upnp_correspondences(rows);
        let (pose, info) = self.solver.estimate(&corrs[..], options).map_err(estimate_failure)?;
        Ok((pose_numbers(&pose.rotation, &pose.translation, None), info))
    }
}

/// Generalized relative pose and scale (GRPS) between two multi-camera rigs.
struct Grps {
    solvers: GrpsSolvers,
}

/// `simhc.grps`: GRPS for data with noise `noise` (pixels at [`FOCAL_PX`]; the estimator's
/// default is [`RANSAC_NOISE_PX`], the noise of a RANSAC sample's pose).
pub fn grps(noise: f64) -> Result<Arc<dyn DynSolver>, String> {
    let solvers = GrpsSolvers::new(noise).map_err(|e| format!("the shipped GRPS weights: {e}"))?;
    Ok(Arc::new(Grps { solvers: solvers.certifying(Certification::Report) }))
}

fn grps_pose(x: &nalgebra::SVector<f64, 8>) -> Result<Vec<f64>, Failure> {
    let pose = GrpsPose::from_unknowns(x).ok_or_else(|| Failure::NoSolution("the solution has no rotation".into()))?;
    Ok(pose_numbers(&pose.rotation, &pose.translation, Some(pose.scale)))
}

impl DynSolver for Grps {
    fn name(&self) -> &'static str {
        "grps"
    }

    fn fields(&self) -> Fields {
        Fields {
            row: ["f", "v", "fp", "vp"].map(|name| Field::new(name, &[3])).to_vec(),
            globals: vec![],
            solution: pose_fields(true),
            rows: 8,
            more_rows: true,
            threshold: Some(0.01),
            estimate_noise: RANSAC_NOISE_PX,
            about: "`grps`: generalized relative pose and scale between two multi-camera rigs from N >= 8 \
                    correspondences (estimate: N >= 7, with outliers), `alpha * f + v = R @ (alpha' * fp + s * vp) + t` \
                    (rig 2 to rig 1, `s` the metric length of one rig-2 unit). Bearings `f` and ray origins `v` are in \
                    rig 1, `fp` and `vp` in rig 2; (N, 3) arrays each. Returns R, t, s and q. `noise` is in pixels at a \
                    focal length of 800 px (estimate's default 1.6); estimate's `threshold` is the largest angular \
                    residual (the sine of the angle between a first-view bearing and the plane of its epipolar \
                    constraint), default the paper's 0.01 (8 px at 800 px), and it keeps up to 4 roots per sample of 7."
                .into(),
        }
    }

    fn solve(&self, _: usize, rows: &[f64], _: &[f64]) -> Result<(Vec<f64>, Option<f64>), Failure> {
        let corrs: Vec<_> = rows.chunks_exact(ROW_LEN).map(correspondence_of_row).collect();
        let solution = self.solvers.solve(&corrs).map_err(|e| match e {
            GrpsSolversError::Count(_) => Failure::Input(e.to_string()),
            GrpsSolversError::Solve(e) => solve_failure(e),
        })?;
        Ok((grps_pose(&solution.x)?, solution.certified.and_then(|c| c.ok()).map(|c| c.error_bound())))
    }

    fn estimate(&self, rows: &[f64], globals: &[f64], options: &RansacOptions) -> Result<(Vec<f64>, EstimateInfo), Failure> {
        // Degenerate data as a whole (one camera pair, a central view) is an input error, not a
        // sample that fails to validate; a NaN is named by the estimator (correspondence, field).
        let corrs: Vec<_> = rows.chunks_exact(ROW_LEN).map(correspondence_of_row).collect();
        if corrs.len() >= 7 && rows.iter().all(|v| v.is_finite()) {
            validate(&corrs).map_err(|e| Failure::Input(e.to_string()))?;
        }
        let (x, info) = self.solvers.seven.estimate((rows, globals), options).map_err(estimate_failure)?;
        Ok((grps_pose(&x)?, info))
    }
}
