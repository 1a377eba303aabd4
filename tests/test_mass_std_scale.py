"""``mass_std_scale`` (round 2, session 62): a calibration factor on the data part of ``dffrls-aekf``'s and ``fused``'s
reported mass σ, the prior's σ staying the cap; the estimates themselves do not move
(``scripts/std_calibration.py``, ``results/estimation/std_calibration.md``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import estimators
from estimators.metrics import smallest_covering_scale
from uuom_core.trace import Trace
from uuom_core.vehicle import DEFAULT_VEHICLE
from uuom_gym.sim.protocol_runs import RunSpec, make_run

PRIOR_STD_KG = 0.5 * (DEFAULT_VEHICLE.max_mass_kg - DEFAULT_VEHICLE.empty_mass_kg)
"""The mass prior's σ (half the mass range): what no calibration may report more than."""


@pytest.fixture(scope="module")
def plant_run() -> Trace:
    """Plant tuning run 1000 (a tuning run, not an evaluation run)."""
    return make_run(RunSpec("plant", "plant-1000", 1000, 1000, "plant"))


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_the_default_is_the_uncalibrated_sigma(plant_run: Trace, name: str) -> None:
    a = estimators.make(name).run(plant_run)
    b = estimators.make(name, mass_std_scale=1.0).run(plant_run)
    np.testing.assert_array_equal(a.mass_std_kg, b.mass_std_kg)
    np.testing.assert_array_equal(a.mass_kg, b.mass_kg)


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_the_scale_moves_the_sigma_only(plant_run: Trace, name: str) -> None:
    one = estimators.make(name).run(plant_run)
    for scale in (0.3, 3.0):
        s = estimators.make(name, mass_std_scale=scale).run(plant_run)
        np.testing.assert_array_equal(s.mass_kg, one.mass_kg)  # the estimate is not touched
        np.testing.assert_array_equal(s.slope_deg, one.slope_deg)
        if scale < 1.0:
            assert np.all(s.mass_std_kg <= one.mass_std_kg * (1 + 1e-12))
            assert np.mean(s.mass_std_kg) < 0.8 * np.mean(one.mass_std_kg)  # it does calibrate something
        else:
            assert np.all(s.mass_std_kg >= one.mass_std_kg * (1 - 1e-12))


def test_a_single_filter_scales_exactly_below_the_cap(plant_run: Trace) -> None:
    """One filter (a bank's mixture adds its members' spread, which is not scaled): where σ is below the prior's cap,
    the scaled σ is the factor times it, and no factor reports more than the prior."""
    one = estimators.make("dffrls-aekf", train_length_m=12.0).run(plant_run)
    half = estimators.make("dffrls-aekf", train_length_m=12.0, mass_std_scale=0.5).run(plant_run)
    below = one.mass_std_kg < 0.99 * PRIOR_STD_KG
    assert below.sum() > 100
    np.testing.assert_allclose(half.mass_std_kg[below], 0.5 * one.mass_std_kg[below], rtol=1e-9)
    triple = estimators.make("dffrls-aekf", train_length_m=12.0, mass_std_scale=3.0).run(plant_run)
    assert np.all(triple.mass_std_kg <= PRIOR_STD_KG * (1 + 1e-9))
    assert np.any(triple.mass_std_kg >= PRIOR_STD_KG * (1 - 1e-9))


@pytest.mark.parametrize("bad", [0.0, -0.5, math.nan, math.inf, True, "0.3"])
def test_bad_values_name_the_option(bad) -> None:
    with pytest.raises((ValueError, TypeError), match="mass_std_scale"):
        estimators.make("dffrls-aekf", mass_std_scale=bad)


def test_smallest_covering_scale() -> None:
    scales = [1.0, 0.5, 0.4, 0.3]
    assert smallest_covering_scale(scales, [0.99, 0.97, 0.95, 0.93]) == 0.4
    assert smallest_covering_scale(scales[::-1], [0.93, 0.95, 0.97, 0.99]) == 0.4  # any order
    assert smallest_covering_scale(scales, [0.9, 0.9, 0.9, 0.9]) is None
    with pytest.raises(ValueError, match="scales"):
        smallest_covering_scale([1.0, 0.0], [0.99, 0.9])
    with pytest.raises(ValueError):
        smallest_covering_scale([1.0, 0.5], [0.99])  # unmatched lengths
