"""Estimators on the project's pymunk plant (short runs; the full comparison is scripts/benchmark_estimators.py)."""

from __future__ import annotations

import numpy as np
import pytest

import estimators
from uuom_gym.sim import recording


@pytest.fixture(scope="module")
def section2():
    return recording.simulate_run("section2", seed=1, duration_s=60.0)


def _rmse(trace, series, settle_s: float = 10.0) -> tuple[float, float]:
    m = trace["t_s"] >= settle_s
    mass_pct = 100 * np.sqrt(np.mean((series.mass_kg[m] / trace["mass_kg"][m] - 1) ** 2))
    slope_deg = np.sqrt(np.mean((series.slope_deg[m] - trace["slope_deg"][m]) ** 2))
    return float(mass_pct), float(slope_deg)


def test_sf_kf_on_plant_beats_paper_method(section2) -> None:
    sf = _rmse(section2, estimators.make("sf-kf").run(section2))
    paper = _rmse(section2, estimators.make("dffrls-aekf").run(section2))
    assert sf[0] < 8.0 and sf[1] < 0.3
    assert sf[0] < paper[0] and sf[1] < paper[1]


@pytest.mark.parametrize("name", ["rls", "ffrls", "dffrls", "ekf", "rls-ekf", "dffrls-aekf", "sf-kf"])
def test_plant_outputs_finite_and_in_range(section2, name: str) -> None:
    s = estimators.make(name).run(section2)
    assert np.all(np.isfinite(s.mass_kg)) and np.all(np.isfinite(s.slope_rad))
    assert np.all(np.isfinite(s.mass_std_kg)) and np.all(np.isfinite(s.slope_std_rad))
    assert np.all(s.mass_std_kg >= 0) and np.all(s.slope_std_rad >= 0)
    v = estimators.make(name).vehicle
    assert s.mass_kg.min() >= v.empty_mass_kg - 1e-6 and s.mass_kg.max() <= v.max_mass_kg + 1e-6
