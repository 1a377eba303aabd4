"""Fault injection: after a sensor fault ends, every estimator returns to what it gives on the clean data.

One 40 s run with all seven inputs (the varying-grade synthetic signal of :mod:`uuom_core.synthetic`, with motor
speed, gyro and normal accelerometer derived from its truth) is replayed clean and with one fault from 10 s to
13 s:

* ``dropout``: every input missing (NaN);
* ``stuck``: the speed encoder frozen at its last value (a plausible but wrong reading);
* ``spike``: twelve single-sample spikes (torque x 20, speed + 5 m/s, specific force + 30 m/s^2);
* ``bias``: the accelerometer reads 0.5 m/s^2 high and the torque 10 % high (a miscalibration that goes away).

From 25 s on (12 s after the fault) each declared output (``Estimator.outputs``) of the faulted run must be within
a bound of the clean run's: mass 2 % of the true mass, slope 0.15 deg, slip ratio 0.01, drive radius 0.5 mm (mean
absolute difference over the window) -- the issue-10 requirement "recovery to the clean-data accuracy within 10 s
after a fault ends", measured against the estimator itself so that the test isolates recovery from accuracy.
Outputs are finite throughout.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pytest

import estimators
from uuom_core.synthetic import synthetic_trace
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2

DT = 0.005
FAULT = slice(int(10.0 / DT), int(13.0 / DT))
SCORED = slice(int(25.0 / DT), None)
MASS_KG = 26_000.0
BOUND = {"mass": 0.02 * MASS_KG, "slope": math.radians(0.15), "slip_ratio": 0.01, "drive_radius_m": 5e-4}
FAULTS = ("dropout", "stuck", "spike", "bias")
COLUMNS = ("torque_nm", "speed_mps", "accel_mps2", "dt_s", "motor_speed_radps", "gyro_radps", "accel_normal_mps2")

# The trace is a point mass; mmae's default models the project plant's 18 m train (rear section 9 m behind), which
# on a point-mass trace is the wrong model (clean mass error 2.8 t instead of 0.2 t, measured) and makes it
# ill-conditioned. Configured for the world the data come from, as tests/test_mmae.py does.
OPTIONS: dict[str, dict[str, float]] = {"mmae": {"rear_offset_m": 0.0}}

_OTHERS = "estimator owned by the estimators helper (issue 10); measured and reported in docs/robustness.md"
# (estimator, fault) -> reason: recovery failures measured in estimators this test's author does not own
KNOWN_FAILURES: dict[tuple[str, str], str] = {
    ("dffrls-aekf-paper", "dropout"): "the paper's equations as printed have no recovery mechanism; " + _OTHERS,
    ("dffrls-aekf-paper", "stuck"): "the paper's equations as printed have no recovery mechanism; " + _OTHERS,
    ("dffrls-aekf-paper", "bias"): "the paper's equations as printed have no recovery mechanism; " + _OTHERS,
    ("ekf", "bias"): "mass 537 kg from the clean run 12-27 s after the bias (bound 520); " + _OTHERS,
    ("rls", "bias"): "no forgetting: slope 0.30 deg from the clean run (bound 0.15); " + _OTHERS,
    ("sf-kf", "bias"): "mass 1443 kg from the clean run (bound 520); " + _OTHERS,
}


@lru_cache(maxsize=1)
def clean_rows() -> np.ndarray:
    base = synthetic_trace("varying", seed=3, mass_kg=MASS_KG, duration_s=40.0, dt_s=DT)
    rng = np.random.default_rng(3)
    n = len(base)
    th = np.radians(base["slope_deg"])
    v = base["true_speed_mps"]
    rows = np.empty((n, 7))
    rows[:, 0] = base["torque_nm"]
    rows[:, 1] = base["speed_mps"]
    rows[:, 2] = base["accel_mps2"]
    rows[:, 3] = DT
    rows[:, 4] = v * 1.003 / DEFAULT_VEHICLE.drive_wheel_radius_m + 0.02 * rng.standard_normal(n)
    rows[:, 5] = np.gradient(th, DT) + 2e-3 * rng.standard_normal(n)
    rows[:, 6] = G_MPS2 * np.cos(th) + 0.05 * rng.standard_normal(n)
    return rows


def faulted_rows(kind: str) -> np.ndarray:
    rows = clean_rows().copy()
    f = rows[FAULT]
    if kind == "dropout":
        f[:, [0, 1, 2, 4, 5, 6]] = np.nan
    elif kind == "stuck":
        f[:, 1] = rows[FAULT.start - 1, 1]
    elif kind == "spike":
        hits = np.linspace(0, len(f) - 1, 12).astype(int)
        f[hits, 0] *= 20.0
        f[hits, 1] += 5.0
        f[hits, 2] += 30.0
    elif kind == "bias":
        f[:, 2] += 0.5
        f[:, 0] *= 1.1
    else:  # pragma: no cover
        raise ValueError(kind)
    return rows


def run(name: str, rows: np.ndarray) -> dict[str, np.ndarray]:
    est = estimators.make(name, **OPTIONS.get(name, {}))
    keys = est.outputs
    out = {k: np.empty(len(rows)) for k in keys}
    for i, row in enumerate(rows.tolist()):
        e = est.update(*row)
        for k in keys:
            out[k][i] = e.mass_kg if k == "mass" else e.slope_rad if k == "slope" else e.extras[k]
    return out


@lru_cache(maxsize=None)
def clean_outputs(name: str) -> dict[str, np.ndarray]:
    return run(name, clean_rows())


def _cases() -> list[object]:
    out = []
    for name in estimators.available():
        for kind in FAULTS:
            reason = KNOWN_FAILURES.get((name, kind))
            marks = [pytest.mark.xfail(strict=False, reason=reason)] if reason else []
            out.append(pytest.param(name, kind, marks=marks, id=f"{name}-{kind}"))
    return out


@pytest.mark.parametrize("name, kind", _cases())
def test_recovers_after_fault(name: str, kind: str) -> None:
    clean = clean_outputs(name)
    bad = run(name, faulted_rows(kind))
    for key, series in bad.items():
        assert np.all(np.isfinite(series)), f"{name}/{kind}: {key} not finite"
        diff = float(np.mean(np.abs(series[SCORED] - clean[key][SCORED])))
        bound = BOUND.get(key)
        assert bound is not None, f"{name}: no recovery bound for output {key!r}; add one to BOUND"
        assert diff <= bound, (
            f"{name}/{kind}: {key} differs from the clean run by {diff:.4g} on average 12-27 s after the fault "
            f"(bound {bound:.4g})"
        )


def test_faults_change_the_input() -> None:
    """Guard against a vacuous test: each fault alters the replayed samples inside its window only."""
    clean = clean_rows()
    for kind in FAULTS:
        bad = faulted_rows(kind)
        inside = ~np.isclose(bad[FAULT], clean[FAULT], equal_nan=False)
        assert inside.any(), kind
        np.testing.assert_array_equal(bad[FAULT.stop:], clean[FAULT.stop:])
