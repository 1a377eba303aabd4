"""UNIT-TEST SIGNALS, NOT THE PLANT: small generators for the estimators' and the IMU pipeline's own tests.

Two drive cycles over one longitudinal model (spec §2: one rigid body, ``(M + m_rot) dv/dt = F - M g (sin theta +
mu cos theta)``, no swinging load, no couplers, no slip) and one sensor model (noisy, quantised speed; noisy torque
and specific force), so unit tests can check convergence against a known truth without the pymunk plant:

* :func:`synthetic_trace` - a PI speed-tracking driver on a fixed slope profile (the estimators' tests);
* :func:`synthetic_imu_run` - a kinematic stop-and-go drive cycle over a random grade profile, with an IMU on the
  drive unit (gyro, along-track and normal accelerometer) whose pitch follows the track plus a swaying-load
  oscillation (the IMU pipeline's tests). Sensor columns and conventions are those of the plant's ``SensorSuite``:

  * ``gyro_radps`` = d(pitch)/dt + bias + white noise
  * ``accel_mps2`` = dv/dt + g sin(pitch) + sway vibration + bias + white noise (specific force along track)
  * ``accel_normal_mps2`` = g cos(pitch) + noise (normal axis, +g when level)

Accuracy figures of the project are measured on the plant (:func:`uuom_gym.sim.recording.simulate_run`), never on
these signals. Their outputs are pinned by tests: a change of the arithmetic or of the order of random draws is a
change of every test that uses them.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from uuom_core.trace import Trace
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2, VehicleParams

__all__ = ["SLOPE_PROFILES", "synthetic_imu_run", "synthetic_trace"]


def _speed_sensor(true_speed_mps: np.ndarray, noise_mps: np.ndarray, resolution_mps: float) -> np.ndarray:
    """Ground-speed sensor: true speed plus noise, quantised to the resolution."""
    return np.round((true_speed_mps + noise_mps) / resolution_mps) * resolution_mps


def _section1(s: np.ndarray | float) -> np.ndarray | float:
    # level 30 m, 20 m transition, then 8 deg up
    x = np.clip((np.asarray(s) - 30.0) / 20.0, 0.0, 1.0)
    return np.radians(8.0) * (3 * x**2 - 2 * x**3)


def _varying(s: np.ndarray | float) -> np.ndarray | float:
    s = np.asarray(s)
    return np.radians(5.0 + 4.0 * np.sin(2 * np.pi * s / 60.0))


def _level(s: np.ndarray | float) -> np.ndarray | float:
    return np.zeros_like(np.asarray(s, dtype=float))


SLOPE_PROFILES: dict[str, Callable] = {"section1": _section1, "varying": _varying, "level": _level}


def synthetic_trace(
    profile: str = "section1",
    *,
    seed: int = 0,
    mass_kg: float = 26_000.0,
    running_resistance: float = 0.02,
    duration_s: float = 60.0,
    dt_s: float = 0.005,
    cruise_speed_mps: float = 1.0,
    vehicle: VehicleParams = DEFAULT_VEHICLE,
    torque_noise_nm: float = 60.0,
    speed_noise_mps: float = 0.005,
    speed_resolution_mps: float = 0.002,
    accel_noise_mps2: float = 0.05,
) -> Trace:
    """Simulate the point-mass model on a slope profile and return a trace with truth columns.

    Parameters
    ----------
    profile : {"section1", "varying", "level"}
        Slope as a function of position.
    seed : int
        Seed of the noise generator (the only randomness).
    mass_kg, running_resistance : float
        True total mass and running-resistance coefficient.
    duration_s, dt_s : float
        Length and sample interval.
    cruise_speed_mps : float
        Target speed; the driver speeds up to it, slows to 60 % of it at mid-run and back (excitation).
    """
    if profile not in SLOPE_PROFILES:
        raise ValueError(f"unknown synthetic profile {profile!r}; choose from {sorted(SLOPE_PROFILES)}")
    slope_fn = SLOPE_PROFILES[profile]
    rng = np.random.default_rng(seed)
    n = int(round(duration_s / dt_s))
    r = vehicle.drive_wheel_radius_m
    m_rot = vehicle.rotating_mass_kg
    mu = running_resistance
    t = np.arange(n) * dt_s
    v_ref = np.minimum(t / 4.0, 1.0) * cruise_speed_mps
    mid = (t > 0.45 * duration_s) & (t < 0.6 * duration_s)
    v_ref[mid] *= 0.6
    v = 0.0
    s = 0.0
    integ = 0.0
    out_T = np.empty(n)
    out_v = np.empty(n)
    out_a = np.empty(n)
    out_f = np.empty(n)
    out_th = np.empty(n)
    f_max = vehicle.max_traction_n
    for i in range(n):
        th = float(slope_fn(s))
        err = v_ref[i] - v
        integ += err * dt_s
        force = mass_kg * (1.5 * err + 0.6 * integ) + mass_kg * G_MPS2 * (math.sin(th) + mu * math.cos(th))
        force = min(max(force, 0.0), f_max)
        a = (force - mass_kg * G_MPS2 * (math.sin(th) + mu * math.cos(th))) / (mass_kg + m_rot)
        if v <= 0.0 and a < 0.0:
            a = 0.0  # static friction holds the train
        out_T[i] = force * r
        out_v[i] = v
        out_a[i] = a
        out_f[i] = a + G_MPS2 * math.sin(th)
        out_th[i] = th
        v = max(v + a * dt_s, 0.0)
        s += v * dt_s
    speed = _speed_sensor(out_v, rng.normal(0.0, speed_noise_mps, n), speed_resolution_mps)
    cols = {
        "t_s": t,
        "torque_nm": out_T + rng.normal(0.0, torque_noise_nm, n),
        "speed_mps": speed,
        "accel_mps2": out_f + rng.normal(0.0, accel_noise_mps2, n),
        "mass_kg": np.full(n, float(mass_kg)),
        "slope_deg": np.degrees(out_th),
        "true_speed_mps": out_v,
    }
    return Trace(cols, source=f"synthetic:{profile}:seed{seed} (unit-test signal, not the plant)")


# --- stop-and-go IMU run ------------------------------------------------------------------------------------

def _grade_profile(rng: np.random.Generator, length_m: float, max_grade_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """Slope (rad) on a 0.5 m grid: constant grades joined by raised-cosine transitions."""
    s = np.arange(0.0, length_m + 0.5, 0.5)
    slope = np.empty_like(s)
    pos, grade = 0.0, math.radians(rng.uniform(-max_grade_deg, max_grade_deg) * rng.choice([0.0, 1.0]))
    knots = [(0.0, grade)]
    while pos < length_m:
        pos += rng.uniform(20.0, 80.0)
        grade = math.radians(rng.uniform(-max_grade_deg, max_grade_deg))
        knots.append((pos, grade))
    slope[:] = knots[0][1]
    for (p0, g0), (p1, g1) in zip(knots[:-1], knots[1:]):
        width = rng.uniform(8.0, 25.0)
        start = p1 - width
        w = np.clip((s - start) / width, 0.0, 1.0)
        blend = 0.5 - 0.5 * np.cos(math.pi * w)
        mask = s >= start
        slope[mask] = g0 + (g1 - g0) * blend[mask]
    return s, slope


def _speed_profile(rng: np.random.Generator, n: int, dt: float, max_speed_mps: float) -> np.ndarray:
    """Drive cycle as an acceleration command with jerk-limited ramps; returns true speed (m/s)."""
    acc = np.zeros(n)
    i = int(rng.uniform(2.0, 6.0) / dt)  # initial standstill
    v = 0.0
    while i < n:
        # one or two cruise levels, then stop
        for _ in range(int(rng.integers(1, 3))):
            target = rng.uniform(0.3, max_speed_mps)
            a_mag = rng.uniform(0.08, 0.35)
            dur = abs(target - v) / a_mag
            k = max(int(dur / dt), 1)
            acc[i:i + k] = math.copysign(a_mag, target - v)
            i += k
            v = target
            i += int(rng.uniform(4.0, 14.0) / dt)
            if i >= n:
                break
        if i >= n:
            break
        a_mag = rng.uniform(0.1, 0.4)
        k = max(int(v / a_mag / dt), 1)
        acc[i:i + k] = -a_mag
        i += k
        v = 0.0
        i += int(rng.uniform(3.0, 10.0) / dt)
    # jerk limit: smooth the acceleration command over 0.4 s, then integrate
    w = max(int(0.4 / dt), 1)
    kernel = np.ones(w) / w
    acc = np.convolve(acc, kernel, mode="full")[:n]
    speed = np.cumsum(acc) * dt
    return np.maximum(speed, 0.0)


def synthetic_imu_run(seed: int, duration_s: float = 60.0, sample_hz: float = 200.0, *,
                      max_grade_deg: float = 12.0, max_speed_mps: float = 1.5, load_kg: float | None = None,
                      gyro_noise_radps: float = 0.002, gyro_bias_radps: float | None = None,
                      accel_noise_mps2: float = 0.03, sway_amplitude_rad: float = 0.004,
                      vehicle: VehicleParams | None = None) -> Trace:
    """Generate one synthetic IMU run (unit-test signal).

    Parameters
    ----------
    seed : int
        Seed of the ``np.random.Generator`` all randomness comes from.
    duration_s, sample_hz : float
        Length and sample rate.
    max_grade_deg, max_speed_mps : float
        Ranges of the random grade profile and cruise speeds.
    load_kg : float, optional
        Payload; random in [0, rated] by default.
    gyro_noise_radps, accel_noise_mps2 : float
        White-noise standard deviations per sample.
    gyro_bias_radps : float, optional
        Constant gyro bias; random N(0, 0.002) by default.
    sway_amplitude_rad : float
        Amplitude of the pitch oscillation of the drive unit caused by the swaying load.
    vehicle : VehicleParams, optional

    Returns
    -------
    Trace
        Sensor and truth columns; ``source`` says it is a synthetic unit-test signal.
    """
    if not (duration_s > 0 and sample_hz > 0):
        raise ValueError(f"duration_s and sample_hz must be > 0, got {duration_s}, {sample_hz}")
    veh = vehicle or DEFAULT_VEHICLE
    rng = np.random.default_rng(seed)
    dt = 1.0 / sample_hz
    n = int(round(duration_s * sample_hz))
    t = np.arange(n) * dt
    speed = _speed_profile(rng, n, dt, max_speed_mps)
    accel = np.gradient(speed, dt)
    pos = np.concatenate(([0.0], np.cumsum(0.5 * (speed[1:] + speed[:-1]) * dt)))
    s_grid, slope_grid = _grade_profile(rng, float(pos[-1]) + 10.0, max_grade_deg)
    slope = np.interp(pos, s_grid, slope_grid)
    # swaying load: lightly damped pendulum excited by the acceleration changes
    f_sway = rng.uniform(0.3, 0.6)
    phase = rng.uniform(0, 2 * math.pi)
    sway = sway_amplitude_rad * np.sin(2 * math.pi * f_sway * t + phase) * (0.3 + 0.7 * np.tanh(speed / 0.3))
    pitch = slope + sway
    pitch_rate = np.gradient(pitch, dt)
    bias_g = rng.normal(0.0, 0.002) if gyro_bias_radps is None else gyro_bias_radps
    bias_a = rng.normal(0.0, 0.02)
    vib = 0.05 * np.sin(2 * math.pi * 2.0 * f_sway * t) * np.tanh(speed / 0.2)
    gyro = pitch_rate + bias_g + rng.normal(0.0, gyro_noise_radps, n)
    acc_meas = accel + G_MPS2 * np.sin(pitch) + vib + bias_a + rng.normal(0.0, accel_noise_mps2, n)
    acc_norm = G_MPS2 * np.cos(pitch) + rng.normal(0.0, accel_noise_mps2, n)
    speed_meas = _speed_sensor(speed, rng.normal(0.0, 0.005, n), 0.001)
    load = rng.uniform(0.0, veh.rated_load_kg) if load_kg is None else float(load_kg)
    mass = veh.empty_mass_kg + load
    m_rot = veh.rotating_mass_kg
    force = mass * G_MPS2 * (np.sin(slope) + veh.running_resistance * np.cos(slope) * (speed > 1e-3)) \
        + (mass + m_rot) * accel
    torque = force * veh.drive_wheel_radius_m + rng.normal(0.0, 50.0, n)
    cols = {
        "t_s": t,
        "torque_nm": torque,
        "speed_mps": speed_meas,
        "accel_mps2": acc_meas,
        "motor_speed_radps": speed / veh.drive_wheel_radius_m,
        "gyro_radps": gyro,
        "accel_normal_mps2": acc_norm,
        "mass_kg": np.full(n, mass),
        "slope_deg": np.degrees(slope),
        "true_speed_mps": speed,
        "position_m": pos,
        "sway_rad": sway,
    }
    return Trace(cols, source=f"synthetic IMU unit-test signal (seed={seed})")
