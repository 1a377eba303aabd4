"""Gymnasium registration of the environments (idempotent).

``UUOM-Track-v0`` is the environment with its default configuration. ``UUOM-Track-SpeedTarget-v0`` is the same
class with the configuration of the README's learned-controller result (docs/rl.md §8): the action asks for a
speed of 0.8-1.3x the cautious limit, capped by the station braking envelope (env rev. 5). Keyword arguments given
to ``gym.make`` override the registered ones.
"""

from __future__ import annotations

import copy
from typing import Any

import gymnasium as gym

SPEED_TARGET_KWARGS: dict[str, Any] = {
    "action_mode": "speed_target",
    "speed_target_cap": "station",
    "speed_tracker": {"integral_clamp_m": 2.0},
    "speed_target_range": [0.8, 1.3],
}
"""The configuration ``UUOM-Track-SpeedTarget-v0`` registers."""

ENV_IDS: tuple[str, ...] = ("UUOM-Track-v0", "UUOM-Track-SpeedTarget-v0")

_KWARGS: dict[str, dict[str, Any]] = {"UUOM-Track-v0": {}, "UUOM-Track-SpeedTarget-v0": SPEED_TARGET_KWARGS}


def register_envs() -> None:
    """Register every UUOM-Gym environment id; calling it twice is harmless."""
    for env_id in ENV_IDS:
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point="uuom_gym.envs.track_env:UUOMTrackEnv", max_episode_steps=30_000,
                         kwargs=copy.deepcopy(_KWARGS[env_id]))


def env_kwargs_of(env_id: str) -> dict[str, Any]:
    """The configuration an id registers (a copy), so code that builds ``UUOM-Track-v0`` with it builds that id.

    Raises
    ------
    ValueError
        An id that is not one of :data:`ENV_IDS`.
    """
    if env_id not in _KWARGS:
        raise ValueError(f"unknown env id {env_id!r}; choose one of {', '.join(ENV_IDS)}")
    return copy.deepcopy(_KWARGS[env_id])
