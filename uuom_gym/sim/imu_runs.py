"""Simulated runs for training and tuning the IMU pipeline.

``source="sim"`` (the default) drives the project's pymunk plant (``uuom_gym.sim.recording.simulate_run``) over
random tracks; ``source="synthetic"`` uses the kinematic unit-test signal of :mod:`uuom_core.synthetic`.
"""

from __future__ import annotations

import numpy as np

from uuom_core.synthetic import synthetic_imu_run
from uuom_core.limits import load_speed_limit_mps
from uuom_core.trace import Trace
from uuom_core.vehicle import DEFAULT_VEHICLE
from uuom_gym.sim.recording import simulate_run
from uuom_gym.sim.scenarios import SpeedProfile
from uuom_gym.sim.track import random_track

__all__ = ["make_runs", "plant_run_with_pitch"]


def plant_run_with_pitch(*args, **kwargs) -> Trace:
    """``simulate_run(*args, **kwargs)`` plus the column ``imu_pitch_deg``: the drive unit's true pitch.

    The IMU sits on a drive unit; its pitch is the rail chord there, which differs from ``slope_deg`` (the
    slope at the train's reference point) on grade transitions. It is the truth of what the attitude filter
    estimates.
    """
    trace, log = simulate_run(*args, return_log=True, **kwargs)
    cols = dict(trace.columns)
    cols["imu_pitch_deg"] = np.degrees(np.asarray(log.pitch_rad, dtype=np.float64))
    return Trace(cols, source=trace.source, meta=dict(trace.meta))


def _plant_run(seed: int) -> Trace:
    """One stop-and-go run of the plant: start from rest, cruise, change speed, brake to a stop, stand.

    The driver's reference speed is a function of position, so a run holds one such cycle; the standstill comes
    at its end (10-25 s of it).
    """
    rng = np.random.default_rng(seed)
    veh = DEFAULT_VEHICLE
    load = float(rng.uniform(0.0, veh.rated_load_kg))
    track = random_track(rng, length_m=(250.0, 400.0), load_kg=load)
    v_max = 0.9 * load_speed_limit_mps(veh, veh.empty_mass_kg + load)
    v1, v2 = (float(rng.uniform(0.3, max(v_max, 0.35))) for _ in range(2))
    d1, d2 = float(rng.uniform(10.0, 35.0)), float(rng.uniform(8.0, 25.0))
    a_lim = float(rng.uniform(0.08, 0.3))
    s1, s2 = 2.0 + d1, 2.0 + d1 + d2
    profile = SpeedProfile(((0.0, v1), (s1, v1), (s1 + 0.5, v2), (s2, v2), (s2 + 0.5, 0.0)),
                           accel_limit_mps2=a_lim)
    moving_s = d1 / v1 + d2 / v2 + 2.0 * (v1 + abs(v2 - v1) + v2) / a_lim + 5.0
    duration = moving_s + float(rng.uniform(10.0, 25.0))
    return plant_run_with_pitch(track, seed=seed, load_kg=load, speed_profile=profile, duration_s=duration)


def make_runs(n: int, seed: int, duration_s: float = 120.0, source: str = "sim") -> tuple[list[Trace], str]:
    """``n`` runs with IMU columns and truth, seeds ``seed, seed+1, ...``; returns ``(traces, source_used)``.

    ``duration_s`` applies to synthetic runs; a plant run lasts its stop-and-go cycle plus 10-25 s at rest.
    Every run has the column ``imu_pitch_deg`` (true pitch of the IMU) besides the trace truth.
    """
    if source not in ("sim", "synthetic"):
        raise ValueError(f"source must be 'sim' or 'synthetic', got {source!r}")
    runs: list[Trace] = []
    if source == "synthetic":
        runs = []
        for k in range(n):
            tr = synthetic_imu_run(seed + k, duration_s)
            cols = dict(tr.columns)
            cols["imu_pitch_deg"] = tr["slope_deg"] + np.degrees(tr["sway_rad"])
            runs.append(Trace(cols, source=tr.source))
    else:
        for k in range(n):
            runs.append(_plant_run(seed + k))
        for tr in runs:
            missing = [c for c in ("gyro_radps", "accel_normal_mps2", "slope_deg", "true_speed_mps") if c not in tr]
            if missing:
                raise ValueError(f"{tr.source}: the plant's trace lacks {', '.join(missing)}")
    return runs, source
