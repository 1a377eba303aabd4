"""Potential-based reward shaping of ``UUOM-Track-v0`` (Ng, Harada & Russell 1999).

The shaping term of a step is ``F = gamma * Phi(s') - Phi(s)`` with ``Phi(terminal) = 0``, so it changes *when*
the agent is told about a coming failure, not which policy is optimal. With the default ``shaping_gamma = 1``
the shaping sums to exactly 0 over every episode (``Phi`` is 0 at rest at the start and at every terminal
state); an agent discounting with ``gamma < 1`` then also sees ``(1 - gamma) Phi(s') <= 0`` per step, a small
extra push away from the limit (``shaping_gamma = gamma`` removes it; with ``gamma < 1`` a state of negative
``Phi`` would otherwise *pay* ``-(1 - gamma) Phi`` for every step spent in it, which the first measurement showed:
+3 to +10 per episode for the oracle controller). ``Phi`` is a function of the true state:

``Phi(s) = -w * [ (v - v_stop(d))+ + (v - (v_lim - LIMIT_MARGIN_MPS))+ ]``  (``w`` = ``reward_weights["shaping"]``,
per m/s)

- ``v_stop(d) = sqrt(2 a d') + STOP_CREEP_MPS`` with ``d' = max(d - 0.5 m, 0)`` and ``a = STOP_DECEL_MPS2``: the
  speed from which a gentle brake still stops at the station. Without it the only news about arriving too fast
  is the overrun 10-30 s later (100-300 policy steps), beyond what ``gamma = 0.995`` credits.
- ``v_lim`` is the true speed limit at the train (spec §6 rule 1); the potential falls from ``LIMIT_MARGIN_MPS``
  below it, before the per-step cost starts and 0.25 m/s before the overspeed trip.

Measured reason (docs/rl.md): plain PPO on the unshaped reward tripped in 40-100 % of its training episodes and
the trip (``-20`` in one step) was the only sharp signal about the limit.
"""

from __future__ import annotations

import math

STOP_DECEL_MPS2 = 0.3
"""Deceleration of the stopping curve in the potential (gentle: a hard stop rebounds the cars)."""

STOP_CREEP_MPS = 0.05
"""Speed allowed on top of the stopping curve (the last metres are crept)."""

LIMIT_MARGIN_MPS = 0.05
"""The limit part of the potential starts this far below the true speed limit."""


def stop_speed_cap_mps(distance_to_go_m: float) -> float:
    """Highest speed the stop part of the potential does not penalise, ``distance_to_go_m`` before the station."""
    d = max(distance_to_go_m - 0.5, 0.0)
    return math.sqrt(2.0 * STOP_DECEL_MPS2 * d) + STOP_CREEP_MPS


def potential(weight: float, speed_mps: float, distance_to_go_m: float, true_limit_mps: float) -> float:
    """``Phi(s)`` (``<= 0``) of the module formula."""
    if weight == 0.0:
        return 0.0
    over_stop = max(speed_mps - stop_speed_cap_mps(distance_to_go_m), 0.0)
    over_limit = max(speed_mps - (true_limit_mps - LIMIT_MARGIN_MPS), 0.0)
    return -weight * (over_stop + over_limit)


def shaping_reward(phi_before: float, phi_after: float, gamma: float, terminated: bool) -> float:
    """``gamma * Phi(s') - Phi(s)``, with ``Phi(s') = 0`` on a terminal step (truncation keeps it)."""
    return (0.0 if terminated else gamma * phi_after) - phi_before


__all__ = [
    "LIMIT_MARGIN_MPS",
    "STOP_CREEP_MPS",
    "STOP_DECEL_MPS2",
    "potential",
    "shaping_reward",
    "stop_speed_cap_mps",
]
