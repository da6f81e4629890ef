//! The built-in problems, UPnP and GRPS, through their own solvers (built once per process).

use crate::arrays::{same_count, vectors};
use crate::errors::Failure;
use crate::pose::Pose;
use pyo3::prelude::*;
use simhc_problems::grps::scene::GrpsCorrespondence;
use simhc_problems::grps::solver::{GrpsSolveError, GrpsSolver};
use simhc_problems::upnp::scene::UpnpCorrespondence;
use simhc_problems::upnp::solver::{SolveError as UpnpSolveError, UpnpSolver};
use std::sync::OnceLock;

fn upnp_solver() -> Result<&'static UpnpSolver, Failure> {
    static SOLVER: OnceLock<Result<UpnpSolver, String>> = OnceLock::new();
    SOLVER
        .get_or_init(|| UpnpSolver::new().map_err(|e| e.to_string()))
        .as_ref()
        .map_err(|e| Failure::NoSolution(format!("the shipped UPnP weights: {e}")))
}

fn grps_solver() -> Result<&'static GrpsSolver, Failure> {
    static SOLVER: OnceLock<Result<GrpsSolver, String>> = OnceLock::new();
    SOLVER
        .get_or_init(|| GrpsSolver::new().map_err(|e| e.to_string()))
        .as_ref()
        .map_err(|e| Failure::NoSolution(format!("the shipped GRPS weights: {e}")))
}

fn upnp_failure(e: UpnpSolveError) -> Failure {
    match e {
        UpnpSolveError::Input(_) => Failure::Input(e.to_string()),
        UpnpSolveError::NotValidated(_) => Failure::NotValidated(e.to_string()),
        _ => Failure::NoSolution(e.to_string()),
    }
}

fn grps_failure(e: GrpsSolveError) -> Failure {
    match e {
        GrpsSolveError::Input(_) | GrpsSolveError::NoCanonicalFrame => Failure::Input(e.to_string()),
        GrpsSolveError::NotValidated(_) => Failure::NotValidated(e.to_string()),
        _ => Failure::NoSolution(e.to_string()),
    }
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
    let p = vectors(points, "points")?;
    let f = vectors(bearings, "bearings")?;
    let v = match origins {
        Some(o) => vectors(o, "origins")?,
        None => vec![nalgebra::Vector3::zeros(); f.len()],
    };
    same_count(&[("points", p.len()), ("bearings", f.len()), ("origins", v.len())])?;
    let corrs: Vec<UpnpCorrespondence> = (0..p.len()).map(|i| UpnpCorrespondence { p: p[i], f: f[i], v: v[i] }).collect();
    let solver = upnp_solver()?;
    let pose = py.detach(|| solver.solve(&corrs)).map_err(upnp_failure)?;
    Pose::new(py, &pose.rotation, &pose.translation, None)
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
    let (f, v, fp, vp) = (vectors(f, "f")?, vectors(v, "v")?, vectors(fp, "fp")?, vectors(vp, "vp")?);
    let n = same_count(&[("f", f.len()), ("v", v.len()), ("fp", fp.len()), ("vp", vp.len())])?;
    let corrs: Vec<GrpsCorrespondence> = (0..n).map(|i| GrpsCorrespondence { f: f[i], v: v[i], fp: fp[i], vp: vp[i] }).collect();
    let solver = grps_solver()?;
    let pose = py.detach(|| solver.solve(&corrs)).map_err(grps_failure)?;
    Pose::new(py, &pose.rotation, &pose.translation, Some(pose.scale))
}
