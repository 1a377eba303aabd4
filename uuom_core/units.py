"""Physical constants and unit conversions shared by every package (SI inside, conversions only at the edges)."""

from __future__ import annotations

import math

G_MPS2 = 9.81
"""Gravitational acceleration used everywhere in the project (plant, estimators, safety rules)."""

KMH_PER_MPS = 3.6


def clamp(x: float, lo: float, hi: float) -> float:
    """``x`` bounded to ``[lo, hi]`` (NaN stays NaN): ``np.clip`` for one number, at a tenth of its cost."""
    return min(max(x, lo), hi)


def deg(rad: float) -> float:
    """Radians to degrees."""
    return math.degrees(rad)


def rad(deg_: float) -> float:
    """Degrees to radians."""
    return math.radians(deg_)


__all__ = ["G_MPS2", "KMH_PER_MPS", "clamp", "deg", "rad"]
