"""The mass regression's residual gate (round 2, session 49). ``sf-kf``'s, on by default: a short miscalibration is
kept out of the mass, a lasting change is learnt after ``residual_gate_persist_s``, and bad settings are refused. The
same gate in the ``dffrls-aekf`` / ``fused`` kernel: an option, off by default.

The trace is the recovery test's rigid synthetic point mass (:func:`estimators.fault_injection.seven_channel_rows`),
``sf-kf`` configured for that world (:data:`estimators.fault_injection.RECOVERY_OPTIONS`).
"""

from __future__ import annotations

import numpy as np
import pytest

import estimators
from estimators.fault_injection import RECOVERY_OPTIONS, inject, run_outputs, seven_channel_rows

DT = 0.005
MASS_KG = 26_000.0
WORLD = RECOVERY_OPTIONS["sf-kf"]


def _mass(rows: np.ndarray, **options: float) -> np.ndarray:
    return run_outputs("sf-kf", rows, **WORLD, **options)["mass"]


def _at(series: np.ndarray, t_s: float) -> float:
    return float(series[int(t_s / DT)])


def test_a_bias_burst_stays_out_of_the_mass_only_with_the_gate() -> None:
    clean = seven_channel_rows(MASS_KG, 40.0, DT, seed=0)
    bad = inject(clean, "bias", int(10.0 / DT), int(13.0 / DT))
    after = slice(int(25.0 / DT), None)
    gated = np.mean(np.abs(_mass(bad)[after] - _mass(clean)[after]))
    ungated = np.mean(np.abs(_mass(bad, residual_gate_sigma=0.0)[after]
                             - _mass(clean, residual_gate_sigma=0.0)[after]))
    assert gated < 0.01 * MASS_KG, gated          # measured 76 kg
    assert ungated > 0.1 * MASS_KG, ungated       # measured 5.7 t: the regression never forgets (lambda = 1)


def test_the_gate_costs_no_accuracy_on_the_clean_trace() -> None:
    clean = seven_channel_rows(MASS_KG, 40.0, DT, seed=0)
    after = slice(int(25.0 / DT), None)
    gated = np.mean(np.abs(_mass(clean)[after] - MASS_KG))
    ungated = np.mean(np.abs(_mass(clean, residual_gate_sigma=0.0)[after] - MASS_KG))
    assert gated <= ungated + 0.002 * MASS_KG, (gated, ungated)


def test_a_lasting_change_is_learnt_after_the_persistence_time() -> None:
    clean = seven_channel_rows(MASS_KG, 40.0, DT, seed=3)
    bad = clean.copy()
    bad[int(10.0 / DT):, 0] *= 1.10  # the torque reads 10 % high from 10 s on, for good
    gated, ungated = _mass(bad), _mass(bad, residual_gate_sigma=0.0)
    base = _at(gated, 9.9)
    # held where it was while the change could be a burst (measured: 26.5 t at 10 s and at 15 s; ungated 32.4 t) ...
    assert abs(_at(gated, 15.0) - base) < 0.02 * MASS_KG
    assert _at(ungated, 15.0) - base > 0.1 * MASS_KG
    # ... then taken as the new truth of the sensors, as the ungated regression takes it (31.7 / 31.2 t at 30 s)
    assert abs(_at(gated, 30.0) - _at(ungated, 30.0)) < 0.03 * MASS_KG
    assert _at(gated, 30.0) - base > 0.1 * MASS_KG


@pytest.mark.parametrize("option, value", [("residual_gate_sigma", -1.0), ("residual_gate_sigma", float("nan")),
                                           ("residual_scale_s", 0.0), ("residual_gate_persist_s", -2.0)])
def test_bad_gate_settings_are_refused(option: str, value: float) -> None:
    with pytest.raises(ValueError, match=option):
        estimators.make("sf-kf", **{option: value})


# --- the same gate in the dffrls-aekf / fused kernel: an option, off by default (measured, not adopted) -----------

@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_kernel_gate_is_off_by_default_and_acts_when_asked(name: str) -> None:
    clean = seven_channel_rows(MASS_KG, 40.0, DT, seed=3)
    bad = inject(clean, "bias", int(10.0 / DT), int(13.0 / DT))
    # the gate alone: the gyro witness (on by default since session 55) holds the regression through this very bias
    # and would leave the gate little to do
    world = {**RECOVERY_OPTIONS[name], "gyro_witness_deg": 0.0}
    default = run_outputs(name, bad, **world)["mass"]
    off = run_outputs(name, bad, **world, residual_gate_sigma=0.0)["mass"]
    on = run_outputs(name, bad, **world, residual_gate_sigma=0.5)["mass"]
    np.testing.assert_array_equal(default, off)
    assert np.all(np.isfinite(on))
    # kg: the gate held the mass on samples the ungated regression learnt from (measured at 0.5 sigma: dffrls-aekf
    # 286 kg at most, fused 2 124 kg; at 1 sigma dffrls-aekf 0 kg since session 58's weak_offset_random_walk, 849 kg
    # before, fused 219 kg)
    assert np.max(np.abs(on - off)) > 50.0


@pytest.mark.parametrize("option, value", [("residual_gate_sigma", -1.0), ("residual_gate_persist_s", 0.0)])
def test_kernel_gate_bad_settings_are_refused(option: str, value: float) -> None:
    with pytest.raises(ValueError, match=option):
        estimators.make("dffrls-aekf", **{option: value})
