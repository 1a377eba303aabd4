"""The learning algorithms ``scripts/train.py`` offers, by name."""

from __future__ import annotations

ALGOS: tuple[str, ...] = ("ppo", "sac", "td3", "ppo-lag")


def algo_class(name: str):
    """The stable-baselines3 class for ``ppo`` / ``sac`` / ``td3`` / ``ppo-lag``
    (:class:`agents.ppo_lagrangian.PPOLagrangian`)."""
    from stable_baselines3 import PPO, SAC, TD3

    from agents.ppo_lagrangian import PPOLagrangian

    table = {"ppo": PPO, "sac": SAC, "td3": TD3, "ppo-lag": PPOLagrangian}
    if name not in table:
        raise ValueError(f"unknown algo {name!r}; choose one of {', '.join(ALGOS)}")
    return table[name]


__all__ = ["ALGOS", "algo_class"]
