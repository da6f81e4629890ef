"""Why simhc's samples fail on KITTI: the share of RANSAC samples that give a model, by input scale.

    python bench/real/starts.py [--pairs 12] [--seed 1] [--scales none,baseline,depth,3,10,20,40]

simhc's estimators solve a sample by Gauss-Newton from the learned start and keep it only if it
validates on the sample (`info["models"]`: models kept; `info["iterations"]`: samples drawn), so
models / iterations is the share of samples whose start lands in Gauss-Newton's basin (times the
share of all-inlier samples, about 0.97^k here). It is printed per problem and input scale (the
similarity of `solvers.py`, L in metres: `none` is metric, `baseline` is half the baseline,
`depth` the median distance of the landmarks from the rig; median L printed), with
the median E_R, E_t against the reference BA and the time per call, over `--pairs` frame pairs
(gaps 1, 3, 5, drawn with the seed). For comparison, the same share on the synthetic scenes of
`bench/peers/robust_grp.py` / `robust_upnp.py` (0 % outliers, 1 px), the order-one scenes the
peers harness uses.
"""

import argparse
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "..", "peers"))

import bench  # noqa: E402
import correspondences  # noqa: E402
import kitti  # noqa: E402
import solvers  # noqa: E402

import gen_relpose  # noqa: E402
import simhc  # noqa: E402


def clean(pair, Rg, tg, rng, sigma=0.0, rig=1.0):
    """The pair with its bearings recomputed from the landmarks and the reference pose, exactly
    (`sigma` = 0) or with isotropic angular noise `sigma` (radians): KITTI's geometry without its
    measurement noise. `rig` multiplies the camera offsets (a wider rig seeing the same points)."""
    import copy

    q = copy.copy(pair)
    q.v1, q.v2 = pair.v1 * rig, pair.v2 * rig
    X = pair.points  # frame i's left camera = rig i
    X2 = (Rg.T @ (X - tg).T).T  # the same points in rig j (X_i = R X_j + t)

    def bear(d):
        d = d / np.linalg.norm(d, axis=1, keepdims=True)
        if sigma > 0:
            n = rng.normal(0, sigma, d.shape)
            d = d + n - d * np.sum(d * n, axis=1, keepdims=True)
            d /= np.linalg.norm(d, axis=1, keepdims=True)
        return d

    q.f1, q.f2 = bear(X - q.v1), bear(X2 - q.v2)
    return q


def synthetic(n, seed):
    """models / iterations of simhc on the peers harness's synthetic scenes (no outliers, 1 px)."""
    import robust_grp
    import robust_upnp

    rng = np.random.default_rng(seed)
    sigma = 1.0 / robust_grp.FOCAL
    out = {"relpose": [], "grps": [], "upnp": []}
    for k in range(n):
        tr = robust_grp.scene(rng, 0.0, sigma)
        f = np.array([m[2] for m in tr["matches"]])
        fp = np.array([m[3] for m in tr["matches"]])
        v = np.array([tr["cams1"][m[0]] for m in tr["matches"]])
        vp = np.array([tr["cams2"][m[1]] for m in tr["matches"]])
        _, info = gen_relpose.estimate(np.hstack([f, v, fp, vp]), threshold=2 * sigma, noise=1.0, seed=k)
        out["relpose"].append(info["models"] / info["iterations"])
        _, info = simhc.grps.estimate(f, v, fp, vp, threshold=2 * sigma, seed=k)
        out["grps"].append(info["models"] / info["iterations"])
        tu = robust_upnp.scene(rng, 0.0, sigma)
        _, info = simhc.upnp.estimate(tu["p"], tu["f"], tu["cams"][tu["cam"]], threshold=3 * sigma, seed=k)
        out["upnp"].append(info["models"] / info["iterations"])
    return {k: float(np.median(v)) for k, v in out.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--pairs", type=int, default=12)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--scales", default="none,baseline,depth,3,10,20,40")
    ap.add_argument("--rel-px", type=float, default=1.0)
    ap.add_argument("--abs-px", type=float, default=3.0)
    ap.add_argument("--problems", default="relpose,grps,upnp")
    ap.add_argument("--geometry", default="real", choices=["real", "clean", "clean1px"],
                    help="real: the measured pixels; clean: bearings recomputed exactly from the landmarks and the "
                         "reference BA pose (no noise, no wrong match); clean1px: the same with 1 px of angular noise")
    ap.add_argument("--rig", type=float, default=1.0, help="with clean geometry: multiply the baseline by this")
    ap.add_argument("--noise-px", type=float, default=1.0, help="simhc's sample tolerance `noise` (px at KITTI's focal)")
    ap.add_argument("--min-iterations", type=int, default=1000, help="RANSAC minimum of samples (PoseLib's default 1000)")
    ap.add_argument("--poselib", action="store_true", help="also PoseLib's row (relpose, upnp) with the same minimum")
    a = ap.parse_args()
    if a.pairs < 1:
        ap.error("--pairs must be >= 1")
    problems = a.problems.split(",")
    print(f"seed {a.seed}; {a.pairs} pairs; thresholds {a.rel_px} / {a.abs_px} px; simhc noise {a.noise_px} px; "
          f"min iterations {a.min_iterations}")
    data = kitti.load()
    ba = kitti.reference(data)
    rng = np.random.default_rng(a.seed)
    all_pairs = correspondences.pairs(len(data.ids), [1, 3, 5])
    chosen = [all_pairs[k] for k in sorted(rng.choice(len(all_pairs), a.pairs, replace=False))]
    built = [correspondences.build(data, i, j, rng) for i, j in chosen]
    if a.geometry != "real":
        sigma = 0.0 if a.geometry == "clean" else 1.0 / data.calib.fx
        built = [clean(p, *solvers.truth("relpose", ba[p.i], ba[p.j]), rng, sigma, a.rig) for p in built]
    print(f"geometry: {a.geometry}" + (f", baseline x {a.rig:g}" if a.geometry != "real" else ""))
    print("pairs:", chosen)
    print("| problem | input scale L | samples with a model (median %) | success % | median E_R deg | median E_t % | ms/call |")
    print("|---|---|---|---|---|---|---|")
    for problem in problems:
        for name in a.scales.split(","):
            share, ok, eR, et, ms, Ls, its = [], [], [], [], [], [], []
            for k, p in enumerate(built):
                L = bench.input_scale(None if name == "none" else (name if name in ("baseline", "depth") else float(name)), data.calib, p)
                Ls.append(L or 1.0)
                if problem == "upnp":
                    res = solvers.simhc_upnp(p, data.calib, a.abs_px, a.noise_px, a.seed + k, L, a.min_iterations)
                else:
                    res = solvers.simhc_relpose(p, data.calib, a.rel_px, a.noise_px, a.seed + k, L, grps=(problem == "grps"),
                                                min_iterations=a.min_iterations)
                share.append(100 * res.get("models", 0) / max(res.get("iterations", 1), 1))
                its.append(res.get("iterations", 0))
                Rg, tg = solvers.truth("upnp" if problem == "upnp" else "relpose", ba[p.i], ba[p.j])
                e = solvers.errors(res, Rg, tg, 1.0 if problem == "grps" else None)
                ok.append(e["success"])
                eR.append(e["e_R"])
                et.append(e["e_t"])
                ms.append(res["ms"])
            label = ("metric (none)" if name == "none" else f"{np.median(Ls):.3g} m ({name})") + f", median {np.median(its):.0f} samples"
            print(f"| {problem} | {label} | {np.median(share):.1f} | {100 * np.mean(ok):.0f} | {np.nanmedian(eR):.3f} | {np.nanmedian(et):.2f} | {np.median(ms):.1f} |")
    if a.poselib:
        for problem in [q for q in problems if q != "grps"]:
            ok, eR, et, ms, its = [], [], [], [], []
            for p in built:
                res = (solvers.poselib_upnp(p, data.calib, a.abs_px, a.min_iterations) if problem == "upnp"
                       else solvers.poselib_relpose(p, data.calib, a.rel_px, a.min_iterations))
                Rg, tg = solvers.truth("upnp" if problem == "upnp" else "relpose", ba[p.i], ba[p.j])
                e = solvers.errors(res, Rg, tg)
                ok.append(e["success"])
                eR.append(e["e_R"])
                et.append(e["e_t"])
                ms.append(res["ms"])
                its.append(res.get("iterations", 0))
            print(f"| {problem} | PoseLib (metres), median {np.median(its):.0f} samples | - | {100 * np.mean(ok):.0f} | {np.nanmedian(eR):.3f} | "
                  f"{np.nanmedian(et):.2f} | {np.median(ms):.1f} |")
    syn = synthetic(10, a.seed)
    print("synthetic scenes of bench/peers (robust_grp.scene / robust_upnp.scene, 0 % outliers, 1 px, 10 scenes): "
          + ", ".join(f"{k} {100 * v:.1f} %" for k, v in syn.items()) + " of samples give a model (median)")


if __name__ == "__main__":
    main()
