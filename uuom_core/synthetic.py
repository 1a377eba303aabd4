"""UNIT-TEST SIGNAL, NOT THE PLANT: a small point-mass generator for the estimators' own tests.

It integrates exactly the estimators' model (spec §2, one rigid body, no swinging load, no couplers, no slip) with
a PI speed-tracking driver and adds simple sensor noise, so unit tests can check convergence against a known truth
without the pymunk plant. Accuracy figures of the project are measured on the plant
(:func:`uuom_gym.sim.recording.simulate_run`), never on this signal.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from uuom_core.trace import Trace
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2, VehicleParams

__all__ = ["synthetic_trace", "SLOPE_PROFILES"]


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
    speed = out_v + rng.normal(0.0, speed_noise_mps, n)
    speed = np.round(speed / speed_resolution_mps) * speed_resolution_mps
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
