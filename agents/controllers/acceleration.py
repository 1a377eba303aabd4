"""The rule-based controller driven through the acceleration-demand action (``action_mode="acceleration"``).

Why it exists: the opt-in acceleration action (env rev. 16, docs/rl.md §32) asks the env's speed tracker for an
acceleration instead of sending a traction command, so :class:`RuleBasedController`'s command means nothing there.
This adapter keeps the rule-based controller's reference speed (the pessimistic limit, its ramp and the braking
curve to the station) and asks for the acceleration that moves the env's tracker target onto it. It is the
reference of that action, and the demonstrator whose episodes can seed an off-policy learner's replay buffer
(``uuom-train --demo-episodes``, :mod:`agents.demonstrations`). It sees what the learner sees: the observation, plus
the env's own tracker target reported in ``info`` (the target is the integral of the learner's past actions).
"""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from agents.control_input import ControlInput
from agents.controllers.rule_based import RuleBasedController
from uuom_core.vehicle import VehicleParams

STOP_ZONE_M = 0.3
"""Inside this distance short of the aimed stop the adapter asks for the full deceleration (target ramps to 0,
then the tracker holds with the brake): the rule-based controller's own station hold starts at the same point."""


def accel_action(demand_mps2: float, span: tuple[float, float]) -> float:
    """The action in ``[-1, 1]`` whose demand (``uuom_gym.envs.actions.accel_demand_mps2``) is ``demand_mps2``,
    clipped to the span ``(lo, hi)``: ``demand / hi`` above zero, ``-demand / lo`` below."""
    lo, hi = float(span[0]), float(span[1])
    if demand_mps2 >= 0.0:
        a = demand_mps2 / hi if hi > 0.0 else 0.0
    else:
        a = -demand_mps2 / lo if lo < 0.0 else 0.0
    return float(min(max(a, -1.0), 1.0))


class AccelerationRuleBased(RuleBasedController):
    """:class:`RuleBasedController` for ``action_mode="acceleration"``: demand ``(v_ref - target) / step``.

    Parameters are :class:`RuleBasedController`'s (its speed cap, ramp and station curve are used unchanged; its
    force law is not: the env's tracker does the force). ``accel_span_mps2`` is the env's ``accel_demand_mps2``,
    read from the env at ``reset`` when one is given.
    """

    name = "rule-based-accel"
    action_modes = ("acceleration",)

    def __init__(self, vehicle: VehicleParams, dt_s: float = 0.1, *,
                 accel_span_mps2: tuple[float, float] = (-0.5, 0.5), **kwargs: Any) -> None:
        super().__init__(vehicle, dt_s, **kwargs)
        self.accel_span_mps2 = (float(accel_span_mps2[0]), float(accel_span_mps2[1]))

    def reset(self, env: Any = None, info: Mapping[str, Any] | None = None) -> None:
        super().reset(env, info)  # refuses an env with another action_mode
        config = getattr(getattr(env, "unwrapped", env), "config", None)
        span = config.get("accel_demand_mps2") if isinstance(config, Mapping) else None
        if span is not None:
            self.accel_span_mps2 = (float(span[0]), float(span[1]))

    def demand_mps2(self, x: ControlInput, target_mps: float) -> float:
        """Acceleration that moves the tracker's target to the reference speed in one step."""
        self._remember(x)
        if x.distance_to_go_m - self.stop_offset_m <= STOP_ZONE_M:
            return self.accel_span_mps2[0]
        v_ref = self.reference_speed(x)
        return (v_ref - target_mps) / self.dt_s

    def act(self, obs: Any, info: Mapping[str, Any]) -> np.ndarray:
        x = self.control_input(obs, info)
        target = info.get("target_speed_mps") if info else None
        target_mps = float(target) if target is not None and np.isfinite(target) else 0.0
        a = accel_action(self.demand_mps2(x, target_mps), self.accel_span_mps2)
        return np.array([a], dtype=np.float32)

    def command(self, x: ControlInput) -> float:
        return accel_action(self.demand_mps2(x, 0.0), self.accel_span_mps2)


__all__ = ["AccelerationRuleBased", "STOP_ZONE_M", "accel_action"]
