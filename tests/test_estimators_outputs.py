"""What each registered estimator estimates (``Estimator.outputs``), and that those columns are estimates.

A consumer (``uuom-estimate``, the environment's info, a plot) writes only the quantities in ``outputs``; the
rest of an :class:`~estimators.base.Estimate` may be a prior placeholder (the mass ``imu-ukf`` and ``aupf``
report). Issue 12: ``aupf`` estimates the drive slip ratio and the effective drive-wheel radius, ``imu-ukf`` the
slope; neither estimates mass. (That ``aupf``'s radius follows wear is tested in ``tests/test_aupf.py``.)
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import estimators
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2

BUILT_IN = {"mass", "slope"}


def stream(n: int, *, grade_deg: float = 2.0, radius_m: float | None = None, seed: int = 0) -> np.ndarray:
    """Rows of the seven inputs: a train at ~1 m/s on a constant grade, the drive wheel of ``radius_m``."""
    rng = np.random.default_rng(seed)
    veh = DEFAULT_VEHICLE
    r_true = veh.drive_wheel_radius_m if radius_m is None else radius_m
    mass = veh.empty_mass_kg + 0.5 * veh.rated_load_kg
    th = math.radians(grade_deg)
    t = np.arange(n) * 0.005
    speed = 1.0 + 0.2 * np.sin(0.4 * t)
    acc = 0.08 * np.cos(0.4 * t)
    force = mass * (G_MPS2 * (math.sin(th) + veh.running_resistance * math.cos(th)) + acc)
    out = np.empty((n, 7))
    out[:, 0] = force * veh.drive_wheel_radius_m + 20.0 * rng.standard_normal(n)
    out[:, 1] = speed + 0.005 * rng.standard_normal(n)
    out[:, 2] = acc + G_MPS2 * math.sin(th) + 0.05 * rng.standard_normal(n)
    out[:, 3] = 0.005
    out[:, 4] = speed * 1.003 / r_true + 0.02 * rng.standard_normal(n)  # 0.3 % creep slip
    out[:, 5] = 1e-3 * rng.standard_normal(n)
    out[:, 6] = G_MPS2 * math.cos(th) + 0.05 * rng.standard_normal(n)
    return out


def final(name: str, rows: np.ndarray) -> estimators.Estimate:
    est = estimators.make(name)
    e = est.estimate
    for row in rows.tolist():
        e = est.update(*row)
    return e


def value(e: estimators.Estimate, key: str) -> float:
    return {"mass": e.mass_kg, "slope": e.slope_rad}.get(key, e.extras.get(key, math.nan))


@pytest.mark.parametrize("name", estimators.available())
def test_outputs_are_declared_and_present(name: str) -> None:
    cls = estimators.get_class(name)
    outputs = cls.outputs
    assert isinstance(outputs, tuple) and outputs and all(isinstance(k, str) for k in outputs), name
    for key in BUILT_IN & set(outputs):
        assert key in cls.provides, f"{name}: outputs {key!r} but does not provide it"
    e = final(name, stream(400))
    for key in outputs:
        assert math.isfinite(value(e, key)), f"{name}: output {key!r} missing or not finite: {e}"


def test_aupf_outputs_slip_and_radius_not_mass() -> None:
    cls = estimators.get_class("aupf")
    assert cls.outputs == ("slip_ratio", "drive_radius_m")
    assert "mass" not in cls.provides and "slope" not in cls.provides
    e = final("aupf", stream(10))
    assert {"slip_ratio_std", "drive_radius_m_std"} <= set(e.extras)


def test_imu_ukf_outputs_slope_only() -> None:
    cls = estimators.get_class("imu-ukf")
    assert cls.outputs == ("slope",)
    assert "mass" not in cls.provides


def test_imu_ukf_slope_output_is_an_estimate() -> None:
    """Two grades 4 degrees apart give slope outputs 4 degrees apart (within 0.5 degrees)."""
    low = final("imu-ukf", stream(2000, grade_deg=1.0))
    high = final("imu-ukf", stream(2000, grade_deg=5.0))
    assert abs(math.degrees(high.slope_rad - low.slope_rad) - 4.0) < 0.5
    assert abs(math.degrees(high.slope_rad) - 5.0) < 0.5


# What uuom-estimate writes for these estimators is tested in tests/test_cli_estimate.py.
