#!/usr/bin/env python3
"""Seeded trial generator for the peers benchmark (UPnP and GRPS), in simhc's --trials-file JSON.

UPnP scene (simhc `UpnpScene`):
    {"correspondences": [{"p": [x,y,z], "f": [x,y,z], "v": [x,y,z]}, ...],
     "rotation": [[..],[..],[..]] (row-major), "translation": [x,y,z]}
with  alpha_i f_i + v_i = R p_i + t,  alpha_i > 0  (p world point; f unit bearing and v ray
origin in the viewer frame; (R, t) maps world into viewer coordinates).

GRPS scene (simhc `GrpsScene`):
    {"correspondences": [{"f": .., "v": .., "fp": .., "vp": ..}, ...],
     "rotation": [[..]], "translation": [..], "scale": s}
with  alpha f + v = R (alpha' fp + s vp) + t  (view 2 mapped into view 1); here s = 1.

All randomness comes from ONE numpy Generator, default_rng(seed), drawn scene after scene in a
fixed order (documented per sampler below), so a (seed, options) pair always gives the same file.
"""

import argparse
import json
import math
import sys

import numpy as np

HALF_PI = math.pi / 2


# ---------------------------------------------------------------------------------------------
# small helpers
# ---------------------------------------------------------------------------------------------

def euler_rotation(rng, max_angle=HALF_PI):
    """R = Rz(yaw) Ry(pitch) Rx(roll); roll, pitch, yaw drawn (in that order) in [-max, max]."""
    roll, pitch, yaw = rng.uniform(-max_angle, max_angle, size=3)
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    ry = np.array([[cp, 0, sp], [0, 1, 0], [-sp, 0, cp]])
    rz = np.array([[cy, -sy, 0], [sy, cy, 0], [0, 0, 1]])
    return rz @ ry @ rx


def uniform_rotation(rng):
    """A rotation uniform on SO(3): a normalized 4D Gaussian as a unit quaternion."""
    q = rng.standard_normal(4)
    q /= np.linalg.norm(q)
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
    ])


def in_box(rng, lo, hi, n=None):
    lo = np.asarray(lo, dtype=float)
    hi = np.asarray(hi, dtype=float)
    size = 3 if n is None else (n, 3)
    return lo + (hi - lo) * rng.random(size)


def normalize(x):
    return x / np.linalg.norm(x)


def tangent_basis(f):
    """OpenGV's tangent basis at unit f: n1 from the largest-magnitude coordinate, n2 = f x n1
    (ties go to the earlier coordinate, like simhc)."""
    x, y, z = f
    if abs(x) >= abs(y) and abs(x) >= abs(z):
        n1 = np.array([-y / x, 1.0, 0.0])
    elif abs(y) >= abs(z):
        n1 = np.array([0.0, -z / y, 1.0])
    else:
        n1 = np.array([1.0, 0.0, -x / z])
    n1 = normalize(n1)
    return n1, np.cross(f, n1)


def add_noise(f, noise_px, focal_px, rng):
    """OpenGV's addNoise: normalize(focal f + e1 n1 + e2 n2), e1, e2 ~ U[-noise/sqrt2, noise/sqrt2].
    Always draws two numbers (also for noise 0), so the geometry of a seed does not depend on
    the noise level."""
    u = rng.random(2)
    f = normalize(f)
    n1, n2 = tangent_basis(f)
    amp = noise_px / math.sqrt(2.0)
    e1, e2 = amp * (2 * u - 1)
    return normalize(focal_px * f + e1 * n1 + e2 * n2)


def lst(a):
    return [float(x) for x in np.asarray(a).ravel()]


def rows(m):
    return [[float(x) for x in r] for r in np.asarray(m)]


# ---------------------------------------------------------------------------------------------
# UPnP
# ---------------------------------------------------------------------------------------------

def sample_upnp(rng, args, stats):
    """One UPnP scene. Draw order per attempt: roll, pitch, yaw; t (3); camera centres (cameras x 3);
    points (points x 3); then, after acceptance, 2 noise draws per bearing in order; then (with
    --rigid) W (4 normals), t_w (3), V (4 normals), t_v (3)."""
    while True:
        rot = euler_rotation(rng)
        t = in_box(rng, [-1, -1, -1], [1, 1, 1])
        cams = in_box(rng, [-1, -1, -1], [1, 1, 1], args.cameras)
        box = in_box(rng, [-1, -1, 4], [1, 1, 8], args.points)
        v = cams[np.arange(args.points) % args.cameras]
        if args.variant == "world-box":
            p = box                          # world points drawn in the WORLD frame
            x = p @ rot.T + t                # their viewer-frame coordinates R p + t
        else:
            x = box                          # points drawn in the VIEWER frame (simhc's sampler)
            p = (x - t) @ rot                # p = R^T (X - t)
        d = x - v
        f = d / np.linalg.norm(d, axis=1, keepdims=True)
        alpha = np.einsum("ij,ij->i", f, d)  # depth along the bearing
        if np.all(alpha > 0):
            break
        stats["rejected"] += 1
    stats["behind_pinhole"] += int(np.sum(f[:, 2] <= 0))
    stats["scenes_behind_pinhole"] += int(np.any(f[:, 2] <= 0))
    f_clean = f.copy()
    f = np.array([add_noise(fi, args.noise_px, args.focal_px, rng) for fi in f])
    R, tt = rot, t
    if args.rigid:
        W = uniform_rotation(rng)
        t_w = in_box(rng, [-10] * 3, [10] * 3)
        V = uniform_rotation(rng)
        t_v = in_box(rng, [-10] * 3, [10] * 3)
        p = p @ W.T + t_w                    # p' = W p + t_w
        f = f @ V.T                          # f' = V f (the noisy bearing: same noise, new frame)
        f_clean = f_clean @ V.T
        v = v @ V.T + t_v                    # v' = V v + t_v
        R = V @ rot @ W.T                    # R' = V R W^T
        tt = V @ (t - rot @ W.T @ t_w) + t_v  # t' = V (t - R W^T t_w) + t_v
    # exact check of the convention on the noise-free bearings: alpha f + v = R p + t
    y = p @ R.T + tt - v
    alpha = np.einsum("ij,ij->i", f_clean, y)
    resid = np.max(np.linalg.norm(alpha[:, None] * f_clean - y, axis=1))
    scale = max(1.0, float(np.max(np.abs(y))))
    stats["max_resid"] = max(stats["max_resid"], resid / scale)
    stats["min_alpha"] = min(stats["min_alpha"], float(alpha.min()))
    if resid > 1e-9 * scale or alpha.min() <= 0:
        raise AssertionError(f"convention check failed: residual {resid:.3e}, min alpha {alpha.min():.3e}")
    return {
        "correspondences": [{"p": lst(p[i]), "f": lst(f[i]), "v": lst(v[i])} for i in range(args.points)],
        "rotation": rows(R),
        "translation": lst(tt),
    }


# ---------------------------------------------------------------------------------------------
# GRPS
# ---------------------------------------------------------------------------------------------

def sample_grps(rng, args, stats):
    """One GRPS scene, simhc's model with the scale fixed to 1. Draw order: R1 (roll, pitch, yaw),
    o1 (3), R2, o2, camera offsets of view 1 (cameras x 3), of view 2 (cameras x 3), points
    X in [-1,1]^2 x [2,20] (world; a point closer than 1e-6 to one of its ray origins is redrawn),
    2 noise draws per f, then per f'; then (with --rigid) V1, a1, V2, a2."""
    r1 = euler_rotation(rng)
    o1 = in_box(rng, [-1] * 3, [1] * 3)
    r2 = euler_rotation(rng)
    o2 = in_box(rng, [-1] * 3, [1] * 3)
    cams1 = in_box(rng, [-1] * 3, [1] * 3, args.cameras)
    cams2 = in_box(rng, [-1] * 3, [1] * 3, args.cameras)
    f, v, fp, vp = [], [], [], []
    for i in range(args.points):
        c = i % args.cameras
        while True:
            x = in_box(rng, [-1, -1, 2], [1, 1, 20])
            d1 = r1.T @ (x - o1) - cams1[c]
            d2 = r2.T @ (x - o2) - cams2[c]
            if np.linalg.norm(d1) >= 1e-6 and np.linalg.norm(d2) >= 1e-6:
                break
        f.append(normalize(d1))
        v.append(cams1[c])
        fp.append(normalize(d2))
        vp.append(cams2[c])
    f, v, fp, vp = map(np.array, (f, v, fp, vp))
    f_clean, fp_clean = f.copy(), fp.copy()
    f = np.array([add_noise(x, args.noise_px, args.focal_px, rng) for x in f])
    fp = np.array([add_noise(x, args.noise_px, args.focal_px, rng) for x in fp])
    R = r1.T @ r2
    t = r1.T @ (o2 - o1)
    if args.rigid:
        V1 = uniform_rotation(rng)
        a1 = in_box(rng, [-10] * 3, [10] * 3)
        V2 = uniform_rotation(rng)
        a2 = in_box(rng, [-10] * 3, [10] * 3)
        f, f_clean, v = f @ V1.T, f_clean @ V1.T, v @ V1.T + a1
        fp, fp_clean, vp = fp @ V2.T, fp_clean @ V2.T, vp @ V2.T + a2
        t = V1 @ (t - R @ V2.T @ a2) + a1     # Y1' = V1 Y1 + a1, Y2' = V2 Y2 + a2
        R = V1 @ R @ V2.T
    # check alpha f + v = R (alpha' fp + vp) + t on the noise-free rays: the two rays meet.
    worst = 0.0
    for i in range(args.points):
        a = np.stack([f_clean[i], -(R @ fp_clean[i])], axis=1)
        b = R @ vp[i] + t - v[i]
        depths, *_ = np.linalg.lstsq(a, b, rcond=None)
        gap = np.linalg.norm(a @ depths - b) / max(1.0, np.linalg.norm(b))
        worst = max(worst, gap)
        stats["min_alpha"] = min(stats["min_alpha"], float(depths.min()))
        if gap > 1e-9 or depths.min() <= 0:
            raise AssertionError(f"convention check failed: gap {gap:.3e}, depths {depths}")
    stats["max_resid"] = max(stats["max_resid"], worst)
    return {
        "correspondences": [
            {"f": lst(f[i]), "v": lst(v[i]), "fp": lst(fp[i]), "vp": lst(vp[i])} for i in range(args.points)
        ],
        "rotation": rows(R),
        "translation": lst(t),
        "scale": 1.0,
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--problem", choices=["upnp", "grps"], default="upnp")
    ap.add_argument("--variant", choices=["world-box", "viewer-box"], default="world-box",
                    help="UPnP: where the 16 points are drawn uniformly ([-1,1]^2 x [4,8]): in the world "
                         "frame (the paper's text read literally) or in the viewer frame (simhc's sampler)")
    ap.add_argument("--trials", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--noise-px", type=float, default=None,
                    help="bearing noise in pixels at --focal-px (default: 2 for upnp, 0 for grps)")
    ap.add_argument("--focal-px", type=float, default=800.0)
    ap.add_argument("--points", type=int, default=None, help="correspondences (default: 16 upnp, 8 grps)")
    ap.add_argument("--cameras", type=int, default=None, help="cameras (default: 4 upnp, 3 per view grps)")
    ap.add_argument("--rigid", action="store_true",
                    help="apply a random rigid change to the world and viewer frames (ground truth adjusted)")
    ap.add_argument("--out", "-o", default="-", help="output file (default: stdout)")
    args = ap.parse_args()
    if args.noise_px is None:
        args.noise_px = 2.0 if args.problem == "upnp" else 0.0
    if args.points is None:
        args.points = 16 if args.problem == "upnp" else 8
    if args.cameras is None:
        args.cameras = 4 if args.problem == "upnp" else 3

    rng = np.random.default_rng(args.seed)
    stats = {"rejected": 0, "behind_pinhole": 0, "scenes_behind_pinhole": 0, "max_resid": 0.0, "min_alpha": math.inf}
    sampler = sample_upnp if args.problem == "upnp" else sample_grps
    scenes = [sampler(rng, args, stats) for _ in range(args.trials)]

    text = json.dumps(scenes)
    if args.out == "-":
        sys.stdout.write(text + "\n")
    else:
        with open(args.out, "w") as fh:
            fh.write(text + "\n")
    desc = f"problem {args.problem}" + (f", variant {args.variant}" if args.problem == "upnp" else "")
    print(f"gen_trials: seed {args.seed}, {desc}, {args.trials} trials, {args.points} points, "
          f"{args.cameras} cameras{' per view' if args.problem == 'grps' else ''}, noise {args.noise_px} px "
          f"at f = {args.focal_px:g}, rigid {'yes' if args.rigid else 'no'} -> {args.out}", file=sys.stderr)
    if args.problem == "upnp":
        print(f"gen_trials: {stats['rejected']} scenes rejected and resampled for a non-positive depth "
              f"alpha_i = f_i.(R p_i + t - v_i) (f_i is that vector normalized, so this is ~never)", file=sys.stderr)
        if not args.rigid:
            print(f"gen_trials: {stats['behind_pinhole']} of {args.trials * args.points} bearings "
                  f"({stats['scenes_behind_pinhole']} scenes) have f_z <= 0, i.e. lie behind a +z-looking "
                  f"pinhole at the ray origin (no constraint for a generalized camera)", file=sys.stderr)
    print(f"gen_trials: convention check on the noise-free data: max relative residual "
          f"{stats['max_resid']:.2e}, min depth {stats['min_alpha']:.3f}", file=sys.stderr)


if __name__ == "__main__":
    main()
