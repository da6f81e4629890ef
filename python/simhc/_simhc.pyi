"""Type stubs of the simhc extension module (``simhc._simhc``)."""

from types import ModuleType
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

class ProblemSolver:
    """A declared problem's solver, built once at import."""

    name: str
    rows: int
    row_fields: list[tuple[str, int]]
    global_fields: list[tuple[str, int]]
    unknowns: list[tuple[str, int]]
    def solve(self, rows: ArrayLike, globals: Optional[ArrayLike] = None, *, noise: float = 0.0) -> dict[str, Any]:
        """Solve one instance: ``rows`` is (rows, per_row), fields in ``row_fields`` order;
        ``noise`` is the data's (the validator's tolerance). Returns the unknowns by name."""
    def solve_batch(
        self, rows: ArrayLike, globals: Optional[ArrayLike] = None, *, noise: float = 0.0
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
        """Solve (B, rows, per_row) instances across cores: ``(x, ok)``, ``x`` (B, unknowns),
        NaN where ``ok`` is False."""
    def estimate(
        self,
        rows: ArrayLike,
        globals: Optional[ArrayLike] = None,
        *,
        threshold: float,
        noise: float = 0.0,
        max_iterations: int = 100000,
        min_iterations: int = 1000,
        confidence: float = 0.9999,
        seed: int = 0,
        local_optimization: bool = True,
        refine_rounds: int = 2,
    ) -> tuple[dict[str, Any], Info]:
        """Robust estimate from (N, per_row) rows with outliers: ``(unknowns, info)``."""

def upnp(points: ArrayLike, bearings: ArrayLike, origins: Optional[ArrayLike] = None) -> Pose:
    """Generalized absolute pose from (N, 3) world ``points``, rig ``bearings`` and ray
    ``origins`` (None: one central camera): ``alpha * bearings[i] + origins[i] = R @ points[i] + t``."""

def grps(f: ArrayLike, v: ArrayLike, fp: ArrayLike, vp: ArrayLike) -> Pose:
    """Generalized relative pose and scale from (N, 3) arrays, N >= 8:
    ``alpha * f + v = R @ (alpha' * fp + s * vp) + t``."""

def gen_relpose(f: ArrayLike, v: ArrayLike, fp: ArrayLike, vp: ArrayLike, *, noise: float = 0.0) -> Pose:
    """Generalized relative pose with known scale from exactly 7 correspondences, (7, 3)
    arrays; ``X1 = R @ X2 + t``."""

def estimate_gen_relpose(
    f: ArrayLike,
    v: ArrayLike,
    fp: ArrayLike,
    vp: ArrayLike,
    *,
    threshold: float = 0.00125,
    noise: float = 1.0,
    max_iterations: int = 100000,
    min_iterations: int = 1000,
    confidence: float = 0.9999,
    seed: int = 0,
    local_optimization: bool = True,
    refine_rounds: int = 2,
) -> tuple[Pose, Info]:
    """Robust generalized relative pose from (N, 3) arrays with outliers, N >= 7.
    ``info``: iterations, num_inliers, inlier_ratio, inlier_mask, score, refinements, models."""

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
) -> tuple[Pose, Info]:
    """Robust generalized relative pose and scale from (N, 3) arrays with outliers, N >= 7.
    ``threshold``: largest angular residual (sine of the angle between a bearing and its epipolar plane) for an inlier.
    ``info``: iterations, num_inliers, inlier_ratio, inlier_mask, score, refinements, models."""

grp: ModuleType
