#!/usr/bin/env python3
"""Converts a GRPS trials file of scale-1 scenes (gen_trials.py --problem grps) to the trials file
of the generalized-relative-pose example (`grp bench grp --trials-file`): per trial, `params` =
the correspondences' [f, v, fp, vp] row by row (bearings as given) and `truth` = [q (w, x, y, z),
t]. Both read `alpha f + v = R (alpha' fp + vp) + t`, so the numbers are the same ones.

    python3 to_grp.py TRIALS_IN TRIALS_OUT
"""
import json
import math
import sys


def quaternion(R):
    """Unit quaternion [w, x, y, z] of a rotation matrix (Shepperd's method)."""
    tr = R[0][0] + R[1][1] + R[2][2]
    if tr > 0:
        s = math.sqrt(tr + 1.0) * 2
        return [0.25 * s, (R[2][1] - R[1][2]) / s, (R[0][2] - R[2][0]) / s, (R[1][0] - R[0][1]) / s]
    if R[0][0] > R[1][1] and R[0][0] > R[2][2]:
        s = math.sqrt(1.0 + R[0][0] - R[1][1] - R[2][2]) * 2
        return [(R[2][1] - R[1][2]) / s, 0.25 * s, (R[0][1] + R[1][0]) / s, (R[0][2] + R[2][0]) / s]
    if R[1][1] > R[2][2]:
        s = math.sqrt(1.0 + R[1][1] - R[0][0] - R[2][2]) * 2
        return [(R[0][2] - R[2][0]) / s, (R[0][1] + R[1][0]) / s, 0.25 * s, (R[1][2] + R[2][1]) / s]
    s = math.sqrt(1.0 + R[2][2] - R[0][0] - R[1][1]) * 2
    return [(R[1][0] - R[0][1]) / s, (R[0][2] + R[2][0]) / s, (R[1][2] + R[2][1]) / s, 0.25 * s]


def main():
    src, dst = sys.argv[1], sys.argv[2]
    with open(src) as fh:
        trials = json.load(fh)
    out = []
    for i, scene in enumerate(trials):
        if abs(scene.get("scale", 1.0) - 1.0) > 1e-12:
            sys.exit(f"to_grp: trial {i} has scale {scene['scale']}; the example has a known scale of 1")
        params = [x for c in scene["correspondences"] for k in ("f", "v", "fp", "vp") for x in c[k]]
        out.append({"params": params, "truth": quaternion(scene["rotation"]) + list(scene["translation"])})
    with open(dst, "w") as fh:
        json.dump(out, fh)
    print(f"to_grp: {len(out)} trials of {len(trials[0]['correspondences'])} correspondences -> {dst}", file=sys.stderr)


if __name__ == "__main__":
    main()
