"""Session 26's kernel options: the fixed-lag smoother of the slope layer (``smoothing_lag_s``;
``estimators.fixed_lag_kernel``) and the accelerometer noise read online (``accel_std_per_noise``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import estimators
from estimators import dffrls_aekf_kernel as kern
from estimators.dffrls_aekf import DFFRLSAEKF
from estimators.fixed_lag_kernel import ldl_solve3
from uuom_gym.sim.point_mass import point_mass_scenario, simulate_point_mass


def test_ldl_solve3_matches_numpy_and_refuses_indefinite() -> None:
    rng = np.random.default_rng(0)
    for _ in range(200):
        # SPD with the slope layer's spread of scales (speed ~1e-4, grade ~1e-7, curvature ~1e-9)
        a = rng.normal(size=(3, 3))
        scale = np.diag([1e-2, 3e-4, 3e-5])
        A = scale @ (a @ a.T + 0.1 * np.eye(3)) @ scale
        b = rng.normal(size=3) * np.array([1e-2, 1e-3, 1e-4])
        y1, y2, y3, ok = ldl_solve3(A[0, 0], A[0, 1], A[0, 2], A[1, 1], A[1, 2], A[2, 2], *b)
        assert ok
        np.testing.assert_allclose([y1, y2, y3], np.linalg.solve(A, b), rtol=1e-8)
    for bad in ([1.0, 2.0, 0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 0.0, 1.0, 0.0, 1.0], [math.nan, 0, 0, 1, 0, 1]):
        assert ldl_solve3(*bad, 1.0, 1.0, 1.0)[3] is False


@pytest.fixture(scope="module")
def section1():
    return simulate_point_mass(point_mass_scenario("pm-section1"), seed=0)


def _regression_grades(tr, lag_s: float) -> tuple[np.ndarray, np.ndarray, int]:
    """A point filter stepped online: the slope layer's filtered grade per sample, and the grade the regression used
    for each sample (read right after each backward pass, which ends on the sample ``lag`` behind the newest)."""
    est = DFFRLSAEKF(train_length_m=0.0, spread_length_m=12.0, smoothing_lag_s=lag_s)
    lag = int(est.C[kern.SMOOTH_L])
    n = len(tr["t_s"])
    filt = np.full(n, np.nan)
    used = np.full(n, np.nan)
    dts = np.diff(tr["t_s"], prepend=tr["t_s"][0] - 0.005)
    for k in range(n):
        est.update(tr["torque_nm"][k], tr["speed_mps"][k], tr["accel_mps2"][k], dts[k])
        filt[k] = est.S[kern.TH]
        if lag == 0 or (est.S[kern.RING_N] == lag and k > 2 * lag):
            used[k - lag] = est.S[kern.TH_TRAIN]
    return filt, used, lag


def test_regression_reads_the_smoothed_grade(section1) -> None:
    """Section 1 of the point-mass world (grade changes at speed): the grade the regression reads is the slope
    layer's own with the lag off, and with a 0.5 s lag it is the smoothed one, well closer to the truth (measured
    0.082 -> 0.035 deg RMSE after 10 s)."""
    true = np.radians(section1["effective_slope_deg"])
    filt0, used0, lag0 = _regression_grades(section1, 0.0)
    assert lag0 == 0
    np.testing.assert_array_equal(used0, filt0)
    filt, used, lag = _regression_grades(section1, 0.5)
    assert lag == 100
    keep = ~np.isnan(used) & (np.arange(len(used)) > 2000)
    assert keep.sum() > 300
    rmse_f = math.sqrt(np.mean((filt[keep] - true[keep]) ** 2))
    rmse_s = math.sqrt(np.mean((used[keep] - true[keep]) ** 2))
    assert rmse_s < 0.6 * rmse_f, (math.degrees(rmse_s), math.degrees(rmse_f))
    # the slope layer itself is the same filter either way (the smoother only reads it)
    np.testing.assert_array_equal(filt, filt0)


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_smoothed_estimator_learns_the_mass(section1, name: str) -> None:
    """With the regression 0.5 s behind the slope layer the mass is still learnt (within 5 % after 30 s) and the
    reported slope is the slope layer's of now, not the regression's of 0.5 s ago (RMSE within 0.15 deg)."""
    s = estimators.make(name, smoothing_lag_s=0.5).run(section1)
    t = section1["t_s"]
    late = t > 30.0
    rel = np.abs(s.mass_kg[late] / section1["mass_kg"][late] - 1.0)
    assert rel.max() < 0.05, rel.max()
    after = t > 10.0
    rmse = math.sqrt(np.mean((s.slope_deg[after] - section1["effective_slope_deg"][after]) ** 2))
    assert rmse < 0.15, rmse


def test_faults_and_gaps_with_smoothing() -> None:
    """NaN / inf / huge inputs and data gaps with the lag on: every output finite, the covariances positive, and a gap
    sends the samples before it through the regression at once (the ring starts again after it)."""
    tr = simulate_point_mass(point_mass_scenario("pm-stop-and-go"), seed=1)
    est = estimators.make("dffrls-aekf", smoothing_lag_s=0.5)
    rows = np.column_stack([tr["torque_nm"], tr["speed_mps"], tr["accel_mps2"]])[:6000].copy()
    rng = np.random.default_rng(3)
    hit = rng.random(rows.shape) < 0.02
    rows[hit] = rng.choice([math.nan, math.inf, -math.inf, 1e300], hit.sum())
    dts = np.full(len(rows), 0.005)
    dts[[1500, 4000]] = [1e9, math.inf]
    dts[[2500, 2501]] = [0.0, -0.005]
    for k, (row, dt) in enumerate(zip(rows, dts)):
        e = est.update(*row, dt) if dt > 0 else est.estimate
        assert all(math.isfinite(x) for x in (e.mass_kg, e.slope_rad, e.mass_std_kg, e.slope_std_rad)), k
        if k in (1500, 4000):
            assert all(m.S[kern.RING_N] <= 1.0 for m in est.members), k
    for m in est.members:
        S = m.S
        assert S[kern.P11] > 0 and S[kern.P22] > 0 and S[kern.P11] * S[kern.P22] > S[kern.P12] ** 2
        assert S[kern.PC] > 0 and S[kern.PD] > 0


@pytest.mark.parametrize("lag", [-0.1, math.nan, 10.0])
def test_bad_lag_is_refused(lag: float) -> None:
    with pytest.raises(ValueError, match="smoothing_lag_s"):
        estimators.make("dffrls-aekf", smoothing_lag_s=lag)


def test_reported_slope_before_the_first_backward_pass(section1) -> None:
    """A 12 m window filter with the lag on reports the slope it stands on from the first samples, not a window
    of an empty history (the regression, which fills it, has not run yet)."""
    est = DFFRLSAEKF(train_length_m=12.0, smoothing_lag_s=0.5)
    dts = np.diff(section1["t_s"], prepend=section1["t_s"][0] - 0.005)
    for k in range(120):  # 0.6 s: before the first pass (lag 100 + block 50 samples)
        e = est.update(section1["torque_nm"][k], section1["speed_mps"][k], section1["accel_mps2"][k], dts[k])
        assert e.slope_rad == est.S[kern.TH], k


def test_accelerometer_noise_is_read_online() -> None:
    """``accel_std_per_noise``: the noise the kernel reads from the accelerometer follows the sensor (twice the
    noise, about four times the variance), and the slope layer's accelerometer std starts at ``accel_std_mps2``."""
    from dataclasses import fields, replace

    from uuom_gym.sim.point_mass import with_options

    est0 = DFFRLSAEKF(accel_std_per_noise=7.0)
    assert est0.S[kern.NOISE_F] * 49.0 == pytest.approx(0.3**2)
    read = []
    for k in (1.0, 2.0):
        sc = point_mass_scenario("pm-section1")
        sen = replace(sc.sensors, **{f.name: k * getattr(sc.sensors, f.name) for f in fields(sc.sensors)
                                      if f.name != "vibration_hz"})
        tr = simulate_point_mass(with_options(sc, sensors=sen), seed=0)
        est = DFFRLSAEKF(accel_std_per_noise=7.0)
        est.run(tr)
        read.append(est.S[kern.NOISE_F])
    assert 0.03**2 < read[0] < 0.1**2, math.sqrt(read[0])
    assert 3.0 < read[1] / read[0] < 5.0, read
