"""Residual policy learning: the agent's action corrects a reference controller's command.

``command = clip(base(obs) + scale * action, -1, 1)``, with the rule-based controller as the base
(Johannink et al. 2019, "Residual Reinforcement Learning for Robot Control"; Silver et al. 2018). A fresh
policy (action ~ 0) therefore already drives like the rule-based controller and the few hundred episodes a
30-minute budget allows are spent on improving it (driving closer to the limit where the estimate is good,
smoother stops) instead of rediscovering how to start and stop a train. The base sees exactly the agent's
observation (:func:`agents.controllers.control_input_from_obs`), never the truth.

Put it *outside* :class:`agents.shield.ShieldWrapper` (the shield filters the combined command) and inside
any normalisation.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from agents.base_controller_wrapper import OnBaseController
from agents.controllers import SpeedController
from uuom_core.units import clamp


class ResidualWrapper(OnBaseController):
    """Adds a reference controller's command to the (scaled) agent action.

    Parameters
    ----------
    env : gymnasium.Env
        A ``UUOM-Track-v0`` env (possibly shielded).
    base : SpeedController, optional
        Reference controller (default: :class:`RuleBasedController` for the env's vehicle).
    scale : float
        Authority of the agent: the action in [-1, 1] moves the command by at most ``scale``.

    Notes
    -----
    ``info["base_command"]`` and ``info["residual_command"]`` report both parts of each step's command.
    """

    def __init__(self, env: gym.Env, base: SpeedController | None = None, scale: float = 0.5) -> None:
        if not (0.0 < scale <= 2.0):
            raise ValueError(f"ResidualWrapper scale must lie in (0, 2], got {scale!r}")
        super().__init__(env, base)
        self.scale = float(scale)

    def command(self, action: Any) -> tuple[np.ndarray, dict[str, Any]]:
        a = clamp(float(np.asarray(action, dtype=np.float64).reshape(-1)[0]), -1.0, 1.0)
        base = float(self.base.act(self._obs, self._info)[0])
        cmd = float(clamp(base + self.scale * a, -1.0, 1.0))
        return np.array([cmd], dtype=np.float32), {"base_command": base, "residual_command": self.scale * a}


__all__ = ["ResidualWrapper"]
