"""scripts/learned_margin_bound.py: the learned-margin bound's scoring, causal features and a tiny end-to-end run."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from uuom_core.vehicle import VehicleParams

_SPEC = importlib.util.spec_from_file_location(
    "learned_margin_bound", Path(__file__).parents[1] / "scripts" / "learned_margin_bound.py")
lm = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(lm)  # type: ignore[union-attr]


def test_score_counts_uncovered_steps_light_tracks_and_pessimism():
    truth = np.full(6, 100.0)
    planning = np.array([110.0, 99.5, 105.0, 98.0, 120.0, 101.0])
    seed = np.array([0, 0, 1, 1, 2, 2])
    sc = lm.score(planning, truth, seed)
    assert sc["uncovered"] == pytest.approx(2 / 6)
    assert sc["tracks_light"] == pytest.approx(1 / 3)  # only track 1 has a step > 1 % light (98); 99.5 is within
    assert sc["median"] == pytest.approx(np.median(planning / truth) - 1)


def test_lagged_features_are_causal_and_per_track():
    seed = np.array([0, 0, 0, 0, 1, 1, 1])
    v = np.array([1.0, 5.0, 2.0, 3.0, 10.0, 7.0, 9.0])
    np.testing.assert_array_equal(lm._lagged(seed, v, 1, "lag"), [1, 1, 5, 2, 10, 10, 7])
    np.testing.assert_array_equal(lm._lagged(seed, v, 2, "max"), [1, 5, 5, 5, 10, 10, 10])
    np.testing.assert_array_equal(lm._lagged(seed, v, 2, "min"), [1, 1, 1, 2, 10, 7, 7])
    # changing a later value never changes an earlier feature
    w = v.copy()
    w[3] = 100.0
    np.testing.assert_array_equal(lm._lagged(seed, w, 2, "max")[:3], lm._lagged(seed, v, 2, "max")[:3])


def test_features_turn_a_zero_sigma_or_a_missing_mu_into_missing_values_not_infinities():
    n = 4
    d = {c: np.ones(n) for c in lm.COLUMNS}
    d.update(seed=np.zeros(n), t_s=np.arange(n) * 0.1, mass_kg=np.full(n, 2e4), mass_std_kg=np.zeros(n),
             mu=np.full(n, np.nan), mu_std=np.full(n, np.nan), nis=np.zeros(n))
    x = lm.features(d)
    assert x.shape == (n, 14) and not np.isinf(x).any()
    assert np.isnan(x[:, 1]).all() and np.isfinite(x[:, 0]).all()


def test_history_features_are_causal_and_count_the_accelerations():
    n = 150
    v = np.concatenate([np.linspace(0, 1, 50), np.ones(50), np.linspace(1, 2, 50)])  # two accelerations
    d = {c: np.zeros(n) for c in lm.COLUMNS}
    d.update(seed=np.zeros(n), mass_kg=np.linspace(2e4, 3e4, n), speed_mps=v)
    h = lm.history_features(d)
    assert h.shape == (n, 6)
    assert h[-1, 4] == 2 and h[60, 4] == 1  # separate accelerations so far
    assert np.isnan(h[:100, 5]).all() and np.isfinite(h[101:, 5]).all()  # the change since 10 s exists after 10 s
    later = dict(d, mass_kg=d["mass_kg"].copy())
    later["mass_kg"][120:] *= 2
    np.testing.assert_array_equal(lm.history_features(later)[:120], h[:120])


def test_online_features_from_the_last_steps_equal_the_training_features():
    rng = np.random.default_rng(0)
    n = 400
    d = {c: rng.uniform(0.5, 1.5, n) for c in lm.COLUMNS}
    d.update(seed=np.zeros(n), mass_kg=rng.uniform(2e4, 3e4, n), t_s=np.arange(n) * 0.1)
    full = lm.features(d)
    for end in (10, 151, 152, 400):  # what the controller computes at step `end`: only the last 151 steps
        recent = {c: v[max(end - lm.RANGE_STEPS - 1, 0):end] for c, v in d.items()}
        np.testing.assert_allclose(lm.features(recent)[-1], full[end - 1])


def test_k_sigma_at_interpolates_the_curve():
    curve = [(1.0, {"uncovered": 0.2, "median": 0.02}), (2.0, {"uncovered": 0.02, "median": 0.06})]
    k, med = lm.k_sigma_at(0.11, curve)
    assert k == pytest.approx(1.5) and med == pytest.approx(0.04)


def test_bad_arguments_are_refused_before_any_episode(capsys, tmp_path):
    with pytest.raises(SystemExit) as exc:
        lm.main(["--train", "0", "--out", str(tmp_path)])
    assert exc.value.code == 2 and "--train and --validate must be >= 1" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        lm.main(["--quantiles", "1.5", "--out", str(tmp_path)])
    with pytest.raises(SystemExit) as exc:
        lm.main(["--drive", "3", "--quantiles", "0.9", "--drive-quantile", "0.99", "--out", str(tmp_path)])
    assert "--drive-quantile must be one of --quantiles" in capsys.readouterr().err


def test_end_to_end_on_three_tracks_writes_the_table_and_reuses_its_cache(tmp_path):
    args = ["--train", "2", "--validate", "1", "--workers", "1", "--sizes", "--quantiles", "0.9",
            "--cache", str(tmp_path / "steps.npz"), "--out", str(tmp_path / "out")]
    assert lm.main(args) == 0
    text = (tmp_path / "out" / "summary.md").read_text()
    assert "rule-based default" in text and "learned q0.9, 2 training tracks" in text
    assert (tmp_path / "out" / "tradeoff.png").stat().st_size > 0
    z = np.load(tmp_path / "steps.npz")
    assert set(np.unique(z["seed"])) == {0, 1, 2}
    # the planning mass of the default controller is never below its own estimate + 2 sigma (clamped to the vehicle)
    cap = VehicleParams().max_mass_kg
    assert np.all(z["planning_mass_kg"] >= np.minimum(z["mass_kg"] + 2 * z["mass_std_kg"], cap) - 1e-6)
    before = (tmp_path / "steps.npz").stat().st_mtime_ns
    assert lm.main(args) == 0
    assert (tmp_path / "steps.npz").stat().st_mtime_ns == before  # cached: no episode run again


def test_paired_lines_pair_by_track_and_price_cost_per_step():
    def row(seed, learned, t, cost, steps, viol=0):
        return {"seed": seed, "learned": learned, "trip_time_s": t, "success": True, "overspeed_trip": False,
                "cost": cost, "steps": steps, "violations/speed_limit": viol}
    rows = [row(1, False, 100.0, 0.0, 1000), row(2, False, 200.0, 1.0, 2000, 3),
            row(1, True, 90.0, 2.0, 900, 5), row(2, True, 220.0, 0.0, 2200)]
    default, learned = lm.paired_lines(rows)
    assert "| 2/2 | 0 | 3.33e-04 | 1 | 1 |" in default  # 1 cost over 3000 steps, one violating track
    assert "| 2/2 | 0 | 6.45e-04 | 1 | 1.000 (" in learned and "faster on 1" in learned  # (0.9 + 1.1) / 2


def test_the_learned_margin_controller_plans_with_the_model_and_drives_a_track():
    class Constant:  # a "model" that always answers log(1.1): plan 10 % above the estimate
        def predict(self, x):
            assert x.shape == (1, 14) and np.isfinite(x[0, 0])
            return np.full(1, np.log(1.1))

    row = lm.drive((100000, "dffrls-aekf", Constant(), False))
    assert row["learned"] and row["success"] and row["steps"] > 100
    ctrl = lm._learned_margin_controller(VehicleParams(), Constant(), False)
    assert ctrl.memory_s == 0.0
