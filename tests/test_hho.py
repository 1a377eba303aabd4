"""Generic tuner: improved HHO (paper 001 §3.1), plain HHO and random search at equal budget."""

import math

import numpy as np
import pytest

from estimators.imu.hho import METHODS, TuneError, chi2_escape_factor, linear_escape_factor, tune


def sphere(x):
    return float(np.sum((x - 0.5) ** 2))


def test_escape_factor_schedules():
    assert chi2_escape_factor(0.0) == pytest.approx(2.0)
    assert chi2_escape_factor(1.0) == pytest.approx(0.0, abs=1e-12)
    xs = np.linspace(0, 1, 50)
    vals = [chi2_escape_factor(x) for x in xs]
    assert all(a > b for a, b in zip(vals[:-1], vals[1:]))
    # slow early and in the middle, fast at the end (paper Fig. 5)
    assert chi2_escape_factor(0.5) > linear_escape_factor(0.5)
    assert chi2_escape_factor(0.8) > 1.0
    assert linear_escape_factor(0.8) < 1.0


@pytest.mark.parametrize("method", METHODS)
def test_uses_exactly_the_budget_and_stays_in_bounds(method):
    calls = []
    bounds = [(-2.0, 3.0), (10.0, 20.0)]

    def obj(x):
        calls.append(x.copy())
        return sphere(x)

    r = tune(obj, bounds, 137, seed=1, method=method, population=6)
    assert len(calls) == 137 == r.n_evals
    pts = np.array(calls)
    assert np.all(pts[:, 0] >= -2.0) and np.all(pts[:, 0] <= 3.0)
    assert np.all(pts[:, 1] >= 10.0) and np.all(pts[:, 1] <= 20.0)
    assert r.fun == pytest.approx(min(sphere(p) for p in pts))
    assert np.all(np.diff(r.history) <= 0) and r.history.size == 137


@pytest.mark.parametrize("method", METHODS)
def test_deterministic_for_a_seed(method):
    a = tune(sphere, [(-5, 5)] * 3, 80, seed=3, method=method)
    b = tune(sphere, [(-5, 5)] * 3, 80, seed=3, method=method)
    c = tune(sphere, [(-5, 5)] * 3, 80, seed=4, method=method)
    np.testing.assert_array_equal(a.x, b.x)
    assert a.fun != c.fun


@pytest.mark.parametrize("method", ["ihho", "hho"])
def test_hawks_beat_random_search_at_equal_budget(method):
    bounds = [(-5.0, 5.0)] * 5
    hawks = np.median([tune(sphere, bounds, 400, s, method).fun for s in range(3)])
    rand = np.median([tune(sphere, bounds, 400, s, "random").fun for s in range(3)])
    assert hawks < 0.1 * rand


def test_nan_objective_counts_as_worst():
    def obj(x):
        return math.nan if x[0] > 0 else float(x[0] ** 2)

    r = tune(obj, [(-1.0, 1.0)], 50, seed=0, method="ihho", population=5)
    assert r.x[0] <= 0 and math.isfinite(r.fun)


@pytest.mark.parametrize("kwargs, word", [
    ({"bounds": [(1.0, 0.0)]}, "bounds"), ({"bounds": [(0.0, math.inf)]}, "bounds"),
    ({"budget": 0}, "budget"), ({"method": "pso"}, "method"), ({"budget": 5}, "too small"),
])
def test_bad_arguments_are_named(kwargs, word):
    args = {"bounds": [(0.0, 1.0)], "budget": 50, "method": "ihho"}
    args.update(kwargs)
    with pytest.raises(TuneError, match=word):
        tune(sphere, args["bounds"], args["budget"], 0, args["method"])
