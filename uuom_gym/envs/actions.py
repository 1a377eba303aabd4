"""The action of ``UUOM-Track-v0``: one finite real number, checked with a message that names what is wrong."""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np


ACTION_MODES: tuple[str, ...] = ("command", "speed_target", "acceleration")
"""Values of the config key ``action_mode``: what the action in ``[-1, 1]`` asks the plant for."""


def accel_demand_mps2(action: float, span: tuple[float, float]) -> float:
    """``action_mode="acceleration"``: the acceleration an action asks for, ``a * hi`` for ``a >= 0``, ``-a * lo``
    below, so that ``a = 0`` asks for none whatever the span."""
    a = min(max(float(action), -1.0), 1.0)
    return a * float(span[1]) if a >= 0.0 else -a * float(span[0])


class InvalidActionError(ValueError):
    """An action that is not one finite real number (a Python/NumPy real scalar or a real array of shape (1,))."""


_ACTION_HELP = "action must be one real number: a Python/NumPy int or float, or a real array of shape (1,)"


def check_action(action: Any) -> float:
    """The action as a float in ``[-1, 1]``; anything but one finite real number raises InvalidActionError.

    Accepted: ``int``/``float`` (not ``bool``), NumPy integer/floating scalars, and real (integer or floating
    dtype) arrays or sequences of shape ``()`` or ``(1,)``. Rejected with the type named: ``bool``, complex,
    strings, ``None``, objects, other shapes, NaN/inf.
    """
    if isinstance(action, (bool, np.bool_)):
        raise InvalidActionError(f"{_ACTION_HELP}, got bool {action!r}")
    if isinstance(action, (int, float, np.integer, np.floating)):
        x = float(action)
    else:
        if action is None or isinstance(action, (str, bytes, complex, np.complexfloating, Mapping)):
            raise InvalidActionError(f"{_ACTION_HELP}, got {type(action).__name__} {action!r}")
        try:
            a = np.asarray(action)
        except (TypeError, ValueError):
            raise InvalidActionError(f"{_ACTION_HELP}, got {type(action).__name__} {action!r}") from None
        if a.dtype.kind not in "iuf":
            raise InvalidActionError(
                f"{_ACTION_HELP}, got {type(action).__name__} of dtype {a.dtype} ({action!r})"
            )
        if a.shape not in ((), (1,)):
            raise InvalidActionError(f"action must have shape (1,), got shape {a.shape}")
        x = float(a.reshape(-1)[0])
    if not math.isfinite(x):
        raise InvalidActionError(f"action must be finite, got {type(action).__name__} {x!r}")
    return min(max(x, -1.0), 1.0)


__all__ = ["ACTION_MODES", "InvalidActionError", "accel_demand_mps2", "check_action"]
