"""The reward of ``UUOM-Track-v0``: progress, arrival, time, traction energy and safety penalties.

==============  =====================================================================  =======================
term (key)      per policy step                                                         default weight
==============  =====================================================================  =======================
``progress``    ``+w * (s_end - s_start) / track_length`` (sums to ``w`` over a run)    10
``arrival``     ``+w * (1 - 0.5 * |stop error| / stop_tolerance)`` on success           10
``time``        ``-w * step duration in s``                                              0.01 per s
``energy``      ``-w * traction energy in MJ`` (``sum(max(T * omega, 0) dt)``)           0.2 per MJ
``safety``      ``-w * info["cost"]`` (the weighted safety cost)                         1
``failure``     ``-w`` when the episode ends as a failure (overspeed trip, overrun,      10
                rolled back, stopped short, ran off the start)
``idle``        ``-w`` more when the failure is ``stopped_short`` (standing costs more    15
                than an overspeed trip's -10 failure -10 cost, see below)
``shaping``     ``gamma Phi(s') - Phi(s)``, potential-based (:mod:`.reward_shaping`)    20 per m/s in Phi
``caution``     ``-w * (v - cautious limit)+ * step duration``: speed above the limit    0 (off)
                at the estimate's pessimistic corner (observation 13), per m/s per s
==============  =====================================================================  =======================

The reward is the sum of the terms; ``info["rewards"]`` holds each one.

Why ``idle``: with failure = -10 for every ending, a policy that never moves (-10 after ``idle_limit_s``) beats
any attempt that trips before the station (-10 failure, -10 trip cost, +10 x the fraction covered). Measured:
plain PPO on rev. 2 without this term had learnt by 100 000 steps to hold the brake at the start (deterministic
policy: 0.0 m covered on held-out seeds 100000-100002, ``stopped_short`` after 60 s); docs/rl.md.

Why ``caution`` (off by default): it is not potential-based, so it changes the optimal policy — towards the
rule-based controller's, which keeps under the cautious limit and never trips. It is the dense form of what the
trips teach sparsely: a policy that cannot yet tell a heavy train from the prior (the first second or two) or is
told a mass that reads light is charged at once, on every episode, instead of on the few that trip (docs/rl.md §29).
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from uuom_gym.envs.config import REWARD_TERMS


def traction_energy_j(drive_torque_nm: np.ndarray, wheel_speed_radps: np.ndarray, dt_s: float) -> float:
    """Energy delivered by the drive motors over a step: ``sum(max(T * omega, 0)) * dt`` (no regeneration)."""
    power = np.asarray(drive_torque_nm, dtype=float) * np.asarray(wheel_speed_radps, dtype=float)
    return float(np.maximum(power, 0.0).sum()) * dt_s


def reward_terms(
    weights: Mapping[str, float],
    *,
    progress_m: float,
    track_length_m: float,
    step_s: float,
    energy_j: float,
    cost: float,
    arrived: bool,
    stop_error_m: float,
    stop_tolerance_m: float,
    failed: bool,
    idle: bool = False,
    shaping: float = 0.0,
    over_cautious_mps: float = 0.0,
) -> dict[str, float]:
    """The reward terms of one policy step (already weighted and signed; the reward is their sum).

    ``idle`` marks a ``stopped_short`` ending (``failed`` must be set too). ``shaping`` is the step's potential difference from :func:`uuom_gym.envs.reward_shaping.shaping_reward`
    (already weighted: the weight scales the potential).
    ``over_cautious_mps`` is how far the speed is above the cautious limit the policy was shown (0 when under it).
    """
    if track_length_m <= 0:
        raise ValueError(f"track_length_m must be > 0, got {track_length_m!r}")
    arrival = 0.0
    if arrived:
        arrival = weights["arrival"] * (1.0 - 0.5 * min(abs(stop_error_m) / stop_tolerance_m, 1.0))
    terms = {
        "progress": weights["progress"] * progress_m / track_length_m,
        "arrival": arrival,
        "time": -weights["time"] * step_s,
        "energy": -weights["energy"] * energy_j * 1e-6,
        "safety": -weights["safety"] * cost,
        "failure": -weights["failure"] if failed else 0.0,
        "idle": -weights["idle"] if idle else 0.0,
        "shaping": float(shaping),
        "caution": -weights["caution"] * max(over_cautious_mps, 0.0) * step_s,
    }
    assert tuple(terms) == REWARD_TERMS
    return terms


__all__ = ["reward_terms", "traction_energy_j"]
