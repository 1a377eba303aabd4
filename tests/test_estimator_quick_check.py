"""scripts/estimator_quick_check.py: ``--decimate K`` (what a logger at 200/K Hz records), ``--settle``, ``--scenario-seeds``,
``--clean-sensors``."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from uuom_core.trace import Trace

_SPEC = importlib.util.spec_from_file_location(
    "estimator_quick_check", Path(__file__).parents[1] / "scripts" / "estimator_quick_check.py")
qc = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(qc)  # type: ignore[union-attr]


def _trace(n: int = 10) -> Trace:
    t = np.arange(n) * 0.005
    return Trace({"t_s": t, "torque_nm": t * 10, "speed_mps": t * 2, "accel_mps2": t * 3, "mass_kg": np.full(n, 2e4)},
                 source="made-up", meta={"chain_m": "2.5"})


def test_decimate_keeps_every_kth_row_of_every_column_and_the_meta():
    tr = _trace()
    d = qc.decimate(tr, 4)
    assert list(d.columns) == list(tr.columns)
    for c in tr.columns:
        np.testing.assert_array_equal(d[c], tr[c][::4])
    assert np.allclose(np.diff(d["t_s"]), 0.02) and d.meta == tr.meta
    assert qc.decimate(tr, 1) is tr


def test_decimate_below_one_is_refused_before_any_run(capsys):
    with pytest.raises(SystemExit) as exc:
        qc.main(["--decimate", "0", "--runs", "0", "--tuning", "0"])
    assert exc.value.code == 2 and "--decimate must be >= 1" in capsys.readouterr().err


@pytest.mark.parametrize("settle", ["-1", "60"])
def test_settle_outside_the_runs_is_refused_before_any_run(capsys, settle):
    with pytest.raises(SystemExit) as exc:
        qc.main(["--settle", settle, "--runs", "0", "--tuning", "0"])
    assert exc.value.code == 2 and "--settle must be in [0, 55)" in capsys.readouterr().err


def test_settle_moves_the_scoring_window():
    """The same run scored after 10 s and after 30 s: the later window cannot hold a larger maximum."""
    job = ("point", qc.RunSpec("point", "point-000", 0, 0, "point"), [["mmae", "mmae", {"n_models": 6}]], 4)
    (_, _, early, _), = qc._score((*job, 10.0, False))
    (_, _, late, _), = qc._score((*job, 30.0, False))
    assert np.isfinite(early) and 0.0 <= late <= early


def test_scenario_seeds_run_every_scenario_with_each_sensor_seed():
    specs = [s for g, s in qc._specs(0, 0, scenario_seeds=3) if g.startswith("pm-sc:")]
    one = [s for g, s in qc._specs(0, 0) if g.startswith("pm-sc:")]
    assert len(specs) == 3 * len(one) and specs[:len(one)] == one  # seed 0 is the protocol's run, unchanged
    assert {s.seed for s in specs} == {0, 1, 2} and len({s.name for s in specs}) == len(specs)
    assert {s.scenario for s in specs[len(one):]} == {s.scenario for s in one}


def test_scenario_seeds_below_one_are_refused_before_any_run(capsys):
    with pytest.raises(SystemExit) as exc:
        qc.main(["--scenario-seeds", "0", "--runs", "0", "--tuning", "0"])
    assert exc.value.code == 2 and "--scenario-seeds must be >= 1" in capsys.readouterr().err


def test_clean_sensors_leave_only_the_physics():
    """``--clean-sensors``: the point-mass scenario's sensors read the simulated truth (no noise, bias, quantisation,
    vibration), so every sensor seed gives the same trace, and the noisy run differs from it."""
    from dataclasses import replace

    from uuom_gym.sim.protocol_runs import make_run, protocol_runs

    spec = next(s for s in protocol_runs(0, 0, paper_seeds=1, fault_seeds=0) if s.scenario == "pm-section1")
    a, b = qc.scaled_scenario_run(spec, 0.0), qc.scaled_scenario_run(replace(spec, seed=7), 0.0)
    for c in ("torque_nm", "speed_mps", "accel_mps2"):
        np.testing.assert_array_equal(a[c], b[c])
    np.testing.assert_allclose(a["speed_mps"], a["true_speed_mps"], atol=0.0)
    assert not np.array_equal(a["accel_mps2"], make_run(spec)["accel_mps2"])


def test_point_tuning_runs_are_seeded_outside_the_evaluation_set():
    specs = qc._specs(0, 0, 1, 3)
    tun = [s for g, s in specs if g == "tun-pt"]
    assert [(s.world, s.seed) for s in tun] == [("point", 1000), ("point", 1001), ("point", 1002)]
    assert not [s for g, s in qc._specs(0, 0, 1) if g == "tun-pt"]


def test_negative_run_counts_are_refused_before_any_run(capsys):
    with pytest.raises(SystemExit) as exc:
        qc.main(["--point-tuning", "-1", "--runs", "0", "--tuning", "0"])
    assert exc.value.code == 2 and "must be >= 0" in capsys.readouterr().err


def test_sensor_scale_scales_every_imperfection():
    """``--sensor-scale K``: K = 1 is the scenario as the protocol records it, K = 0 the perfect sensors of
    ``--clean-sensors``, and K = 2 reads twice as far from the truth (noise, bias, quantisation, vibration)."""
    from uuom_gym.sim.point_mass import PointMassSensors, simulate_point_mass, with_options
    from uuom_gym.sim.protocol_runs import make_run, protocol_runs

    spec = next(s for s in protocol_runs(0, 0, paper_seeds=1, fault_seeds=0) if s.scenario == "pm-section1")
    own = make_run(spec)
    one, two = qc.scaled_scenario_run(spec, 1.0), qc.scaled_scenario_run(spec, 2.0)
    for c in ("torque_nm", "speed_mps", "accel_mps2"):
        np.testing.assert_array_equal(one[c], own[c])
    perfect = simulate_point_mass(with_options(spec.scenario, sensors=PointMassSensors.perfect()), seed=spec.seed)
    np.testing.assert_array_equal(qc.scaled_scenario_run(spec, 0.0)["accel_mps2"], perfect["accel_mps2"])
    dv1 = np.std(one["speed_mps"] - one["true_speed_mps"])
    dv2 = np.std(two["speed_mps"] - two["true_speed_mps"])
    assert 1.7 < dv2 / dv1 < 2.3, dv2 / dv1


def test_clean_sensors_and_a_sensor_scale_are_one_choice(capsys):
    with pytest.raises(SystemExit):
        qc.main(["--runs", "0", "--tuning", "0", "--clean-sensors", "--sensor-scale", "2"])
    assert "--clean-sensors is --sensor-scale 0" in capsys.readouterr().err


def test_clean_scenarios_are_those_without_faults_or_a_resistance_mismatch():
    from uuom_gym.sim.point_mass import POINT_MASS_SCENARIOS

    clean = {n for n, sc in POINT_MASS_SCENARIOS.items() if qc.is_clean_scenario(sc)}
    assert clean == set(POINT_MASS_SCENARIOS) - {"pm-sensor-faults", "pm-resistance-mismatch"}


def test_clean_bounds_count_only_fault_free_scenarios_and_need_both_bounds():
    rows = [("pm-sc:pm-section1", "a", 2.0, 0.15),      # on both bounds: met
            ("pm-sc:pm-section2", "a", 2.01, 0.05),     # mass over
            ("pm-sc:pm-roadtest", "a", 0.5, 0.151),     # slope over
            ("pm-sc:pm-sensor-faults", "a", 0.1, 0.01),  # a fault trace: not a clean one
            ("pm-sc:pm-resistance-mismatch", "a", 0.1, 0.01),
            ("tuning", "a", 0.1, 0.01),                 # not a scenario
            ("pm-sc:pm-section1", "b", 0.1, 0.01)]
    assert qc.clean_bounds_met(rows) == {"a": (1, 3), "b": (1, 1)}
