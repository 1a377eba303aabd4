"""Gymnasium registration of the environments (idempotent)."""

from __future__ import annotations

import gymnasium as gym

ENV_IDS: tuple[str, ...] = ("UUOM-Track-v0",)


def register_envs() -> None:
    """Register every UUOM-Gym environment id; calling it twice is harmless."""
    if "UUOM-Track-v0" not in gym.registry:
        gym.register(
            id="UUOM-Track-v0",
            entry_point="uuom_gym.envs.track_env:UUOMTrackEnv",
            max_episode_steps=30_000,
        )
