"""simhc from Python: correct poses on seeded synthetic scenes, typed exceptions on bad input.

Run with ``pytest python/tests`` after ``pip install ./python`` (what ``.ci/run`` does; the
example problem's module ``gen_relpose`` has its tests in ``examples/generalized-relative-pose/python``). Every scene comes from ``numpy.random.default_rng(seed)``; a failure prints
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
    assert "s" not in pose and pose["t"] is pose.t
    # Noise-free data: the returned rotation is certified next to an exact root.
    assert pose.certified is not None and 0 <= pose.certified < 1e-6, f"seed {seed}: {pose.certified}"


@pytest.mark.parametrize("seed", range(10))
def test_grps_returns_the_true_pose_and_scale(seed):
    f, v, fp, vp, r, t = relative_scene(seed, 8, scale=1.7)
    pose = simhc.grps(f, v, fp, vp)
    assert rotation_error_deg(pose.R, r) < 1e-3, f"seed {seed}"
    assert np.linalg.norm(pose.t - t) < 1e-3 * np.linalg.norm(t), f"seed {seed}"
    assert abs(pose.s - 1.7) < 1e-3, f"seed {seed}"


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
    pose, info = simhc.upnp.estimate(p, f, v, seed=seed)
    truth = np.ones(80, bool)
    truth[outliers] = False
    kept, wrong = recall_and_wrong(info, truth)
    assert kept >= 47, f"seed {seed}: recall {kept} of 48"
    assert wrong <= 1, f"seed {seed}: {wrong} outliers taken as inliers"
    assert rotation_error_deg(pose.R, r) < 2.0, f"seed {seed}"
    assert np.linalg.norm(pose.t - t) < 0.05 * np.linalg.norm(t), f"seed {seed}"


def test_skip_explained_solves_fewer_samples_and_finds_the_same_inliers():
    rng = np.random.default_rng(1021)
    p, f, v, r, t = upnp_scene(21, n=80)
    outliers = rng.choice(80, 16, replace=False)  # 20 %
    p[outliers] += rng.uniform(-3, 3, (16, 3))
    plain_pose, plain = simhc.upnp.estimate(p, f, v, seed=3)
    pose, info = simhc.upnp.estimate(p, f, v, seed=3, skip_explained=True)
    assert info["iterations"] == plain["iterations"]  # skipped samples still count
    assert info["models"] < plain["models"], (info["models"], plain["models"])
    assert (info["inlier_mask"] == plain["inlier_mask"]).all()
    assert rotation_error_deg(pose.R, r) < 2.0


def test_estimate_grps_finds_the_inliers_among_outliers():
    seed = 23
    rng = np.random.default_rng(seed + 1000)
    f, v, fp, vp, r, t = relative_scene(seed, 60, scale=1.7)
    outliers = rng.choice(60, 18, replace=False)  # 30 %
    fp[outliers] = unit(rng.normal(size=(18, 3)))
    pose, info = simhc.grps.estimate(f, v, fp, vp, seed=seed)
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
        simhc.upnp.estimate(p, f, v)
    f[7, 2] = 1.0
    with pytest.raises(simhc.InputError, match="too few correspondences: got 3, need at least 4"):
        simhc.upnp.estimate(p[:3], f[:3], v[:3])
    with pytest.raises(simhc.InputError, match="noise"):
        simhc.upnp.estimate(p, f, v, noise=-1.0)
    f2, v2, fp2, vp2, _, _ = relative_scene(4, 9)
    with pytest.raises(simhc.InputError, match="too few correspondences: got 6, need at least 7"):
        simhc.grps.estimate(f2[:6], v2[:6], fp2[:6], vp2[:6])
    with pytest.raises(simhc.InputError, match="confidence"):
        simhc.grps.estimate(f2, v2, fp2, vp2, confidence=1.5)


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
    f2, v2, fp2, vp2, _, _ = relative_scene(4, 8)
    vp2[4, 0] = np.inf
    with pytest.raises(simhc.InputError, match=r"correspondence 4, field `vp`"):
        simhc.grps(f2, v2, fp2, vp2)
    vp2[4, 0] = 0.0
    with pytest.raises(simhc.InputError, match=r"`fp` has 7 rows, `f` has 8"):
        simhc.grps(f2, v2, fp2[:7], vp2)
    with pytest.raises(simhc.InputError, match="not an array of numbers"):
        simhc.grps("f", "v", "fp", "vp")
    assert issubclass(simhc.InputError, ValueError)
    assert issubclass(simhc.NotValidatedError, simhc.SolveError) and issubclass(simhc.SolveError, RuntimeError)
    assert issubclass(simhc.NoSolutionError, simhc.SolveError)


def test_exceptions_are_named_simhc():
    for name in ("InputError", "SolveError", "NotValidatedError", "NoSolutionError"):
        cls = getattr(simhc, name)
        assert cls.__module__ == "simhc" and cls.__qualname__ == name, f"{cls!r}"
    with pytest.raises(simhc.InputError) as raised:
        simhc.upnp(np.zeros((2, 3)), np.zeros((2, 3)))
    assert repr(raised.type) == "<class 'simhc.InputError'>"


def test_empty_arrays_raise_and_do_not_crash():
    empty = np.zeros((0, 3))
    for call in (
        lambda: simhc.upnp(empty, empty, empty),
        lambda: simhc.grps(empty, empty, empty, empty),
        lambda: simhc.upnp.estimate(empty, empty, empty),
        lambda: simhc.grps.estimate(empty, empty, empty, empty),
        lambda: simhc.upnp([], [], []),
    ):
        with pytest.raises(simhc.InputError):
            call()


def test_help_says_what_the_arrays_are():
    assert "(N, 3)" in simhc.upnp.about and "origins" in simhc.upnp.about
    for solver in (simhc.upnp, simhc.grps):
        assert "inlier_mask" in solver.estimate.__doc__ and "(N, 3)" in solver.about
        assert "threshold" in solver.estimate.__text_signature__


def test_the_built_ins_are_the_one_class_of_every_problem():
    for solver, name in ((simhc.upnp, "upnp"), (simhc.grps, "grps")):
        assert type(solver) is simhc.ProblemSolver and solver.name == name and solver.more_rows
        assert type(solver).__module__ == "simhc"
    assert simhc.upnp.row_fields == [("points", [3]), ("bearings", [3]), ("origins", [3])]
    assert simhc.grps.solution_fields == [("R", [3, 3]), ("t", [3]), ("s", []), ("q", [4])]
    assert repr(simhc.upnp) == "<simhc.ProblemSolver `upnp`: 3+ rows of [points, bearings, origins] -> [R, t, q]>"


def test_fields_by_name_by_position_or_as_rows_give_the_same_pose():
    p, f, v, r, _ = upnp_scene(5)
    by_position = simhc.upnp(p, f, v)
    by_name = simhc.upnp.solve(bearings=f, points=p, origins=v)
    as_rows = simhc.upnp(np.hstack([p, f, v]))
    for pose in (by_name, as_rows):
        assert np.array_equal(pose.R, by_position.R) and np.array_equal(pose.t, by_position.t)
    assert rotation_error_deg(by_position.R, r) < 1e-4
    assert sorted(by_position.keys()) == ["R", "certified", "q", "t"] and dict(by_position.items())["t"] is by_position.t
    # `origins` is optional: one central camera at the rig origin.
    pc, _, _, rc, _ = upnp_scene(6)
    tc = np.array([0.1, -0.2, 0.3])
    central = simhc.upnp(points=pc, bearings=unit(pc @ rc.T + tc))
    assert rotation_error_deg(central.R, rc) < 1e-4 and np.linalg.norm(central.t - tc) < 1e-5
    with pytest.raises(simhc.InputError, match="`bearing`: not a field of `upnp`'s rows"):
        simhc.upnp(points=p, bearing=f)
    with pytest.raises(simhc.InputError, match="`points`: given twice"):
        simhc.upnp(p, f, points=p)
    with pytest.raises(simhc.InputError, match="`bearings`: missing"):
        simhc.upnp(p)
    with pytest.raises(AttributeError, match="no field `s`"):
        by_position.s


def test_batch_of_a_built_in_gives_the_single_answers():
    scenes = [upnp_scene(300 + s) for s in range(4)]
    rows = np.stack([np.hstack(sc[:3]) for sc in scenes])
    x, ok = simhc.upnp.solve_batch(rows)
    assert x.shape == (4, 16) and ok.all()
    for i, sc in enumerate(scenes):
        assert np.allclose(x[i, :9].reshape(3, 3), simhc.upnp(*sc[:3]).R, atol=1e-12)
