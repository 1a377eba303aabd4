"""Quaternion attitude UKF and the ``imu-ukf`` estimator (paper 001 §3.2) on the synthetic unit-test signal."""

import math

import numpy as np
import pytest

import estimators
from estimators.imu.attitude_ukf import PitchQuaternionUKF, UKFConfigError
from uuom_core.synthetic import synthetic_imu_run

G = 9.81


def _p_matrix(ukf):
    return np.array(ukf.P).reshape(3, 3)


def test_static_pitch_and_gyro_bias_converge():
    rng = np.random.default_rng(0)
    ukf = PitchQuaternionUKF(gyro_noise_radps=2e-3, gyro_bias_walk_radps=1e-4, accel_noise_mps2=0.05,
                             accel_normal_noise_mps2=0.05)
    pitch, bias = math.radians(5.0), 0.01
    ukf.initialize(0.0, math.radians(10.0))
    for _ in range(6000):  # 30 s at 200 Hz
        ukf.predict(bias + rng.normal(0, 2e-3), 0.005)
        ukf.update(G * math.sin(pitch) + rng.normal(0, 0.05), G * math.cos(pitch) + rng.normal(0, 0.05))
        P = _p_matrix(ukf)
        assert np.allclose(P, P.T)
    assert math.degrees(ukf.pitch_rad) == pytest.approx(5.0, abs=0.1)
    assert ukf.bias_radps == pytest.approx(bias, abs=1e-3)
    assert np.all(np.linalg.eigvalsh(_p_matrix(ukf)) > 0)
    assert 0 < ukf.pitch_std_rad < math.radians(0.5)
    assert math.hypot(ukf.x[0], ukf.x[1]) == pytest.approx(1.0)


def test_gyro_alone_tracks_a_rotation():
    ukf = PitchQuaternionUKF()
    ukf.initialize(0.0, 1e-3, 0.0)
    for _ in range(200):  # 1 s at 0.1 rad/s, no accelerometer
        ukf.predict(0.1, 0.005)
        ukf.update(math.nan, math.nan)
    assert ukf.pitch_rad == pytest.approx(0.1, abs=1e-6)


@pytest.mark.parametrize("name", ["gyro_noise_radps", "accel_noise_mps2", "alpha"])
def test_bad_ukf_settings_are_named(name):
    with pytest.raises(UKFConfigError, match=name):
        PitchQuaternionUKF(**{name: -1.0})


@pytest.fixture(scope="module")
def run():
    return synthetic_imu_run(7, duration_s=60.0)


def test_estimator_tracks_slope(run):
    est = estimators.make("imu-ukf")
    s = est.run(run)
    keep = run["t_s"] > 5.0
    err = s.slope_deg[keep] - run["slope_deg"][keep]
    assert float(np.sqrt(np.mean(err ** 2))) < 0.3
    assert np.all(np.isfinite(s.slope_rad)) and np.all(s.slope_std_rad > 0)
    # mass is the documented wide prior
    v = est.vehicle
    assert np.all(s.mass_kg == v.empty_mass_kg + 0.5 * v.rated_load_kg)
    assert np.all(s.mass_std_kg == 0.5 * v.rated_load_kg)
    assert set(s.extras) == {"gyro_bias_radps", "lin_accel_mps2"}


def test_without_speed_compensation_the_error_is_larger(run):
    """The accelerometer sees dv/dt: the speed-derived a_lin must matter on a run with accelerations."""
    est = estimators.make("imu-ukf")
    est.run(run)
    cols = dict(run.columns)
    cols["speed_mps"] = np.zeros(len(run))  # a speed sensor that says 'standing still'
    from uuom_core.trace import Trace

    s_bad = est.run(Trace(cols))
    s_good = est.run(run)
    keep = run["t_s"] > 5.0
    e_bad = np.abs(s_bad.slope_deg - run["slope_deg"])[keep].max()
    e_good = np.abs(s_good.slope_deg - run["slope_deg"])[keep].max()
    assert e_bad > 2 * e_good


def test_nan_inputs_predict_only_and_never_nan(run):
    est = estimators.make("imu-ukf")
    cols = {k: v.copy() for k, v in run.columns.items()}
    cols["accel_mps2"][4000:4400] = np.nan
    cols["accel_normal_mps2"][4000:4400] = np.nan
    cols["gyro_radps"][6000:6100] = np.nan
    cols["speed_mps"][7000:7200] = np.nan
    from uuom_core.trace import Trace

    s = est.run(Trace(cols))
    assert np.all(np.isfinite(s.slope_rad)) and np.all(np.isfinite(s.slope_std_rad))
    assert s.slope_std_rad[4399] > 1.2 * s.slope_std_rad[3999]  # uncertainty grows without the accelerometer
    keep = run["t_s"] > 5.0
    assert np.abs(s.slope_deg - run["slope_deg"])[keep].max() < 1.5


def test_covariance_stays_symmetric_positive_definite(run):
    est = estimators.make("imu-ukf")
    for i in range(0, 3000):
        est.update(run["torque_nm"][i], run["speed_mps"][i], run["accel_mps2"][i], 0.005, math.nan,
                   run["gyro_radps"][i], run["accel_normal_mps2"][i])
        if i % 500 == 499:
            P = _p_matrix(est.ukf)
            assert np.allclose(P, P.T)
            assert np.all(np.linalg.eigvalsh(P) > 0)


def test_all_missing_gives_the_prior():
    est = estimators.make("imu-ukf")
    e = est.update(0.0, math.nan, math.nan, 0.005)
    assert e.slope_rad == 0.0 and e.slope_std_rad > math.radians(10)
    assert est.estimate is e


def test_estimator_bad_input():
    with pytest.raises(TypeError, match="bogus"):
        estimators.make("imu-ukf", bogus=1.0)
    with pytest.raises(UKFConfigError, match="jerk_std_mps3"):
        estimators.make("imu-ukf", jerk_std_mps3=0.0)
    est = estimators.make("imu-ukf")
    with pytest.raises(ValueError, match="dt_s"):
        est.update(0.0, 0.0, 0.0, 0.0)


def test_options_reach_the_filter():
    est = estimators.make("imu-ukf", accel_noise_mps2=0.5, gyro_noise_radps=1e-3)
    assert est.ukf.accel_noise_mps2 == 0.5 and est.ukf.gyro_noise_radps == 1e-3
    assert "slope" in est.provides


# ----------------------------------------------------------------- on the project's plant
def test_imu_ukf_on_the_plant_follows_the_drive_unit_pitch():
    from uuom_gym.sim import recording
    tr, log = recording.simulate_run("section1", seed=3, return_log=True, duration_s=60.0)
    s = estimators.make("imu-ukf").run(tr)
    keep = tr["t_s"] >= 10.0
    e_pitch = s.slope_deg[keep] - np.degrees(log.pitch_rad[keep])
    e_slope = s.slope_deg[keep] - tr["slope_deg"][keep]
    # an accelerometer bias b gives a constant pitch error b/g (unobservable from these sensors); the rest of the
    # error is the filter's
    assert abs(float(np.mean(e_pitch))) < 0.3
    assert float(np.std(e_pitch)) < 0.05
    assert float(np.sqrt(np.mean(e_slope ** 2))) < 0.5
    assert "imu-ukf" in estimators.available()
