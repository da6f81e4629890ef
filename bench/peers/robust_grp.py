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

On simhc's own trials (the example's `grp` binary writes and reads them):

    grp ransac grp --trials 20 --seed 1 --noise 1 --threshold 0.004 --dump-trials T.json --json > simhc.json
    python3 bench/peers/robust_grp.py --trials-file T.json --simhc-report simhc.json

runs PoseLib on the file's trials (its threshold) and prints its rows in `simhc ransac`'s
columns beside simhc's.
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


def look_along(d):
    """A rotation whose third row is the direction d: a camera turned to look along d."""
    z = d / np.linalg.norm(d)
    a = np.array([1.0, 0.0, 0.0]) if abs(z[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    x = np.cross(a, z)
    x /= np.linalg.norm(x)
    return np.array([x, np.cross(z, x), z])


def run_poselib(tr, threshold, min_iterations=1000):
    """PoseLib with its defaults but the threshold and the minimum of iterations (its default
    1000); returns (R, t, mask, micros) in our convention. A trial may turn its cameras
    (`turn1`, `turn2`: one rotation per camera, rig to camera, default none); a bearing that is
    then not in front of its camera (z <= 0.05) cannot be an image point and is left out
    (never an inlier)."""
    turn1 = tr.get("turn1", [np.eye(3)] * len(tr["cams1"]))
    turn2 = tr.get("turn2", [np.eye(3)] * len(tr["cams2"]))
    groups = {}
    for k, (i, j, f, fp) in enumerate(tr["matches"]):
        if "turn1" in tr and ((turn1[i] @ f)[2] <= 0.05 or (turn2[j] @ fp)[2] <= 0.05):
            continue
        groups.setdefault((i, j), []).append(k)

    def image(turn, b):
        b = turn @ b if "turn1" in tr else b
        return b[:2] / b[2]

    pm = []
    for (i, j), ks in groups.items():
        m = poselib.PairwiseMatches()
        m.cam_id1, m.cam_id2 = i, j
        m.x1 = np.array([image(turn1[i], tr["matches"][k][2]) for k in ks])
        m.x2 = np.array([image(turn2[j], tr["matches"][k][3]) for k in ks])
        pm.append(m)

    def ext(c, turn):
        e = poselib.CameraPose()
        e.R = turn
        e.t = -turn @ c
        return e

    exts1 = [ext(c, r) for c, r in zip(tr["cams1"], turn1)]
    exts2 = [ext(c, r) for c, r in zip(tr["cams2"], turn2)]
    cam = {"model": "PINHOLE", "width": 2, "height": 2, "params": [1.0, 1.0, 0.0, 0.0]}
    t0 = time.perf_counter()
    pose, info = poselib.estimate_generalized_relative_pose(pm, exts1, [cam] * len(exts1), exts2, [cam] * len(exts2),
                                                            {"max_epipolar_error": threshold, "min_iterations": min_iterations}, {})
    micros = (time.perf_counter() - t0) * 1e6
    # PoseLib's pose maps rig 1 to rig 2 (X2 = R X1 + t); ours is its inverse.
    R = pose.R.T
    t = -pose.R.T @ pose.t
    mask = np.zeros(len(tr["matches"]), dtype=bool)
    flat = [k for ks in groups.values() for k in ks]
    for k, inl in zip(flat, [b for m in info.get("inliers", []) for b in np.atleast_1d(m)]):
        mask[k] = bool(inl)
    return R, t, mask, micros, info


def quaternion_rotation(q):
    w, x, y, z = np.asarray(q) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def grp_trial(t):
    """A trial of `grp ransac grp --dump-trials` (rows [f, v, fp, vp], truth [q (w, x, y, z), t],
    X1 = R X2 + t) as this script's scene: one camera per distinct ray origin of each rig,
    turned to look along the sum of its bearings (the example's rig 2 has any rotation, so its
    bearings point anywhere)."""
    rows = np.array(t["rows"])
    f, v, fp, vp = rows[:, 0:3], rows[:, 3:6], rows[:, 6:9], rows[:, 9:12]
    cams1, i = np.unique(v, axis=0, return_inverse=True)
    cams2, j = np.unique(vp, axis=0, return_inverse=True)
    i, j = i.reshape(-1), j.reshape(-1)
    turn1 = [look_along(f[i == c].sum(axis=0)) for c in range(len(cams1))]
    turn2 = [look_along(fp[j == c].sum(axis=0)) for c in range(len(cams2))]
    return {"matches": [(int(a), int(b), f[k], fp[k]) for k, (a, b) in enumerate(zip(i, j))], "cams1": cams1, "cams2": cams2,
            "turn1": turn1, "turn2": turn2, "R": quaternion_rotation(t["truth"][:4]), "t": np.array(t["truth"][4:7]),
            "inlier": np.array(t["inlier"], dtype=bool)}


def in_child(call, timeout):
    """`call()` in a forked process (the time is measured inside it); None when it does not
    return within `timeout` seconds (the process is then ended)."""
    import multiprocessing

    ctx = multiprocessing.get_context("fork")
    queue = ctx.Queue()
    child = ctx.Process(target=lambda: queue.put(call()))
    child.start()
    try:
        return queue.get(timeout=timeout)
    except Exception:  # queue.Empty: no answer in time
        return None
    finally:
        child.terminate()
        child.join()


def on_trials_file(a):
    """PoseLib on the trials of `grp ransac grp --dump-trials FILE`, in simhc ransac's columns."""
    doc = read_simhc_trials(a.trials_file, "grp")
    threshold = doc["threshold"]
    print(f"robust_grp: {len(doc['trials'])} trials from {a.trials_file} (sampled by simhc with seed {doc['seed']}, "
          f"noise {doc['noise']} px), threshold {threshold}, min_iterations {a.min_iterations}", flush=True)
    results, timed_out = [], []
    for k, t in enumerate(doc["trials"]):
        tr = grp_trial(t)
        out = in_child(lambda: run_poselib(tr, threshold, a.min_iterations)[:4] + (None,), a.timeout)
        if out is None:
            # PoseLib did not return: no model, a failure, the time limit as its time.
            timed_out.append(k)
            results.append((t["outliers"], False, 0.0, 0, False, a.timeout * 1e3))
            continue
        R, tt, mask, micros, _ = out
        er, et = errors(R, tt, tr["R"], tr["t"])
        truth = tr["inlier"]
        model = mask.any()
        recall = 100 * np.sum(mask & truth) / max(truth.sum(), 1) if model else 0.0
        results.append((t["outliers"], er < 2 and et < 5, recall, int(np.sum(mask & ~truth)) if model else 0, model, micros / 1e3))
    if timed_out:
        print(f"PoseLib did not return within {a.timeout} s on trials {timed_out} (counted as failures without a model, "
              f"their time as {a.timeout} s)")
    table = {}
    if a.simhc_report:
        with open(a.simhc_report) as fh:
            report = json.load(fh)
        table["grp ransac grp"] = report["rows"]
    table["poselib.estimate_generalized_relative_pose"] = ransac_rows(results)
    print_ransac_rows(table)
    if a.simhc_report:
        compare_trials(report["trials"], results, "PoseLib")


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


def read_simhc_trials(path, problem):
    """The trials file of `simhc ransac PROBLEM --dump-trials FILE` (bench/peers/README.md):
    {"problem", "row_fields", "truth_fields", "seed", "noise", "threshold", "trials": [{"outliers",
    "estimator_seed", "inlier", "rows", "globals", "truth"}, ..]}. Python's json reads simhc's
    numbers exactly (shortest round-trip decimals), so both run on bit-identical data."""
    with open(path) as fh:
        doc = json.load(fh)
    if doc.get("problem") != problem:
        raise SystemExit(f"{path}: trials for `{doc.get('problem')}`, not `{problem}`")
    return doc


def ransac_rows(results):
    """simhc ransac's summary rows of per-trial results [(outliers, success, recall %, wrong
    taken, has model, ms)]: one row per outlier ratio in order of first appearance, with the
    same statistics (success %, median recall %, median wrong taken, trials without a model,
    median and mean ms; a trial without a model counts recall 0 and wrong 0)."""
    rows = []
    for ratio in dict.fromkeys(r[0] for r in results):
        of = [r for r in results if r[0] == ratio]
        ms = np.array([r[5] for r in of])
        rows.append({"outliers": ratio, "trials": len(of), "success_pct": 100 * np.mean([r[1] for r in of]),
                     "recall_pct": float(np.median([r[2] for r in of])), "wrong_taken": float(np.median([r[3] for r in of])),
                     "no_model": sum(not r[4] for r in of), "ms_median": float(np.median(ms)), "ms_mean": float(ms.mean())})
    return rows


def print_ransac_rows(named_rows):
    """A markdown table of {solver: rows} in simhc ransac's columns."""
    print("| solver | outliers | trials | success % | inlier recall % (median) | wrong taken (median) | no model | t med ms | t mean ms |")
    print("|---|---|---|---|---|---|---|---|---|")
    for name, rows in named_rows.items():
        for r in rows:
            print(f"| {name} | {r['outliers']:.2f} | {r['trials']} | {r['success_pct']:.1f} | {r['recall_pct']:.1f} | "
                  f"{r['wrong_taken']:.1f} | {r['no_model']} | {r['ms_median']:.2f} | {r['ms_mean']:.2f} |")


def compare_trials(ours, peer, name):
    """The trials where exactly one of simhc (`ours`, its `--json` report's trials) and the peer
    (per-trial results as in `ransac_rows`) succeeds."""
    only_ours = [k for k, (o, p) in enumerate(zip(ours, peer)) if o["success"] and not p[1]]
    only_peer = [k for k, (o, p) in enumerate(zip(ours, peer)) if p[1] and not o["success"]]
    print(f"trials only simhc solves: {len(only_ours)} {only_ours[:20]}; only {name}: {len(only_peer)} {only_peer[:20]}")


def main():
    ap = common_arguments()
    ap.add_argument("--runner", default="target/release/grp_robust")
    ap.add_argument("--out", default="bench/peers/build/results")
    ap.add_argument("--min-iterations", type=int, default=1000,
                    help="RANSAC iterations at least, for both estimators (PoseLib's default 1000)")
    ap.add_argument("--trials-file", help="run PoseLib on the trials of `grp ransac grp --dump-trials FILE` instead")
    ap.add_argument("--simhc-report", help="with --trials-file: `grp ransac grp --trials-file FILE --json`'s output, printed beside")
    ap.add_argument("--timeout", type=float, default=30.0,
                    help="with --trials-file: seconds PoseLib may take on one trial (it did not return on some)")
    a = ap.parse_args()
    if a.trials_file:
        return on_trials_file(a)
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
