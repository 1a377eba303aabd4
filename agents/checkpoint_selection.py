"""Pick a training run's checkpoint on *validation* tracks, never on the held-out ones it is judged on.

PPO on ``UUOM-Track-v0`` often peaks and then drifts (docs/rl.md §27, §30, §32): its last policy is not its best.
rl-baselines3-zoo keeps the best model by a periodic evaluation; this does the same after training, from the
run's checkpoints, on validation tracks (:data:`agents.tune.VALIDATION_SEED_BASE` on, disjoint from the held-out
seeds 100 000 on that every table uses), so the choice never sees a held-out track.

The rule (:func:`rank`): fewest failures weighted for safety, ``arrived - TRIP_WEIGHT * trips``; then the faster
mean trip time of the arrivals; then the later checkpoint.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from agents.checkpoints import STEP_DIR_RE, list_checkpoints

TRIP_WEIGHT = 10.0
"""One overspeed trip counts as this many missed arrivals (issue 11's floor allows 1 trip in 100 but 5 misses)."""

def step_of(model_dir: Path) -> int | None:
    """The step count of a ``checkpoints/step_<n>`` folder; ``None`` for a run's final model."""
    m = STEP_DIR_RE.fullmatch(Path(model_dir).name)
    return int(m.group(1)) if m and Path(model_dir).parent.name == "checkpoints" else None


def candidates(run_dir: Path, min_step: int = 0, every: int = 0) -> list[Path]:
    """The run's checkpoint folders with ``step >= min_step`` (and a multiple of ``every`` if > 0), then its final
    model. Raises ``FileNotFoundError`` when there is none, and ``ValueError`` when ``every`` matches none of the
    checkpoints at or after ``min_step`` (a run started with ``--init-from`` saves at its first step plus multiples
    of its checkpoint interval: choosing the final model alone there would be a silent mistake)."""
    run_dir = Path(run_dir)
    saved = [c for c in list_checkpoints(run_dir / "checkpoints") if c.steps >= min_step]
    found = [c.path for c in saved if every <= 0 or c.steps % every == 0]
    if saved and not found:
        raise ValueError(f"{run_dir}: --every {every} matches none of its checkpoints (steps "
                         f"{', '.join(str(c.steps) for c in saved)}); pass --every 0 or a divisor of those steps")
    if (run_dir / "model.zip").is_file():
        found.append(run_dir)
    if not found:
        raise FileNotFoundError(f"{run_dir}: no model.zip and no checkpoints/step_<n>/model.zip to choose from")
    return found


def rank(rows: list[dict[str, Any]], labels: dict[str, Path]) -> list[dict[str, Any]]:
    """Per candidate (``labels``: controller label -> folder), best first by the module's rule.

    ``rows`` are episode rows (``episodes.csv``): ``controller``, ``termination``, ``success``, ``trip_time_s``.
    """
    table = []
    for label, folder in labels.items():
        rs = [r for r in rows if r["controller"] == label]
        if not rs:
            raise ValueError(f"no episodes of candidate {label!r}")
        arrived = sum(bool(r["success"]) for r in rs)
        trips = sum(r["termination"] == "overspeed_trip" for r in rs)
        times = [float(r["trip_time_s"]) for r in rs if r["success"] and math.isfinite(float(r["trip_time_s"]))]
        step = step_of(folder)
        table.append(dict(candidate=label, folder=str(folder), step=step, episodes=len(rs), arrived=arrived,
                          trips=trips, score=arrived - TRIP_WEIGHT * trips,
                          mean_trip_time_s=sum(times) / len(times) if times else math.inf))
    last = max((t["step"] or 0) for t in table) + 1
    return sorted(table, key=lambda t: (-t["score"], t["mean_trip_time_s"],
                                        -(last if t["step"] is None else t["step"])))


def ranking_markdown(table: list[dict[str, Any]]) -> str:
    """The ranking as a markdown table, the chosen candidate in bold."""
    lines = ["| candidate | step | episodes | arrived | trips | score | mean trip time of arrivals (s) |",
             "|---|---:|---:|---:|---:|---:|---:|"]
    for i, t in enumerate(table):
        name = f"**{t['candidate']}**" if i == 0 else t["candidate"]
        step = "final" if t["step"] is None else str(t["step"])
        lines.append(f"| {name} | {step} | {t['episodes']} | {t['arrived']} | {t['trips']} | {t['score']:g} "
                     f"| {t['mean_trip_time_s']:.1f} |")
    return "\n".join(lines)


__all__ = ["TRIP_WEIGHT", "candidates", "rank", "ranking_markdown", "step_of"]
