"""The gyro witness of ``dffrls-aekf`` and ``fused`` (``gyro_witness_deg``): an accelerometer bias reads exactly like
a grade change to the accelerometer and the encoder; the pitch-rate gyro is the sensor that tells them apart.

The fault trace of ``tests/test_estimators_faults.py`` (a 26 t point mass on a varying grade, all seven inputs; a 3 s
bias of +0.5 m/s^2 on the accelerometer and +10 % on the torque at 10 s) over its eight noise seeds: without the
witness ``fused`` ends more than 2 % of the mass from its clean run on four seeds and ``dffrls-aekf`` on one, with it
on one and none. On fault-free data with a consistent gyro, and on data without a gyro, the witness changes nothing.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import estimators
from estimators.fault_injection import RECOVERY_BOUNDS, RECOVERY_MASS_KG, RECOVERY_OPTIONS, inject, seven_channel_rows

DT = 0.005
FAULT = slice(int(10.0 / DT), int(13.0 / DT))
SCORED = slice(int(25.0 / DT), None)


def _mass(rows: np.ndarray, name: str = "fused", **options: float) -> np.ndarray:
    est = estimators.make(name, **RECOVERY_OPTIONS[name], **options)
    return np.array([est.update(*row).mass_kg for row in rows.tolist()])


def _bias_misses(name: str, **options: float) -> int:
    """How many of the eight noise seeds end more than the recovery bound from their clean run after the bias."""
    misses = 0
    for seed in range(8):
        rows = seven_channel_rows(RECOVERY_MASS_KG, 40.0, DT, seed=seed)
        clean = _mass(rows, name, **options)
        bad = _mass(inject(rows, "bias", FAULT.start, FAULT.stop), name, **options)
        misses += float(np.mean(np.abs(bad[SCORED] - clean[SCORED]))) > RECOVERY_BOUNDS["mass"]
    return misses


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_the_witness_is_the_default_and_reads_the_gyro(name: str) -> None:
    est = estimators.make(name)
    assert est.config.gyro_witness_deg == pytest.approx(0.75)
    assert "gyro_radps" in est.inputs


# fused's "without" is shown on its two-state slope layer (before session 62): with the curvature state it recovers
# from this bias on all eight seeds without the witness too, so that slope layer cannot show what the witness does
@pytest.mark.parametrize("name, most_with, least_without, layer", [
    ("fused", 0, 3, {"grade_curvature_std": 0.0}), ("dffrls-aekf", 0, 1, {})])
def test_the_witness_recovers_from_the_bias(name: str, most_with: int, least_without: int, layer: dict) -> None:
    assert _bias_misses(name) <= most_with
    assert _bias_misses(name, **layer) <= 1
    # the same trace without the witness: the test can fail
    assert _bias_misses(name, gyro_witness_deg=0.0, **layer) >= least_without


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_no_change_without_a_fault_or_without_a_gyro(name: str) -> None:
    rows = seven_channel_rows(RECOVERY_MASS_KG, 40.0, DT, seed=3)
    off = _mass(rows, name, gyro_witness_deg=0.0)
    np.testing.assert_array_equal(_mass(rows, name), off)  # a consistent gyro never disagrees
    no_gyro = rows.copy()
    no_gyro[:, 5] = np.nan
    biased = inject(no_gyro, "bias", FAULT.start, FAULT.stop)
    np.testing.assert_array_equal(_mass(biased, name), _mass(biased, name, gyro_witness_deg=0.0))


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_batch_block_and_sample_paths_agree(name: str) -> None:
    from uuom_core.trace import Trace

    rows = inject(seven_channel_rows(RECOVERY_MASS_KG, 40.0, DT, seed=6), "bias", FAULT.start, FAULT.stop)
    t = DT * np.arange(1, len(rows) + 1)
    rows[:, 3] = np.diff(t, prepend=0.0)  # the steps run() reads off the stamps (not all exactly DT)
    online = _mass(rows, name)
    tr = Trace({"t_s": t, "torque_nm": rows[:, 0], "speed_mps": rows[:, 1], "accel_mps2": rows[:, 2],
                "gyro_radps": rows[:, 5]})
    batch = estimators.make(name, **RECOVERY_OPTIONS[name]).run(tr).mass_kg
    np.testing.assert_array_equal(batch, online)
    est = estimators.make(name, **RECOVERY_OPTIONS[name])
    rows[:, 3] = DT
    online = _mass(rows, name)
    for a in range(0, len(rows), 40):
        r = rows[a:a + 40]
        e = est.update_block(r[:, 0], r[:, 1], r[:, 2], DT, gyro_radps=r[:, 5])
        assert e.mass_kg == online[a + len(r) - 1]
    with pytest.raises(ValueError, match="gyro_radps"):
        est.update_block(rows[:4, 0], rows[:4, 1], rows[:4, 2], DT, gyro_radps=rows[:3, 5])


@pytest.mark.parametrize("gyro", [math.nan, math.inf, -math.inf, 1e300, 5.0])
def test_a_bad_gyro_is_a_missing_one(gyro: float) -> None:
    """An implausible or missing pitch rate never makes the witness hold the regression: the run is the one without
    a gyro for those samples, finite throughout."""
    rows = seven_channel_rows(RECOVERY_MASS_KG, 40.0, DT, seed=3)
    rows[FAULT, 5] = gyro
    m = _mass(rows)
    assert np.all(np.isfinite(m))
    clean = _mass(seven_channel_rows(RECOVERY_MASS_KG, 40.0, DT, seed=3), gyro_witness_deg=0.0)
    assert float(np.mean(np.abs(m[SCORED] - clean[SCORED]))) < RECOVERY_BOUNDS["mass"]


@pytest.mark.parametrize("option, value", [("gyro_witness_deg", -1.0), ("gyro_witness_deg", math.nan),
                                           ("gyro_witness_tau_s", 0.0), ("gyro_witness_persist_s", 0.0),
                                           ("gyro_witness_hold_s", -1.0), ("gyro_witness_settle_s", math.inf)])
def test_options_are_checked(option: str, value: float) -> None:
    for name in ("dffrls-aekf", "fused"):
        with pytest.raises(ValueError, match=option):
            estimators.make(name, **{option: value})


def test_margin_script_reports_the_gap_under_the_threshold(capsys) -> None:
    import importlib.util
    from pathlib import Path

    spec = importlib.util.spec_from_file_location(
        "gyro_witness_margin", Path(__file__).parents[1] / "scripts" / "gyro_witness_margin.py")
    script = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(script)
    script.main(["--plant-runs", "1", "--no-paper"])
    out = capsys.readouterr().out
    assert "| plant-000 |" in out and "threshold 0.75 deg" in out and "runs with a hold: 0" in out
