"""simhc: Simulator HC minimal solvers from numpy.

A solve predicts a rough solution with a small learned network, builds a start problem that
solution solves exactly, and tracks one homotopy path to your data; every answer is validated
on all correspondences, and a solve without a validated answer raises a ``SolveError``.

- ``upnp(points, bearings, origins=None)``: generalized absolute pose (UPnP), N >= 3.
- ``grps(f, v, fp, vp)``: generalized relative pose and scale, N >= 8.
- ``estimate_upnp(points, bearings, origins=None, threshold=...)``: UPnP, robust (LO-RANSAC),
  N >= 4.
- ``estimate_grps(f, v, fp, vp, threshold=...)``: GRPS, robust (LO-RANSAC), N >= 7.

A problem of your own (and the example, generalized relative pose with known scale) is a module
of its own, made by one line of its crate, ``simhc_pymodule::python_module!(gen_relpose, ...)``: ``import
gen_relpose`` (``pip install ./examples/generalized-relative-pose/python``), with its own ``gen_relpose.InputError``
and ``gen_relpose.SolveError``.

Exceptions: ``InputError`` (a ``ValueError`` naming the array or correspondence and field),
``SolveError`` (a ``RuntimeError``) with ``NotValidatedError`` and ``NoSolutionError``.
"""

from ._simhc import (
    InputError,
    NoSolutionError,
    NotValidatedError,
    Pose,
    SolveError,
    estimate_grps,
    estimate_upnp,
    grps,
    upnp,
)

__all__ = [
    "InputError",
    "NoSolutionError",
    "NotValidatedError",
    "Pose",
    "SolveError",
    "estimate_grps",
    "estimate_upnp",
    "grps",
    "upnp",
]
