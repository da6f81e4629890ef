"""Robust generalized absolute pose, side by side on identical data, both from Python in this
process: simhc's `simhc.upnp.estimate` against PoseLib's `estimate_generalized_absolute_pose`
(defaults but the threshold).

    python3 bench/peers/robust_upnp.py --trials 100 --seed 1 --outliers 0.2 [--noise-px 1]

Needs `pip install poselib numpy` and the simhc package (`cd python && maturin develop --release`).

On simhc's own trials (no simhc package needed: simhc runs from its command line on the same file):

    simhc ransac upnp --trials 20 --seed 1 --threshold 0.005 --noise 1 --dump-trials T.json --json > simhc.json
    python3 bench/peers/robust_upnp.py --trials-file T.json [--simhc-report simhc.json]

reads the trials `--dump-trials` wrote (correspondences `[p, f, v]`, wrong matches included,
the true-match mask, the true rotation and translation, the threshold) and runs PoseLib on each,
with the file's threshold; it prints PoseLib's rows in `simhc ransac`'s columns (success
E_R < 2 deg and E_t < 5 %, as simhc's), and simhc's rows from its `--json` report beside them.

Scenes (one seeded numpy generator, seed printed): a rig of 4 cameras looking along +z with
centres in [-1, 1]^3; 100-200 points in [-4, 4]^2 x [4, 20] (rig frame), each seen by a random
camera; the world frame is the rig's turned by any rotation and moved by up to 2 in each axis
(`alpha f + v = R p + t`, world to rig); bearing noise of `--noise-px` pixels at focal 800; a
fraction `--outliers` of the correspondences get a random bearing in their camera's field of
view (wrong matches).

Success: E_R < 2 deg and E_t < 5 %. Inlier recall: true inliers marked inliers. Time: wall time
of one call, bindings included. Threshold: 3 sigma of the bearing angle, as an angle for simhc
and as a distance in the normalized image plane for PoseLib (`max_reproj_error`, its cameras
have focal 1).
"""

import json
import math
import time

import numpy as np
import poselib

from robust_grp import (FOCAL, common_arguments, compare_trials, errors, perturb, print_ransac_rows, print_table,
                        ransac_rows, read_simhc_trials, rotation)


def scene(rng, outliers, sigma):
    R = rotation(rng.normal(size=3), rng.uniform(0, math.pi))
    t = rng.uniform(-2, 2, 3)
    cams = rng.uniform(-1, 1, (4, 3))
    n = int(rng.integers(100, 201))
    p, f, cam, inlier = [], [], [], []
    while len(p) < n:
        X = np.array([rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(4, 20)])
        i = int(rng.integers(4))
        d = X - cams[i]
        if d[2] < 0.5:
            continue
        b = perturb(d / np.linalg.norm(d), sigma, rng)
        out = rng.uniform() < outliers
        if out:
            b = np.array([rng.uniform(-0.5, 0.5), rng.uniform(-0.5, 0.5), 1.0])
            b /= np.linalg.norm(b)
        p.append(R.T @ (X - t))
        f.append(b)
        cam.append(i)
        inlier.append(not out)
    return {"p": np.array(p), "f": np.array(f), "cam": np.array(cam), "cams": cams, "R": R, "t": t, "inlier": np.array(inlier)}


def run_simhc(tr, threshold, noise_px, seed):
    import simhc

    v = tr["cams"][tr["cam"]]
    t0 = time.perf_counter()
    try:
        pose, info = simhc.upnp.estimate(tr["p"], tr["f"], v, threshold=threshold, noise=noise_px, seed=seed)
    except simhc.SolveError:
        return None, None, np.zeros(len(tr["p"]), bool), (time.perf_counter() - t0) * 1e6
    return pose.R, pose.t, info["inlier_mask"], (time.perf_counter() - t0) * 1e6


def simhc_trial(t):
    """A trial of simhc's trials file as this script's scene: one camera per distinct ray origin."""
    rows = np.array(t["rows"])
    cams, cam = np.unique(rows[:, 6:9], axis=0, return_inverse=True)
    return {"p": rows[:, 0:3], "f": rows[:, 3:6], "cam": cam.reshape(-1), "cams": cams, "R": np.array(t["truth"][:9]).reshape(3, 3),
            "t": np.array(t["truth"][9:]), "inlier": np.array(t["inlier"], dtype=bool)}


def on_trials_file(a):
    doc = read_simhc_trials(a.trials_file, "upnp")
    threshold = doc["threshold"]
    print(f"robust_upnp: {len(doc['trials'])} trials from {a.trials_file} (sampled by simhc with seed {doc['seed']}, "
          f"noise {doc['noise']} px), threshold {threshold}", flush=True)
    results = []
    for t in doc["trials"]:
        tr = simhc_trial(t)
        R, tt, mask, micros, inliers = run_poselib(tr, threshold)
        er, et = errors(R, tt, tr["R"], tr["t"])
        truth = tr["inlier"]
        recall = 100 * np.sum(mask & truth) / max(truth.sum(), 1) if inliers > 0 else 0.0
        results.append((t["outliers"], er < 2 and et < 5, recall, int(np.sum(mask & ~truth)) if inliers > 0 else 0, inliers > 0, micros / 1e3))
    table = {}
    if a.simhc_report:
        with open(a.simhc_report) as fh:
            report = json.load(fh)
        table["simhc ransac upnp"] = report["rows"]
    table["poselib.estimate_generalized_absolute_pose"] = ransac_rows(results)
    print_ransac_rows(table)
    if a.simhc_report:
        compare_trials(report["trials"], results, "PoseLib")


def run_poselib(tr, threshold):
    ks = [np.flatnonzero(tr["cam"] == i) for i in range(len(tr["cams"]))]
    x2d = [tr["f"][k][:, :2] / tr["f"][k][:, 2:] for k in ks]
    x3d = [tr["p"][k] for k in ks]
    exts = []
    for c in tr["cams"]:
        e = poselib.CameraPose()
        e.R = np.eye(3)
        e.t = -c
        exts.append(e)
    cam = {"model": "PINHOLE", "width": 2, "height": 2, "params": [1.0, 1.0, 0.0, 0.0]}
    t0 = time.perf_counter()
    pose, info = poselib.estimate_generalized_absolute_pose(x2d, x3d, exts, [cam] * len(exts), {"max_reproj_error": threshold}, {})
    micros = (time.perf_counter() - t0) * 1e6
    mask = np.zeros(len(tr["p"]), dtype=bool)
    for k, inl in zip(ks, info.get("inliers", [])):
        mask[k] = np.asarray(inl, dtype=bool)
    return pose.R, pose.t, mask, micros, info.get("num_inliers", int(mask.sum()))


def main():
    ap = common_arguments()
    ap.add_argument("--trials-file", help="run PoseLib on the trials of `simhc ransac upnp --dump-trials FILE` instead")
    ap.add_argument("--simhc-report", help="with --trials-file: `simhc ransac upnp --trials-file FILE --json`'s output, printed beside")
    a = ap.parse_args()
    if a.trials_file:
        return on_trials_file(a)
    print(f"robust_upnp: seed {a.seed}, {a.trials} trials, outliers {a.outliers}, noise {a.noise_px} px", flush=True)
    rng = np.random.default_rng(a.seed)
    sigma = a.noise_px / FOCAL
    trials = [scene(rng, a.outliers, sigma) for _ in range(a.trials)]
    threshold = 3 * max(sigma, 1e-6)
    run_simhc(trials[0], threshold, a.noise_px, a.seed)  # warm up: the solver is built once
    table = {"simhc.upnp.estimate": [], "poselib.estimate_generalized_absolute_pose": []}
    for k, tr in enumerate(trials):
        truth = tr["inlier"]
        for name, (R, t, mask, micros) in (
            ("simhc.upnp.estimate", run_simhc(tr, threshold, a.noise_px, a.seed + k)),
            ("poselib.estimate_generalized_absolute_pose", run_poselib(tr, threshold)[:4]),
        ):
            er, et = errors(R, t, tr["R"], tr["t"]) if R is not None else (math.inf, math.inf)
            table[name].append((er < 2 and et < 5, np.sum(mask & truth) / truth.sum(), micros, er, et))
    medians = print_table(table)
    s, p = medians["simhc.upnp.estimate"], medians["poselib.estimate_generalized_absolute_pose"]
    print(f"time per call, simhc / PoseLib (median): {s / p:.2f}")


if __name__ == "__main__":
    main()
