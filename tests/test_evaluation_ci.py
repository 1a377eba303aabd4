"""Confidence intervals in the evaluation table and the trip-time-vs-trip-rate figure (synthetic rows)."""

from __future__ import annotations

import numpy as np

from agents.evaluation_plots import plot_tradeoff
from agents.evaluation_table import RULES, markdown_ci_table, summarise


def _rows() -> list[dict]:
    rng = np.random.default_rng(0)
    rows = []
    for seed in range(40):
        base = {"distance_m": 200.0, "steps": 1000, "cost": 0.0, "energy_kj_per_tkm": 350.0, "mass_err_pct": 1.0,
                "slope_err_deg": 0.1, **{f"violations/{r}": 0 for r in RULES}}
        rows.append({**base, "controller": "oracle", "observer": "oracle", "seed": seed, "success": True,
                     "overspeed_trip": False, "trip_time_s": 100.0})
        trip = seed < 4  # 4 of 40 trip
        rows.append({**base, "controller": "rule-based", "observer": "ekf", "seed": seed, "success": not trip,
                     "overspeed_trip": trip, "trip_time_s": 100.0 * (1.2 + 0.02 * rng.normal())})
    return rows


def test_summary_has_intervals_and_the_ci_table(tmp_path) -> None:
    summary = summarise(_rows())
    rb = next(r for r in summary if r["controller"] == "rule-based")
    assert rb["overspeed_trips"] == 4 and rb["trip_rate_lo"] < 0.1 < rb["trip_rate_hi"]
    assert rb["trip_time_iqm_lo"] < rb["trip_time_iqm"] < rb["trip_time_iqm_hi"]
    assert abs(rb["trip_time_iqm"] - 1.2) < 0.02
    table = markdown_ci_table(summary)
    assert "| rule-based | ekf | 90 % (" in table and "4/40 (" in table and "oracle |" not in table.split("\n", 2)[2]
    png = tmp_path / "tradeoff.png"
    plot_tradeoff(summary, png)
    assert png.stat().st_size > 10_000


def _policy_rows(name: str, ratio: float) -> list[dict]:
    base = {"distance_m": 200.0, "steps": 1000, "cost": 0.0, "energy_kj_per_tkm": 350.0, "mass_err_pct": 1.0,
            "slope_err_deg": 0.1, **{f"violations/{r}": 0 for r in RULES}}
    return [{**base, "controller": name, "observer": "ekf", "seed": seed, "success": True, "overspeed_trip": False,
             "trip_time_s": 100.0 * ratio * (1.0 + 0.01 * (seed % 5))} for seed in range(40)]


def test_pooled_training_seeds_are_one_row_with_a_wider_interval() -> None:
    from agents.evaluation_table import pool_rows

    oracle = [r for r in _rows() if r["controller"] == "oracle"]
    seeds = _policy_rows("run_s0", 1.05) + _policy_rows("run_s1", 1.15) + _policy_rows("run_s2", 1.10)
    pooled = summarise(pool_rows(oracle + seeds, {"ppo": ["run_s0", "run_s1", "run_s2"]}))
    row = next(r for r in pooled if r["controller"] == "ppo")
    assert row["training_runs"] == 3 and row["episodes"] == 120
    # the seeds differ by far more than the tracks: resampling them widens the interval to span them
    assert row["trip_time_iqm_lo"] < 1.08 and row["trip_time_iqm_hi"] > 1.12
    one = next(r for r in summarise(oracle + _policy_rows("run_s0", 1.05)) if r["controller"] == "run_s0")
    assert one["training_runs"] == 1 and one["trip_time_iqm_hi"] - one["trip_time_iqm_lo"] < 0.02
    assert "| ppo (3 training seeds) | ekf |" in markdown_ci_table(pooled)


def test_pool_errors_name_the_controller() -> None:
    import pytest

    from agents.evaluation_table import pool_rows

    rows = _policy_rows("run_s0", 1.0)
    with pytest.raises(ValueError, match="no episodes: run_s9"):
        pool_rows(rows, {"ppo": ["run_s0", "run_s9"]})
    with pytest.raises(ValueError, match="two pools"):
        pool_rows(rows, {"a": ["run_s0"], "b": ["run_s0"]})


def test_a_pooled_table_merged_again_keeps_every_seed(tmp_path) -> None:
    """Merging an earlier merge's episodes.csv (pooled rows share their label) keeps all the pooled seeds, and a
    directory merged twice still counts each episode once."""
    from agents.evaluation import _merged_rows
    from agents.evaluation_table import pool_rows, write_csv

    oracle = [r for r in _rows() if r["controller"] == "oracle"]
    seeds = _policy_rows("run_s0", 1.05) + _policy_rows("run_s1", 1.15) + _policy_rows("run_s2", 1.10)
    first = tmp_path / "first"
    first.mkdir()
    write_csv(first / "episodes.csv", pool_rows(oracle + seeds, {"ppo": ["run_s0", "run_s1", "run_s2"]}))
    rows = _merged_rows([first, first])
    assert len(rows) == 40 + 120
    row = next(r for r in summarise(rows) if r["controller"] == "ppo")
    assert row["training_runs"] == 3 and row["episodes"] == 120


def _tripping_rows(name: str, trips: int) -> list[dict]:
    return [{**r, "success": r["seed"] >= trips, "overspeed_trip": r["seed"] < trips} for r in _policy_rows(name, 1.1)]


def test_pooled_rates_carry_the_spread_between_seeds() -> None:
    """Three seeds tripping on 2, 20 and 38 of 40 tracks pool to 50 %: the rate's interval must reach towards both
    seeds' extremes, not be a Wilson interval over 120 'independent' episodes (about 41-59 %)."""
    from agents.evaluation_table import pool_rows, rate_interval
    from agents.statistics import wilson_interval

    oracle = [r for r in _rows() if r["controller"] == "oracle"]
    seeds = _tripping_rows("run_s0", 2) + _tripping_rows("run_s1", 20) + _tripping_rows("run_s2", 38)
    row = next(r for r in summarise(pool_rows(oracle + seeds, {"ppo": ["run_s0", "run_s1", "run_s2"]}))
               if r["controller"] == "ppo")
    assert row["overspeed_trips"] == 60 and row["episodes"] == 120
    naive = wilson_interval(60, 120)
    assert row["trip_rate_lo"] < 0.2 < naive[0] and row["trip_rate_hi"] > 0.8 > naive[1]
    assert abs(row["success_lo"] - (1 - row["trip_rate_hi"])) < 1e-9 and abs(row["success_hi"] - (1 - row["trip_rate_lo"])) < 1e-9
    # one policy: still the Wilson interval over its episodes
    one = _tripping_rows("run_s1", 20)
    assert rate_interval(one, "overspeed_trip") == wilson_interval(20, 40)
    # seeds that never trip: the interval is the Wilson interval over the 40 tracks, not [0, 0] and not over 120
    clean = [{**r, "training_run": r["controller"]} for r in _tripping_rows("a", 0) + _tripping_rows("b", 0)]
    lo, hi = rate_interval(clean, "overspeed_trip")
    assert lo == 0.0 and abs(hi - wilson_interval(0, 40)[1]) < 1e-12 and hi > wilson_interval(0, 80)[1]
