"""simhc from Python: correct poses on seeded synthetic scenes, typed exceptions on bad input.

Run with ``pytest python/tests`` after ``maturin develop --release -m python/Cargo.toml`` (what
``.ci/run`` does). Every scene comes from ``numpy.random.default_rng(seed)``; a failure prints
its seed.
"""

import numpy as np
import pytest

import simhc


def random_rotation(rng):
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
            [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
            [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)],
        ]
    )


def unit(a):
    return a / np.linalg.norm(a, axis=1, keepdims=True)


def rotation_error_deg(r, r_gt):
    c = (np.trace(r_gt.T @ r) - 1) / 2
    return np.degrees(np.arccos(np.clip(c, -1, 1)))


def upnp_scene(seed, n=10):
    """alpha f + v = R p + t: 4 cameras of a rig, points in front of them."""
    rng = np.random.default_rng(seed)
    r, t = random_rotation(rng), rng.uniform(-1, 1, 3)
    v = rng.uniform(-0.5, 0.5, (4, 3))[rng.integers(0, 4, n)]
    x = v + np.column_stack([rng.uniform(-2, 2, (n, 2)), rng.uniform(4, 8, n)])  # rig frame
    p = (x - t) @ r  # world: R p + t = x
    return p, unit(x - v), v, r, t


def relative_scene(seed, n, scale=1.0):
    """Two rigs: X1 = R (X2 s) + t for GRPS (s = scale), rays (v, f) and (vp, fp)."""
    rng = np.random.default_rng(seed)
    r, t = random_rotation(rng), rng.uniform(-1, 1, 3)
    v = rng.uniform(-1, 1, (5, 3))[rng.integers(0, 5, n)]
    vp = rng.uniform(-1, 1, (5, 3))[rng.integers(0, 5, n)]
    x1 = np.column_stack([rng.uniform(-2, 2, (n, 2)), rng.uniform(3, 10, n)])
    x2 = (x1 - t) @ r / scale  # rig-2 units
    return unit(x1 - v), v, unit(x2 - vp), vp, r, t


@pytest.mark.parametrize("seed", range(20))
def test_upnp_returns_the_true_pose(seed):
    p, f, v, r, t = upnp_scene(seed)
    pose = simhc.upnp(p, f, v)
    assert rotation_error_deg(pose.R, r) < 1e-4, f"seed {seed}"
    assert np.linalg.norm(pose.t - t) < 1e-5, f"seed {seed}"
    assert pose.s is None
    # Noise-free data: the returned rotation is certified next to an exact root.
    assert pose.certified is not None and 0 <= pose.certified < 1e-6, f"seed {seed}: {pose.certified}"


@pytest.mark.parametrize("seed", range(10))
def test_grps_returns_the_true_pose_and_scale(seed):
    f, v, fp, vp, r, t = relative_scene(seed, 8, scale=1.7)
    pose = simhc.grps(f, v, fp, vp)
    assert rotation_error_deg(pose.R, r) < 1e-3, f"seed {seed}"
    assert np.linalg.norm(pose.t - t) < 1e-3 * np.linalg.norm(t), f"seed {seed}"
    assert abs(pose.s - 1.7) < 1e-3, f"seed {seed}"


def test_gen_relpose_solves_most_and_is_never_wrong():
    solved = 0
    for seed in range(30):
        f, v, fp, vp, r, t = relative_scene(100 + seed, 7)
        try:
            pose = simhc.gen_relpose(f, v, fp, vp)
        except simhc.SolveError:
            continue  # flagged: allowed, but never a wrong pose
        assert rotation_error_deg(pose.R, r) < 0.1, f"seed {100 + seed}: a wrong pose came back"
        assert np.linalg.norm(pose.t - t) < 1e-2 * np.linalg.norm(t), f"seed {100 + seed}"
        solved += 1
    assert solved >= 27, f"{solved} of 30 solved"


def test_the_generic_module_matches_the_function():
    f, v, fp, vp, r, t = relative_scene(7, 7)
    rows = np.hstack([f, v, fp, vp])
    assert simhc.grp.solver.row_fields == [("f", 3), ("v", 3), ("fp", 3), ("vp", 3)]
    assert simhc.grp.solver.unknowns == [("q", 4), ("t", 3)]
    x = simhc.grp.solve(rows)
    pose = simhc.gen_relpose(f, v, fp, vp)
    assert np.allclose(x["t"], pose.t, atol=1e-12)
    # The same certificate from both, for the exact root of noise-free data.
    assert x["certified"] is not None and x["certified"] == pose.certified and x["certified"] < 1e-6
    assert np.linalg.norm(x["t"] - t) < 1e-2 * np.linalg.norm(t)


def test_batch_gives_the_single_answers():
    scenes = [relative_scene(200 + s, 7) for s in range(12)]
    rows = np.stack([np.hstack(sc[:4]) for sc in scenes])
    x, ok = simhc.grp.solve_batch(rows)
    assert x.shape == (12, 7) and ok.dtype == np.bool_
    assert ok.sum() >= 10
    for i, sc in enumerate(scenes):
        if ok[i]:
            single = simhc.grp.solve(rows[i])
            assert np.allclose(x[i, 4:], single["t"], atol=1e-12)
        else:
            assert np.isnan(x[i]).all()
    empty_x, empty_ok = simhc.grp.solve_batch(np.zeros((0, 7, 12)))
    assert empty_x.shape == (0, 7) and empty_ok.shape == (0,)


def test_estimate_finds_the_inliers_among_outliers():
    seed = 11
    rng = np.random.default_rng(seed)
    f, v, fp, vp, r, t = relative_scene(seed, 60)
    outliers = rng.choice(60, 24, replace=False)  # 40 %
    fp[outliers] = unit(rng.normal(size=(24, 3)))
    fp = unit(fp + rng.normal(scale=0.5 / 800, size=fp.shape))  # about half a pixel at f = 800 px
    pose, info = simhc.estimate_gen_relpose(f, v, fp, vp, threshold=2.5 / 800, seed=seed)  # 2.5 px
    truth = np.ones(60, bool)
    truth[outliers] = False
    assert info["inlier_mask"].dtype == np.bool_ and info["inlier_mask"].shape == (60,)
    assert (info["inlier_mask"] & truth).sum() >= 35, f"seed {seed}: recall {(info['inlier_mask'] & truth).sum()} of 36"
    assert info["num_inliers"] == info["inlier_mask"].sum()
    assert abs(info["inlier_ratio"] - info["num_inliers"] / 60) < 1e-12
    assert info["iterations"] >= 1000  # PoseLib's minimum
    assert (info["inlier_mask"] & ~truth).sum() <= 1, "outliers taken as inliers"
    assert rotation_error_deg(pose.R, r) < 2.0  # the success: E_R < 2 deg, E_t < 5 %
    assert np.linalg.norm(pose.t - t) < 0.05 * np.linalg.norm(t)


def recall_and_wrong(info, truth):
    mask = info["inlier_mask"]
    assert mask.dtype == np.bool_ and mask.shape == truth.shape
    assert info["num_inliers"] == mask.sum()
    assert info["iterations"] >= 1000  # PoseLib's minimum
    return (mask & truth).sum(), (mask & ~truth).sum()


@pytest.mark.parametrize("seed", [21, 22])
def test_estimate_upnp_finds_the_inliers_among_outliers(seed):
    rng = np.random.default_rng(seed + 1000)
    p, f, v, r, t = upnp_scene(seed, n=80)
    outliers = rng.choice(80, 32, replace=False)  # 40 %
    p[outliers] += rng.uniform(-3, 3, (32, 3))  # wrong matches: other world points
    f = unit(f + rng.normal(scale=0.5 / 800, size=f.shape))  # about half a pixel
    pose, info = simhc.estimate_upnp(p, f, v, seed=seed)
    truth = np.ones(80, bool)
    truth[outliers] = False
    kept, wrong = recall_and_wrong(info, truth)
    assert kept >= 47, f"seed {seed}: recall {kept} of 48"
    assert wrong <= 1, f"seed {seed}: {wrong} outliers taken as inliers"
    assert rotation_error_deg(pose.R, r) < 2.0, f"seed {seed}"
    assert np.linalg.norm(pose.t - t) < 0.05 * np.linalg.norm(t), f"seed {seed}"


def test_estimate_grps_finds_the_inliers_among_outliers():
    seed = 23
    rng = np.random.default_rng(seed + 1000)
    f, v, fp, vp, r, t = relative_scene(seed, 60, scale=1.7)
    outliers = rng.choice(60, 18, replace=False)  # 30 %
    fp[outliers] = unit(rng.normal(size=(18, 3)))
    pose, info = simhc.estimate_grps(f, v, fp, vp, seed=seed)
    truth = np.ones(60, bool)
    truth[outliers] = False
    kept, wrong = recall_and_wrong(info, truth)
    assert kept >= 41, f"seed {seed}: recall {kept} of 42"
    assert wrong <= 1, f"seed {seed}: {wrong} outliers taken as inliers"
    assert rotation_error_deg(pose.R, r) < 2.0
    assert abs(pose.s - 1.7) < 0.05 * 1.7


def test_the_estimators_name_a_bad_correspondence():
    p, f, v, _, _ = upnp_scene(3, n=12)
    f[7, 2] = np.nan
    with pytest.raises(simhc.InputError, match=r"correspondence 7, field `bearings`"):
        simhc.estimate_upnp(p, f, v)
    f[7, 2] = 1.0
    with pytest.raises(simhc.InputError, match="too few correspondences: got 3, need at least 4"):
        simhc.estimate_upnp(p[:3], f[:3], v[:3])
    with pytest.raises(simhc.InputError, match="noise"):
        simhc.estimate_upnp(p, f, v, noise=-1.0)
    f2, v2, fp2, vp2, _, _ = relative_scene(4, 9)
    with pytest.raises(simhc.InputError, match="too few correspondences: got 6, need at least 7"):
        simhc.estimate_grps(f2[:6], v2[:6], fp2[:6], vp2[:6])
    with pytest.raises(simhc.InputError, match="confidence"):
        simhc.estimate_grps(f2, v2, fp2, vp2, confidence=1.5)


def test_bad_input_raises_input_error_that_says_where():
    p, f, v, _, _ = upnp_scene(3)
    p[4, 1] = np.nan
    with pytest.raises(simhc.InputError, match=r"correspondence 4, field `points`"):
        simhc.upnp(p, f, v)
    p[4, 1] = 0.0
    with pytest.raises(simhc.InputError, match=r"`bearings`: expected an array of shape \(N, 3\), got shape \(10, 2\)"):
        simhc.upnp(p, f[:, :2], v)
    with pytest.raises(simhc.InputError, match="rows"):
        simhc.upnp(p[:5], f, v)
    with pytest.raises(simhc.InputError, match="too few"):
        simhc.upnp(p[:2], f[:2], v[:2])
    f2, v2, fp2, vp2, _, _ = relative_scene(4, 7)
    vp2[4, 0] = np.inf
    with pytest.raises(simhc.InputError, match=r"correspondence 4, field `vp`"):
        simhc.gen_relpose(f2, v2, fp2, vp2)
    vp2[4, 0] = 0.0
    with pytest.raises(simhc.InputError, match="exactly 7"):
        simhc.gen_relpose(f2[:6], v2[:6], fp2[:6], vp2[:6])
    with pytest.raises(simhc.InputError, match="too few correspondences: got 5, need at least 7"):
        simhc.estimate_gen_relpose(f2[:5], v2[:5], fp2[:5], vp2[:5])
    with pytest.raises(simhc.InputError, match="threshold"):
        simhc.estimate_gen_relpose(f2, v2, fp2, vp2, threshold=-1.0)
    rows = np.hstack([f2, v2, fp2, vp2])
    rows[2, 9] = np.nan
    with pytest.raises(simhc.InputError, match=r"row 2, field `vp`"):
        simhc.grp.solve(rows)
    with pytest.raises(simhc.InputError, match="not an array of numbers"):
        simhc.grps("f", "v", "fp", "vp")
    assert issubclass(simhc.InputError, ValueError)
    assert issubclass(simhc.NotValidatedError, simhc.SolveError) and issubclass(simhc.SolveError, RuntimeError)


def test_empty_arrays_raise_and_do_not_crash():
    empty = np.zeros((0, 3))
    for call in (
        lambda: simhc.upnp(empty, empty, empty),
        lambda: simhc.grps(empty, empty, empty, empty),
        lambda: simhc.gen_relpose(empty, empty, empty, empty),
        lambda: simhc.estimate_gen_relpose(empty, empty, empty, empty),
        lambda: simhc.estimate_upnp(empty, empty, empty),
        lambda: simhc.estimate_grps(empty, empty, empty, empty),
        lambda: simhc.upnp([], [], []),
    ):
        with pytest.raises(simhc.InputError):
            call()


def test_data_no_pose_fits_is_never_a_pose():
    rng = np.random.default_rng(5)
    f, v, fp, vp = (unit(rng.normal(size=(7, 3))), rng.normal(size=(7, 3)), unit(rng.normal(size=(7, 3))), rng.normal(size=(7, 3)))
    try:
        pose = simhc.gen_relpose(f, v, fp, vp)
    except simhc.SolveError:
        return
    # Seven random rays can have a pose by chance only if all seven are coplanar with it.
    r, t = pose.R, pose.t
    for i in range(7):
        n = np.cross(f[i], r @ fp[i])
        assert abs(n @ (r @ vp[i] + t - v[i])) < 1e-6 * (1 + np.linalg.norm(n))


def test_help_says_what_the_arrays_are():
    assert "(N, 3)" in simhc.upnp.__doc__ and "origins" in simhc.upnp.__doc__
    assert "inlier_mask" in simhc.estimate_gen_relpose.__doc__
    assert "threshold" in simhc.estimate_gen_relpose.__text_signature__
    for estimate in (simhc.estimate_upnp, simhc.estimate_grps):
        assert "inlier_mask" in estimate.__doc__ and "(N, 3)" in estimate.__doc__
        assert "threshold" in estimate.__text_signature__
