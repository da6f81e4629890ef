"""KITTI seq 00's stereo rig: simhc and PoseLib on identical correspondences (issue 45).

    python bench/real/bench.py [--gaps 1,3,5] [--stride 1] [--max-pairs N] [--seed 1]
                               [--rel-px 1] [--abs-px 3] [--noise-px 1] [--scale depth]
                               [--grps-scale 2] [--problems relpose,grps,upnp] [--json OUT]
                               [--plot target/figures] [--max-corr N]

(`bench/real/run.sh` makes the virtual env and calls this.) For every frame pair (i, i + gap),
positions in the 135-frame list, it builds one set of correspondences (`correspondences.py`,
cameras drawn with the seed) and runs:
- relpose: gen_relpose.estimate (the example problem's module) vs PoseLib estimate_generalized_relative_pose;
- grps: simhc.grps.estimate at true scale 1 and at `--grps-scale` (frame j's camera offsets
  divided by it); no PoseLib peer (PoseLib has no generalized relative pose and scale);
- upnp: simhc.upnp.estimate vs PoseLib estimate_generalized_absolute_pose.
Errors against the GTSAM stereo BA (`kitti.py`, cached) and the shipped VO poses. Success:
E_R < 1 deg and (translation direction < 5 deg or E_t < 5 % of the motion). Times: one call's
wall time from Python, median. `--scale`: simhc's input similarity (`solvers.py`): `none`
(metres), `baseline` (L = baseline / 2: cameras at +-1), `depth` (the default: L = the median
distance of the pair's landmarks, triangulated in frame i, from the rig centre, so that the
scene is at unit distance; see `starts.py` for why) or a length in metres.
"""

import argparse
import json
import os
import sys
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import correspondences  # noqa: E402
import kitti  # noqa: E402
import solvers  # noqa: E402

PROBLEMS = ("relpose", "grps", "upnp")


def parse_args(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--gaps", default="1,3,5", help="frame gaps j - i (comma-separated positive integers)")
    ap.add_argument("--stride", type=int, default=1, help="step between first frames i")
    ap.add_argument("--max-pairs", type=int, default=None, help="at most this many pairs per gap, drawn with the seed")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--rel-px", type=float, default=1.0, help="inlier threshold (px) for relpose and grps, both solvers")
    ap.add_argument("--abs-px", type=float, default=3.0, help="inlier threshold (px) for upnp, both solvers")
    ap.add_argument("--noise-px", type=float, default=1.0, help="simhc's sample tolerance `noise` (px at KITTI's focal)")
    ap.add_argument("--scale", default="depth", help="simhc input unit: none (metres), baseline (half of it), depth (median point distance), or metres")
    ap.add_argument("--grps-scale", type=float, default=2.0, help="known scale applied to frame j's offsets for the second GRPS run")
    ap.add_argument("--problems", default=",".join(PROBLEMS))
    ap.add_argument("--max-corr", type=int, default=None, help="at most this many correspondences per pair")
    ap.add_argument("--skip-explained", action="store_true",
                    help="simhc's estimators skip samples the best model explains (RansacOptions::skip_explained)")
    ap.add_argument("--json", default=None, help="write every run and the table as JSON here ('-': stdout)")
    ap.add_argument("--plot", default=None, help="directory for PNG plots of the errors along the trajectory")
    ap.add_argument("--quiet", action="store_true")
    a = ap.parse_args(argv)
    try:
        a.gaps = [int(g) for g in a.gaps.split(",")]
    except ValueError:
        ap.error(f"--gaps {a.gaps!r}: expected comma-separated integers")
    if not a.gaps or min(a.gaps) < 1:
        ap.error("--gaps: every gap must be >= 1")
    if a.stride < 1:
        ap.error("--stride must be >= 1")
    if a.max_pairs is not None and a.max_pairs < 1:
        ap.error("--max-pairs must be >= 1")
    if a.max_corr is not None and a.max_corr < 7:
        ap.error("--max-corr must be >= 7 (the relative solvers' sample)")
    for name in ("rel_px", "abs_px", "noise_px", "grps_scale"):
        if not getattr(a, name) > 0:
            ap.error(f"--{name.replace('_', '-')} must be > 0")
    a.problems = [p for p in a.problems.split(",") if p]
    bad = [p for p in a.problems if p not in PROBLEMS]
    if bad or not a.problems:
        ap.error(f"--problems: unknown {bad}, expected some of {','.join(PROBLEMS)}")
    a.scale_name = a.scale
    if a.scale == "none":
        a.scale = None
    elif a.scale not in ("baseline", "depth"):
        try:
            a.scale = float(a.scale)
        except ValueError:
            ap.error(f"--scale {a.scale!r}: expected none, baseline, depth or a length in metres")
        if not a.scale > 0:
            ap.error("--scale must be > 0")
    return a


def select_pairs(n_frames, a, rng):
    out = []
    for g in a.gaps:
        ps = correspondences.pairs(n_frames, [g], a.stride)
        if a.max_pairs is not None and len(ps) > a.max_pairs:
            ps = [ps[k] for k in sorted(rng.choice(len(ps), a.max_pairs, replace=False))]
        out += ps
    return out


def input_scale(scale, calib, pair):
    """simhc's input unit L (metres) for `--scale`: None (metric), half the baseline, the median
    distance of frame i's triangulated points from the rig centre (`depth`), or a number."""
    if scale == "baseline":
        return calib.baseline / 2
    if scale == "depth":
        return float(np.median(np.linalg.norm(pair.points - [calib.baseline / 2, 0, 0], axis=1)))
    return scale


def run_pair(data, refs, i, j, a, rng, seed):
    """All solvers on one pair; a list of records (one per problem variant and solver)."""
    pair = correspondences.build(data, i, j, rng, a.max_corr)
    scale = input_scale(a.scale, data.calib, pair)
    base = {"i": i, "j": j, "frame_i": int(data.ids[i]), "frame_j": int(data.ids[j]), "gap": j - i, "n": len(pair.f1)}
    runs = []
    if len(pair.f1) < 7:
        print(f"pair ({i}, {j}): {len(pair.f1)} common landmarks, skipped (< 7)", file=sys.stderr)
        return runs
    if "relpose" in a.problems:
        runs.append(("relpose", "simhc", None, solvers.simhc_relpose(pair, data.calib, a.rel_px, a.noise_px, seed, scale, skip_explained=a.skip_explained)))
        runs.append(("relpose", "poselib", None, solvers.poselib_relpose(pair, data.calib, a.rel_px)))
    if "grps" in a.problems:
        for s in (1.0, a.grps_scale):
            runs.append((f"grps s={s:g}", "simhc", s, solvers.simhc_relpose(pair, data.calib, a.rel_px, a.noise_px, seed, scale, grps=True, s_true=s,
                                                                                  skip_explained=a.skip_explained)))
    if "upnp" in a.problems:
        runs.append(("upnp", "simhc", None, solvers.simhc_upnp(pair, data.calib, a.abs_px, a.noise_px, seed, scale, skip_explained=a.skip_explained)))
        runs.append(("upnp", "poselib", None, solvers.poselib_upnp(pair, data.calib, a.abs_px)))
    records = []
    for problem, solver, s, res in runs:
        rec = dict(base, problem=problem, solver=solver, ms=res["ms"], inlier_ratio=float(res["mask"].mean()), error=res["error"])
        for ref_name, poses in refs.items():
            Rg, tg = solvers.truth("upnp" if problem == "upnp" else "relpose", poses[i], poses[j])
            rec[ref_name] = solvers.errors(res, Rg, tg, s)
        records.append(rec)
    return records


def summarize(records, ref):
    """Per (problem, gap, solver): the table's row against reference `ref`."""
    keys = sorted({(r["problem"], r["gap"], r["solver"]) for r in records})
    rows = []
    for problem, gap, solver in keys:
        rs = [r for r in records if (r["problem"], r["gap"], r["solver"]) == (problem, gap, solver)]
        e = [r[ref] for r in rs]

        def med(k):
            v = [x[k] for x in e if x["ok"] and np.isfinite(x[k])]
            return float(np.median(v)) if v else float("nan")

        rows.append({"problem": problem, "gap": gap, "solver": solver, "pairs": len(rs),
                     "success": 100 * float(np.mean([x["success"] for x in e])),
                     "failed_calls": sum(not x["ok"] for x in e),
                     "e_R": med("e_R"), "e_t": med("e_t"), "e_dir": med("e_dir"), "e_s": med("e_s"),
                     "inlier_ratio": 100 * float(np.median([r["inlier_ratio"] for r in rs])),
                     "ms": float(np.median([r["ms"] for r in rs]))})
    return rows


def print_table(rows, title, out=None):
    out = out or sys.stdout
    print(f"\n{title}", file=out)
    print("| problem | gap | solver | pairs | success % | median E_R deg | median E_t % | median t dir deg | median E_s % | inliers % | ms/call |", file=out)
    print("|---|---|---|---|---|---|---|---|---|---|---|", file=out)
    for r in rows:
        es = "-" if np.isnan(r["e_s"]) else f"{r['e_s']:.2f}"
        fail = f" ({r['failed_calls']} no model)" if r["failed_calls"] else ""
        print(f"| {r['problem']} | {r['gap']} | {r['solver']} | {r['pairs']} | {r['success']:.1f}{fail} | {r['e_R']:.3f} | {r['e_t']:.2f} | "
              f"{r['e_dir']:.2f} | {es} | {r['inlier_ratio']:.1f} | {r['ms']:.1f} |", file=out)


def plot(records, outdir, ref):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    os.makedirs(outdir, exist_ok=True)
    problems = sorted({r["problem"] for r in records})
    gaps = sorted({r["gap"] for r in records})
    paths = []
    for problem in problems:
        fig, axes = plt.subplots(2, len(gaps), figsize=(5 * len(gaps), 6), squeeze=False)
        for c, gap in enumerate(gaps):
            for solver, mark in (("simhc", "o"), ("poselib", "x")):
                rs = sorted((r for r in records if r["problem"] == problem and r["gap"] == gap and r["solver"] == solver), key=lambda r: r["i"])
                if not rs:
                    continue
                x = [r["frame_i"] for r in rs]
                axes[0][c].semilogy(x, [max(r[ref]["e_R"], 1e-4) if r[ref]["ok"] else np.nan for r in rs], mark, ms=3, label=solver)
                axes[1][c].semilogy(x, [max(r[ref]["e_t"], 1e-3) if r[ref]["ok"] else np.nan for r in rs], mark, ms=3, label=solver)
            axes[0][c].set_title(f"{problem}, gap {gap}")
            axes[0][c].set_ylabel("E_R (deg)")
            axes[1][c].set_ylabel("E_t (% of motion)")
            axes[1][c].set_xlabel("frame i")
            axes[0][c].axhline(1.0, color="gray", lw=0.5)
            axes[1][c].axhline(5.0, color="gray", lw=0.5)
            axes[0][c].legend()
        label = {"ba": "the GTSAM stereo BA", "vo": "the shipped VO poses"}[ref]
        fig.suptitle(f"KITTI 00 stereo rig, {problem}: simhc and PoseLib, errors against {label} (seed in the run's output)")
        fig.tight_layout()
        path = os.path.join(outdir, f"kitti_{problem.replace(' ', '_').replace('=', '')}.png")
        fig.savefig(path, dpi=100)
        plt.close(fig)
        paths.append(path)
    return paths


def finite(o):
    """JSON without NaN (null instead) and with numpy scalars as numbers."""
    if isinstance(o, dict):
        return {k: finite(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [finite(v) for v in o]
    if hasattr(o, "item"):
        o = o.item()
    if isinstance(o, float) and not np.isfinite(o):
        return None
    return o


def main(argv=None):
    a = parse_args(argv)
    import gen_relpose
    import poselib
    import simhc

    log = sys.stderr if a.json == "-" else sys.stdout
    print(f"seed {a.seed}; gaps {a.gaps}; stride {a.stride}; max pairs per gap {a.max_pairs}; thresholds {a.rel_px} px (relpose, grps), "
          f"{a.abs_px} px (upnp); simhc noise {a.noise_px} px; simhc input scale {a.scale_name}; grps known scale {a.grps_scale}", file=log)
    from importlib.metadata import version

    print(f"simhc {version('simhc')} from {os.path.dirname(simhc.__file__)}; gen_relpose {version('gen-relpose')} from {gen_relpose.__file__}; poselib {version('poselib')}; gtsam {version('gtsam')}", file=log)
    data = kitti.load()
    if max(a.gaps) >= len(data.ids):
        sys.exit(f"bench.py: --gaps {max(a.gaps)}: the sequence has {len(data.ids)} frames, so a gap must be below {len(data.ids)}")
    refs = {"ba": kitti.reference(data), "vo": data.vo}
    rng = np.random.default_rng(a.seed)
    pairs = select_pairs(len(data.ids), a, rng)
    records = []
    t0 = time.perf_counter()
    for k, (i, j) in enumerate(pairs):
        records += run_pair(data, refs, i, j, a, rng, seed=a.seed + k)
        if not a.quiet and (k + 1) % 25 == 0:
            print(f"  {k + 1}/{len(pairs)} pairs, {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    tables = {ref: summarize(records, ref) for ref in refs}
    # With `--json -` stdout holds the JSON alone; the tables go to stderr.
    out = sys.stderr if a.json == "-" else sys.stdout
    print_table(tables["ba"], "Errors against the GTSAM stereo BA reference (bench/real/kitti.py)", out)
    print_table(tables["vo"], "Errors against the shipped VO poses (VO_camera_poses00.txt)", out)
    if a.plot:
        for p in plot(records, a.plot, "ba"):
            print(f"plot: {p}", file=log)
    if a.json:
        out = {"args": {k: v for k, v in vars(a).items() if k != "json"}, "tables": tables, "records": records}
        text = json.dumps(finite(out), indent=1)
        if a.json == "-":
            print(text)
        else:
            with open(a.json, "w") as fh:
                fh.write(text)
            print(f"json: {a.json}")


if __name__ == "__main__":
    main()
