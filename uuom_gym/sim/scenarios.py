"""Named scenarios of paper 000: track, load and the driver's speed profile.

=========  =========================================================  ======  ===============================
name       track                                                      load    driver speed (m/s)
=========  =========================================================  ======  ===============================
section1   level 45 m, 20 m transition, 8 deg up-grade (§4.2)         10 t    1.0 on the level, 0.8 up-grade
section2   continuously varying grade 0..7.7 deg (§4.3)               10 t    0.8
roadtest   near-level (+-0.6 deg) 43 m, 8 m transition, 11 deg        10 t    1.0, then 0.5 on the grade,
           up-grade easing to 7 deg, high level stretch at 0.8 deg            then 0.7 (paper Fig. 11b: grade
           (§5.2, max grade < 15 deg)                                         from 43 s, level from 72 s)
=========  =========================================================  ======  ===============================

Each runs 120 s, long enough for the estimators to converge.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from uuom_gym.sim.track import SCENARIO_NAMES, TrackError, TrackProfile, scenario_track


@dataclass(frozen=True)
class SpeedProfile:
    """Driver's reference speed as a function of position: piecewise linear through ``(s_m, speed_mps)`` knots.

    Parameters
    ----------
    knots : tuple of (float, float)
        Increasing positions (m) with the reference speed there (>= 0). Constant beyond the ends.
    accel_limit_mps2 : float
        The driver ramps the reference no faster than this.
    """

    knots: tuple[tuple[float, float], ...]
    accel_limit_mps2: float = 0.15

    def __post_init__(self) -> None:
        if len(self.knots) < 1:
            raise ValueError("SpeedProfile needs at least one (s_m, speed_mps) knot")
        s = [k[0] for k in self.knots]
        v = [k[1] for k in self.knots]
        if any(b <= a for a, b in zip(s, s[1:])):
            raise ValueError(f"SpeedProfile knot positions must increase strictly, got {s}")
        if any(not np.isfinite(x) or x < 0 for x in v) or any(not np.isfinite(x) for x in s):
            raise ValueError(f"SpeedProfile speeds must be finite and >= 0, got {v}")
        if not self.accel_limit_mps2 > 0:
            raise ValueError(f"accel_limit_mps2 must be > 0, got {self.accel_limit_mps2!r}")

    @classmethod
    def constant(cls, speed_mps: float) -> "SpeedProfile":
        return cls(((0.0, float(speed_mps)),))

    def speed_at(self, s_m: float) -> float:
        s = [k[0] for k in self.knots]
        v = [k[1] for k in self.knots]
        return float(np.interp(s_m, s, v))


@dataclass(frozen=True)
class Scenario:
    """A fixed test case: track, load, driver speed profile, duration."""

    name: str
    track: TrackProfile
    load_kg: float
    speed_profile: SpeedProfile
    duration_s: float = 120.0
    start_s_m: float = 0.0
    description: str = ""


# driver's speed profile, load and description of each scenario (the tracks: uuom_gym.sim.track.scenario_track)
_SCENARIOS: dict[str, tuple[SpeedProfile, float, str]] = {
    "section1": (SpeedProfile(((0.0, 1.0), (40.0, 1.0), (48.0, 0.8))), 10_000.0,
                 "level track, transition, 8 deg up-grade (paper 000 §4.2)"),
    "section2": (SpeedProfile.constant(0.8), 10_000.0, "continuously varying grade (paper 000 §4.3)"),
    "roadtest": (SpeedProfile(((0.0, 1.0), (40.0, 1.0), (43.0, 0.5), (60.0, 0.5), (63.0, 0.7))), 10_000.0,
                 "near-level stretch, transition, up-grade, high level stretch; 10 t (paper 000 §5.2)"),
}


def scenario(name: str) -> Scenario:
    """The scenario called ``name`` (one of :data:`SCENARIO_NAMES`)."""
    entry = _SCENARIOS.get(name) if isinstance(name, str) else None
    if entry is None:
        raise TrackError(f"unknown scenario {name!r}; known: {', '.join(SCENARIO_NAMES)}")
    profile, load_kg, description = entry
    return Scenario(name, scenario_track(name), load_kg, profile, 120.0, 0.0, description)


__all__ = ["SCENARIO_NAMES", "Scenario", "SpeedProfile", "scenario"]
