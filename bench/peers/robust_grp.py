"""Robust generalized relative pose, side by side on identical data: simhc's estimator
(`grp_robust`, the example crate's `Solver::estimate`) against PoseLib's
`estimate_generalized_relative_pose` (defaults, from Python).

    python3 bench/peers/robust_grp.py --trials 100 --seed 1 --outliers 0.2 [--noise-px 1]

Scenes (one seeded numpy generator, seed printed): rig 1 at the origin and rig 2, each of 4
cameras looking along +z with centres in [-1, 1]^3; rig 2 turned by up to 30 deg and moved by
up to 2 in each axis; 100-200 points in [-4, 4]^2 x [4, 20] seen by a random camera of each rig,
in front of both; bearing noise of `--noise-px` pixels at focal 800; a fraction `--outliers` of
the correspondences get a random bearing in rig 2. Convention: X1 = R X2 + t.

Success: E_R < 2 deg and E_t < 5 %. Inlier recall: true inliers marked inliers. Time: wall time
of one call (PoseLib's from Python, its binding included). Threshold: 3 sqrt(2) sigma of the
bearing angles, as an angle for simhc (its `row_error`, radians) and as a distance in the
normalized image plane for PoseLib (`max_epipolar_error`, its cameras have focal 1).
"""

import argparse
import json
import math
import os
import subprocess
import sys
import time

import numpy as np
import poselib

FOCAL = 800.0


def rotation(axis, angle):
    axis = axis / np.linalg.norm(axis)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def perturb(f, sigma, rng):
    if sigma == 0:
        return f
    n = rng.normal(0, sigma, 3)
    g = f + (n - f * f.dot(n))
    return g / np.linalg.norm(g)


def scene(rng, outliers, sigma):
    R = rotation(rng.normal(size=3), math.radians(rng.uniform(0, 30)))
    t = rng.uniform(-2, 2, 3)
    cams1 = rng.uniform(-1, 1, (4, 3))
    cams2 = rng.uniform(-1, 1, (4, 3))
    n = int(rng.integers(100, 201))
    rows, matches, inlier = [], [], []
    while len(rows) < n:
        X = np.array([rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(4, 20)])
        i, j = int(rng.integers(4)), int(rng.integers(4))
        X2 = R.T @ (X - t)
        d1, d2 = X - cams1[i], X2 - cams2[j]
        if d1[2] < 0.5 or d2[2] < 0.5:
            continue
        f = perturb(d1 / np.linalg.norm(d1), sigma, rng)
        fp = perturb(d2 / np.linalg.norm(d2), sigma, rng)
        out = rng.uniform() < outliers
        if out:
            # A wrong match: a random bearing of rig 2's camera, in its field of view.
            fp = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), 1.0])
            fp /= np.linalg.norm(fp)
        rows.append([*f, *cams1[i], *fp, *cams2[j]])
        matches.append((i, j, f, fp))
        inlier.append(not out)
    return {"rows": rows, "R": R.tolist(), "t": t.tolist(), "inlier": inlier, "matches": matches, "cams1": cams1, "cams2": cams2}


def errors(R, t, Rg, tg):
    R, t, Rg, tg = np.array(R), np.array(t), np.array(Rg), np.array(tg)
    c = np.clip((np.trace(R @ Rg.T) - 1) / 2, -1, 1)
    return math.degrees(math.acos(c)), 100 * np.linalg.norm(t - tg) / np.linalg.norm(tg)


def run_poselib(tr, threshold, min_iterations=1000):
    """PoseLib with its defaults but the threshold and the minimum of iterations (its default
    1000); returns (R, t, mask, micros) in our convention."""
    groups = {}
    for k, (i, j, f, fp) in enumerate(tr["matches"]):
        groups.setdefault((i, j), []).append(k)
    pm = []
    for (i, j), ks in groups.items():
        m = poselib.PairwiseMatches()
        m.cam_id1, m.cam_id2 = i, j
        m.x1 = np.array([tr["matches"][k][2][:2] / tr["matches"][k][2][2] for k in ks])
        m.x2 = np.array([tr["matches"][k][3][:2] / tr["matches"][k][3][2] for k in ks])
        pm.append(m)

    def ext(c):
        e = poselib.CameraPose()
        e.R = np.eye(3)
        e.t = -c
        return e

    exts1 = [ext(c) for c in tr["cams1"]]
    exts2 = [ext(c) for c in tr["cams2"]]
    cam = {"model": "PINHOLE", "width": 2, "height": 2, "params": [1.0, 1.0, 0.0, 0.0]}
    t0 = time.perf_counter()
    pose, info = poselib.estimate_generalized_relative_pose(pm, exts1, [cam] * 4, exts2, [cam] * 4, {"max_epipolar_error": threshold, "min_iterations": min_iterations}, {})
    micros = (time.perf_counter() - t0) * 1e6
    # PoseLib's pose maps rig 1 to rig 2 (X2 = R X1 + t); ours is its inverse.
    R = pose.R.T
    t = -pose.R.T @ pose.t
    mask = np.zeros(len(tr["matches"]), dtype=bool)
    flat = [k for ks in groups.values() for k in ks]
    for k, inl in zip(flat, [b for m in info.get("inliers", []) for b in np.atleast_1d(m)]):
        mask[k] = bool(inl)
    return R, t, mask, micros, info


def common_arguments():
    """The arguments of both robust scripts (this one and robust_upnp.py)."""
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=100)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--outliers", type=float, default=0.2)
    ap.add_argument("--noise-px", type=float, default=1.0)
    return ap


def print_table(table):
    """One row per solver of `table` ({name: [(success, recall, micros, E_R deg, E_t %), ..]}),
    the trials each failed, and the median times {name: us}. The median errors are over all
    trials (a trial without a model counts as infinite)."""
    print("| solver | success % | inlier recall % (median) | E_R deg (median) | E_t % (median) | t med us | t mean us |")
    print("|---|---|---|---|---|---|---|")
    medians = {}
    for name, rows in table.items():
        ok = np.array([r[0] for r in rows])
        recall = np.array([r[1] for r in rows])
        us = np.array([r[2] for r in rows])
        er = np.array([r[3] for r in rows])
        et = np.array([r[4] for r in rows])
        medians[name] = np.median(us)
        print(f"| {name} | {100 * ok.mean():.1f} | {100 * np.median(recall):.1f} | {np.median(er):.3f} | {np.median(et):.2f} "
              f"| {np.median(us):.0f} | {us.mean():.0f} |")
    for name, rows in table.items():
        failed = [k for k, r in enumerate(rows) if not r[0]]
        if failed:
            print(f"  {name} failed trials: {failed[:20]}")
    return medians


def main():
    ap = common_arguments()
    ap.add_argument("--runner", default="target/release/grp_robust")
    ap.add_argument("--out", default="bench/peers/build/results")
    ap.add_argument("--min-iterations", type=int, default=1000,
                    help="RANSAC iterations at least, for both estimators (PoseLib's default 1000)")
    a = ap.parse_args()
    print(f"robust_grp: seed {a.seed}, {a.trials} trials, outliers {a.outliers}, noise {a.noise_px} px, "
          f"min_iterations {a.min_iterations}", flush=True)
    rng = np.random.default_rng(a.seed)
    sigma = a.noise_px / FOCAL
    trials = [scene(rng, a.outliers, sigma) for _ in range(a.trials)]
    os.makedirs(a.out, exist_ok=True)
    tag = f"robust-grp-o{a.outliers}-px{a.noise_px}-n{a.trials}-s{a.seed}"
    path = os.path.join(a.out, f"trials-{tag}.json")
    with open(path, "w") as fh:
        json.dump({"trials": [{"rows": tr["rows"]} for tr in trials]}, fh)
    angle = 3 * math.sqrt(2) * max(sigma, 1e-6)
    res = subprocess.run([a.runner, path, "--threshold", str(angle), "--noise", str(a.noise_px), "--seed", str(a.seed),
                          "--min-iterations", str(a.min_iterations)],
                         capture_output=True, text=True, check=True)
    ours = [json.loads(line) for line in res.stdout.splitlines()]
    table = {"simhc.estimate": [], "poselib.estimate_generalized_relative_pose": []}
    for tr, o in zip(trials, ours):
        truth = np.array(tr["inlier"])
        if o["rotation"] is not None:
            er, et = errors(o["rotation"], o["translation"], tr["R"], tr["t"])
            recall = np.sum(np.array(o["inlier_mask"]) & truth) / truth.sum()
        else:
            er, et, recall = math.inf, math.inf, 0.0
        table["simhc.estimate"].append((er < 2 and et < 5, recall, o["micros"], er, et))
        R, t, mask, micros, _ = run_poselib(tr, angle, a.min_iterations)
        er, et = errors(R, t, tr["R"], tr["t"])
        recall = np.sum(mask & truth) / truth.sum()
        table["poselib.estimate_generalized_relative_pose"].append((er < 2 and et < 5, recall, micros, er, et))
    print_table(table)

if __name__ == "__main__":
    sys.exit(main())
