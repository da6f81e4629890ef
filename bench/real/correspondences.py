"""Correspondences of a frame pair (i, j) of KITTI's stereo rig, identical for every solver.

The rig of a frame is its left camera's frame (x right, y down, z forward); the right camera
sits at (+baseline, 0, 0) with the same orientation. A landmark with stereo factors in both
frames gives ONE correspondence: a ray from the left or the right camera of frame i and a ray
from the left or the right camera of frame j, each camera drawn at random (seeded), so both rigs
are non-central. Every record keeps the pixel, camera index and unit bearing, so that simhc
(bearings and ray origins) and PoseLib (pixels, per-camera matches) see the same data.

- relative pose (and GRPS): (cam_i, pixel_i, f_i, v_i) <-> (cam_j, pixel_j, f_j, v_j);
  truth `X_i = R X_j + t` from the reference poses;
- absolute pose (UPnP): frame i is the world; the landmark's X Y Z from frame i's factor (its
  stereo triangulation in frame i's left camera) against a ray of frame j; truth
  `alpha f + v = R p + t`, R and t taking frame-i coordinates into frame j's.
"""

from dataclasses import dataclass

import numpy as np


@dataclass
class Pair:
    i: int                 # positions in the frame list
    j: int
    cam1: np.ndarray       # (N,) 0 left, 1 right, in frame i
    px1: np.ndarray        # (N, 2) pixels in frame i
    f1: np.ndarray         # (N, 3) unit bearings, frame i's rig frame
    v1: np.ndarray         # (N, 3) ray origins
    cam2: np.ndarray       # frame j likewise
    px2: np.ndarray
    f2: np.ndarray
    v2: np.ndarray
    points: np.ndarray     # (N, 3) landmark in frame i's left camera (its stereo triangulation)
    landmarks: np.ndarray  # (N,) ids


def bearing(calib, px):
    x = np.column_stack([(px[:, 0] - calib.cx) / calib.fx, (px[:, 1] - calib.cy) / calib.fy, np.ones(len(px))])
    return x / np.linalg.norm(x, axis=1, keepdims=True)


def camera_centres(calib):
    return np.array([[0.0, 0.0, 0.0], [calib.baseline, 0.0, 0.0]])


def _rays(calib, rows, cams):
    """Pixels, bearings and origins of factor rows seen through `cams` (0 left, 1 right)."""
    px = np.column_stack([np.where(cams == 0, rows[:, 2], rows[:, 3]), rows[:, 4]])
    return px, bearing(calib, px), camera_centres(calib)[cams]


def build(data, i, j, rng, max_corr=None):
    """The correspondences of frames i and j (positions), cameras drawn from `rng`."""
    if not (0 <= i < len(data.ids) and 0 <= j < len(data.ids)) or i == j:
        raise ValueError(f"frame positions ({i}, {j}): expected two different positions in 0..{len(data.ids) - 1}")
    a, b = data.frame_factors(i), data.frame_factors(j)
    common = np.array(sorted(set(a) & set(b)), dtype=int)
    if max_corr is not None and len(common) > max_corr:
        common = np.sort(rng.choice(common, max_corr, replace=False))
    ra = np.array([a[k] for k in common]).reshape(-1, 8)
    rb = np.array([b[k] for k in common]).reshape(-1, 8)
    cam1 = rng.integers(0, 2, len(common))
    cam2 = rng.integers(0, 2, len(common))
    px1, f1, v1 = _rays(data.calib, ra, cam1)
    px2, f2, v2 = _rays(data.calib, rb, cam2)
    return Pair(i, j, cam1, px1, f1, v1, cam2, px2, f2, v2, ra[:, 5:8].copy(), common)


def pairs(n_frames, gaps, stride=1):
    """All (i, i + gap) for each gap, i stepping by `stride`."""
    return [(i, i + g) for g in gaps for i in range(0, n_frames - g, stride)]
