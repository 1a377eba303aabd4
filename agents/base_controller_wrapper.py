"""Shared part of the wrappers whose command comes from a reference controller driven by the agent's action.

:class:`agents.residual.ResidualWrapper` adds the action to the rule-based controller's command;
:class:`agents.margin_schedule.MarginScheduleWrapper` lets the action set the controller's margin. Both keep the last
observation and ``info`` for the controller (it sees exactly what the agent sees), reset it with the env, and refuse
a step before ``reset``; :class:`OnBaseController` holds that, the subclasses only :meth:`~OnBaseController.command`.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from agents.controllers import RuleBasedController, SpeedController


class OnBaseController(gym.Wrapper):
    """A wrapper whose plant command is computed from the agent's action and a reference controller ``base``."""

    def __init__(self, env: gym.Env, base: SpeedController | None = None) -> None:
        super().__init__(env)
        self.base = base or RuleBasedController(env.unwrapped.vehicle)
        self._obs: Any = None
        self._info: dict[str, Any] = {}

    def command(self, action: Any) -> tuple[np.ndarray, dict[str, Any]]:
        """The plant command for ``action`` (base already has the last observation) and the ``info`` entries to add."""
        raise NotImplementedError

    def reset(self, **kwargs: Any):
        obs, info = self.env.reset(**kwargs)
        self.base.reset(self.env, info)
        self._obs, self._info = obs, info
        return obs, info

    def step(self, action: Any):
        if self._obs is None:
            raise gym.error.ResetNeeded(f"{type(self).__name__}: call reset() before step()")
        cmd, extra = self.command(action)
        obs, reward, term, trunc, info = self.env.step(cmd)
        info = {**info, **extra}
        self._obs, self._info = obs, info
        return obs, reward, term, trunc, info


__all__ = ["OnBaseController"]
