"""How good must an estimator be? Trip rate and trip time against a set mass or slope error.

A controller is run on the held-out tracks with the ``oracle`` observer told the truth plus a fixed error
(``observer_options={"mass_error": e}`` or ``{"slope_error_deg": e}``, reported standard deviation 0: the
controller believes it), one error at a time. For each error: success rate, overspeed-trip rate with its Wilson 95 %
interval, and trip time relative to the oracle controller on the same track (interquartile mean over successful
episodes, 95 % bootstrap interval over tracks; :mod:`agents.statistics`). :func:`run_sensitivity` writes ``summary.csv``, ``summary.md``, the figure and the
per-episode ``episodes.csv`` (git-ignored; regenerate with the command in ``summary.md``).

Sign convention: a negative mass error (told lighter) and a positive slope error (told the track rises more or falls
less) both raise the speed limit the controller computes above the true one: the unsafe directions.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from agents.evaluation import DEFAULT_SEED_BASE, Task, run_tasks
from agents.evaluation_table import read_episodes, write_csv
from agents.statistics import bootstrap_ci, iqm, wilson_interval

DEFAULT_MASS_ERRORS: tuple[float, ...] = (-0.3, -0.2, -0.1, -0.05, 0.05, 0.1, 0.2, 0.3)
DEFAULT_SLOPE_ERRORS_DEG: tuple[float, ...] = (-3.0, -2.0, -1.0, -0.5, 0.5, 1.0, 2.0, 3.0)


@dataclass
class SensitivityConfig:
    """What :func:`run_sensitivity` runs (the options of ``scripts/sensitivity.py``)."""

    controller: str = "rule-based"
    mass_errors: Sequence[float] = DEFAULT_MASS_ERRORS
    slope_errors_deg: Sequence[float] = DEFAULT_SLOPE_ERRORS_DEG
    episodes: int = 100
    seed_base: int = DEFAULT_SEED_BASE
    workers: int = 1
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    out: Path = Path("results/sensitivity")
    command: str | None = None


def _tasks(config: SensitivityConfig) -> list[tuple[str, float, Task]]:
    seeds = range(config.seed_base, config.seed_base + config.episodes)
    settings = [("none", 0.0)] + [("mass", e) for e in config.mass_errors] + \
        [("slope", e) for e in config.slope_errors_deg]
    out: list[tuple[str, float, Task]] = []
    for s in seeds:
        out.append(("reference", 0.0, Task("oracle", "oracle", s, json.dumps(config.env_kwargs, sort_keys=True))))
    for kind, err in settings:
        opts = {} if kind == "none" else {"mass_error": err} if kind == "mass" else {"slope_error_deg": err}
        kw = json.dumps({**config.env_kwargs, "observer_options": opts}, sort_keys=True)
        for s in seeds:
            out.append((kind, err, Task(config.controller, "oracle", s, kw)))
    return out


def summarise_sensitivity(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per (error kind, error): rates with Wilson intervals, trip time / oracle as IQM with bootstrap CI."""
    ref = {r["seed"]: r["trip_time_s"] for r in rows if r["error_kind"] == "reference" and r["success"]}
    groups: dict[tuple[str, float], list[dict[str, Any]]] = {}
    for r in rows:
        if r["error_kind"] != "reference":
            groups.setdefault((r["error_kind"], float(r["error"])), []).append(r)
    out = []
    for (kind, err), rs in sorted(groups.items(), key=lambda kv: (kv[0][0] != "none", kv[0][0], kv[0][1])):
        n = len(rs)
        trips = sum(bool(r["overspeed_trip"]) for r in rs)
        ratios = [r["trip_time_s"] / ref[r["seed"]] for r in rs if r["success"] and r["seed"] in ref]
        lo, hi = wilson_interval(trips, n)
        tlo, thi = bootstrap_ci(ratios)
        out.append({
            "error_kind": kind, "error": err, "episodes": n,
            "success_rate": sum(bool(r["success"]) for r in rs) / n,
            "trip_rate": trips / n, "trip_rate_lo": lo, "trip_rate_hi": hi,
            "trip_time_vs_oracle": iqm(ratios),
            "trip_time_lo": tlo, "trip_time_hi": thi,
            "cost_rate": float(np.mean([r["cost_rate"] for r in rs])),
        })
    return out


def markdown(summary: list[dict[str, Any]]) -> str:
    lines = ["| injected error | success | overspeed trips (95 % CI) | trip time / oracle, IQM (95 % CI) | cost rate |",
             "|---|---|---|---|---|"]
    for r in summary:
        what = ("none" if r["error_kind"] == "none" else
                f"mass {100 * r['error']:+.0f} %" if r["error_kind"] == "mass" else f"slope {r['error']:+.1f}°")
        lines.append(
            f"| {what} | {100 * r['success_rate']:.0f} % | {100 * r['trip_rate']:.0f} % "
            f"({100 * r['trip_rate_lo']:.0f}–{100 * r['trip_rate_hi']:.0f} %) | "
            f"{r['trip_time_vs_oracle']:.3f} ({r['trip_time_lo']:.3f}–{r['trip_time_hi']:.3f}) | "
            f"{r['cost_rate']:.2e} |")
    return "\n".join(lines) + "\n"


def plot(summary: list[dict[str, Any]], path: Path, controller: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    base = [r for r in summary if r["error_kind"] == "none"]
    fig, axes = plt.subplots(2, 2, figsize=(10, 6.5), sharex="col")
    for col, (kind, scale, label) in enumerate((("mass", 100.0, "injected mass error (%)"),
                                                 ("slope", 1.0, "injected slope error (deg)"))):
        rs = sorted([r for r in summary if r["error_kind"] == kind] + [dict(b, error=0.0) for b in base],
                    key=lambda r: r["error"])
        x = np.array([scale * r["error"] for r in rs])
        for row, (key, ylab) in enumerate((("trip_rate", "overspeed-trip rate"),
                                           ("trip_time_vs_oracle", "trip time / oracle"))):
            ax = axes[row, col]
            y = np.array([r[key] for r in rs])
            lo_key, hi_key = ("trip_rate_lo", "trip_rate_hi") if key == "trip_rate" else ("trip_time_lo",
                                                                                          "trip_time_hi")
            lo = np.array([r[lo_key] for r in rs])
            hi = np.array([r[hi_key] for r in rs])
            ax.plot(x, y, "o-", color="C3" if row == 0 else "C0")
            ax.fill_between(x, lo, hi, alpha=0.25, color="C3" if row == 0 else "C0")
            ax.axvline(0.0, color="0.6", lw=0.8)
            ax.set_ylabel(ylab)
            ax.grid(alpha=0.3)
            if row == 1:
                ax.set_xlabel(label + ("\n(negative: told lighter, unsafe)" if kind == "mass"
                                       else "\n(positive: told less downhill, unsafe)"))
    n = base[0]["episodes"] if base else 0
    fig.suptitle(f"{controller} with the oracle observer plus a set error, {n} held-out tracks (95 % CI)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run_sensitivity(config: SensitivityConfig, progress: bool = True) -> list[dict[str, Any]]:
    """Run the grid; write ``episodes.csv``, ``summary.csv``, ``summary.md`` and ``sensitivity.png``."""
    if config.episodes < 1:
        raise ValueError(f"episodes must be >= 1, got {config.episodes}")
    labelled = _tasks(config)
    rows = run_tasks([t for _, _, t in labelled], config.workers, progress=progress)
    for (kind, err, _), row in zip(labelled, rows):
        row["error_kind"] = kind
        row["error"] = err
    return _write(rows, config)


def _write(rows: list[dict[str, Any]], config: SensitivityConfig, note: str = "") -> list[dict[str, Any]]:
    summary = summarise_sensitivity(rows)
    out = Path(config.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "episodes.csv", rows)
    write_csv(out / "summary.csv", summary)
    plot(summary, out / "sensitivity.png", config.controller)
    seeds = sorted({int(r["seed"]) for r in rows})
    cmd = config.command or "(called from Python)"
    (out / "summary.md").write_text(
        f"{config.controller}, oracle observer plus a set error, held-out seeds {seeds[0]}..{seeds[-1]} "
        f"({len(seeds)} tracks), {len(rows)} episodes.\n"
        f"Command: `{cmd}`{note}\n\n" + markdown(summary) + "\nFigure: sensitivity.png\n")
    return summary


def rebuild(config: SensitivityConfig) -> list[dict[str, Any]]:
    """Recompute the summary, table and figure from ``config.out/episodes.csv`` without running episodes."""
    rows = read_episodes(Path(config.out) / "episodes.csv")
    old = Path(config.out) / "summary.md"
    note = ""
    if old.exists():  # keep the command that ran the episodes
        for line in old.read_text().splitlines():
            if line.startswith("Command: `") and "--rebuild" not in line:
                note = f" (table rebuilt by `{config.command or 'rebuild()'}`)"
                config = replace(config, command=line[len("Command: `"):].split("`")[0])
                break
    for r in rows:
        r["error_kind"] = str(r["error_kind"])
        r["error"] = float(r["error"])
    return _write(rows, config, note)


__all__ = ["SensitivityConfig", "markdown", "rebuild", "run_sensitivity", "summarise_sensitivity"]
