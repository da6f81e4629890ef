"""Where simhc's UPnP accuracy gap to PoseLib comes from: the final refinement or the inliers.

    python bench/real/refine_check.py [--pairs 40] [--seed 1] [--abs-px 3]

For random frame pairs (gaps 1, 3, 5): simhc.upnp.estimate (depth-scaled input, as bench.py)
and PoseLib estimate_generalized_absolute_pose, then PoseLib's own refinement
(`refine_generalized_absolute_pose`, its default Cauchy loss of 1 px) started from simhc's pose
on simhc's inliers only. If the refined simhc pose matches PoseLib's errors, the gap is simhc's
final least squares (angular residual, squared loss, on the inlier set), not its sampling or its
inliers. Median E_R (deg) and E_t (%) against the reference BA.
"""

import argparse
import os
import sys

import numpy as np
import poselib

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import bench  # noqa: E402
import correspondences  # noqa: E402
import kitti  # noqa: E402
import solvers  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pairs", type=int, default=40)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--abs-px", type=float, default=3.0)
    a = ap.parse_args()
    print(f"seed {a.seed}; {a.pairs} pairs; threshold {a.abs_px} px")
    data = kitti.load()
    ba = kitti.reference(data)
    rng = np.random.default_rng(a.seed)
    all_pairs = correspondences.pairs(len(data.ids), [1, 3, 5])
    chosen = [all_pairs[k] for k in sorted(rng.choice(len(all_pairs), a.pairs, replace=False))]
    cams, exts = solvers._cameras(data.calib)
    rows = {"simhc": [], "poselib": [], "simhc + PoseLib refinement on simhc's inliers": [], "PoseLib refinement on PoseLib's inliers": []}
    for k, (i, j) in enumerate(chosen):
        p = correspondences.build(data, i, j, rng)
        Rg, tg = solvers.truth("upnp", ba[i], ba[j])
        s = solvers.simhc_upnp(p, data.calib, a.abs_px, 1.0, a.seed + k, bench.input_scale("depth", data.calib, p))
        q = solvers.poselib_upnp(p, data.calib, a.abs_px)
        rows["simhc"].append(solvers.errors(s, Rg, tg))
        rows["poselib"].append(solvers.errors(q, Rg, tg))
        for name, res in (("simhc + PoseLib refinement on simhc's inliers", s), ("PoseLib refinement on PoseLib's inliers", q)):
            ks = [np.flatnonzero((p.cam2 == c) & res["mask"]) for c in (0, 1)]
            init = poselib.CameraPose()
            init.R, init.t = res["R"], res["t"]
            pose, _ = poselib.refine_generalized_absolute_pose([p.px2[m] for m in ks], [p.points[m] for m in ks], init, exts, cams, {})
            rows[name].append(solvers.errors({"ok": True, "R": np.array(pose.R), "t": np.array(pose.t), "s": None}, Rg, tg))
    print("| UPnP | median E_R deg | median E_t % | success % |")
    print("|---|---|---|---|")
    for name, es in rows.items():
        print(f"| {name} | {np.median([e['e_R'] for e in es]):.4f} | {np.median([e['e_t'] for e in es]):.3f} | {100 * np.mean([e['success'] for e in es]):.0f} |")


if __name__ == "__main__":
    main()
