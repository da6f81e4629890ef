"""simhc: Simulator HC minimal solvers from numpy.

A solve predicts a rough solution with a small learned network, builds a start problem that
solution solves exactly, and tracks one homotopy path to your data; every answer is validated
on all correspondences, and a solve without a validated answer raises a ``SolveError``.

- ``upnp(points, bearings, origins=None)``: generalized absolute pose (UPnP), N >= 3.
- ``grps(f, v, fp, vp)``: generalized relative pose and scale, N >= 8.
- ``estimate_upnp(points, bearings, origins=None, threshold=...)``: UPnP, robust (LO-RANSAC),
  N >= 4.
- ``estimate_grps(f, v, fp, vp, threshold=...)``: GRPS, robust (LO-RANSAC), N >= 7.
- ``gen_relpose(f, v, fp, vp)``: generalized relative pose with known scale, exactly 7.
- ``estimate_gen_relpose(f, v, fp, vp, threshold=...)``: the same, robust (LO-RANSAC), N >= 7.
- ``grp``: that problem's module as ``simhc_python::python_module!`` makes it for any declared
  problem (``grp.solve``, ``grp.solve_batch``, ``grp.estimate``, ``grp.solver``).

Exceptions: ``InputError`` (a ``ValueError`` naming the array or correspondence and field),
``SolveError`` (a ``RuntimeError``) with ``NotValidatedError`` and ``NoSolutionError``.
"""

from ._simhc import (
    InputError,
    NoSolutionError,
    NotValidatedError,
    Pose,
    ProblemSolver,
    SolveError,
    estimate_gen_relpose,
    estimate_grps,
    estimate_upnp,
    gen_relpose,
    grp,
    grps,
    upnp,
)

__all__ = [
    "InputError",
    "NoSolutionError",
    "NotValidatedError",
    "Pose",
    "ProblemSolver",
    "SolveError",
    "estimate_gen_relpose",
    "estimate_grps",
    "estimate_upnp",
    "gen_relpose",
    "grp",
    "grps",
    "upnp",
]
