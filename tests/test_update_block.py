"""``Estimator.update_block``: a block of samples gives the same state as ``update`` on each (the env's path)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import estimators
from uuom_core.synthetic import synthetic_trace


@pytest.fixture(scope="module")
def trace():
    return synthetic_trace(duration_s=12.0, seed=3)


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused", "sf-kf", "rls-ekf"])
def test_block_equals_sample_by_sample(trace, name):
    one, block = estimators.make(name), estimators.make(name)
    dt = float(trace["t_s"][1] - trace["t_s"][0])
    cols = [np.asarray(trace[k], dtype=float) for k in ("torque_nm", "speed_mps", "accel_mps2")]
    cols[1][50:53] = np.nan  # a dropout inside a block
    for start in range(0, len(cols[0]), 20):
        part = [c[start:start + 20] for c in cols]
        for i in range(len(part[0])):
            e1 = one.update(part[0][i], part[1][i], part[2][i], dt)
        e2 = block.update_block(*part, dt)
        assert (e1.mass_kg, e1.slope_rad, e1.mass_std_kg, e1.slope_std_rad) == (
            e2.mass_kg, e2.slope_rad, e2.mass_std_kg, e2.slope_std_rad)
    assert math.isfinite(e2.mass_kg) and e2.extras.keys() == e1.extras.keys()


@pytest.mark.parametrize("name", ["dffrls-aekf", "sf-kf"])
def test_block_columns_must_match(name):
    est = estimators.make(name)
    with pytest.raises(ValueError, match="update_block"):
        est.update_block([1.0, 2.0], [0.1], [0.0, 0.0], 0.005)


def test_empty_block_returns_current_estimate():
    est = estimators.make("dffrls-aekf")
    assert est.update_block([], [], [], 0.005) == est.estimate
