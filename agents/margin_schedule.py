"""A learned margin schedule: the agent sets the rule-based controller's speed margin at every step.

The rule-based controller (:class:`agents.controllers.RuleBasedController`) drives to ``(1 - m) v_lim - m_abs`` of
its pessimistic limit; its default ``m = 0.08`` (``m_abs = 0.035`` m/s) is one fixed point of a trade-off between
trip time and cost rate (docs/rl.md §13: smaller margins are faster and costlier). Measured there: with ``m`` at a
quarter of the default, only trains above 27 t ever cross the limit — so a margin that *depends on the state* could
be faster than every fixed one at the same cost rate. This wrapper makes that a learning problem with the
controller's own terms: the action ``a`` in ``[-1, 1]`` is mapped to

``m = lo + (a + 1) / 2 (hi - lo)``,  ``m_abs = m * 0.035 / 0.08``

(the absolute margin scales with the relative one, as in §13's settings), and the controller computes the command
with it. Every constant action is one of the controller's fixed settings, so the fixed-margin family *is* the
baseline a learned schedule has to beat. The base sees exactly the agent's observation, never the truth.

``info["speed_margin"]`` reports each step's margin. Put it *outside* :class:`agents.shield.ShieldWrapper` (if any)
and inside any normalisation; it replaces, and excludes, :class:`agents.residual.ResidualWrapper`.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from agents.base_controller_wrapper import OnBaseController
from agents.controllers import RuleBasedController
from uuom_core.units import clamp

ABS_PER_REL_MARGIN_MPS = 0.035 / 0.08
"""Absolute margin (m/s) per unit of relative margin: the rule-based controller's default ratio."""


def margin_of_action(action: float, span: tuple[float, float]) -> float:
    """``lo + (a + 1) / 2 (hi - lo)`` for an action clipped to ``[-1, 1]``."""
    lo, hi = span
    return lo + 0.5 * (clamp(float(action), -1.0, 1.0) + 1.0) * (hi - lo)


def check_span(span: Any) -> tuple[float, float]:
    """``(lo, hi)`` with ``0 <= lo < hi <= 0.5``.

    Raises
    ------
    ValueError
        Naming what is wrong with ``span``.
    """
    try:
        lo, hi = (float(x) for x in span)
    except (TypeError, ValueError):
        raise ValueError(f"margin schedule must be two numbers (lo, hi), got {span!r}") from None
    if not (0.0 <= lo < hi <= 0.5) or not (np.isfinite(lo) and np.isfinite(hi)):
        raise ValueError(f"margin schedule needs 0 <= lo < hi <= 0.5, got ({lo!r}, {hi!r})")
    return lo, hi


class MarginScheduleWrapper(OnBaseController):
    """The agent's action sets the rule-based controller's speed margin; the controller gives the command.

    Parameters
    ----------
    env : gymnasium.Env
        A ``UUOM-Track-v0`` env with the default (command) action, possibly shielded.
    span : (float, float)
        ``(lo, hi)``: the relative speed margin at ``a = -1`` and ``a = +1`` (default ``(0, 0.12)``: ``a = 0`` is
        0.06, three quarters of the controller's default).
    base : RuleBasedController, optional
        The controller (default: one with its default settings for the env's vehicle).
    """

    def __init__(self, env: gym.Env, span: tuple[float, float] = (0.0, 0.12),
                 base: RuleBasedController | None = None) -> None:
        self.span = check_span(span)
        super().__init__(env, base)

    def command(self, action: Any) -> tuple[np.ndarray, dict[str, Any]]:
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.size != 1 or not np.isfinite(a[0]):
            raise ValueError(f"MarginScheduleWrapper: action must be one finite number, got {action!r}")
        m = margin_of_action(float(a[0]), self.span)
        self.base.speed_margin = m
        self.base.speed_margin_mps = m * ABS_PER_REL_MARGIN_MPS
        return self.base.act(self._obs, self._info), {"speed_margin": m}


__all__ = ["ABS_PER_REL_MARGIN_MPS", "MarginScheduleWrapper", "check_span", "margin_of_action"]
