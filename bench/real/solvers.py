"""The runners: simhc and PoseLib on one frame pair's correspondences (`correspondences.Pair`).

Every runner returns a dict {ok, R, t, s, mask, ms, error} in one convention per problem:
- `relpose`, `grps`: X_i = R (s X_j) + t (frame j's rig into frame i's; s = 1 for `relpose`);
- `upnp`: frame i is the world, alpha f + v = R p + t (frame-i coordinates into frame j's rig).

Thresholds: one threshold `px` in pixels for both sides. simhc's estimators take an angle in
radians (`gen_relpose.estimate`, the example problem's module: the Sampson error of the coplanarity as an angle, both bearings
noisy; `simhc.grps.estimate`: the sine of the angle between a bearing and its triangulated point, both
views; `simhc.upnp.estimate`: the angle between a bearing and the direction to its point), so simhc
gets `px / fx`; PoseLib gets pixels with KITTI's real pinhole cameras (`max_epipolar_error`,
a Sampson error in pixels; `max_reproj_error`), which it divides by the focal length itself.
Iteration bounds: PoseLib's defaults on both sides (min 1000, max 100000, confidence 0.9999).

Input scaling for simhc (`scale`): its learned starts were trained on synthetic scenes of order
one (camera offsets in [-1, 1]^3, depths 2-20). `scale=None` passes KITTI's metres as they are;
a number L applies the similarity X' = (X - c) / L to both rigs (c: the rig's centre, midway
between its two cameras; for UPnP the world, frame i, is moved with frame i's rig) and undoes it
on the result. PoseLib always gets the metric data (it does not need it).
"""

import time

import numpy as np
import poselib

import gen_relpose
import simhc

# The focal length (pixels) that simhc's `noise` argument refers to (python/src/builtin.rs and
# the example problem's FOCAL_PX).
SIMHC_FOCAL = 800.0


def quaternion_rotation(q):
    """The rotation of a quaternion [w, x, y, z] (normalized first), as the example crate's `pose`."""
    w, x, y, z = np.asarray(q, float) / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def _failed(ms, error, n):
    return {"ok": False, "R": None, "t": None, "s": None, "mask": np.zeros(n, bool), "ms": ms, "error": error}


def _rig_centre(v):
    """Midway between the rig's two camera centres, from the distinct ray origins."""
    u = np.unique(v, axis=0)
    return u.mean(axis=0)


# ---------------------------------------------------------------- simhc


def simhc_relpose(pair, calib, px, noise_px, seed, scale, grps=False, s_true=1.0, min_iterations=1000, skip_explained=False):
    """gen_relpose.estimate (or simhc.grps.estimate with frame j's offsets divided by
    `s_true`, so that the true scale is `s_true`)."""
    f1, v1, f2 = pair.f1, pair.v1, pair.f2
    v2 = pair.v2 / s_true
    c1, c2, L = np.zeros(3), np.zeros(3), 1.0
    if scale is not None:
        c1, c2, L = _rig_centre(v1), _rig_centre(v2), float(scale)
    v1n, v2n = (v1 - c1) / L, (v2 - c2) / L
    th = px / calib.fx
    t0 = time.perf_counter()
    try:
        if grps:
            pose, info = simhc.grps.estimate(f1, v1n, f2, v2n, threshold=th, seed=seed, min_iterations=min_iterations,
                                             skip_explained=skip_explained)
            R, t_unit = np.array(pose.R), np.array(pose.t)
        else:
            x, info = gen_relpose.estimate(np.hstack([f1, v1n, f2, v2n]), threshold=th, noise=noise_px * SIMHC_FOCAL / calib.fx, seed=seed,
                                   min_iterations=min_iterations, skip_explained=skip_explained)
            R, t_unit = quaternion_rotation(x["q"]), np.array(x["t"])
    except (simhc.SolveError, gen_relpose.SolveError) as e:
        return _failed((time.perf_counter() - t0) * 1e3, f"{type(e).__name__}: {e}", len(f1))
    ms = (time.perf_counter() - t0) * 1e3
    s = float(pose.s) if grps else 1.0
    t = L * t_unit - s * R @ c2 + c1
    return {"ok": True, "R": R, "t": t, "s": s if grps else None, "mask": np.asarray(info["inlier_mask"], bool), "ms": ms, "error": None,
            "iterations": int(info["iterations"]), "models": int(info["models"])}


def simhc_upnp(pair, calib, px, noise_px, seed, scale, min_iterations=1000, skip_explained=False):
    """simhc.upnp.estimate: frame i's triangulated points against frame j's rays."""
    p, f, v = pair.points, pair.f2, pair.v2
    c, L = np.zeros(3), 1.0
    if scale is not None:
        c, L = _rig_centre(np.vstack([pair.v1, v])), float(scale)
    th = px / calib.fx
    t0 = time.perf_counter()
    try:
        pose, info = simhc.upnp.estimate((p - c) / L, f, (v - c) / L, threshold=th, noise=noise_px * SIMHC_FOCAL / calib.fx, seed=seed,
                                         min_iterations=min_iterations, skip_explained=skip_explained)
    except simhc.SolveError as e:
        return _failed((time.perf_counter() - t0) * 1e3, f"{type(e).__name__}: {e}", len(p))
    ms = (time.perf_counter() - t0) * 1e3
    R = np.array(pose.R)
    t = L * np.array(pose.t) - R @ c + c
    return {"ok": True, "R": R, "t": t, "s": None, "mask": np.asarray(info["inlier_mask"], bool), "ms": ms, "error": None,
            "iterations": int(info["iterations"]), "models": int(info["models"])}


# ---------------------------------------------------------------- PoseLib


def _cameras(calib):
    cam = {"model": "PINHOLE", "width": 1241, "height": 376, "params": [calib.fx, calib.fy, calib.cx, calib.cy]}
    exts = []
    for c in ([0.0, 0.0, 0.0], [calib.baseline, 0.0, 0.0]):
        e = poselib.CameraPose()
        e.R = np.eye(3)
        e.t = -np.array(c)  # x_cam = x_rig - c
        exts.append(e)
    return [cam, cam], exts


def poselib_relpose(pair, calib, px, min_iterations=1000):
    """PoseLib estimate_generalized_relative_pose on the same pixels, grouped by camera pair."""
    cams, exts = _cameras(calib)
    groups, order = [], []
    for a in (0, 1):
        for b in (0, 1):
            k = np.flatnonzero((pair.cam1 == a) & (pair.cam2 == b))
            if len(k) == 0:
                continue
            m = poselib.PairwiseMatches()
            m.cam_id1, m.cam_id2 = a, b
            m.x1, m.x2 = pair.px1[k], pair.px2[k]
            groups.append(m)
            order.append(k)
    t0 = time.perf_counter()
    pose, info = poselib.estimate_generalized_relative_pose(groups, exts, cams, exts, cams, {"max_epipolar_error": px, "min_iterations": min_iterations}, {})
    ms = (time.perf_counter() - t0) * 1e3
    mask = np.zeros(len(pair.f1), bool)
    for k, inl in zip(order, info.get("inliers", [])):
        mask[k] = np.asarray(inl, bool)
    if not mask.any():
        return _failed(ms, "no inliers", len(pair.f1))
    # PoseLib's pose maps rig i to rig j (X_j = R X_i + t); ours is its inverse.
    R, t = np.array(pose.R), np.array(pose.t)
    return {"ok": True, "R": R.T, "t": -R.T @ t, "s": None, "mask": mask, "ms": ms, "error": None, "iterations": int(info["iterations"])}


def poselib_upnp(pair, calib, px, min_iterations=1000):
    """PoseLib estimate_generalized_absolute_pose on the same pixels and points."""
    cams, exts = _cameras(calib)
    ks = [np.flatnonzero(pair.cam2 == c) for c in (0, 1)]
    t0 = time.perf_counter()
    pose, info = poselib.estimate_generalized_absolute_pose([pair.px2[k] for k in ks], [pair.points[k] for k in ks], exts, cams,
                                                            {"max_reproj_error": px, "min_iterations": min_iterations}, {})
    ms = (time.perf_counter() - t0) * 1e3
    mask = np.zeros(len(pair.points), bool)
    for k, inl in zip(ks, info.get("inliers", [])):
        mask[k] = np.asarray(inl, bool)
    if not mask.any():
        return _failed(ms, "no inliers", len(pair.points))
    return {"ok": True, "R": np.array(pose.R), "t": np.array(pose.t), "s": None, "mask": mask, "ms": ms, "error": None, "iterations": int(info["iterations"])}


# ---------------------------------------------------------------- errors


def truth(problem, T_i, T_j):
    """(R, t) of the problem's convention from two camera-to-world poses."""
    M = np.linalg.inv(T_i) @ T_j if problem != "upnp" else np.linalg.inv(T_j) @ T_i
    return M[:3, :3], M[:3, 3]


def rotation_angle(M):
    """The angle (deg) of a rotation matrix, accurate near 0 (atan2, not arccos)."""
    w = np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])
    return float(np.degrees(np.arctan2(np.linalg.norm(w) / 2, (np.trace(M) - 1) / 2)))


def errors(res, Rg, tg, sg=None):
    """E_R (deg), E_t (% of the motion), translation direction (deg), E_s (%), success."""
    if not res["ok"]:
        return {"ok": False, "success": False, "e_R": np.nan, "e_t": np.nan, "e_dir": np.nan, "e_s": np.nan}
    R, t = res["R"], res["t"]
    e_R = rotation_angle(R @ Rg.T)
    e_t = 100 * np.linalg.norm(t - tg) / np.linalg.norm(tg)
    e_dir = float(np.degrees(np.arctan2(np.linalg.norm(np.cross(t, tg)), t @ tg)))
    e_s = 100 * abs(res["s"] - sg) / sg if (sg is not None and res["s"] is not None) else np.nan
    success = bool(e_R < 1 and (e_dir < 5 or e_t < 5))
    return {"ok": True, "success": success, "e_R": e_R, "e_t": e_t, "e_dir": e_dir, "e_s": e_s}
