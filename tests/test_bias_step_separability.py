"""The statistic behind docs/robustness.md's bias-step table (scripts/bias_step_separability.py) sees a step of
accelerometer bias as a step of its size, and a grade change of a point mass not at all."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

from uuom_core.units import G_MPS2 as G

_SPEC = importlib.util.spec_from_file_location(
    "bias_step_separability", Path(__file__).parents[1] / "scripts" / "bias_step_separability.py")
sep = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(sep)  # type: ignore[union-attr]

MASS = 26_000.0


def _point_mass(slope_rad: np.ndarray, dt: float = 0.005, force_n: float = 20_000.0, seed: int = 0):
    """A rigid point mass at constant drive force on a given slope profile (per sample): f = F / M_eff exactly."""
    m_eff = MASS + sep.VEH.rotating_mass_kg
    n = len(slope_rad)
    t = np.arange(n) * dt
    a = force_n / m_eff - G * np.sin(slope_rad)
    v = 1.0 + np.concatenate([[0.0], np.cumsum(a[:-1]) * dt])
    rng = np.random.default_rng(seed)
    f = force_n / m_eff + 0.02 * rng.standard_normal(n)
    return t, f, v + 0.005 * rng.standard_normal(n), np.full(n, force_n)


def test_a_bias_step_gives_its_size_and_a_grade_step_nothing() -> None:
    n = 4000  # 20 s
    flat = np.zeros(n)
    t, f, v, force = _point_mass(flat)
    biased = f.copy()
    biased[2000:] += 0.4
    j_bias = sep.joint(*sep.block_steps(t, biased, v, force, MASS))
    assert abs(np.nanmax(j_bias) - 0.4) < 0.05
    grade = np.where(np.arange(n) >= 2000, np.radians(3.0), 0.0)  # a 3 deg step: 0.51 m/s^2 at the sensor
    t, f, v, force = _point_mass(grade)
    d, e = sep.block_steps(t, f, v, force, MASS)
    assert np.nanmax(np.abs(d)) > 0.4  # the rate test alone would call it a bias
    assert np.nanmax(sep.joint(d, e)) < 0.05  # the force balance does not move


def test_a_dropout_block_gives_no_statistic() -> None:
    t, f, v, force = _point_mass(np.zeros(1000))
    f[300:400] = np.nan
    d, e = sep.block_steps(t, f, v, force, MASS)
    assert np.isnan(d).any() and np.isfinite(sep.joint(d, e)).all()
