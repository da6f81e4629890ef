#!/usr/bin/env python3
"""Score peer results against a trials file and print a markdown table.

    python3 score.py TRIALS.json RESULTS.jsonl [RESULTS.jsonl ...] [--title TEXT]

Each results file holds JSON lines {"solver", "trial", "rotation" (row-major 3x3 or null),
"translation" (or null), "micros"}; lines with a "meta" key are printed as notes. The problem
(UPnP or GRPS) is read from the trials file.

E_R = angle of R_est R_gt^T (degrees); E_t = |t_est - t_gt| / |t_gt| * 100.
Success: E_R < 2 deg (UPnP); E_R < 2 deg and E_t < 5 % (GRPS). A trial for which a solver
returned nothing (no line, or a null pose) is a failure. Error medians are over returned poses;
times over all trials that have a line.
"""

import argparse
import json
import math
import sys
from collections import OrderedDict

import numpy as np

ROT_DEG = 2.0
T_PCT = 5.0


def rotation_error_deg(r_est, r_gt):
    """Angle of R_est R_gt^T, from |R_est - R_gt|_F = 2 sqrt(2) sin(angle / 2) (accurate near 0,
    unlike acos of the trace); R_est is first projected onto SO(3) (nearest rotation)."""
    u, _, vt = np.linalg.svd(r_est)
    r = u @ np.diag([1.0, 1.0, np.linalg.det(u @ vt)]) @ vt
    x = np.linalg.norm(r - r_gt) / (2.0 * math.sqrt(2.0))
    return math.degrees(2.0 * math.asin(min(1.0, x)))


def translation_error_pct(t_est, t_gt):
    return float(np.linalg.norm(t_est - t_gt) / np.linalg.norm(t_gt) * 100.0)


def fmt(x, digits=3):
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    if abs(x) >= 1000:
        return f"{x:.0f}"
    if abs(x) >= 100:
        return f"{x:.1f}"
    if abs(x) >= 1e-2 or x == 0:
        return f"{x:.{digits}f}"
    return f"{x:.2e}"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("trials")
    ap.add_argument("results", nargs="+")
    ap.add_argument("--title", default=None)
    ap.add_argument("--simhc", action="append", default=[],
                    help="a `simhc bench upnp|grps --trials-file TRIALS --json` report: its rows are appended "
                         "(simhc's own statistics; its GRPS success also requires E_s < 5 %%)")
    args = ap.parse_args()

    with open(args.trials) as fh:
        trials = json.load(fh)
    grps = "fp" in trials[0]["correspondences"][0]
    gt = [(np.array(s["rotation"], dtype=float), np.array(s["translation"], dtype=float)) for s in trials]
    n = len(trials)

    results = OrderedDict()   # solver -> {trial: record}
    metas = []
    for path in args.results:
        with open(path) as fh:
            for line in fh:
                line = line.strip()
                if not line:
                    continue
                rec = json.loads(line)
                if "meta" in rec:
                    metas.append(rec["meta"])
                    continue
                results.setdefault(rec["solver"], {})[int(rec["trial"])] = rec

    if args.title:
        print(f"### {args.title}\n")
    crit = f"E_R < {ROT_DEG:g} deg" + (f" and E_t < {T_PCT:g} %" if grps else "")
    print(f"{n} {'GRPS' if grps else 'UPnP'} trials from `{args.trials}`; success: {crit}; "
          f"errors over returned poses; times per call in microseconds\n")
    print("| solver | success % | no pose | median E_R (deg) | median E_t (%) | mean E_R (deg) | median time (us) | mean time (us) |")
    print("|---|---|---|---|---|---|---|---|")
    not_rotations = {}
    for solver, recs in results.items():
        er, et, times = [], [], []
        ok = 0
        missing = 0
        for i in range(n):
            rec = recs.get(i)
            if rec is None:
                missing += 1
                continue
            if rec.get("micros") is not None:
                times.append(float(rec["micros"]))
            if rec.get("rotation") is None or rec.get("translation") is None:
                missing += 1
                continue
            r = np.array(rec["rotation"], dtype=float)
            t = np.array(rec["translation"], dtype=float)
            if not (np.all(np.isfinite(r)) and np.all(np.isfinite(t))):
                missing += 1
                continue
            if np.linalg.norm(r.T @ r - np.eye(3)) > 1e-6 or np.linalg.det(r) < 0:
                not_rotations[solver] = not_rotations.get(solver, 0) + 1
            e_r = rotation_error_deg(r, gt[i][0])
            e_t = translation_error_pct(t, gt[i][1])
            er.append(e_r)
            et.append(e_t)
            if e_r < ROT_DEG and (not grps or e_t < T_PCT):
                ok += 1
        med = lambda xs: float(np.median(xs)) if xs else None
        mean = lambda xs: float(np.mean(xs)) if xs else None
        print(f"| {solver} | {100.0 * ok / n:.1f} | {missing} | {fmt(med(er))} | {fmt(med(et))} | {fmt(mean(er))} "
              f"| {fmt(med(times), 1)} | {fmt(mean(times), 1)} |")
    for solver, count in not_rotations.items():
        print(f"\nnote: {solver} returned {count} matrices that are not rotations (|R^T R - I| > 1e-6 or "
              f"det < 0); E_R is measured from their nearest rotation", end="")
    if not_rotations:
        print()
    for path in args.simhc:
        with open(path) as fh:
            report = json.load(fh)
        for row in report.get("rows", []):
            print(f"| simhc: {row['method']} | {row['success_pct']:.1f} | {row['failures']} "
                  f"| {fmt(row['rotation_median_deg'])} | {fmt(row['translation_median_pct'])} "
                  f"| {fmt(row['rotation_mean_deg'])} | {fmt(row['time_median_us'], 1)} | {fmt(row['time_mean_us'], 1)} |")
    for m in metas:
        print()
        print("note: " + ", ".join(f"{k} = {v}" for k, v in m.items()))
    print()


if __name__ == "__main__":
    main()
