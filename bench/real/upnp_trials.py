"""KITTI's UPnP RANSAC samples as a trials file of `simhc bench upnp --trials-file`, to read the
learned start's own error ("Pred Initial") on real samples at an input scale.

    python bench/real/upnp_trials.py OUT.json [--samples 400] [--size 4] [--seed 1] [--scale depth|none|baseline|METRES]
    cargo run --release -p simhc-cli --no-default-features -- bench upnp --trials-file OUT.json
    python bench/real/upnp_trials.py OUT.json --cut-from SYN.json --size 4   # a trials file cut to its first 4

`--cut-from` instead keeps the first `--size` correspondences of each trial of another trials
file (e.g. `simhc bench upnp --trials 300 --seed 1 --dump-trials SYN.json`, the training
sampler's 16-point scenes), for the same comparison on synthetic samples.

Samples of `--size` correspondences of random frame pairs (gaps 1, 3, 5) whose residual under
the reference BA pose is below 3 px (inliers: the start is judged, not the sampling), the world
being frame i and the rig frame j (as `solvers.py`), moved by the input similarity of
`--scale` (as `bench.py`); the truth is the BA pose in those units.
"""

import argparse
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import bench  # noqa: E402
import correspondences  # noqa: E402
import kitti  # noqa: E402
import solvers  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out")
    ap.add_argument("--samples", type=int, default=400)
    ap.add_argument("--size", type=int, default=4)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scale", default="depth")
    ap.add_argument("--cut-from", default=None)
    a = ap.parse_args()
    if a.cut_from:
        with open(a.cut_from) as fh:
            trials = json.load(fh)
        for t in trials:
            t["correspondences"] = t["correspondences"][:a.size]
        with open(a.out, "w") as fh:
            json.dump(trials, fh)
        print(f"{len(trials)} trials of {a.cut_from} cut to {a.size} correspondences -> {a.out}")
        return
    if a.samples < 1 or a.size < 3:
        ap.error("--samples >= 1 and --size >= 3")
    scale = None if a.scale == "none" else (a.scale if a.scale in ("baseline", "depth") else float(a.scale))
    data = kitti.load()
    ba = kitti.reference(data)
    rng = np.random.default_rng(a.seed)
    all_pairs = correspondences.pairs(len(data.ids), [1, 3, 5])
    trials = []
    while len(trials) < a.samples:
        i, j = all_pairs[rng.integers(len(all_pairs))]
        p = correspondences.build(data, i, j, rng)
        R, t = solvers.truth("upnp", ba[i], ba[j])
        X = (R @ p.points.T).T + t - p.v2
        proj = X[:, :2] / X[:, 2:] * data.calib.fx
        obs = p.f2[:, :2] / p.f2[:, 2:] * data.calib.fx
        good = np.flatnonzero((np.linalg.norm(proj - obs, axis=1) < 3.0) & (X[:, 2] > 0))
        if len(good) < a.size:
            continue
        k = rng.choice(good, a.size, replace=False)
        L = bench.input_scale(scale, data.calib, p) or 1.0
        c = np.zeros(3) if scale is None else solvers._rig_centre(np.vstack([p.v1, p.v2]))
        tn = (R @ c + t - c) / L
        trials.append({"correspondences": [{"p": ((p.points[m] - c) / L).tolist(), "f": p.f2[m].tolist(), "v": ((p.v2[m] - c) / L).tolist()} for m in k],
                       "rotation": R.tolist(), "translation": tn.tolist()})
    with open(a.out, "w") as fh:
        json.dump(trials, fh)
    print(f"{len(trials)} samples of {a.size} (seed {a.seed}, scale {a.scale}) -> {a.out}")


if __name__ == "__main__":
    main()
