"""A model-free grade estimate from the accelerometer and the measured speed (the controllers' cross-check)."""

from __future__ import annotations

import math

from agents.control_input import ControlInput
from uuom_core.units import clamp
from uuom_core.vehicle import G_MPS2


class GradeCrossCheck:
    """Model-free grade from the accelerometer and the speed: ``g sin(theta) = f - dv/dt``.

    The estimators infer the grade through the force model; while braking the brake force is not measured and
    their slope can be confidently wrong by 5-12 degrees (measured on seed 100000: estimate -1.4 deg +- 0.05,
    true -14 deg). The specific force minus the measured acceleration needs no force model at all; its noise
    (about 0.3 deg per step) is low-passed.

    Parameters
    ----------
    smoothing : float
        Weight of a new sample in the exponential average (per policy step).
    min_samples : int
        Samples needed before :attr:`slope_rad` is reported.

    Attributes
    ----------
    slope_rad : float or None
        Low-passed model-free grade, ``None`` until enough samples (or without an accelerometer).
    """

    def __init__(self, smoothing: float = 0.3, min_samples: int = 3) -> None:
        if not 0.0 < smoothing <= 1.0 or min_samples < 1:
            raise ValueError(f"GradeCrossCheck needs 0 < smoothing <= 1 and min_samples >= 1, got {smoothing}, {min_samples}")
        self.smoothing = smoothing
        self.min_samples = min_samples
        self.reset()

    def reset(self) -> None:
        """Forget the previous episode."""
        self._last_speed_mps: float | None = None
        self._avg = 0.0
        self._n = 0
        self.slope_rad: float | None = None

    def update(self, x: ControlInput) -> float | None:
        """Add one policy step's measurement; return the current model-free grade (or ``None``)."""
        f = x.specific_force_mps2
        if f is None or not math.isfinite(f) or not math.isfinite(x.speed_mps):
            return self.slope_rad
        if self._last_speed_mps is not None:
            dvdt = (x.speed_mps - self._last_speed_mps) / max(x.dt_s, 1e-3)
            sample = math.asin(float(clamp((f - dvdt) / G_MPS2, -1.0, 1.0)))
            self._avg = sample if self._n == 0 else self._avg + self.smoothing * (sample - self._avg)
            self._n += 1
            if self._n >= self.min_samples:
                self.slope_rad = self._avg
        self._last_speed_mps = x.speed_mps
        return self.slope_rad


__all__ = ["GradeCrossCheck"]
