"""Type stubs of the simhc extension module (``simhc._simhc``)."""

from typing import Any, Optional

import numpy as np
import numpy.typing as npt

ArrayLike = npt.ArrayLike
Info = dict[str, Any]

class InputError(ValueError):
    """Bad input: wrong shape, NaN or infinity, too few correspondences, degenerate geometry.
    The message names the array or correspondence and the field."""

class SolveError(RuntimeError):
    """No validated solution (never a pose to use)."""

class NotValidatedError(SolveError):
    """End points were found and none passed validation on all the data."""

class NoSolutionError(SolveError):
    """No attempt reached an end point."""

class Pose:
    """A pose: ``R`` (3, 3), ``t`` (3,), ``s`` (scale or None), ``q`` (unit quaternion
    ``[w, x, y, z]`` of ``R``), ``certified`` (the distance to an exact root of the solved
    system that an interval Krawczyk test proved, or None)."""

    R: npt.NDArray[np.float64]
    t: npt.NDArray[np.float64]
    s: Optional[float]
    q: npt.NDArray[np.float64]
    certified: Optional[float]

def upnp(points: ArrayLike, bearings: ArrayLike, origins: Optional[ArrayLike] = None) -> Pose:
    """Generalized absolute pose from (N, 3) world ``points``, rig ``bearings`` and ray
    ``origins`` (None: one central camera): ``alpha * bearings[i] + origins[i] = R @ points[i] + t``."""

def grps(f: ArrayLike, v: ArrayLike, fp: ArrayLike, vp: ArrayLike) -> Pose:
    """Generalized relative pose and scale from (N, 3) arrays, N >= 8:
    ``alpha * f + v = R @ (alpha' * fp + s * vp) + t``."""

def estimate_upnp(
    points: ArrayLike,
    bearings: ArrayLike,
    origins: Optional[ArrayLike] = None,
    *,
    threshold: float = 0.00375,
    noise: float = 1.0,
    max_iterations: int = 100000,
    min_iterations: int = 1000,
    confidence: float = 0.9999,
    seed: int = 0,
    local_optimization: bool = True,
    refine_rounds: int = 2,
    skip_explained: bool = False,
) -> tuple[Pose, Info]:
    """Robust generalized absolute pose from (N, 3) arrays with outliers, N >= 4.
    ``threshold``: largest angle (radians) between a bearing and its point for an inlier.
    ``info``: iterations, num_inliers, inlier_ratio, inlier_mask, score, refinements, models."""

def estimate_grps(
    f: ArrayLike,
    v: ArrayLike,
    fp: ArrayLike,
    vp: ArrayLike,
    *,
    threshold: float = 0.01,
    max_iterations: int = 100000,
    min_iterations: int = 1000,
    confidence: float = 0.9999,
    seed: int = 0,
    local_optimization: bool = True,
    refine_rounds: int = 2,
    skip_explained: bool = False,
) -> tuple[Pose, Info]:
    """Robust generalized relative pose and scale from (N, 3) arrays with outliers, N >= 7.
    ``threshold``: largest angular residual (sine of the angle between a bearing and its epipolar plane) for an inlier.
    ``info``: iterations, num_inliers, inlier_ratio, inlier_mask, score, refinements, models."""
