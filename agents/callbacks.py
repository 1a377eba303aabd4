"""stable-baselines3 callbacks for UUOM-Track training: safety/performance scalars in TensorBoard.

:class:`UUOMMetricsCallback` summarises every finished training episode with :mod:`agents.metrics` and logs the
running means under ``uuom/``: success rate, overspeed trips, cost rate, violations per km by rule, trip time,
energy per t km, estimator errors. On the first step it also writes a TensorBoard *custom scalars* layout that
groups them (TensorBoard's "Custom Scalars" tab).
"""

from __future__ import annotations

from collections import deque
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.logger import TensorBoardOutputFormat

from agents.metrics import RULES, EpisodeAccumulator, EpisodeSummary

SCALARS: tuple[str, ...] = (
    "success_rate",
    "overspeed_trip_rate",
    "cost_rate",
    "trip_time_s",
    "energy_kj_per_tkm",
    "mass_err_pct",
    "slope_err_deg",
) + tuple(f"violations_per_km/{r}" for r in RULES)


def custom_scalar_layout() -> dict[str, dict[str, list]]:
    """Layout for ``SummaryWriter.add_custom_scalars`` (category -> chart -> [Multiline, tags])."""
    return {
        "UUOM safety": {
            "cost rate": ["Multiline", ["uuom/cost_rate"]],
            "violations per km": ["Multiline", [f"uuom/violations_per_km/{r}" for r in RULES]],
            "success / trips": ["Multiline", ["uuom/success_rate", "uuom/overspeed_trip_rate"]],
        },
        "UUOM performance": {
            "trip time": ["Multiline", ["uuom/trip_time_s"]],
            "energy": ["Multiline", ["uuom/energy_kj_per_tkm"]],
            "estimator error": ["Multiline", ["uuom/mass_err_pct", "uuom/slope_err_deg"]],
        },
    }


class UUOMMetricsCallback(BaseCallback):
    """Logs the running means of the last ``window`` training episodes' :class:`EpisodeSummary` figures.

    Parameters
    ----------
    window : int
        Number of recent episodes averaged.
    """

    def __init__(self, window: int = 50, verbose: int = 0) -> None:
        super().__init__(verbose)
        self.window = window
        self.summaries: deque[EpisodeSummary] = deque(maxlen=window)
        self.n_episodes = 0
        self._acc: list[EpisodeAccumulator] = []
        self._layout_written = False

    def _on_training_start(self) -> None:
        self._acc = [EpisodeAccumulator() for _ in range(self.training_env.num_envs)]
        if not self._layout_written:
            for fmt in self.logger.output_formats:
                if isinstance(fmt, TensorBoardOutputFormat):
                    fmt.writer.add_custom_scalars(custom_scalar_layout())
                    fmt.writer.flush()
            self._layout_written = True

    def _on_step(self) -> bool:
        infos: list[dict[str, Any]] = self.locals.get("infos", [])
        dones = self.locals.get("dones", np.zeros(len(infos), dtype=bool))
        finished = False
        for i, info in enumerate(infos):
            acc = self._acc[i]
            acc.add(info)
            if dones[i]:
                self.summaries.append(acc.finish(info))
                self.n_episodes += 1
                acc.reset()
                finished = True
        # Means change only when an episode ends; the logger keeps the last recorded value until its dump.
        if finished:
            flat = [s.flat() for s in self.summaries]
            for key in SCALARS:
                if key == "success_rate":
                    val = np.mean([f["success"] for f in flat])
                elif key == "overspeed_trip_rate":
                    val = np.mean([f["overspeed_trip"] for f in flat])
                else:
                    vals = [f[key] for f in flat if np.isfinite(f[key])]
                    if not vals:
                        continue
                    val = np.mean(vals)
                self.logger.record(f"uuom/{key}", float(val))
            self.logger.record("uuom/episodes", self.n_episodes)
        return True


__all__ = ["SCALARS", "UUOMMetricsCallback", "custom_scalar_layout"]
