"""Per-call solvers from Python, side by side on identical data: simhc's Python bindings
against PoseLib's (both called from this process, bindings included in every time).

    python3 bench/peers/python_calls.py --trials 1000 --seed 1 [--noise-px 0]

Needs `pip install poselib numpy ./python ./examples/generalized-relative-pose/python` (the
`simhc` wheel and the example problem's module `gen_relpose`).

- Generalized relative pose with known scale: `gen_relpose.solve` (the example problem's module, made by
  `simhc_pymodule::python_module!`) on the rows of 7 correspondences, stacked from the four
  arrays in the timed call (its answer is validated on all 7) against `poselib.gen_relpose_6pt` on the first 6, whose
  solutions are ranked on the 7th (the smallest coplanarity residual), as a caller must.
- Generalized absolute pose: `simhc.upnp` on N = 10 correspondences against `poselib.gp3p` on
  the first 3, ranked on all 10 (the smallest sum of angular errors).

Scenes (one seeded numpy generator, seed printed): rigs of 4 cameras with centres in
[-1, 1]^3 looking along +z; points in [-4, 4]^2 x [4, 20]; relative pose: rig 2 turned by up to
30 deg and moved by up to 2; absolute pose: any rotation, translation in [-2, 2]^3. Bearing
noise of `--noise-px` pixels at focal 800. Success: E_R < 2 deg and E_t < 5 % (a flagged
simhc solve is a failure, not a wrong answer). Times: microseconds per call, median and mean;
PoseLib's include ranking its solutions in numpy. Last, the binding costs: simhc's calls whose
arrays are converted and checked, then rejected before any solve, and PoseLib's `gp3p` on two
correspondences, too few for a pose (an upper bound of its binding cost).
"""

import argparse
import math
import time


import numpy as np
import poselib

import gen_relpose
import simhc

# The rig scenes' rotation, error metrics and focal length are robust_grp.py's (this folder).
from robust_grp import FOCAL, errors, rotation


def noisy(d, sigma, rng):
    f = d / np.linalg.norm(d)
    if sigma == 0:
        return f
    g = f + rng.normal(0, sigma, 3)
    return g / np.linalg.norm(g)


def quaternion_rotation(q):
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def point(rng):
    return np.array([rng.uniform(-4, 4), rng.uniform(-4, 4), rng.uniform(4, 20)])


def relative_trial(rng, sigma, n=7):
    R = rotation(rng.normal(size=3), math.radians(rng.uniform(0, 30)))
    t = rng.uniform(-2, 2, 3)
    cams1, cams2 = rng.uniform(-1, 1, (4, 3)), rng.uniform(-1, 1, (4, 3))
    f, v, fp, vp = [], [], [], []
    while len(f) < n:
        X = point(rng)
        c1, c2 = cams1[rng.integers(4)], cams2[rng.integers(4)]
        X2 = R.T @ (X - t)
        if (X - c1)[2] < 0.5 or (X2 - c2)[2] < 0.5:
            continue
        f.append(noisy(X - c1, sigma, rng))
        v.append(c1)
        fp.append(noisy(X2 - c2, sigma, rng))
        vp.append(c2)
    return tuple(np.array(a) for a in (f, v, fp, vp)) + (R, t)


def absolute_trial(rng, sigma, n=10):
    R = rotation(rng.normal(size=3), rng.uniform(0, math.pi))
    t = rng.uniform(-2, 2, 3)
    cams = rng.uniform(-1, 1, (4, 3))
    p, f, v = [], [], []
    while len(p) < n:
        X = point(rng)  # rig frame
        c = cams[rng.integers(4)]
        if (X - c)[2] < 0.5:
            continue
        p.append(R.T @ (X - t))  # world: R p + t = X
        f.append(noisy(X - c, sigma, rng))
        v.append(c)
    return np.array(p), np.array(f), np.array(v), R, t


def summary(name, results):
    ok = [r for r in results if r[0]]
    times = np.array([r[1] for r in results])
    print(f"| {name} | {100 * len(ok) / len(results):.1f} | {np.median(times):.1f} | {times.mean():.1f} |")
    return np.median(times), times.mean()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=1000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--noise-px", type=float, default=0.0)
    a = ap.parse_args()
    sigma = a.noise_px / FOCAL
    print(f"python_calls: seed {a.seed}, {a.trials} trials, noise {a.noise_px} px (focal {FOCAL:g})")
    rng = np.random.default_rng(a.seed)
    rel = [relative_trial(rng, sigma) for _ in range(a.trials)]
    absol = [absolute_trial(rng, sigma) for _ in range(a.trials)]
    clock = time.perf_counter

    def simhc_rel(tr):
        f, v, fp, vp, Rg, tg = tr
        t0 = clock()
        try:
            x = gen_relpose.solve(np.hstack([f, v, fp, vp]), noise=a.noise_px)
        except gen_relpose.SolveError:
            return False, (clock() - t0) * 1e6
        us = (clock() - t0) * 1e6
        eR, et = errors(quaternion_rotation(x["q"]), x["t"], Rg, tg)
        return eR < 2 and et < 5, us

    def poselib_rel(tr):
        f, v, fp, vp, Rg, tg = tr
        t0 = clock()
        poses = poselib.gen_relpose_6pt(v[:6], f[:6], vp[:6], fp[:6])
        best, cost = None, math.inf
        for p in poses:  # PoseLib: X2 = R X1 + t; ours is the inverse
            R, t = p.R.T, -p.R.T @ p.t
            n = np.cross(f[6], R @ fp[6])
            c = abs(n @ (R @ vp[6] + t - v[6])) / (np.linalg.norm(n) + 1e-300)
            if c < cost:
                best, cost = (R, t), c
        us = (clock() - t0) * 1e6
        if best is None:
            return False, us
        eR, et = errors(*best, Rg, tg)
        return eR < 2 and et < 5, us

    def simhc_abs(tr):
        p, f, v, Rg, tg = tr
        t0 = clock()
        try:
            pose = simhc.upnp(p, f, v)
        except simhc.SolveError:
            return False, (clock() - t0) * 1e6
        us = (clock() - t0) * 1e6
        eR, et = errors(pose.R, pose.t, Rg, tg)
        return eR < 2 and et < 5, us

    def poselib_abs(tr):
        p, f, v, Rg, tg = tr
        t0 = clock()
        poses = poselib.gp3p(v[:3], f[:3], p[:3])
        best, cost = None, math.inf
        for q in poses:
            d = p @ q.R.T + q.t - v
            c = np.sum(np.arccos(np.clip(np.sum(d * f, axis=1) / np.linalg.norm(d, axis=1), -1, 1)))
            if c < cost:
                best, cost = (q.R, q.t), c
        us = (clock() - t0) * 1e6
        if best is None:
            return False, us
        eR, et = errors(*best, Rg, tg)
        return eR < 2 and et < 5, us

    for tr in rel[:20] + absol[:20]:  # warm up (solvers built, caches filled)
        (simhc_rel if len(tr) == 6 else simhc_abs)(tr)
    print("| call | succ % | t med us | t mean us |")
    print("|---|---|---|---|")
    s_rel = summary("gen_relpose.solve (7 corr.)", [simhc_rel(t) for t in rel])
    p_rel = summary("poselib.gen_relpose_6pt (6 + pick on the 7th)", [poselib_rel(t) for t in rel])
    s_abs = summary("simhc.upnp (10 corr.)", [simhc_abs(t) for t in absol])
    p_abs = summary("poselib.gp3p (3 + pick on 10)", [poselib_abs(t) for t in absol])
    # simhc's binding cost: a call whose four arrays are stacked, converted and checked, then
    # rejected (6 rows where 7 are needed) before any solve.
    f, v, fp, vp = rel[0][:4]
    reps = 20000
    t0 = clock()
    for _ in range(reps):
        try:
            gen_relpose.solve(np.hstack([f[:6], v[:6], fp[:6], vp[:6]]))
        except gen_relpose.InputError:
            pass
    print(f"simhc binding cost (four (6, 3) arrays stacked, converted and checked, then rejected): {(clock() - t0) * 1e6 / reps:.2f} us per call")
    # PoseLib's binding cost, bounded above: `gp3p` on 2 correspondences (too few for a pose)
    # converts its three lists of vectors and returns at once or nearly; simhc's `upnp` on 2 is
    # the same arrays converted, checked and rejected.
    p, f, v = absol[0][:3]
    t0 = clock()
    for _ in range(reps):
        poselib.gp3p(v[:2], f[:2], p[:2])
    poselib_2 = (clock() - t0) * 1e6 / reps
    t0 = clock()
    for _ in range(reps):
        try:
            simhc.upnp(p[:2], f[:2], v[:2])
        except simhc.InputError:
            pass
    simhc_2 = (clock() - t0) * 1e6 / reps
    print(f"three (2, 3) arrays: poselib.gp3p {poselib_2:.2f} us per call, simhc.upnp (rejected) {simhc_2:.2f} us per call")
    print(f"PoseLib / simhc, median and mean: relative {p_rel[0] / s_rel[0]:.1f}x, {p_rel[1] / s_rel[1]:.1f}x; "
          f"absolute {p_abs[0] / s_abs[0]:.1f}x, {p_abs[1] / s_abs[1]:.1f}x")


if __name__ == "__main__":
    main()
