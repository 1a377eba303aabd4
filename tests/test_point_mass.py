"""The point-mass world (uuom_gym.sim.point_mass): physics sanity, sensors, faults, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uuom_core.trace import REQUIRED_COLUMNS
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2
from uuom_gym.sim.point_mass import (POINT_MASS_SCENARIOS, GradeProfile, PointMassError, PointMassFaults,
                                     PointMassModel, PointMassScenario, PointMassSensors, SpeedPlan,
                                     simulate_point_mass)

IDEAL = PointMassSensors(**{k: 0.0 for k in PointMassSensors.__dataclass_fields__})


def _model(mu: float = 0.0, damping: float = 0.0) -> PointMassModel:
    return PointMassModel(body_kg=15_700.0, rotating_kg=1045.0, pendulum_kg=10_300.0, length_m=2.5,
                          damping_nms=damping, running_resistance=mu)


@pytest.mark.parametrize("slope_deg", [0.0, 6.0, -9.0])
def test_energy_is_conserved_without_friction_damping_or_drive(slope_deg: float) -> None:
    model, th = _model(), math.radians(slope_deg)
    x, v, phi, w = 0.0, 1.0, 0.2, 0.0
    e0 = model.energy_j(x, th, v, phi, w)
    h = 1e-4
    for _ in range(50_000):  # 5 s of swing and (on the grade) free sliding
        x_dd, phi_dd = model.accelerations(th, v, phi, w, 0.0)
        v += h * x_dd
        w += h * phi_dd
        x += h * v
        phi += h * w
    scale = model.pendulum_kg * G_MPS2 * model.length_m
    assert abs(model.energy_j(x, th, v, phi, w) - e0) < 1e-3 * scale


def test_work_of_the_drive_goes_into_energy_and_friction() -> None:
    """Over a run with drive force, resistance and sway damping: work in = energy gained + dissipated."""
    model, th = _model(mu=0.02, damping=4000.0), math.radians(4.0)
    x, v, phi, w = 0.0, 0.5, 0.0, 0.0
    e0 = model.energy_j(x, th, v, phi, w)
    work = lost = 0.0
    h, force = 1e-4, 40_000.0
    for _ in range(40_000):
        x_dd, phi_dd = model.accelerations(th, v, phi, w, force)
        resist = model.running_resistance * model.total_kg * G_MPS2 * math.cos(th) * math.tanh(v / 0.005)
        work += force * v * h
        lost += (resist * v + model.damping_nms * w * w) * h
        v += h * x_dd
        w += h * phi_dd
        x += h * v
        phi += h * w
    gained = model.energy_j(x, th, v, phi, w) - e0
    assert gained > 0.1 * work  # the train climbed and sped up
    assert gained + lost == pytest.approx(work, rel=2e-3)


def test_force_balance_at_constant_speed_on_a_constant_grade() -> None:
    """At steady speed the drive force is resistance plus the grade force; the accelerometer reads g sin(slope)."""
    mu, load = 0.025, 8000.0
    sc = PointMassScenario("steady", GradeProfile(((0.0, 5.0),)), SpeedPlan(((0.0, 0.6),)), load, duration_s=80.0,
                           running_resistance=mu, sensors=IDEAL)
    tr = simulate_point_mass(sc, seed=0)
    late = tr["t_s"] > 50.0
    m = DEFAULT_VEHICLE.empty_mass_kg + load
    th = math.radians(5.0)
    expected = m * G_MPS2 * (math.sin(th) + mu * math.cos(th))
    force = tr["torque_nm"][late] / DEFAULT_VEHICLE.drive_wheel_radius_m
    assert np.mean(force) == pytest.approx(expected, rel=0.01)
    assert np.mean(tr["accel_mps2"][late]) == pytest.approx(G_MPS2 * math.sin(th), abs=0.01)
    assert np.mean(tr["speed_mps"][late]) == pytest.approx(0.6, abs=0.01)
    assert np.all(tr["mass_kg"] == m)


def test_same_seed_same_trace_other_seed_other_noise_same_physics() -> None:
    a = simulate_point_mass("pm-stop-and-go", seed=5)
    b = simulate_point_mass("pm-stop-and-go", seed=5)
    c = simulate_point_mass("pm-stop-and-go", seed=6)
    for k in a.columns:
        np.testing.assert_array_equal(a[k], b[k])
    assert not np.array_equal(a["accel_mps2"], c["accel_mps2"])
    np.testing.assert_array_equal(a["true_speed_mps"], c["true_speed_mps"])


def test_trace_contract_and_truth_columns() -> None:
    tr = simulate_point_mass("pm-section1", seed=0)
    for c in REQUIRED_COLUMNS + ("mass_kg", "slope_deg", "effective_slope_deg"):
        assert c in tr and np.all(np.isfinite(tr[c]))
    assert np.allclose(np.diff(tr["t_s"]), 0.005)
    assert tr["slope_deg"].max() == pytest.approx(8.0, abs=0.05)
    assert len(POINT_MASS_SCENARIOS) >= 8


def test_faults_dropouts_stuck_and_bias_drift() -> None:
    faults = PointMassFaults(dropout_prob=0.1, stuck_channel="speed_mps", stuck_start_s=20.0, stuck_duration_s=2.0,
                             bias_drift_per_s={"accel_mps2": 0.01})
    base = POINT_MASS_SCENARIOS["pm-section2"]
    clean = simulate_point_mass(base, seed=1)
    tr = simulate_point_mass(PointMassScenario(**{**base.__dict__, "faults": faults}), seed=1)
    frac = np.mean(np.isnan(tr["torque_nm"]))
    assert 0.07 < frac < 0.13
    stuck = (tr["t_s"] >= 20.0) & (tr["t_s"] < 22.0)
    vals = tr["speed_mps"][stuck]
    assert np.unique(vals[np.isfinite(vals)]).size == 1
    late = (tr["t_s"] > 100) & np.isfinite(tr["accel_mps2"])
    drift = np.mean(tr["accel_mps2"][late] - clean["accel_mps2"][late])
    assert drift == pytest.approx(0.01 * np.mean(tr["t_s"][late]), rel=0.05)


def test_bad_scenarios_are_one_clear_error() -> None:
    with pytest.raises(PointMassError, match="increasing"):
        GradeProfile(((0.0, 1.0), (0.0, 2.0)))
    with pytest.raises(PointMassError, match="unknown point-mass scenario"):
        simulate_point_mass("nope", seed=0)
    with pytest.raises(PointMassError, match="seed"):
        simulate_point_mass("pm-section1", seed=1.5)
    with pytest.raises(PointMassError, match="stuck channel"):
        PointMassFaults(stuck_channel="gyro")


def test_sensor_scale_multiplies_every_imperfection() -> None:
    import dataclasses

    from uuom_gym.sim.point_mass import PointMassSensors, point_mass_scenario, with_sensor_scale

    base = point_mass_scenario("pm-section1")
    twice = with_sensor_scale("pm-section1", 2.0)
    for f in dataclasses.fields(base.sensors):
        a, b = getattr(base.sensors, f.name), getattr(twice.sensors, f.name)
        assert b == (a if f.name == "vibration_hz" else 2.0 * a), f.name
    assert with_sensor_scale(base, 0.0).sensors == PointMassSensors.perfect()
    assert twice.grade == base.grade and twice.faults == base.faults  # the physics and the faults kept
    for bad in (-1.0, math.nan, math.inf, True, "2"):
        with pytest.raises(PointMassError, match="sensor scale"):
            with_sensor_scale("pm-section1", bad)
