//! The built-in problems, UPnP and GRPS, through their library solvers and robust estimators
//! (built once per process).

use crate::pose::Pose;
use crate::raise;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use simhc::solver::EstimateError;
use simhc_problems::grps::declared::{GrpsSolvers, GrpsSolversError, RANSAC_NOISE_PX};
use simhc_problems::grps::geometry::validate;
use simhc_problems::grps::pose::GrpsPose;
use simhc_problems::grps::row_numbers;
use simhc_problems::grps::scene::GrpsCorrespondence;
use simhc_problems::upnp::instance::{upnp_pose, UpnpLibrarySolver, UpnpProblem};
use simhc_problems::upnp::scene::UpnpCorrespondence;
use simhc_pymodule::arrays::{same_count, vectors};
use simhc_pymodule::{info_dict, ransac_options, solve_failure, Error, Failure};
use std::sync::{Arc, OnceLock};

/// The focal length (pixels) the estimators' pixel defaults refer to.
const FOCAL_PX: f64 = 800.0;

/// The UPnP library solver (`simhc::solver::InstanceSolver`, the assembly of every problem),
/// built once.
fn upnp_library() -> Result<&'static UpnpLibrarySolver, Failure> {
    static SOLVER: OnceLock<Result<UpnpLibrarySolver, String>> = OnceLock::new();
    SOLVER
        .get_or_init(|| {
            UpnpLibrarySolver::new(UpnpProblem::default())
                .map(|s| s.certifying(simhc::solver::Certification::Report))
                .map_err(|e| e.to_string())
        })
        .as_ref()
        .map_err(|e| Failure::NoSolution(format!("the shipped UPnP weights: {e}")))
}

/// The GRPS library solvers for noise-free data (`GrpsSolvers`: 7, 8 or more
/// correspondences), built once.
fn grps_solvers() -> Result<&'static GrpsSolvers, Failure> {
    static SOLVERS: OnceLock<Result<GrpsSolvers, String>> = OnceLock::new();
    SOLVERS
        .get_or_init(|| GrpsSolvers::new(0.0).map(|s| s.certifying(simhc::solver::Certification::Report)).map_err(|e| e.to_string()))
        .as_ref()
        .map_err(|e| Failure::NoSolution(format!("the shipped GRPS weights: {e}")))
}

/// The GRPS library solvers whose validator takes a RANSAC sample's pose
/// ([`RANSAC_NOISE_PX`]), built once.
fn grps_estimators() -> Result<&'static GrpsSolvers, Failure> {
    static SOLVERS: OnceLock<Result<GrpsSolvers, String>> = OnceLock::new();
    SOLVERS
        .get_or_init(|| GrpsSolvers::new(RANSAC_NOISE_PX).map_err(|e| e.to_string()))
        .as_ref()
        .map_err(|e| Failure::NoSolution(format!("the shipped GRPS weights: {e}")))
}

/// A built-in estimator's error as an exception: bad input, or no model.
/// The correspondences of `upnp`'s arrays (`origins=None`: a central camera at the origin).
fn upnp_correspondences(
    points: &Bound<'_, PyAny>,
    bearings: &Bound<'_, PyAny>,
    origins: Option<&Bound<'_, PyAny>>,
) -> Result<Vec<UpnpCorrespondence>, Error> {
    let p = vectors(points, "points")?;
    let f = vectors(bearings, "bearings")?;
    let v = match origins {
        Some(o) => vectors(o, "origins")?,
        None => vec![nalgebra::Vector3::zeros(); f.len()],
    };
    same_count(&[("points", p.len()), ("bearings", f.len()), ("origins", v.len())])?;
    Ok((0..p.len()).map(|i| UpnpCorrespondence { p: p[i], f: f[i], v: v[i] }).collect())
}

/// The correspondences of `grps`'s arrays.
fn grps_correspondences(
    f: &Bound<'_, PyAny>,
    v: &Bound<'_, PyAny>,
    fp: &Bound<'_, PyAny>,
    vp: &Bound<'_, PyAny>,
) -> Result<Vec<GrpsCorrespondence>, Error> {
    let (f, v, fp, vp) = (vectors(f, "f")?, vectors(v, "v")?, vectors(fp, "fp")?, vectors(vp, "vp")?);
    let n = same_count(&[("f", f.len()), ("v", v.len()), ("fp", fp.len()), ("vp", vp.len())])?;
    Ok((0..n).map(|i| GrpsCorrespondence { f: f[i], v: v[i], fp: fp[i], vp: vp[i] }).collect())
}

/// `noise` (pixels at [`FOCAL_PX`]) as an angle; an error unless finite and non-negative.
fn noise_angle(noise: f64) -> Result<f64, Failure> {
    if noise.is_finite() && noise >= 0.0 {
        Ok(noise / FOCAL_PX)
    } else {
        Err(Failure::Input(format!("`noise`: {noise}, expected a number >= 0")))
    }
}

fn grps_failure(e: GrpsSolversError) -> Failure {
    match e {
        GrpsSolversError::Count(_) => Failure::Input(e.to_string()),
        GrpsSolversError::Solve(e) => solve_failure(e),
    }
}

/// The library estimator's error as an exception: bad input, or no model.
fn estimate_failure(e: EstimateError) -> Failure {
    match e {
        EstimateError::NoModel { .. } | EstimateError::NotSolved { .. } => Failure::NoSolution(e.to_string()),
        _ => Failure::Input(e.to_string()),
    }
}

/// A GRPS solution's unknowns as a pose, or why not.
fn grps_pose(x: &nalgebra::SVector<f64, 8>) -> Result<GrpsPose, Failure> {
    GrpsPose::from_unknowns(x).ok_or_else(|| Failure::NoSolution("the solution has no rotation".into()))
}

/// Generalized absolute pose (UPnP) from N >= 3 correspondences of a multi-camera rig:
/// `alpha_i * bearings[i] + origins[i] = R @ points[i] + t` (world to rig).
///
/// Arguments are (N, 3) arrays: `points` in the world frame, `bearings` (any length, not zero)
/// and `origins` (the ray's camera centre) in the rig frame; `origins=None` is a single
/// central camera at the rig origin. Returns a `Pose` (R, t) validated on all correspondences.
///
/// Raises `InputError` (a ValueError naming the correspondence and field) for wrong shapes,
/// NaN, too few correspondences or degenerate geometry; `NotValidatedError` or
/// `NoSolutionError` (both `SolveError`) when no pose validates.
#[pyfunction]
#[pyo3(signature = (points, bearings, origins = None))]
pub fn upnp(py: Python<'_>, points: &Bound<'_, PyAny>, bearings: &Bound<'_, PyAny>, origins: Option<&Bound<'_, PyAny>>) -> PyResult<Pose> {
    solve_upnp(py, points, bearings, origins).map_err(|e| raise(py, e))
}

fn solve_upnp(
    py: Python<'_>,
    points: &Bound<'_, PyAny>,
    bearings: &Bound<'_, PyAny>,
    origins: Option<&Bound<'_, PyAny>>,
) -> Result<Pose, Error> {
    let corrs = upnp_correspondences(points, bearings, origins)?;
    let solver = upnp_library()?;
    let solution = py.detach(|| solver.solve(&corrs[..])).map_err(solve_failure)?;
    // A validated quaternion has a pose: the rays were checked before the solve.
    let pose = upnp_pose(&solution.x, &corrs).ok_or_else(|| Failure::NoSolution("the validated rotation has no translation".into()))?;
    Ok(Pose::new(py, &pose.rotation, &pose.translation, None)?.certified(solution.certified.and_then(|c| c.ok()).map(|c| c.error_bound())))
}

/// Generalized relative pose and scale (GRPS) from N >= 8 correspondences between two
/// multi-camera rigs: `alpha * f + v = R @ (alpha' * fp + s * vp) + t` (rig 2 to rig 1, with
/// `s` the metric length of one rig-2 unit).
///
/// Arguments are (N, 3) arrays: bearings `f` and ray origins `v` in rig 1, bearings `fp` and
/// origins `vp` in rig 2. Returns a `Pose` (R, t, s) validated on all correspondences.
///
/// Raises `InputError` for wrong shapes, NaN, too few correspondences or degenerate geometry;
/// `NotValidatedError` or `NoSolutionError` when no pose validates.
#[pyfunction]
pub fn grps(py: Python<'_>, f: &Bound<'_, PyAny>, v: &Bound<'_, PyAny>, fp: &Bound<'_, PyAny>, vp: &Bound<'_, PyAny>) -> PyResult<Pose> {
    solve_grps(py, f, v, fp, vp).map_err(|e| raise(py, e))
}

fn solve_grps(
    py: Python<'_>,
    f: &Bound<'_, PyAny>,
    v: &Bound<'_, PyAny>,
    fp: &Bound<'_, PyAny>,
    vp: &Bound<'_, PyAny>,
) -> Result<Pose, Error> {
    let corrs = grps_correspondences(f, v, fp, vp)?;
    let solvers = grps_solvers()?;
    let solution = py.detach(|| solvers.solve(&corrs)).map_err(grps_failure)?;
    let pose = grps_pose(&solution.x)?;
    Ok(Pose::new(py, &pose.rotation, &pose.translation, Some(pose.scale))?
        .certified(solution.certified.and_then(|c| c.ok()).map(|c| c.error_bound())))
}

/// Robust generalized absolute pose (LO-RANSAC over samples of 4 correspondences solved by
/// Gauss-Newton from UPnP's learned start, PoseLib's defaults) from N >= 4 correspondences with
/// outliers, as `upnp`'s (N, 3) arrays. `threshold` is the largest angle (radians) between a
/// bearing and the direction to its point for an inlier, default three pixels at a focal
/// length of 800 px; `noise` (pixels at that focal length, default 1) sets how far a sample's
/// pose may miss its own correspondences (8 times the noise).
///
/// Returns `(pose, info)`: `info` holds `iterations`, `num_inliers`, `inlier_ratio`,
/// `inlier_mask` (bool array of N), `score`, `refinements` and `models`. Raises `InputError`
/// (naming the correspondence and field) or `NoSolutionError` when no sample validated.
/// `skip_explained=True`: past the confidence, samples the best pose explains are not solved
/// (much faster with few outliers).
#[pyfunction]
#[pyo3(signature = (points, bearings, origins = None, *, threshold = 3.0 / FOCAL_PX, noise = 1.0, max_iterations = 100_000, min_iterations = 1000, confidence = 0.9999, seed = 0, local_optimization = true, refine_rounds = 2, skip_explained = false))]
#[allow(clippy::too_many_arguments)]
pub fn estimate_upnp<'py>(
    py: Python<'py>,
    points: &Bound<'py, PyAny>,
    bearings: &Bound<'py, PyAny>,
    origins: Option<&Bound<'py, PyAny>>,
    threshold: f64,
    noise: f64,
    max_iterations: usize,
    min_iterations: usize,
    confidence: f64,
    seed: u64,
    local_optimization: bool,
    refine_rounds: usize,
    skip_explained: bool,
) -> PyResult<(Pose, Bound<'py, PyDict>)> {
    (|| -> Result<_, Error> {
        let options = ransac_options(threshold, max_iterations, min_iterations, confidence, seed, local_optimization, refine_rounds)?
            .skipping_explained(skip_explained);
        let max_angle = (8.0 * noise_angle(noise)?).max(1e-6);
        let corrs = upnp_correspondences(points, bearings, origins)?;
        // The library solver's learned start, shared: one copy of the weights in the process; a
        // sample's pose may miss its own correspondences by `max_angle`.
        let learned = upnp_library()?.learned_start().clone();
        let problem = Arc::new(UpnpProblem { max_angle, ..UpnpProblem::default() });
        let solver = UpnpLibrarySolver::with_learned(problem, learned, 0.0)
            .map_err(|e| Failure::NoSolution(format!("the shipped UPnP weights: {e}")))?;
        let (pose, info) = py.detach(|| solver.estimate(&corrs, &options)).map_err(estimate_failure)?;
        Ok((Pose::new(py, &pose.rotation, &pose.translation, None)?, info_dict(py, &info)?))
    })()
    .map_err(|e| raise(py, e))
}

/// Robust generalized relative pose and scale (LO-RANSAC over samples of 7 correspondences,
/// up to 4 roots per sample scored by consensus, PoseLib's defaults) from N >= 7
/// correspondences with outliers, as `grps`'s (N, 3) arrays. `threshold` is the largest
/// angular residual (sine of the angle between a first-view bearing and the plane of the
/// correspondence's epipolar constraint) for an inlier, default the paper's 0.01 (8 px at 800 px).
///
/// Returns `(pose, info)` with `pose.s` the scale: `info` holds `iterations`, `num_inliers`,
/// `inlier_ratio`, `inlier_mask` (bool array of N), `score`, `refinements` and `models`.
/// Raises `InputError` (naming the correspondence and field) or `NoSolutionError`.
/// `skip_explained=True`: past the confidence, samples the best pose explains are not solved
/// (much faster with few outliers, about one point of success less at 20-40 %).
#[pyfunction]
#[pyo3(signature = (f, v, fp, vp, *, threshold = 0.01, max_iterations = 100_000, min_iterations = 1000, confidence = 0.9999, seed = 0, local_optimization = true, refine_rounds = 2, skip_explained = false))]
#[allow(clippy::too_many_arguments)]
pub fn estimate_grps<'py>(
    py: Python<'py>,
    f: &Bound<'py, PyAny>,
    v: &Bound<'py, PyAny>,
    fp: &Bound<'py, PyAny>,
    vp: &Bound<'py, PyAny>,
    threshold: f64,
    max_iterations: usize,
    min_iterations: usize,
    confidence: f64,
    seed: u64,
    local_optimization: bool,
    refine_rounds: usize,
    skip_explained: bool,
) -> PyResult<(Pose, Bound<'py, PyDict>)> {
    (|| -> Result<_, Error> {
        let options = ransac_options(threshold, max_iterations, min_iterations, confidence, seed, local_optimization, refine_rounds)?
            .skipping_explained(skip_explained);
        let corrs = grps_correspondences(f, v, fp, vp)?;
        // Degenerate data as a whole (one camera pair, a central view) is an input error, not a
        // sample that fails to validate; a NaN is named by the estimator (correspondence, field).
        let rows: Vec<f64> = row_numbers(&corrs).collect();
        if corrs.len() >= 7 && rows.iter().all(|v| v.is_finite()) {
            validate(&corrs).map_err(|e| Failure::Input(e.to_string()))?;
        }
        let solvers = grps_estimators()?;
        let (x, info) = py.detach(|| solvers.seven.estimate((&rows, &[]), &options)).map_err(estimate_failure)?;
        let pose = grps_pose(&x)?;
        Ok((Pose::new(py, &pose.rotation, &pose.translation, Some(pose.scale))?, info_dict(py, &info)?))
    })()
    .map_err(|e| raise(py, e))
}
