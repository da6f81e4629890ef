"""The example problem's module, ``import gen_relpose``: made by the one line a user's crate writes
(``simhc_pymodule::python_module!``), it must solve, estimate and batch correctly, and its
errors and help must name ``gen_relpose``, not ``simhc``.

Run with ``pytest examples/generalized-relative-pose/python/tests`` after
``pip install ./examples/generalized-relative-pose/python`` (what ``.ci/run`` does). Every scene
comes from ``numpy.random.default_rng(seed)``; a failure prints its seed.
"""

import numpy as np
import pytest

import gen_relpose


def quaternion_rotation(q):
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


def relative_scene(seed, n):
    """Two rigs, X1 = R X2 + t, rays (v, f) in rig 1 and (vp, fp) in rig 2."""
    rng = np.random.default_rng(seed)
    r, t = quaternion_rotation(rng.normal(size=4)), rng.uniform(-1, 1, 3)
    v = rng.uniform(-1, 1, (5, 3))[rng.integers(0, 5, n)]
    vp = rng.uniform(-1, 1, (5, 3))[rng.integers(0, 5, n)]
    x1 = np.column_stack([rng.uniform(-2, 2, (n, 2)), rng.uniform(3, 10, n)])
    x2 = (x1 - t) @ r
    return unit(x1 - v), v, unit(x2 - vp), vp, r, t


def rows_of(f, v, fp, vp):
    return np.hstack([f, v, fp, vp])


def test_solve_returns_the_true_pose_with_its_certificate():
    f, v, fp, vp, r, t = relative_scene(7, 7)
    assert gen_relpose.solver.name and gen_relpose.solver.rows == 7
    assert gen_relpose.solver.row_fields == [("f", [3]), ("v", [3]), ("fp", [3]), ("vp", [3])]
    assert gen_relpose.solver.solution_fields == [("q", [4]), ("t", [3])]
    assert gen_relpose.solver.global_fields == []
    x = gen_relpose.solve(rows_of(f, v, fp, vp))
    by_name = gen_relpose.solve(f=f, v=v, fp=fp, vp=vp)
    assert np.array_equal(by_name.q, x["q"]) and np.array_equal(by_name["t"], x.t)
    assert rotation_error_deg(quaternion_rotation(x["q"]), r) < 1e-4
    assert np.linalg.norm(x["t"] - t) < 1e-6 * np.linalg.norm(t)
    # Noise-free data: the solution is certified next to an exact root.
    assert x["certified"] is not None and 0 <= x["certified"] < 1e-6


def test_solve_solves_most_and_is_never_wrong():
    solved = 0
    for seed in range(30):
        f, v, fp, vp, r, t = relative_scene(100 + seed, 7)
        try:
            x = gen_relpose.solve(rows_of(f, v, fp, vp))
        except gen_relpose.SolveError:
            continue  # flagged: allowed, but never a wrong pose
        assert rotation_error_deg(quaternion_rotation(x["q"]), r) < 0.1, f"seed {100 + seed}: a wrong pose came back"
        assert np.linalg.norm(x["t"] - t) < 1e-2 * np.linalg.norm(t), f"seed {100 + seed}"
        solved += 1
    assert solved >= 27, f"{solved} of 30 solved"


def test_batch_gives_the_single_answers():
    scenes = [relative_scene(200 + s, 7) for s in range(12)]
    rows = np.stack([rows_of(*sc[:4]) for sc in scenes])
    x, ok = gen_relpose.solve_batch(rows)
    assert x.shape == (12, 7) and ok.dtype == np.bool_
    assert ok.sum() >= 10
    for i, sc in enumerate(scenes):
        if ok[i]:
            single = gen_relpose.solve(rows[i])
            assert np.allclose(x[i, 4:], single["t"], atol=1e-12)
            assert np.linalg.norm(x[i, 4:] - sc[5]) < 1e-2 * np.linalg.norm(sc[5]), f"scene {i}"
        else:
            assert np.isnan(x[i]).all()
    empty_x, empty_ok = gen_relpose.solve_batch(np.zeros((0, 7, 12)))
    assert empty_x.shape == (0, 7) and empty_ok.shape == (0,)


def test_estimate_finds_the_inliers_among_outliers():
    seed = 11
    rng = np.random.default_rng(seed)
    f, v, fp, vp, r, t = relative_scene(seed, 60)
    outliers = rng.choice(60, 24, replace=False)  # 40 %
    fp[outliers] = unit(rng.normal(size=(24, 3)))
    fp = unit(fp + rng.normal(scale=0.5 / 800, size=fp.shape))  # about half a pixel at f = 800 px
    x, info = gen_relpose.estimate(rows_of(f, v, fp, vp), threshold=2.5 / 800, noise=1.0, seed=seed)  # 2.5 px
    truth = np.ones(60, bool)
    truth[outliers] = False
    assert info["inlier_mask"].dtype == np.bool_ and info["inlier_mask"].shape == (60,)
    assert (info["inlier_mask"] & truth).sum() >= 35, f"seed {seed}: recall {(info['inlier_mask'] & truth).sum()} of 36"
    assert info["num_inliers"] == info["inlier_mask"].sum()
    assert abs(info["inlier_ratio"] - info["num_inliers"] / 60) < 1e-12
    assert info["iterations"] >= 1000  # PoseLib's minimum
    assert (info["inlier_mask"] & ~truth).sum() <= 1, "outliers taken as inliers"
    assert rotation_error_deg(quaternion_rotation(x["q"]), r) < 2.0  # the success: E_R < 2 deg, E_t < 5 %
    assert np.linalg.norm(x["t"] - t) < 0.05 * np.linalg.norm(t)


def test_bad_input_raises_the_modules_input_error_that_says_where():
    f, v, fp, vp, _, _ = relative_scene(4, 7)
    rows = rows_of(f, v, fp, vp)
    rows[4, 9] = np.inf
    with pytest.raises(gen_relpose.InputError, match=r"correspondence 4, field `vp`"):
        gen_relpose.solve(rows)
    rows[4, 9] = 0.0
    rows[2, 9] = np.nan
    with pytest.raises(gen_relpose.InputError, match=r"correspondence 2, field `vp`"):
        gen_relpose.solve(rows)
    rows[2, 9] = 0.0
    with pytest.raises(gen_relpose.InputError, match="exactly 7"):
        gen_relpose.solve(rows[:6])
    with pytest.raises(gen_relpose.InputError, match=r"expected an array of shape \(N, 12\), got shape \(7, 11\)"):
        gen_relpose.solve(rows[:, :11])
    with pytest.raises(gen_relpose.InputError, match="too few correspondences: got 5, need at least 7"):
        gen_relpose.estimate(rows[:5], threshold=1 / 800)
    with pytest.raises(gen_relpose.InputError, match="threshold"):
        gen_relpose.estimate(rows, threshold=-1.0)
    with pytest.raises(gen_relpose.InputError, match="noise"):
        gen_relpose.solve(rows, noise=-1.0)
    with pytest.raises(gen_relpose.InputError, match="not an array of numbers"):
        gen_relpose.solve("rows")


def test_empty_arrays_raise_and_do_not_crash():
    empty = np.zeros((0, 12))
    for call in (
        lambda: gen_relpose.solve(empty),
        lambda: gen_relpose.estimate(empty, threshold=1 / 800),
        lambda: gen_relpose.solve([]),
    ):
        with pytest.raises(gen_relpose.InputError):
            call()


def test_data_no_pose_fits_is_never_a_pose():
    rng = np.random.default_rng(5)
    f, v, fp, vp = (unit(rng.normal(size=(7, 3))), rng.normal(size=(7, 3)), unit(rng.normal(size=(7, 3))), rng.normal(size=(7, 3)))
    try:
        x = gen_relpose.solve(rows_of(f, v, fp, vp))
    except gen_relpose.SolveError:
        return
    # Seven random rays can have a pose by chance only if all seven are coplanar with it.
    r, t = quaternion_rotation(x["q"]), x["t"]
    for i in range(7):
        n = np.cross(f[i], r @ fp[i])
        assert abs(n @ (r @ vp[i] + t - v[i])) < 1e-6 * (1 + np.linalg.norm(n))


def test_errors_and_help_name_the_module_not_simhc():
    for name, base in (("InputError", ValueError), ("SolveError", RuntimeError), ("NotValidatedError", RuntimeError), ("NoSolutionError", RuntimeError)):
        cls = getattr(gen_relpose, name)
        assert cls.__module__ == "gen_relpose" and cls.__qualname__ == name, f"{cls!r}"
        assert issubclass(cls, base)
    assert issubclass(gen_relpose.NotValidatedError, gen_relpose.SolveError) and issubclass(gen_relpose.NoSolutionError, gen_relpose.SolveError)
    with pytest.raises(gen_relpose.InputError) as raised:
        gen_relpose.solve(np.zeros((3, 12)))
    assert type(raised.value).__module__ == "gen_relpose" and type(raised.value) is gen_relpose.InputError
    # What a traceback prints: `gen_relpose.InputError: ...`.
    assert repr(raised.type) == "<class 'gen_relpose.InputError'>"
    assert type(gen_relpose.solver).__module__ == "gen_relpose" and type(gen_relpose.solver) is gen_relpose.ProblemSolver
    assert repr(gen_relpose.solver).startswith("<gen_relpose.ProblemSolver ")
    doc = gen_relpose.__doc__
    for text in ("gen_relpose.solve(", "gen_relpose.estimate(", "gen_relpose.solve_batch(", "gen_relpose.InputError", "gen_relpose.SolveError", "[f (3), v (3), fp (3), vp (3)]"):
        assert text in doc, text
    assert "simhc." not in doc
    assert "inlier_mask" in gen_relpose.estimate.__doc__
    assert "threshold" in gen_relpose.estimate.__text_signature__
