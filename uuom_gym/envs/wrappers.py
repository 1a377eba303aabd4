"""Wrappers for ``UUOM-Track-v0``.

:class:`SafetyGymnasiumStep` gives the six-value ``step`` of safety-gymnasium
(``obs, reward, cost, terminated, truncated, info``) for constrained-RL libraries (OmniSafe, FSRL, ...), with the
cost taken from ``info["cost"]``.
"""

from __future__ import annotations

from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np


class SafetyGymnasiumStep(gym.Wrapper):
    """Return ``(obs, reward, cost, terminated, truncated, info)`` from ``step``, as safety-gymnasium does.

    Parameters
    ----------
    env : gymnasium.Env
        An environment that reports ``info["cost"]`` (any UUOM-Gym env, possibly wrapped).

    Notes
    -----
    ``reset`` is unchanged (``obs, info``). The cost is a ``float`` (safety-gymnasium's vector envs stack it).
    Because the six-value step breaks the Gymnasium API, this wrapper must be the outermost one.
    """

    def step(  # type: ignore[override]
        self, action: Any
    ) -> tuple[Any, SupportsFloat, float, bool, bool, dict[str, Any]]:
        obs, reward, terminated, truncated, info = self.env.step(action)
        if "cost" not in info:
            raise KeyError("SafetyGymnasiumStep: the wrapped environment does not report info['cost']")
        cost = float(info["cost"])
        if not np.isfinite(cost):
            raise ValueError(f"SafetyGymnasiumStep: info['cost'] is not finite: {cost!r}")
        return obs, reward, cost, terminated, truncated, info


__all__ = ["SafetyGymnasiumStep"]
