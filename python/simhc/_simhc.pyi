"""Type stubs of the simhc extension module (``simhc._simhc``)."""

from typing import Any, Iterator, Optional

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

class Solution:
    """A validated solution: each field of ``solution_fields`` by name (``x["t"]`` or ``x.t``;
    a float for a scalar, an array of the field's shape otherwise), and ``certified`` (the
    distance to an exact root that an interval Krawczyk test proved, or None)."""

    certified: Optional[float]
    def __getitem__(self, name: str) -> Any: ...
    def __getattr__(self, name: str) -> Any: ...
    def __contains__(self, name: str) -> bool: ...
    def __len__(self) -> int: ...
    def __iter__(self) -> Iterator[str]: ...
    def keys(self) -> list[str]: ...
    def items(self) -> list[tuple[str, Any]]: ...

class ProblemSolver:
    """A problem's solver, built once: every problem, built-in or declared, is one of these.
    Correspondences are one (N, per_row) array of rows, or one array per field, in
    ``row_fields`` order or by name."""

    name: str
    rows: int
    more_rows: bool
    row_fields: list[tuple[str, list[int]]]
    global_fields: list[tuple[str, list[int]]]
    solution_fields: list[tuple[str, list[int]]]
    about: str
    def solve(self, *arrays: ArrayLike, globals: Optional[ArrayLike] = None, noise: Optional[float] = None, **fields: ArrayLike) -> Solution:
        """One instance; raises ``InputError`` or a ``SolveError``."""
    def __call__(self, *arrays: ArrayLike, globals: Optional[ArrayLike] = None, noise: Optional[float] = None, **fields: ArrayLike) -> Solution:
        """``solve``."""
    def solve_batch(
        self, rows: ArrayLike, globals: Optional[ArrayLike] = None, *, noise: float = 0.0
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
        """(B, N, per_row) rows across cores: ``(x, ok)``, ``x`` (B, solution numbers)."""
    def estimate(
        self,
        *arrays: ArrayLike,
        globals: Optional[ArrayLike] = None,
        threshold: Optional[float] = None,
        noise: Optional[float] = None,
        max_iterations: int = 100000,
        min_iterations: int = 1000,
        confidence: float = 0.9999,
        seed: int = 0,
        local_optimization: bool = True,
        refine_rounds: int = 2,
        skip_explained: bool = False,
        **fields: ArrayLike,
    ) -> tuple[Solution, Info]:
        """Robust (LO-RANSAC) from any number of correspondences with outliers. ``info``:
        iterations, num_inliers, inlier_ratio, inlier_mask, score, refinements, models, certified."""

upnp: ProblemSolver
"""Generalized absolute pose: ``alpha * bearings[i] + origins[i] = R @ points[i] + t``, N >= 3."""

grps: ProblemSolver
"""Generalized relative pose and scale: ``alpha * f + v = R @ (alpha' * fp + s * vp) + t``, N >= 8."""
