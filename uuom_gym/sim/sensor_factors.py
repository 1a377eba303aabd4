"""Named imperfections of the point-mass world's sensors scaled one by one (the noise studies' ``--scale-fields``).

Kept out of :mod:`uuom_gym.sim.point_mass` on purpose: that module's source is part of the protocol runs' fingerprint
(:func:`uuom_gym.sim.protocol_runs.runs_fingerprint`), and a helper for studies must not invalidate the runs' cache.
"""

from __future__ import annotations

import math
from dataclasses import fields, replace
from typing import Mapping

from uuom_gym.sim.point_mass import PointMassSensors

__all__ = ["scale_sensor_fields"]


def scale_sensor_fields(sensors: PointMassSensors, factors: Mapping[str, float]) -> PointMassSensors:
    """``sensors`` with each named field multiplied by its factor (0 removes that imperfection).

    Raises
    ------
    ValueError
        A name that is not a field of :class:`PointMassSensors` (the message lists them), or a factor that is not a
        finite number >= 0.
    """
    names = {f.name for f in fields(PointMassSensors)}
    unknown = sorted(set(factors) - names)
    if unknown:
        raise ValueError(f"unknown sensor field(s) {unknown}; choose from {sorted(names)}")
    for name, k in factors.items():
        if isinstance(k, bool) or not isinstance(k, (int, float)) or not (0.0 <= k < math.inf):
            raise ValueError(f"sensor field {name}: every factor must be a finite number >= 0, got {k!r}")
    return replace(sensors, **{name: k * getattr(sensors, name) for name, k in factors.items()})
