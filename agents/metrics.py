"""Per-episode safety and performance figures of a ``UUOM-Track-v0`` run, shared by training logs and evaluation.

An :class:`EpisodeAccumulator` takes every step's ``info``; :meth:`EpisodeAccumulator.finish` returns an
:class:`EpisodeSummary`:

- ``success``: stood still within the stop tolerance of the far station (``info["is_success"]``);
- ``overspeed_trip``: the emergency brake fell (rule 5), the run ended as a failure;
- ``violations``: per rule, the number of policy steps in which the rule was breached (env's count);
- ``violations_per_km``: the same per km driven;
- ``cost`` and ``cost_rate``: the summed ``info["cost"]`` and its mean per policy step;
- ``trip_time_s``; ``energy_kj_per_tkm``: traction energy per tonne (true mass) and km driven;
- ``mass_err_pct`` / ``slope_err_deg``: mean absolute estimator errors over the episode.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, Mapping

import numpy as np

RULES: tuple[str, ...] = ("speed_limit", "adhesion", "rollback", "sway", "overspeed_trip", "stall")


@dataclass
class EpisodeSummary:
    """Figures of one episode (see the module docstring)."""

    success: bool
    termination: str
    overspeed_trip: bool
    steps: int
    trip_time_s: float
    distance_m: float
    track_length_m: float
    mass_kg: float
    cost: float
    cost_rate: float
    energy_kj_per_tkm: float
    mass_err_pct: float
    slope_err_deg: float
    max_overspeed_mps: float
    violations: dict[str, int] = field(default_factory=dict)
    violations_per_km: dict[str, float] = field(default_factory=dict)

    def flat(self) -> dict[str, Any]:
        """One flat dict (``violations_per_km/<rule>`` keys) for CSV rows and loggers."""
        d = asdict(self)
        v = d.pop("violations")
        vk = d.pop("violations_per_km")
        for r in RULES:
            d[f"violations/{r}"] = v.get(r, 0)
            d[f"violations_per_km/{r}"] = vk.get(r, 0.0)
        return d


class EpisodeAccumulator:
    """Collects one episode's step infos."""

    def __init__(self) -> None:
        self.reset()

    def reset(self) -> None:
        self.steps = 0
        self.cost = 0.0
        self._mass_err: list[float] = []
        self._slope_err: list[float] = []
        self.max_overspeed_mps = -math.inf
        self.start_position_m: float | None = None

    def start(self, info: Mapping[str, Any]) -> None:
        """Take the reset info (start position)."""
        self.reset()
        self.start_position_m = float(info.get("position_m", 0.0))

    def add(self, info: Mapping[str, Any]) -> None:
        """Take one step's info."""
        self.steps += 1
        self.cost += float(info.get("cost", 0.0))
        m, me = info.get("true_mass_kg"), info.get("est_mass_kg")
        if m is not None and me is not None and m > 0:
            self._mass_err.append(abs(float(me) - float(m)) / float(m) * 100.0)
        th, the = info.get("true_slope_rad"), info.get("est_slope_rad")
        if th is not None and the is not None:
            self._slope_err.append(math.degrees(abs(float(the) - float(th))))
        v, lim = info.get("speed_mps"), info.get("true_speed_limit_mps")
        if v is not None and lim is not None:
            self.max_overspeed_mps = max(self.max_overspeed_mps, float(v) - float(lim))

    def finish(self, info: Mapping[str, Any]) -> EpisodeSummary:
        """Summary from the final step's info (which must already have been :meth:`add`-ed)."""
        start = self.start_position_m or 0.0
        dist = max(float(info.get("position_m", 0.0)) - start, 0.0)
        km = max(dist / 1000.0, 1e-6)
        mass = float(info.get("true_mass_kg", float("nan")))
        counts = {r: int(info.get("violation_counts", {}).get(r, 0)) for r in RULES}
        energy = float(info.get("episode_energy_j", 0.0))
        term = str(info.get("termination", ""))
        return EpisodeSummary(
            success=bool(info.get("is_success", False)),
            termination=term,
            overspeed_trip=term == "overspeed_trip" or counts.get("overspeed_trip", 0) > 0,
            steps=self.steps,
            trip_time_s=float(info.get("t_s", float("nan"))),
            distance_m=dist,
            track_length_m=float(info.get("track_length_m", float("nan"))),
            mass_kg=mass,
            cost=self.cost,
            cost_rate=self.cost / max(self.steps, 1),
            energy_kj_per_tkm=energy / 1000.0 / (mass / 1000.0) / km if dist > 1.0 else float("nan"),
            mass_err_pct=float(np.mean(self._mass_err)) if self._mass_err else float("nan"),
            slope_err_deg=float(np.mean(self._slope_err)) if self._slope_err else float("nan"),
            max_overspeed_mps=self.max_overspeed_mps,
            violations=counts,
            violations_per_km={r: c / km if dist > 1.0 else 0.0 for r, c in counts.items()},
        )


def drive_episode(env: Any, controller: Any, seed: int) -> tuple[EpisodeSummary, dict[str, Any]]:
    """Reset ``env`` with ``seed``, drive it with ``controller`` (``reset(env, info)``, ``act(obs, info)``) to the
    end of the episode; return its summary and the last step's info."""
    obs, info = env.reset(seed=seed)
    controller.reset(env, info)
    acc = EpisodeAccumulator()
    acc.start(info)
    while True:
        obs, _, term, trunc, info = env.step(controller.act(obs, info))
        acc.add(info)
        if term or trunc:
            return acc.finish(info), info


__all__ = ["EpisodeAccumulator", "EpisodeSummary", "RULES", "drive_episode"]
