"""KITTI odometry sequence 00 as shipped inside the `gtsam` wheel, and its reference poses.

    python bench/real/kitti.py [--force]     # (re)computes and caches the reference BA

Data (read from the installed package with `gtsam.findExampleDataFile`, never copied):
`VO_calibration00.txt` (fx fy skew cx cy baseline), `VO_camera_poses00.txt` (frame id, then the
left camera's 4x4 camera-to-world pose, row-major; 135 frames, ids 0..153 with gaps) and
`VO_stereo_factors00.txt` (frame landmark uL uR v X Y Z; X Y Z in that frame's left camera).

References:
- `vo`: the shipped visual-odometry poses (`VO_camera_poses00.txt`), not ground truth;
- `ba`: a stereo bundle adjustment of all shipped factors in GTSAM, as gtsam's
  `StereoVOExample_large` does (`GenericStereoFactor3D`, `Cal3_S2Stereo`, Levenberg-Marquardt,
  the first pose fixed, the VO poses and the factors' own triangulations as the start), with a
  Huber loss (k = 3 px) on the 1 px stereo noise so that wrong matches do not pull the poses
  (the example itself uses a plain Gaussian). Cached in `bench/real/cache/ba_poses.npz`
  (gitignored) with the command and gtsam version; `--force` recomputes.
"""

import argparse
import os
import sys
import time
from dataclasses import dataclass

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
CACHE = os.path.join(HERE, "cache", "ba_poses.npz")
HUBER_K = 3.0


@dataclass
class Calibration:
    fx: float
    fy: float
    skew: float
    cx: float
    cy: float
    baseline: float


@dataclass
class Kitti:
    calib: Calibration
    ids: np.ndarray        # (F,) frame ids, ascending
    vo: np.ndarray         # (F, 4, 4) shipped left-camera poses, camera to world
    factors: np.ndarray    # (M, 8) frame landmark uL uR v X Y Z

    def frame_factors(self, k):
        """The factors of the k-th frame (by position in `ids`), as a dict landmark -> row."""
        rows = self.factors[self._start[k]:self._start[k + 1]]
        return {int(r[1]): r for r in rows}

    def __post_init__(self):
        order = np.argsort(self.factors[:, 0], kind="stable")
        self.factors = self.factors[order]
        pos = np.searchsorted(self.factors[:, 0], self.ids)
        self._start = np.append(pos, len(self.factors))


def data_file(name):
    import gtsam

    path = gtsam.findExampleDataFile(name)
    if not path or not os.path.isfile(path):
        raise FileNotFoundError(f"{name}: not found in the installed gtsam package (pip install gtsam)")
    return path


def load():
    """The calibration, shipped poses and stereo factors, checked for shape."""
    c = np.loadtxt(data_file("VO_calibration00.txt"))
    if c.shape != (6,):
        raise ValueError(f"VO_calibration00.txt: expected 6 numbers, got shape {c.shape}")
    p = np.loadtxt(data_file("VO_camera_poses00.txt"))
    if p.ndim != 2 or p.shape[1] != 17:
        raise ValueError(f"VO_camera_poses00.txt: expected rows of 17 numbers, got shape {p.shape}")
    f = np.loadtxt(data_file("VO_stereo_factors00.txt"))
    if f.ndim != 2 or f.shape[1] != 8:
        raise ValueError(f"VO_stereo_factors00.txt: expected rows of 8 numbers, got shape {f.shape}")
    ids = p[:, 0].astype(int)
    if np.any(np.diff(ids) <= 0):
        raise ValueError("VO_camera_poses00.txt: frame ids are not increasing")
    unknown = set(f[:, 0].astype(int)) - set(ids.tolist())
    if unknown:
        raise ValueError(f"VO_stereo_factors00.txt: frames without a pose: {sorted(unknown)[:5]}")
    return Kitti(Calibration(*c), ids, p[:, 1:].reshape(-1, 4, 4), f)


def bundle_adjust(data, verbose=True, positions=None):
    """Stereo BA of all factors (GTSAM, LM); returns (F, 4, 4) camera-to-world poses.
    `positions`: only these frames (by position) and their factors, the first one fixed (a
    windowed BA of seconds, for the test); the poses of the other frames are returned as VO's."""
    import gtsam
    from gtsam.symbol_shorthand import L, X

    c = data.calib
    K = gtsam.Cal3_S2Stereo(c.fx, c.fy, c.skew, c.cx, c.cy, c.baseline)
    noise = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(HUBER_K), gtsam.noiseModel.Isotropic.Sigma(3, 1.0))
    graph = gtsam.NonlinearFactorGraph()
    values = gtsam.Values()
    keep = list(range(len(data.ids))) if positions is None else sorted(set(positions))
    for k in keep:
        values.insert(X(int(data.ids[k])), gtsam.Pose3(data.vo[k]))
    pose_of = {int(data.ids[k]): data.vo[k] for k in keep}
    rows = data.factors if positions is None else data.factors[np.isin(data.factors[:, 0], data.ids[keep])]
    for r in rows:
        fid, lid = int(r[0]), int(r[1])
        graph.add(gtsam.GenericStereoFactor3D(gtsam.StereoPoint2(r[2], r[3], r[4]), noise, X(fid), L(lid), K))
        if not values.exists(L(lid)):
            T = pose_of[fid]
            values.insert(L(lid), T[:3, :3] @ r[5:8] + T[:3, 3])
    first = int(data.ids[keep[0]])
    graph.add(gtsam.NonlinearEqualityPose3(X(first), values.atPose3(X(first))))
    params = gtsam.LevenbergMarquardtParams()
    params.setMaxIterations(100)
    t0 = time.perf_counter()
    e0 = graph.error(values)
    result = gtsam.LevenbergMarquardtOptimizer(graph, values, params).optimize()
    if verbose:
        print(f"reference BA: {len(rows)} stereo factors, {len(keep)} poses, error {e0:.1f} -> "
              f"{graph.error(result):.1f} in {time.perf_counter() - t0:.1f} s", file=sys.stderr)
    out = data.vo.copy()
    for k in keep:
        out[k] = result.atPose3(X(int(data.ids[k]))).matrix()
    return out


def reference(data, force=False, verbose=True):
    """The BA poses, from the cache when it matches this data (else computed and cached)."""
    import gtsam

    if not force and os.path.isfile(CACHE):
        z = np.load(CACHE)
        if np.array_equal(z["ids"], data.ids) and float(z["huber_k"]) == HUBER_K:
            return z["poses"]
    poses = bundle_adjust(data, verbose)
    os.makedirs(os.path.dirname(CACHE), exist_ok=True)
    np.savez(CACHE, poses=poses, ids=data.ids, huber_k=HUBER_K, command="python bench/real/kitti.py --force",
             gtsam_file=gtsam.findExampleDataFile("VO_stereo_factors00.txt"))
    return poses


def relative(T_i, T_j):
    """Frame j's left camera in frame i's: T_i^-1 T_j (so X_i = R X_j + t)."""
    return np.linalg.inv(T_i) @ T_j


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--force", action="store_true", help="recompute the BA even if cached")
    a = ap.parse_args()
    data = load()
    ba = reference(data, force=a.force)
    d = [np.linalg.norm(ba[k][:3, 3] - data.vo[k][:3, 3]) for k in range(len(data.ids))]
    ang = [np.degrees(np.arccos(np.clip((np.trace(ba[k][:3, :3].T @ data.vo[k][:3, :3]) - 1) / 2, -1, 1))) for k in range(len(data.ids))]
    print(f"BA vs VO poses: position differs by median {np.median(d):.3f} m (max {np.max(d):.3f}), "
          f"orientation by median {np.median(ang):.3f} deg (max {np.max(ang):.3f})")


if __name__ == "__main__":
    main()
