"""simhc: Simulator HC minimal solvers from numpy.

A solve predicts a rough solution with a small learned network, builds a start problem that
solution solves exactly, and tracks one homotopy path to your data; every answer is validated
on all correspondences, and a solve without a validated answer raises a ``SolveError``.

The built-in problems are registered solvers, each a ``ProblemSolver`` (the one class of every
problem; ``solver.about`` says what it solves, its conventions and units):

- ``upnp``: generalized absolute pose. ``simhc.upnp(points, bearings, origins=None)``, (N, 3)
  arrays, N >= 3, returns a ``Solution`` with ``R``, ``t``, ``q``, ``certified``;
  ``simhc.upnp.estimate(points, bearings, origins, threshold=3 / 800)`` is robust (LO-RANSAC),
  N >= 4 with outliers, and returns ``(solution, info)``.
- ``grps``: generalized relative pose and scale. ``simhc.grps(f, v, fp, vp)``, N >= 8, adds
  ``s``; ``simhc.grps.estimate(f, v, fp, vp, threshold=0.01)``, N >= 7 with outliers.

Arrays are given in ``row_fields`` order or by name (``simhc.upnp(points=p, bearings=f)``), or
as one (N, per_row) array of rows.

A problem of your own (and the example, generalized relative pose with known scale) is a module
of its own with the same class, made by one line of its crate,
``simhc_pymodule::python_module!(gen_relpose, ...)``: ``import gen_relpose``
(``pip install ./examples/generalized-relative-pose/python``), with its own
``gen_relpose.InputError`` and ``gen_relpose.SolveError``.

Exceptions: ``InputError`` (a ``ValueError`` naming the array or correspondence and field),
``SolveError`` (a ``RuntimeError``) with ``NotValidatedError`` and ``NoSolutionError``.
"""

from ._simhc import (
    InputError,
    NoSolutionError,
    NotValidatedError,
    ProblemSolver,
    Solution,
    SolveError,
    grps,
    upnp,
)

__all__ = [
    "InputError",
    "NoSolutionError",
    "NotValidatedError",
    "ProblemSolver",
    "Solution",
    "SolveError",
    "grps",
    "upnp",
]
