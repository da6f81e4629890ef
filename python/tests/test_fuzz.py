"""Bad input from Python never crashes, hangs or raises anything but the module's own errors
(issue 43, deliverable 7): the one class's entry points (``solve``, calling the solver,
``estimate``, ``solve_batch``) of both built-ins on hostile arrays (NaN, infinities, 1e308,
subnormals, zeros, repeated rows), wrong shapes and types, unknown or repeated field names, and
0 / 1 / few / 10^4 correspondences. Every call returns a Solution (or ``(solution, info)``,
``(x, ok)``) or raises ``InputError`` / ``SolveError``; a returned solution holds finite numbers.
Seeded; prints the seed and the count of cases tried.
"""

import numpy as np
import pytest

import simhc

SEED = 4343
HOSTILE = np.array([np.nan, np.inf, -np.inf, 1e308, -1e308, np.finfo(float).tiny / 4, 5e-324, 0.0, -0.0])


def hostile_array(rng, shape):
    """Mostly ordinary numbers, some hostile ones, sometimes a repeated row."""
    a = rng.uniform(-2, 2, shape)
    mask = rng.random(shape) < rng.choice([0.0, 0.02, 0.3, 1.0])
    a[mask] = rng.choice(HOSTILE, mask.sum())
    if a.ndim == 2 and len(a) > 1 and rng.random() < 0.3:
        a[-1] = a[0]
    return a


def count(rng):
    return int(rng.choice([0, 1, 2, 3, 7, 8, 9, 20]))


def check_solution(x):
    for name, _ in x.items():
        if name != "certified":
            assert np.all(np.isfinite(np.asarray(x[name]))), f"a returned solution holds a non-finite `{name}`"


def call(f, outcomes):
    """Runs one case: an answer or the module's own error, nothing else."""
    try:
        result = f()
        outcomes["answer"] += 1
        return result
    except simhc.InputError:
        outcomes["InputError"] += 1
    except simhc.SolveError:
        outcomes["SolveError"] += 1
    return None


@pytest.mark.parametrize("solver", [simhc.upnp, simhc.grps], ids=["upnp", "grps"])
def test_hostile_input_ends_in_an_answer_or_the_modules_error(solver):
    rng = np.random.default_rng(SEED)
    print(f"seed {SEED}")
    names = [name for name, _ in solver.row_fields]
    per_row = sum(int(np.prod(shape)) for _, shape in solver.row_fields)
    cases = 0
    outcomes = {"answer": 0, "InputError": 0, "SolveError": 0}
    for _ in range(150):
        n = count(rng)
        fields = {name: hostile_array(rng, (n, 3)) for name in names}
        kind = rng.integers(0, 6)
        if kind == 0:  # by position
            f = lambda: solver(*fields.values())
        elif kind == 1:  # by name, maybe a field left out or misnamed
            named = dict(fields)
            if rng.random() < 0.3:
                named.pop(names[-1])
            if rng.random() < 0.2:
                named["nonsense"] = named.pop(names[0])
            f = lambda: solver.solve(**named)
        elif kind == 2:  # one array of rows, maybe of the wrong width
            width = per_row if rng.random() < 0.8 else int(rng.integers(0, 20))
            f = lambda: solver.solve(hostile_array(rng, (n, width)))
        elif kind == 3:  # the robust estimate, hostile options sometimes
            threshold = float(rng.choice([0.01, 0.0, -1.0, np.nan, np.inf]))
            f = lambda: solver.estimate(*fields.values(), threshold=threshold, max_iterations=2000, seed=int(rng.integers(0, 9)))
        elif kind == 4:  # a batch
            f = lambda: solver.solve_batch(hostile_array(rng, (int(rng.integers(0, 3)), max(n, 1), per_row)))
        else:  # wrong types and shapes
            bad = rng.choice(["text", "ragged", "3d", "none-noise"])
            if bad == "text":
                f = lambda: solver("a", "b")
            elif bad == "ragged":
                f = lambda: solver(*[fields[k][: max(n - i, 0)] for i, k in enumerate(names)])
            elif bad == "3d":
                f = lambda: solver(*[a.reshape(1, *a.shape) for a in fields.values()])
            else:
                f = lambda: solver(*fields.values(), noise=float(rng.choice([-1.0, np.nan, np.inf, 1e308])))
        result = call(f, outcomes)
        cases += 1
        if kind in (0, 1, 2) and result is not None:
            check_solution(result)
        elif kind == 3 and result is not None:
            check_solution(result[0])
    # 10^4 correspondences, half of them hostile: ends, and in bounded time.
    big = {name: hostile_array(rng, (10_000, 3)) for name in names}
    call(lambda: solver(*big.values()), outcomes)
    call(lambda: solver.estimate(*big.values(), max_iterations=1000), outcomes)
    cases += 2
    print(f"{solver.name}: {cases} cases tried: {outcomes}")
    # The cases reach the solver, not only the input checks.
    assert outcomes["answer"] + outcomes["SolveError"] > 0, outcomes
