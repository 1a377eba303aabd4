"""Sensors (noise, bias, quantisation, faults) and run recording (simulate_run)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from uuom_gym.sim import (
    CHANNELS,
    FaultConfig,
    MonorailPlant,
    PlantConfig,
    SensorConfig,
    SensorConfigError,
    SensorSuite,
    SpeedProfile,
    profile_from_knots,
    random_track,
    simulate_run,
)
from uuom_core.trace import read_trace_csv, write_trace_csv
from uuom_core.vehicle import DEFAULT_VEHICLE as V
from uuom_core.vehicle import G_MPS2


@pytest.fixture(scope="module")
def log():
    tr = profile_from_knots([(0, 0.0), (25, 0.0), (35, 6.0), (300, 6.0)])
    plant = MonorailPlant(V, tr, PlantConfig(load_kg=10_000), start_s_m=20.0)
    return plant.advance(0.45, 4000)


def test_ideal_sensors_read_the_truth(log):
    m = SensorSuite(SensorConfig.ideal(), np.random.default_rng(0)).measure(log)
    assert set(m) == set(CHANNELS)
    assert np.array_equal(m["torque_nm"], log.drive_torque_nm)
    assert np.array_equal(m["accel_mps2"], log.specific_force_mps2)
    assert np.array_equal(m["motor_speed_radps"], log.wheel_speed_radps)
    assert np.array_equal(m["gyro_radps"], log.pitch_rate_radps)
    # the ground-speed encoder sits on a carrying wheel: it reads the ground speed (no slip, no wear)
    assert np.max(np.abs(m["speed_mps"][200:] - log.speed_mps[200:])) < 0.02
    # the accelerometer reads specific force: on the grade it is about dv/dt + g sin(slope), not dv/dt
    on_grade = log.slope_rad > math.radians(5.9)
    assert on_grade.sum() > 200
    f_model = log.accel_mps2[on_grade] + G_MPS2 * np.sin(log.slope_rad[on_grade])
    assert np.mean(m["accel_mps2"][on_grade]) == pytest.approx(np.mean(f_model), abs=0.03)


def test_noise_bias_and_resolution_match_the_config(log):
    cfg = SensorConfig()
    suite = SensorSuite(cfg, np.random.default_rng(1))
    m = suite.measure(log)
    err = m["torque_nm"] - log.drive_torque_nm
    assert np.std(err) == pytest.approx(cfg.torque_noise_std_nm, rel=0.1)
    assert np.mean(err) == pytest.approx(suite.bias["torque_nm"], abs=5 * cfg.torque_noise_std_nm / math.sqrt(len(err)))
    acc_err = m["accel_mps2"] - log.specific_force_mps2
    assert np.std(acc_err) == pytest.approx(cfg.accel_noise_std_mps2, rel=0.1)
    q = m["speed_mps"] / cfg.speed_resolution_mps
    assert np.allclose(q, np.round(q), atol=1e-6)
    q = m["motor_speed_radps"] / cfg.motor_speed_resolution_radps
    assert np.allclose(q, np.round(q), atol=1e-6)
    for k in CHANNELS:
        assert np.all(np.isfinite(m[k])), k


def test_randomized_config_is_seeded_and_within_range():
    a = SensorConfig.randomized(np.random.default_rng(5))
    b = SensorConfig.randomized(np.random.default_rng(5))
    c = SensorConfig.randomized(np.random.default_rng(6))
    assert a == b and a != c
    base = SensorConfig()
    for f in dataclasses.fields(base):
        ratio = getattr(a, f.name) / getattr(base, f.name)
        assert 0.5 <= ratio <= 2.0


def test_faults(log):
    faults = FaultConfig(
        channels=("torque_nm", "speed_mps"), dropout_prob=0.05, spike_prob=0.01, spike_size=2.0,
        stuck_channel="gyro_radps", stuck_start_s=5.0, stuck_duration_s=3.0,
        bias_drift_per_s={"accel_mps2": 0.01},
    )
    ideal = SensorSuite(SensorConfig.ideal(), np.random.default_rng(2)).measure(log)
    m = SensorSuite(SensorConfig.ideal(), np.random.default_rng(2), faults=faults).measure(log)
    n = len(log)
    for k in ("torque_nm", "speed_mps"):
        frac = np.mean(np.isnan(m[k]))
        assert 0.03 < frac < 0.07, k
    for k in ("accel_mps2", "gyro_radps", "motor_speed_radps", "accel_normal_mps2"):
        assert not np.isnan(m[k]).any(), k
    ok = ~np.isnan(m["torque_nm"])
    spikes = np.abs(m["torque_nm"][ok] - ideal["torque_nm"][ok]) > 1000.0
    assert 0.004 * n < spikes.sum() < 0.02 * n
    stuck = (log.t_s >= 5.0) & (log.t_s < 8.0)
    assert np.unique(m["gyro_radps"][stuck]).size == 1
    assert np.array_equal(m["gyro_radps"][~stuck], ideal["gyro_radps"][~stuck])
    drift = m["accel_mps2"] - ideal["accel_mps2"]
    assert np.allclose(drift, 0.01 * log.t_s)


def test_sensor_config_errors():
    with pytest.raises(SensorConfigError, match="torque_noise_std_nm"):
        SensorConfig(torque_noise_std_nm=-1.0)
    with pytest.raises(SensorConfigError, match="unknown channel"):
        FaultConfig(channels=("speed",))
    with pytest.raises(SensorConfigError, match="dropout_prob"):
        FaultConfig(dropout_prob=1.5)
    with pytest.raises(SensorConfigError, match="Generator"):
        SensorSuite(SensorConfig(), rng=None)


@pytest.mark.parametrize("name", ["section1", "section2", "roadtest"])
def test_simulate_run_scenarios(name):
    tr = simulate_run(name, seed=0)
    assert tr.has_truth and len(tr) >= 100 * 200
    assert tr.duration_s >= 100.0
    for col in ("motor_speed_radps", "gyro_radps", "accel_normal_mps2", "slip_ratio", "drive_radius_m",
                "true_speed_mps", "sway_rad", "position_m"):
        assert col in tr, col
        assert np.all(np.isfinite(tr[col])), col
    assert np.all(tr["mass_kg"] == V.empty_mass_kg + 10_000)
    v = tr["true_speed_mps"]
    assert v.max() < 1.3 and np.mean(v[tr["t_s"] > 10]) > 0.4
    assert np.abs(tr["sway_rad"]).max() < math.radians(5.0)
    if name == "roadtest":
        on_grade = tr["slope_deg"] > 9.0
        assert on_grade.any() and np.mean(v[on_grade]) == pytest.approx(0.5, abs=0.1)
        assert np.mean(v[(tr["t_s"] > 15) & (tr["t_s"] < 35)]) == pytest.approx(1.0, abs=0.08)


def test_simulate_run_is_deterministic_and_seeded():
    a = simulate_run("section1", seed=3, duration_s=20.0)
    b = simulate_run("section1", seed=3, duration_s=20.0)
    c = simulate_run("section1", seed=4, duration_s=20.0)
    for k in a.columns:
        assert np.array_equal(a[k], b[k], equal_nan=True), k
    assert np.array_equal(a["true_speed_mps"], c["true_speed_mps"])  # physics does not depend on the seed
    assert not np.array_equal(a["torque_nm"], c["torque_nm"])  # the sensor noise does


def test_simulate_run_options_and_csv_roundtrip(tmp_path):
    track = random_track(np.random.default_rng(7), length_m=300.0, load_kg=5_000)
    tr = simulate_run(
        track, seed=1, load_kg=5_000, duration_s=15.0, speed_profile=SpeedProfile.constant(0.8),
        plant_config=PlantConfig(wheel_wear_m=0.004, adhesion=V.adhesion_wet),
        fault_config=FaultConfig(dropout_prob=0.01),
    )
    assert len(tr) == 15 * 200
    assert np.all(tr["drive_radius_m"] == pytest.approx(V.drive_wheel_radius_m - 0.004))
    assert np.isnan(tr["torque_nm"]).any()
    path = tmp_path / "run.csv"
    write_trace_csv(tr, path)
    back = read_trace_csv(path)
    assert set(back.columns) == set(tr.columns) - {"effective_slope_deg"}  # in-memory only column
    for k in back.columns:
        assert np.allclose(back[k], tr[k], equal_nan=True, rtol=0, atol=0), k

    # the slope gravity acts on (mass-weighted under the 18 m train) equals the rail slope at the reference point
    # once the whole train is on the constant 8 deg grade of section1, and trails it in the transition
    s1 = simulate_run("section1", seed=0)
    on_grade = s1["position_m"] > 65.0 + 13.0
    assert on_grade.sum() > 1000
    assert np.allclose(s1["effective_slope_deg"][on_grade], 8.0, atol=1e-9)
    in_curve = (s1["position_m"] > 50.0) & (s1["position_m"] < 65.0)
    assert np.all(s1["effective_slope_deg"][in_curve] < s1["slope_deg"][in_curve])


def test_scenario_load_survives_a_plant_config():
    tr = simulate_run("roadtest", seed=0, duration_s=1.0, plant_config=PlantConfig(wheel_wear_m=0.002))
    assert tr["mass_kg"][0] == V.empty_mass_kg + 10_000
    tr = simulate_run("roadtest", seed=0, duration_s=1.0, load_kg=0.0)
    assert tr["mass_kg"][0] == V.empty_mass_kg


def test_simulate_run_bad_input():
    with pytest.raises(ValueError, match="unknown scenario"):
        simulate_run("nowhere", seed=0)
    with pytest.raises(ValueError, match="seed"):
        simulate_run("section1", seed=1.5)
    with pytest.raises(ValueError, match="duration_s"):
        simulate_run("section1", seed=0, duration_s=-1.0)
    with pytest.raises(ValueError, match="control_hz"):
        simulate_run("section1", seed=0, duration_s=1.0, control_hz=7.0)
