"""The filterpy comparison of ``scripts/bench_estimator_speed.py`` compares the *same* whole model: its filterpy
version of ``dffrls-aekf-paper`` (both layers, the Sage-Husa adaptation, the guards) must give the estimator's
estimates, on clean data and through dropouts, spikes and an implausible sample. No timing is asserted."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import estimators
from uuom_core.synthetic import synthetic_trace
from uuom_core.trace import Trace

pytest.importorskip("filterpy")

_SPEC = importlib.util.spec_from_file_location(
    "bench_estimator_speed", Path(__file__).parents[1] / "scripts" / "bench_estimator_speed.py")
bench = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(bench)  # type: ignore[union-attr]


def _faulty(tr: Trace, seed: int = 0) -> Trace:
    rng = np.random.default_rng(seed)
    cols = {c: v.copy() for c, v in tr.columns.items()}
    n = len(cols["t_s"])
    for name in ("torque_nm", "speed_mps", "accel_mps2"):
        cols[name][rng.random(n) < 0.03] = np.nan  # dropouts
    cols["speed_mps"][rng.integers(0, n, 5)] = 80.0  # beyond any physical speed: counts as missing
    cols["accel_mps2"][rng.integers(0, n, 5)] *= 20.0  # spikes that pass the input limits
    return Trace(cols, source="faulty", meta=dict(tr.meta))


@pytest.mark.parametrize("faults", [False, True])
def test_filterpy_version_is_the_same_whole_model(faults):
    tr = synthetic_trace("section1", seed=3, duration_s=30.0)
    if faults:
        tr = _faulty(tr)
    mass, slope_rad = bench.filterpy_paper_method(tr)()
    ref = estimators.make("dffrls-aekf-paper").run(tr)
    assert np.all(np.isfinite(mass)) and np.all(np.isfinite(slope_rad))
    np.testing.assert_allclose(mass, ref.mass_kg, rtol=1e-9)
    np.testing.assert_allclose(np.degrees(slope_rad), ref.slope_deg, rtol=0, atol=1e-8)
    # the comparison is not vacuous: the estimate moves over the trace
    assert np.ptp(ref.mass_kg) > 100.0 and np.ptp(ref.slope_deg) > 0.1
