"""A plain ramped proportional speed controller on the observation (for pictures and baselines, not a benchmark).

It aims at ``speed_frac`` of the *estimated* speed limit, capped by a 0.25 m/s^2 braking curve to the station, so
what it achieves shows what the estimate is worth (``scripts/render_frame.py``, ``scripts/bench_env.py
--baseline``).
"""

from __future__ import annotations

import math

import numpy as np

from uuom_gym.envs.observation import observation_by_name

STOP_DECEL_MPS2 = 0.25
"""Deceleration of the braking curve to the station."""


def proportional_command(obs: np.ndarray, distance_to_go_m: float, speed_frac: float = 0.7,
                         v_max_mps: float = 2.0) -> float:
    """Command for one step: ``3 (v_target - v)``, ramped (traction up 0.03, braking 0.1 per step).

    Parameters
    ----------
    obs : ndarray
        ``UUOM-Track-v0``'s un-normalised observation.
    distance_to_go_m : float
        ``info["distance_to_go_m"]``.
    speed_frac : float
        Fraction of the estimated limit aimed at.
    v_max_mps : float
        The observation's speed scale (the empty-train limit of the default vehicle).
    """
    o = observation_by_name(obs)
    target = min(speed_frac * o["est_speed_limit"] * v_max_mps,
                 math.sqrt(2 * STOP_DECEL_MPS2 * max(distance_to_go_m, 0.0)))
    a = 3.0 * (target - o["speed"] * v_max_mps)
    # ramp traction up slowly (a sudden pull swings the load), brake faster
    return float(np.clip(a, o["last_command"] - 0.1, o["last_command"] + 0.03))


__all__ = ["proportional_command"]
