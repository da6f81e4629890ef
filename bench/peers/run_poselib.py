#!/usr/bin/env python3
"""Peers benchmark: PoseLib (PyPI `poselib`) on simhc trials files.

    python3 run_poselib.py [--problem upnp|grps] [--repeats N] [--ransac-repeats N]
                           [--threshold-px 4] [--focal-px 800] TRIALS.json > results.jsonl

UPnP (alpha f + v = R p + t, (R, t) world -> viewer). PoseLib's generalized solvers use the same
convention: gp3p(p, x, X) solves p + lambda x = R X + t with p the ray origins (our v), x the
bearings (f), X the world points (p); CameraPose (q, t) maps world to camera, x_cam = R X + t.
So their pose is ours as is (checked on noise-free trials: errors ~1e-12).
  poselib.gp3p        first 3 correspondences; the solution with the least sum of angular errors
                      over all correspondences is kept
  poselib.gp4ps       first 4 correspondences (pose + unknown scale of the rig,
                      s v + lambda f = R p + t; filter_solutions=True); best on all correspondences
  poselib.gen_abs_ransac[...]
                      estimate_generalized_absolute_pose (LO-RANSAC with gp3p samples + LM
                      refinement): one camera per distinct ray origin v_c, PINHOLE with
                      fx = fy = 1, cx = cy = 0 (normalized coordinates), extrinsics R_c = I,
                      t_c = -v_c (x_cam = x_viewer - v_c); a camera any of whose bearings is more
                      than 45 deg off +z (points behind an identity pinhole occur in world-box and
                      --rigid trials) is instead turned to look along the mean of its bearings
                      (R_c rows: an orthonormal frame with z = mean bearing, t_c = -R_c v_c); the
                      count is printed. Threshold max_reproj_error = threshold_px / focal_px in
                      normalized coordinates (default 4 / 800: twice the largest 2 px noise
                      offset). Run with PoseLib's RANSAC defaults (min_iterations 1000) and with
                      min_iterations = 0 (adaptive stopping only), bundle loss CAUCHY, scale =
                      threshold / 2.

GRPS (alpha f + v = R (alpha' fp + vp) + t, view 2 -> view 1, scale 1):
  poselib.gen_relpose_6pt
                      first 6 correspondences (view 1 as PoseLib's first rig); its pose maps rig 1
                      into rig 2, so ours is (R^T, -R^T t); among the solutions the one with the
                      least generalized epipolar residual on the remaining correspondences (7th,
                      8th) is kept.

Timing: time.perf_counter_ns around each single call, repeated --repeats times (RANSAC:
--ransac-repeats), median reported as "micros"; "micros_total" includes the choice among
solutions. Nothing is subtracted: a meta line reports the cost of an empty Python call with the
same arguments and of a trivial PoseLib binding call, the floor of these measurements.
Output: JSON lines as run_opengv ({"solver", "trial", "rotation", "translation", "micros", ...}).
"""

import argparse
import json
import math
import sys
import time

import numpy as np
import poselib


def median_ns(repeats, fn):
    ts = []
    out = None
    for _ in range(repeats):
        t0 = time.perf_counter_ns()
        out = fn()
        t1 = time.perf_counter_ns()
        ts.append(t1 - t0)
    return float(np.median(ts)) / 1000.0, out


def emit(solver, trial, R, t, micros, micros_total=None, solutions=None, extra=None):
    rec = {"solver": solver, "trial": trial}
    if R is not None and t is not None and np.all(np.isfinite(R)) and np.all(np.isfinite(t)):
        rec["rotation"] = [[float(x) for x in r] for r in np.asarray(R)]
        rec["translation"] = [float(x) for x in np.asarray(t)]
    else:
        rec["rotation"] = None
        rec["translation"] = None
    rec["micros"] = round(micros, 4)
    rec["micros_total"] = round(micros if micros_total is None else micros_total, 4)
    if solutions is not None:
        rec["solutions"] = solutions
    if extra:
        rec.update(extra)
    print(json.dumps(rec))


# ---------------------------------------------------------------------------------------------
# UPnP
# ---------------------------------------------------------------------------------------------

def unit_rows(a):
    """Normalizes rows that are not unit already (within 1e-12); unit rows are passed on
    bit-for-bit (PoseLib's 6-point solver can change its answer for a 1-ulp change of a bearing)."""
    n = np.linalg.norm(a, axis=1, keepdims=True)
    return np.where(np.abs(n - 1.0) > 1e-12, a / n, a)


def angular_error_sum(R, t, P, F, V):
    y = P @ R.T + t - V
    c = np.linalg.norm(np.cross(F, y), axis=1)
    d = np.einsum("ij,ij->i", F, y)
    s = float(np.sum(np.arctan2(c, d)))
    return s if math.isfinite(s) else math.inf


def best_pose(poses, P, F, V):
    best, best_err = None, math.inf
    for pose in poses:
        R, t = pose.R, pose.t
        if not (np.all(np.isfinite(R)) and np.all(np.isfinite(t))):
            continue
        e = angular_error_sum(R, t, P, F, V)
        if best is None or e < best_err:
            best, best_err = (R, t), e
    return best


def look_along(m):
    """Rows of a rotation whose third row is the unit vector m (so R m = e_z)."""
    z = m / np.linalg.norm(m)
    a = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(a, z)
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    return np.stack([x, y, z])


def rig_input(P, F, V, stats):
    """Per-camera 2D points (normalized), 3D points, extrinsics and camera dicts."""
    groups = {}
    for i, v in enumerate(map(tuple, V)):
        groups.setdefault(v, []).append(i)
    pts2, pts3, exts, cams = [], [], [], []
    cos45 = math.cos(math.radians(45.0))
    for v, idx in groups.items():
        f = F[idx]
        v = np.array(v)
        if np.all(f[:, 2] / np.linalg.norm(f, axis=1) > cos45):
            Rc = np.eye(3)
        else:
            Rc = look_along(f.sum(axis=0))
            stats["rotated_cameras"] += 1
        fc = f @ Rc.T
        keep = fc[:, 2] > 1e-3
        stats["dropped_points"] += int(np.sum(~keep))
        if not np.any(keep):
            continue
        pts2.append(fc[keep, :2] / fc[keep, 2:3])
        pts3.append(P[np.array(idx)[keep]])
        ext = poselib.CameraPose()
        ext.R = Rc
        ext.t = -Rc @ v
        exts.append(ext)
        cams.append({"model": "PINHOLE", "width": 2, "height": 2, "params": [1.0, 1.0, 0.0, 0.0]})
        stats["cameras"] += 1
    return pts2, pts3, exts, cams


def run_upnp(trials, args):
    thr = args.threshold_px / args.focal_px
    ransac_configs = [
        ("poselib.gen_abs_ransac(default)", {"max_reproj_error": thr}),
        ("poselib.gen_abs_ransac(min_it=0)", {"max_reproj_error": thr, "min_iterations": 0}),
    ]
    bundle = {"loss_type": "CAUCHY", "loss_scale": thr / 2.0}
    stats = {"rotated_cameras": 0, "cameras": 0, "dropped_points": 0}
    for i, scene in enumerate(trials):
        C = scene["correspondences"]
        P = np.ascontiguousarray([c["p"] for c in C], dtype=float)
        F = np.ascontiguousarray(unit_rows(np.array([c["f"] for c in C], dtype=float)))
        V = np.ascontiguousarray([c["v"] for c in C], dtype=float)

        v3, f3, p3 = V[:3].copy(), F[:3].copy(), P[:3].copy()
        us, sols = median_ns(args.repeats, lambda: poselib.gp3p(v3, f3, p3))
        tot, best = median_ns(args.repeats, lambda: best_pose(poselib.gp3p(v3, f3, p3), P, F, V))
        emit("poselib.gp3p", i, *(best if best else (None, None)), us, tot, len(sols))

        v4, f4, p4 = V[:4].copy(), F[:4].copy(), P[:4].copy()
        us, (sols, scales) = median_ns(args.repeats, lambda: poselib.gp4ps(v4, f4, p4, True))
        tot, best = median_ns(args.repeats, lambda: best_pose(poselib.gp4ps(v4, f4, p4, True)[0], P, F, V))
        emit("poselib.gp4ps", i, *(best if best else (None, None)), us, tot, len(sols))

        pts2, pts3, exts, cams = rig_input(P, F, V, stats)
        for name, ropt in ransac_configs:
            us, (pose, info) = median_ns(
                args.ransac_repeats,
                lambda: poselib.estimate_generalized_absolute_pose(pts2, pts3, exts, cams, ropt, bundle),
            )
            emit(name, i, pose.R, pose.t, us, us, 1,
                 {"iterations": info.get("iterations"), "inliers": info.get("num_inliers")})
        if (i + 1) % 200 == 0:
            print(f"run_poselib: {i + 1}/{len(trials)}", file=sys.stderr)
    print(f"run_poselib: estimate_generalized_absolute_pose: {stats['cameras']} cameras, "
          f"{stats['rotated_cameras']} turned to their mean bearing (a bearing > 45 deg off +z), "
          f"{stats['dropped_points']} points dropped (behind the turned camera); threshold "
          f"{thr:.5g} normalized = {args.threshold_px:g} px at f = {args.focal_px:g}", file=sys.stderr)
    return stats


# ---------------------------------------------------------------------------------------------
# GRPS
# ---------------------------------------------------------------------------------------------

def epipolar_residuals(R, t, F1, V1, F2, V2):
    """Generalized epipolar residual of rays (v + a f) and (R vp + t + b R fp), view-1 frame."""
    g = F2 @ R.T
    o = V2 @ R.T + t
    return np.einsum("ij,ij->i", F1, np.cross(o, g)) + np.einsum("ij,ij->i", g, np.cross(V1, F1))


def run_grps(trials, args):
    for i, scene in enumerate(trials):
        C = scene["correspondences"]
        F1 = np.array([c["f"] for c in C], dtype=float)
        V1 = np.array([c["v"] for c in C], dtype=float)
        F2 = np.array([c["fp"] for c in C], dtype=float)
        V2 = np.array([c["vp"] for c in C], dtype=float)
        F1, F2 = unit_rows(F1), unit_rows(F2)
        if len(C) < 6:
            continue
        a, b, c_, d = V1[:6].copy(), F1[:6].copy(), V2[:6].copy(), F2[:6].copy()
        rest = slice(6, None) if len(C) > 6 else slice(0, None)

        def pick(poses):
            best, best_err = None, math.inf
            for pose in poses:
                R = pose.R.T                 # PoseLib: rig 1 -> rig 2; ours: view 2 -> view 1
                t = -R @ pose.t
                if not (np.all(np.isfinite(R)) and np.all(np.isfinite(t))):
                    continue
                e = float(np.sum(epipolar_residuals(R, t, F1[rest], V1[rest], F2[rest], V2[rest]) ** 2))
                if best is None or e < best_err:
                    best, best_err = (R, t), e
            return best

        us, sols = median_ns(args.repeats, lambda: poselib.gen_relpose_6pt(a, b, c_, d))
        tot, best = median_ns(args.repeats, lambda: pick(poselib.gen_relpose_6pt(a, b, c_, d)))
        emit("poselib.gen_relpose_6pt", i, *(best if best else (None, None)), us, tot, len(sols))


# ---------------------------------------------------------------------------------------------

def overhead(reps=20000):
    """Median cost of an empty Python call with three array arguments, and of a trivial PoseLib
    binding call (CameraPose()), measured like the solvers."""
    x = np.zeros((3, 3))

    def empty(a, b, c):
        return None

    py, _ = median_ns(reps, lambda: empty(x, x, x))
    pb, _ = median_ns(reps, lambda: poselib.CameraPose())
    return py, pb


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("trials")
    ap.add_argument("--problem", choices=["upnp", "grps"], default=None)
    ap.add_argument("--repeats", type=int, default=10, help="repeats per minimal-solver call (median)")
    ap.add_argument("--ransac-repeats", type=int, default=5, help="repeats per RANSAC call (median)")
    ap.add_argument("--threshold-px", type=float, default=4.0)
    ap.add_argument("--focal-px", type=float, default=800.0)
    args = ap.parse_args()
    with open(args.trials) as fh:
        trials = json.load(fh)
    problem = args.problem or ("grps" if "fp" in trials[0]["correspondences"][0] else "upnp")
    print(f"run_poselib: poselib {getattr(poselib, '__version__', '?')}, {len(trials)} {problem} trials "
          f"from {args.trials}, {args.repeats} repeats per call ({args.ransac_repeats} for RANSAC)", file=sys.stderr)
    py, pb = overhead()
    meta = {"source": "run_poselib.py", "poselib": getattr(poselib, "__version__", "?"),
            "empty_python_call_us": round(py, 3), "trivial_poselib_call_us": round(pb, 3),
            "timer": "perf_counter_ns per call, median of repeats, nothing subtracted"}
    if problem == "upnp":
        stats = run_upnp(trials, args)
        meta["gen_abs_cameras_turned"] = f"{stats['rotated_cameras']} of {stats['cameras']}"
        meta["gen_abs_threshold_normalized"] = round(args.threshold_px / args.focal_px, 6)
    else:
        run_grps(trials, args)
    print(json.dumps({"meta": meta}))
    print(f"run_poselib: empty Python call {py:.3f} us, trivial PoseLib binding call {pb:.3f} us", file=sys.stderr)


if __name__ == "__main__":
    main()
