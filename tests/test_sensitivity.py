"""The sensitivity experiment: the oracle observer with a set error, the interval helpers, a one-track run."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import uuom_gym  # noqa: F401  (registers the env)
from agents.sensitivity import SensitivityConfig, rebuild, run_sensitivity
from agents.statistics import bootstrap_ci, iqm, wilson_interval
from uuom_gym.envs.observation import observation_by_name


def test_oracle_observer_adds_the_set_error() -> None:
    from uuom_core.vehicle import DEFAULT_VEHICLE
    from uuom_gym.envs.observers import make_observer

    exact = make_observer("oracle", DEFAULT_VEHICLE)
    biased = make_observer("oracle", DEFAULT_VEHICLE, {"mass_error": -0.2, "slope_error_deg": 1.5})
    m, s, ms, ss = exact.observe({}, 0.05, 20_000.0, -0.03)
    assert (m, s, ms, ss) == (20_000.0, -0.03, 0.0, 0.0)
    m, s, ms, ss = biased.observe({}, 0.05, 20_000.0, -0.03)
    assert m == pytest.approx(16_000.0) and s == pytest.approx(-0.03 + math.radians(1.5)) and ms == ss == 0.0


def test_the_error_reaches_the_observation() -> None:
    obs = {}
    for opts in ({}, {"mass_error": 0.3}):
        env = gym.make("UUOM-Track-v0", observer="oracle", observer_options=opts)
        env.reset(seed=100_001)
        o, *_ = env.step(np.array([0.3], dtype=np.float32))
        obs[bool(opts)] = observation_by_name(o)
        env.close()
    assert obs[True]["est_load"] > obs[False]["est_load"]
    assert obs[True]["est_speed_limit"] < obs[False]["est_speed_limit"]  # told heavier: a lower limit


@pytest.mark.parametrize("opts, match", [({"bogus": 1}, "unknown option"), ({"mass_error": 5.0}, "mass_error"),
                                         ({"slope_error_deg": "1"}, "slope_error_deg")])
def test_bad_oracle_options_are_refused(opts, match) -> None:
    with pytest.raises(ValueError, match=match):
        gym.make("UUOM-Track-v0", observer="oracle", observer_options=opts)


def test_none_observer_takes_no_options() -> None:
    with pytest.raises(ValueError, match="takes no options"):
        gym.make("UUOM-Track-v0", observer="none", observer_options={"mass_error": 0.1})


def test_wilson_interval() -> None:
    assert wilson_interval(0, 100)[0] == 0.0 and 0.03 < wilson_interval(0, 100)[1] < 0.04
    lo, hi = wilson_interval(50, 100)
    assert lo == pytest.approx(0.4038, abs=1e-3) and hi == pytest.approx(0.5962, abs=1e-3)
    assert all(math.isnan(x) for x in wilson_interval(0, 0))


def test_iqm_and_bootstrap_interval() -> None:
    assert iqm([1, 2, 3, 4, 100, -100, 2.5, 3.5]) == pytest.approx(np.mean([2, 2.5, 3, 3.5]))
    rng = np.random.default_rng(1)
    x = rng.normal(1.1, 0.05, 80)
    lo, hi = bootstrap_ci(x)
    assert lo < iqm(x) < hi and hi - lo < 0.05
    assert bootstrap_ci(x) == (lo, hi)  # seeded: the same table every time
    two_level = rng.normal(1.1, 0.05, (3, 80))
    two_level[0, :5] = np.nan  # failed episodes have no trip time
    lo2, hi2 = bootstrap_ci(two_level, np.mean)
    assert lo2 < np.nanmean(two_level) < hi2
    assert all(math.isnan(v) for v in bootstrap_ci([]))
    with pytest.raises(ValueError, match="seeds x tracks"):
        bootstrap_ci(np.zeros((2, 2, 2)))


def test_one_track_run_writes_the_study(tmp_path) -> None:
    summary = run_sensitivity(SensitivityConfig(mass_errors=(-0.3,), slope_errors_deg=(), episodes=1,
                                                out=tmp_path), progress=False)
    assert [(r["error_kind"], r["error"]) for r in summary] == [("none", 0.0), ("mass", -0.3)]
    assert summary[0]["success_rate"] == 1.0 and summary[0]["trip_time_vs_oracle"] >= 1.0
    for name in ("summary.md", "summary.csv", "episodes.csv", "sensitivity.png"):
        assert (tmp_path / name).exists()
    assert "mass -30 %" in (tmp_path / "summary.md").read_text()
    assert rebuild(SensitivityConfig(out=tmp_path)) == summary  # the table again from episodes.csv


def test_iqm_is_scipys_trimmed_mean_and_the_bootstrap_skips_nan() -> None:
    from scipy.stats import trim_mean

    rng = np.random.default_rng(7)
    for n in (1, 2, 3, 4, 5, 9, 64, 301):
        x = rng.lognormal(0.0, 1.0, n)
        assert iqm(x) == pytest.approx(trim_mean(x, 0.25), rel=1e-12)
    # ±inf and NaN are left out, wherever they sort
    x = rng.lognormal(0.0, 1.0, 9)
    assert iqm(np.r_[-np.inf, x, np.nan, np.inf]) == pytest.approx(trim_mean(x, 0.25), rel=1e-12)
    # the vectorised bootstrap statistic equals the per-resample one it replaced: scipy on the finite entries
    a = rng.normal(1.1, 0.1, (2, 30))
    a[1, ::4] = np.nan
    lo, hi = bootstrap_ci(a, reps=300, seed=3)
    draws = np.random.default_rng(3)
    stats = []
    for _ in range(300):
        rows, cols = draws.integers(0, 2, 2), draws.integers(0, 30, 30)
        s = a[np.ix_(rows, cols)].reshape(-1)
        stats.append(trim_mean(s[np.isfinite(s)], 0.25))
    assert (lo, hi) == pytest.approx((np.percentile(stats, 2.5), np.percentile(stats, 97.5)), rel=1e-12)
