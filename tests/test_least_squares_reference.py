"""The least-squares mass reference (``estimators.least_squares_reference``) behind
``scripts/mass_information_bound.py``: right where its model is exact, and honest about its first seconds."""

from __future__ import annotations

import math

import numpy as np

from estimators.least_squares_reference import expanding_ls_mass, ls_mass_errors, scenario_offset_prior
from uuom_gym.sim.point_mass import point_mass_scenario, simulate_point_mass


def test_converges_on_the_point_mass_world():
    tr = simulate_point_mass(point_mass_scenario("pm-section2"), seed=0)
    worst, end = ls_mass_errors(tr)
    assert end < 1.0, end  # the model is exact there: the whole history pins the mass
    assert worst >= end  # and the early estimate is worse than the late one


def test_nan_until_determined_and_finite_after():
    tr = simulate_point_mass(point_mass_scenario("pm-section1"), seed=1)
    m = expanding_ls_mass(tr)
    assert np.isnan(m[0])  # at rest: nothing to fit
    late = m[np.isfinite(m)]
    assert late.size > 100 and np.all(late > 0)


def test_offset_prior_fit_is_finite_and_converges():
    tr = simulate_point_mass(point_mass_scenario("pm-section2"), seed=0)
    mass = float(tr["mass_kg"][0])
    m = expanding_ls_mass(tr, offset_prior=scenario_offset_prior(mass))
    late = m[np.isfinite(m)]
    assert late.size > 100 and np.all(late > 0)
    worst, end = ls_mass_errors(tr, offset_prior=scenario_offset_prior(mass))
    assert end < 1.0 and worst >= end


def test_offset_prior_matches_the_draws_it_describes():
    p = scenario_offset_prior(20_000.0)
    assert math.isclose(p.mean_mps2, 9.81 * 0.0225)
    assert 0.04 < p.std_mps2 < 0.06  # mu's uniform spread dominates the bias spreads
