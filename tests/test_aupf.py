"""Tests of the adaptive unscented particle filter for drive slip and wheel radius (estimators/aupf.py).

``_slip_signal`` is a *unit-test signal*, not the project's plant: a point-mass train under a PI speed driver whose
friction drive follows a creep curve (with different constants from the estimator's) and goes into macro-slip on a
wet stretch; worn drive wheels; noisy, quantised encoders. The plant tests use ``simulate_run`` with wheel wear and
wet-rail adhesion (the plant's drive sticks exactly, ``omega r = v``, and spins up when the adhesion is exceeded).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import estimators
from estimators.aupf import AUPFConfigError, AUPFEstimator
from uuom_core.trace import Trace
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2


def _slip_signal(
    *,
    seed: int,
    wear_m: float = 0.004,
    duration_s: float = 70.0,
    wet: tuple[float, float] = (40.0, 46.0),
    load_kg: float = 12000.0,
    adhesion_wet: float = 0.12,
    hz: float = 200.0,
) -> Trace:
    """Unit-test signal: 6 deg grade from 20 s, a wet stretch where the demanded traction exceeds the adhesion."""
    veh = DEFAULT_VEHICLE
    rng = np.random.default_rng(seed)
    dt = 1.0 / hz
    n = int(duration_s * hz)
    r = veh.drive_wheel_radius_m - wear_m
    mass = veh.empty_mass_kg + load_kg
    clamp = veh.clamp_force_n
    v = integ = slip = 0.0
    names = ("t_s", "torque_nm", "speed_mps", "accel_mps2", "motor_speed_radps", "slip_ratio", "drive_radius_m",
             "true_speed_mps")
    cols = {k: np.zeros(n) for k in names}
    for k in range(n):
        t = k * dt
        th = math.radians(6.0) if t > 20.0 else 0.0
        err = min(1.0, 0.25 * t) - v
        integ = min(max(integ + err * dt, -1.0), 1.0)
        f_cmd = mass * G_MPS2 * (math.sin(th) + 0.02) + mass * (1.0 * err + 0.2 * integ)
        f_cmd = min(max(f_cmd, 0.0), veh.max_traction_n)
        mu_a = adhesion_wet if wet[0] <= t < wet[1] else 0.33
        u = f_cmd / clamp
        if u < mu_a:
            target, force = -0.004 * math.log(1.0 - u / mu_a), f_cmd
        else:
            target, force = 0.25, mu_a * clamp
        slip += (target - slip) * min(dt / 0.15, 1.0)
        a = (force - mass * G_MPS2 * math.sin(th) - 0.02 * mass * G_MPS2 * (v > 1e-4)) / (
            mass + veh.rotating_mass_kg
        )
        if v <= 0.0 and a < 0.0:
            a = 0.0
        v = max(v + a * dt, 0.0)
        omega = v / (r * (1.0 - slip)) if v > 0.0 else 0.0
        cols["t_s"][k] = t
        cols["torque_nm"][k] = f_cmd * r + 20.0 * rng.standard_normal()
        cols["speed_mps"][k] = round((v + 0.01 * rng.standard_normal()) / 0.005) * 0.005
        cols["accel_mps2"][k] = a + G_MPS2 * math.sin(th) + 0.1 * rng.standard_normal()
        cols["motor_speed_radps"][k] = omega + 0.03 * rng.standard_normal()
        cols["slip_ratio"][k] = slip if v > 0.0 else 0.0
        cols["drive_radius_m"][k] = r
        cols["true_speed_mps"][k] = v
    return Trace(cols, source=f"unit-test slip signal (seed {seed})")


def _errors(trace: Trace, series, settle_s: float = 20.0) -> tuple[np.ndarray, np.ndarray]:
    moving = trace["true_speed_mps"] > 0.2
    # slip counts while moving and while stalled with the drive wheel spinning (slip ~1)
    rim = np.nan_to_num(trace["motor_speed_radps"]) * trace["drive_radius_m"]
    slip_err = (series.extras["slip_ratio"] - trace["slip_ratio"])[moving | (rim > 0.2)]
    settled = moving & (trace["t_s"] > settle_s)
    radius_err = (series.extras["drive_radius_m"] - trace["drive_radius_m"])[settled]
    return slip_err, radius_err


def test_registry_and_provides() -> None:
    est = estimators.make("aupf")
    assert isinstance(est, AUPFEstimator)
    assert {"slip", "radius"} <= est.provides
    e = est.estimate
    assert math.isclose(e.extras["drive_radius_m"], DEFAULT_VEHICLE.drive_wheel_radius_m)
    assert e.mass_std_kg > 1000.0 and e.slope_std_rad > 0.05  # a prior, not an estimate


@pytest.mark.parametrize(
    "options, word",
    [
        ({"n_particles": 1}, "n_particles"),
        ({"alpha": 2.0}, "alpha"),
        ({"max_slip": 1.0}, "max_slip"),
        ({"noise_fading": 1.0}, "noise_fading"),
        ({"speed_std_mps": -1.0}, "speed_std_mps"),
        ({"seed": 1.5}, "seed"),
        ({"creep_slip": math.inf}, "creep_slip"),
    ],
)
def test_bad_options_are_named(options: dict, word: str) -> None:
    with pytest.raises(AUPFConfigError, match=word):
        AUPFEstimator(**options)


def test_learns_wear_and_tracks_macro_slip_on_the_unit_signal() -> None:
    trace = _slip_signal(seed=3)
    est = AUPFEstimator()
    series = est.run(trace)
    slip_err, radius_err = _errors(trace, series)
    assert np.max(np.abs(radius_err)) < 1.5e-3  # 4 mm of wear learned to well within the paper's 3 mm
    wet = (trace["t_s"] > 41.0) & (trace["t_s"] < 45.0)
    assert np.mean(trace["slip_ratio"][wet]) > 0.2  # the signal really slips there
    assert np.max(np.abs(slip_err)) < 0.1
    assert np.quantile(np.abs(slip_err), 0.99) < 0.05
    assert np.mean(series.extras["macro_slip_prob"][wet]) > 0.7
    dry = (trace["t_s"] > 25.0) & (trace["t_s"] < 38.0)
    assert np.mean(series.extras["macro_slip_prob"][dry]) < 0.2
    assert est.n_resamples > 0


def test_reported_std_covers_the_error() -> None:
    trace = _slip_signal(seed=4, wear_m=0.007)
    series = AUPFEstimator().run(trace)
    moving = (trace["true_speed_mps"] > 0.2) & (trace["t_s"] > 20.0)
    r_err = np.abs(series.extras["drive_radius_m"] - trace["drive_radius_m"])[moving]
    r_std = series.extras["drive_radius_m_std"][moving]
    assert np.mean(r_err < 3.0 * r_std) > 0.9
    i_err = np.abs(series.extras["slip_ratio"] - trace["slip_ratio"])[moving]
    i_std = series.extras["slip_ratio_std"][moving]
    assert np.mean(i_err < 3.0 * i_std + 0.005) > 0.9


def test_missing_samples_and_standstill_never_give_nan(drop_samples) -> None:
    trace = drop_samples(_slip_signal(seed=5, duration_s=15.0), ("torque_nm", "speed_mps", "motor_speed_radps"), 1)
    est = AUPFEstimator(n_particles=32)
    series = est.run(trace)
    for arr in series.extras.values():
        assert np.all(np.isfinite(arr))
    assert np.all(np.isfinite(series.mass_kg)) and np.all(np.isfinite(series.slope_rad))
    e = est.update(math.nan, math.nan, math.nan, 0.005, math.nan)
    assert all(math.isfinite(v) for v in e.extras.values())
    assert math.isclose(est.weights.sum(), 1.0)


def test_recovers_from_weight_underflow() -> None:
    est = AUPFEstimator(n_particles=32)
    r = DEFAULT_VEHICLE.drive_wheel_radius_m
    for _ in range(400):
        est.update(1000.0, 1.0, 0.0, 0.005, 1.0 / r)
    # a sample no particle can explain even after the AUKF moved it: the wheel turning backwards (a sign fault)
    e = est.update(1000.0, 1.0, 0.0, 0.005, -1.0 / r)
    assert est.n_underflow_recoveries >= 1
    assert all(math.isfinite(v) for v in e.extras.values())
    assert math.isclose(est.weights.sum(), 1.0)
    for _ in range(400):
        e = est.update(1000.0, 1.0, 0.0, 0.005, 1.0 / r)
    assert abs(e.extras["slip_ratio"]) < 0.02
    assert abs(e.extras["drive_radius_m"] - r) < 1e-3


def test_seeded_and_deterministic() -> None:
    trace = _slip_signal(seed=6, duration_s=10.0)
    a = AUPFEstimator(seed=3).run(trace)
    b = AUPFEstimator(seed=3).run(trace)
    c = AUPFEstimator(seed=4).run(trace)
    assert np.array_equal(a.extras["slip_ratio"], b.extras["slip_ratio"])
    assert not np.array_equal(a.extras["slip_ratio"], c.extras["slip_ratio"])


@pytest.mark.parametrize(
    "name, load_kg, wear_m, adhesion",
    [("section1", 10000.0, 0.004, 0.12), ("section2", 18000.0, 0.002, 0.13)],
)
def test_paper_targets_on_the_plant(name: str, load_kg: float, wear_m: float, adhesion: float) -> None:
    from uuom_gym.sim import recording
    from uuom_gym.sim.plant import PlantConfig

    config = PlantConfig(load_kg=load_kg, wheel_wear_m=wear_m, adhesion=adhesion)
    trace = recording.simulate_run(name, seed=2, load_kg=load_kg, plant_config=config)
    series = AUPFEstimator().run(trace)
    slip_err, radius_err = _errors(trace, series)
    assert np.max(trace["slip_ratio"]) > 0.3  # wet rail: the drive really slipped
    assert np.max(np.abs(slip_err)) <= 0.05  # paper 004: slip error <= 5 %
    assert np.max(np.abs(radius_err)) <= 3e-3  # paper 004: radius error <= 3 mm (after 20 s of driving)
