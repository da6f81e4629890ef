//! The example problem (generalized relative pose with known scale, `examples/`) from Python:
//! `simhc.grp`, made by [`crate::python_module!`] exactly as a user's crate would, and the
//! pose-returning functions `gen_relpose` and `estimate_gen_relpose` over the same solver.

use crate::arrays::{same_count, vectors};
use crate::pose::Pose;
use crate::problem::{ransac_options, ProblemSolver};
use generalized_relative_pose::{pose, GenRelPose, FOCAL_PX};
use nalgebra::{SVector, Vector3};
use pyo3::prelude::*;
use pyo3::sync::PyOnceLock;
use pyo3::types::PyDict;

crate::python_module!(grp, GenRelPose::new());

/// The `simhc.grp` module's solver (looked up once).
fn solver<'py>(py: Python<'py>) -> PyResult<Bound<'py, ProblemSolver>> {
    static SOLVER: PyOnceLock<Py<ProblemSolver>> = PyOnceLock::new();
    let solver = SOLVER.get_or_try_init(py, || -> PyResult<_> {
        Ok(py.import("simhc._simhc")?.getattr("grp")?.getattr("solver")?.cast_into::<ProblemSolver>()?.unbind())
    })?;
    Ok(solver.bind(py).clone())
}

/// The rows `[f, v, fp, vp]` of four `(N, 3)` arrays.
fn rows(f: &Bound<'_, PyAny>, v: &Bound<'_, PyAny>, fp: &Bound<'_, PyAny>, vp: &Bound<'_, PyAny>) -> PyResult<(usize, Vec<f64>)> {
    let (f, v, fp, vp) = (vectors(f, "f")?, vectors(v, "v")?, vectors(fp, "fp")?, vectors(vp, "vp")?);
    let n = same_count(&[("f", f.len()), ("v", v.len()), ("fp", fp.len()), ("vp", vp.len())])?;
    let mut out = Vec::with_capacity(12 * n);
    for i in 0..n {
        for w in [&f[i], &v[i], &fp[i], &vp[i]] {
            out.extend_from_slice(w.as_slice());
        }
    }
    Ok((n, out))
}

fn to_pose(py: Python<'_>, x: &[f64]) -> PyResult<Pose> {
    let (r, t): (_, Vector3<f64>) = pose(&SVector::<f64, 7>::from_column_slice(x));
    Pose::new(py, &r, &t, None)
}

/// Generalized relative pose with known scale from exactly 7 correspondences between two
/// multi-camera rigs (6 determine it, the 7th validates). The pose maps rig-2 coordinates to
/// rig-1 coordinates, `X1 = R @ X2 + t` (in the rigs' common metric unit): the rays
/// `v + alpha * f` and `R @ (vp + alpha' * fp) + t` meet.
///
/// Arguments are (7, 3) arrays: bearings `f` and ray origins `v` in rig 1, `fp` and `vp` in
/// rig 2; `noise` is the bearings' noise in pixels at a focal length of 800 px (the
/// validator's tolerance; 0: exact data). Returns a `Pose` (R, t) validated on all 7. Raises
/// `InputError` (naming the correspondence and field) or a `SolveError`.
#[pyfunction]
#[pyo3(signature = (f, v, fp, vp, *, noise = 0.0))]
pub fn gen_relpose(
    py: Python<'_>,
    f: &Bound<'_, PyAny>,
    v: &Bound<'_, PyAny>,
    fp: &Bound<'_, PyAny>,
    vp: &Bound<'_, PyAny>,
    noise: f64,
) -> PyResult<Pose> {
    let (n, rows) = rows(f, v, fp, vp)?;
    let (x, certified) = solver(py)?.get().solve_rows(py, n, rows, Vec::new(), noise)?;
    Ok(to_pose(py, &x)?.certified(certified))
}

/// Robust generalized relative pose (LO-RANSAC over 7-correspondence samples, PoseLib's
/// defaults) from N >= 7 correspondences with outliers, as `gen_relpose`'s arrays of shape
/// (N, 3). `threshold` is the largest angle (radians) between a correspondence's rays and
/// their common plane for an inlier, the default one pixel at a focal length of 800 px;
/// `noise` (pixels at that focal length) is how far a sample's pose may miss its own 7
/// correspondences, default one pixel.
///
/// Returns `(pose, info)`: `info` holds `iterations`, `num_inliers`, `inlier_ratio`,
/// `inlier_mask` (bool array of N), `score`, `refinements` and `models`.
#[pyfunction]
#[pyo3(signature = (f, v, fp, vp, *, threshold = 1.0 / FOCAL_PX, noise = 1.0, max_iterations = 100_000, min_iterations = 1000, confidence = 0.9999, seed = 0, local_optimization = true, refine_rounds = 2))]
#[allow(clippy::too_many_arguments)]
pub fn estimate_gen_relpose<'py>(
    py: Python<'py>,
    f: &Bound<'py, PyAny>,
    v: &Bound<'py, PyAny>,
    fp: &Bound<'py, PyAny>,
    vp: &Bound<'py, PyAny>,
    threshold: f64,
    noise: f64,
    max_iterations: usize,
    min_iterations: usize,
    confidence: f64,
    seed: u64,
    local_optimization: bool,
    refine_rounds: usize,
) -> PyResult<(Pose, Bound<'py, PyDict>)> {
    let options = ransac_options(threshold, max_iterations, min_iterations, confidence, seed, local_optimization, refine_rounds)?;
    let (_, rows) = rows(f, v, fp, vp)?;
    let (x, info) = solver(py)?.get().estimate_rows(py, rows, Vec::new(), &options, noise)?;
    Ok((to_pose(py, &x)?, info))
}
