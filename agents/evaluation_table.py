"""The evaluation table: per-episode rows -> one summary row per (controller, observer), CSV and Markdown."""

from __future__ import annotations

import csv
import math
from pathlib import Path
from typing import Any

import numpy as np

from agents.statistics import bootstrap_ci, iqm, wilson_interval

DEFAULT_OBSERVERS = ("oracle", "dffrls-aekf", "rls-ekf", "ekf", "ffrls", "none")
"""Observers evaluated by default, in table order."""
RULES = ("speed_limit", "adhesion", "rollback", "sway", "overspeed_trip", "stall")


def summarise(rows: list[dict[str, Any]], oracle_label: str = "oracle") -> list[dict[str, Any]]:
    """One summary row per (controller, observer).

    Rows that carry a ``training_run`` (set by :func:`pool_rows`) are several trained policies under one label:
    ``training_runs`` counts them, and every interval resamples the training runs as well as the tracks (see
    :func:`rate_interval` for the success and trip rates).
    """
    ref = {r["seed"]: r["trip_time_s"] for r in rows if r["controller"] == oracle_label and r["success"]}
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["controller"], r["observer"]), []).append(r)
    out = []
    for (ctrl, obs), rs in groups.items():
        n = len(rs)
        km = sum(r["distance_m"] for r in rs) / 1000.0
        steps = sum(r["steps"] for r in rs)
        # (training run, track, trip time / oracle) of every arrived episode with an oracle reference
        scored = [(str(r.get("training_run", "")), int(r["seed"]), r["trip_time_s"] / ref[r["seed"]])
                  for r in rs if r["success"] and r["seed"] in ref]
        ratios = [x for _, _, x in scored]
        runs = sorted({str(r.get("training_run", "")) for r in rs})
        if len(runs) > 1:
            # several training seeds pooled under one label: resample the seeds and the tracks (two-level)
            ci = bootstrap_ci(_seed_track_grid(scored, runs, sorted({int(r["seed"]) for r in rs})))
        else:
            ci = bootstrap_ci(ratios)
        energy = [r["energy_kj_per_tkm"] for r in rs if r["success"] and math.isfinite(r["energy_kj_per_tkm"])]
        mass_err = [r["mass_err_pct"] for r in rs if math.isfinite(r["mass_err_pct"])]
        slope_err = [r["slope_err_deg"] for r in rs if math.isfinite(r["slope_err_deg"])]
        row = {
            "controller": ctrl,
            "observer": obs,
            "training_runs": len(runs),
            "episodes": n,
            "success_rate": sum(bool(r["success"]) for r in rs) / n,
            "overspeed_trips": sum(bool(r["overspeed_trip"]) for r in rs),
            "cost_rate": sum(r["cost"] for r in rs) / max(steps, 1),
            "trip_time_vs_oracle": float(np.mean(ratios)) if ratios else float("nan"),
            "trip_time_iqm": iqm(ratios),
            "trip_time_iqm_lo": ci[0],
            "trip_time_iqm_hi": ci[1],
            "energy_kj_per_tkm": float(np.mean(energy)) if energy else float("nan"),
            "mass_err_pct": float(np.mean(mass_err)) if mass_err else float("nan"),
            "slope_err_deg": float(np.mean(slope_err)) if slope_err else float("nan"),
            "km": km,
        }
        row["trip_rate_lo"], row["trip_rate_hi"] = rate_interval(rs, "overspeed_trip")
        row["success_lo"], row["success_hi"] = rate_interval(rs, "success")
        for rule in RULES:
            row[f"viol_per_km/{rule}"] = sum(r[f"violations/{rule}"] for r in rs) / max(km, 1e-9)
        out.append(row)
    order = {o: i for i, o in enumerate(DEFAULT_OBSERVERS)}
    out.sort(key=lambda r: (r["controller"] != oracle_label, r["controller"], order.get(r["observer"], 99), r["observer"]))
    return out


def _seed_track_grid(values: list[tuple[str, int, float]], runs: list[str], tracks: list[int]) -> np.ndarray:
    """``(training run, track, value)`` triples as a ``(runs, tracks)`` array, NaN where a pair has no value."""
    row_of = {run: i for i, run in enumerate(runs)}
    col_of = {track: j for j, track in enumerate(tracks)}
    grid = np.full((len(runs), len(tracks)), np.nan)
    for run, track, x in values:
        grid[row_of[run], col_of[track]] = x
    return grid


def rate_interval(rows: list[dict[str, Any]], key: str) -> tuple[float, float]:
    """95 % interval of the rate of ``bool(row[key])`` over the episodes of one (controller, observer) row.

    One trained policy (or a hand-written controller): the Wilson interval over its episodes. Several training
    seeds pooled under one label (rows carrying ``training_run``): the episodes are not independent — a seed that
    trips on 49 of 100 tracks and one that trips on 3 are two draws of the training, not 200 draws of a track — so
    the interval is a two-level percentile bootstrap of the pooled rate (seeds, then tracks, resampled) widened to
    contain the Wilson interval of the pooled rate over the *tracks* (as if one policy had scored it). The bootstrap
    carries the spread between seeds; the Wilson part keeps a rate never seen (0 trips) from an interval of [0, 0].
    """
    n = len(rows)
    if n == 0:
        return math.nan, math.nan
    runs = sorted({str(r.get("training_run", "")) for r in rows})
    k = sum(bool(r[key]) for r in rows)
    if len(runs) == 1:
        return wilson_interval(k, n)
    grid = _seed_track_grid([(str(r.get("training_run", "")), int(r["seed"]), float(bool(r[key]))) for r in rows],
                            runs, sorted({int(r["seed"]) for r in rows}))
    n_tracks = grid.shape[1]
    w_lo, w_hi = wilson_interval(round(k / n * n_tracks), n_tracks)
    b_lo, b_hi = bootstrap_ci(grid, np.mean)
    return min(w_lo, b_lo), max(w_hi, b_hi)


def pool_rows(rows: list[dict[str, Any]], pools: dict[str, list[str]]) -> list[dict[str, Any]]:
    """Relabel the rows of each pool's controllers as the pool's name, keeping the original in ``training_run``.

    ``pools`` maps a label (e.g. ``"PPO span 0.8-1.3 (3 seeds)"``) to the controller labels it pools (e.g. the
    run directories' names of three training seeds); a controller in no pool is left as it is.

    Raises
    ------
    ValueError
        A pooled controller has no rows, or sits in two pools.
    """
    owner: dict[str, str] = {}
    for label, members in pools.items():
        for m in members:
            if m in owner:
                raise ValueError(f"controller {m!r} is in two pools: {owner[m]!r} and {label!r}")
            owner[m] = label
    present = {r["controller"] for r in rows}
    missing = sorted(set(owner) - present)
    if missing:
        raise ValueError(f"pooled controller(s) with no episodes: {', '.join(missing)}; have: {', '.join(sorted(present))}")
    out = []
    for r in rows:
        r = dict(r)
        r["training_run"] = r["controller"] if r["controller"] in owner else r.get("training_run", "")
        r["controller"] = owner.get(r["controller"], r["controller"])
        out.append(r)
    return out


def write_csv(path: Path, rows: list[dict[str, Any]]) -> None:
    """Rows as CSV (columns in first-seen order; the recorded traces are left out)."""
    keys: list[str] = []
    for r in rows:
        for k in r:
            if k not in keys and k != "trace":
                keys.append(k)
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)


def read_episodes(path: Path) -> list[dict[str, Any]]:
    """Rows of an ``episodes.csv`` with numbers and booleans parsed back."""
    rows = []
    with path.open() as fh:
        for r in csv.DictReader(fh):
            out: dict[str, Any] = {}
            for k, v in r.items():
                if v in ("True", "False"):
                    out[k] = v == "True"
                    continue
                try:
                    out[k] = int(v)
                except ValueError:
                    try:
                        out[k] = float(v)
                    except ValueError:
                        out[k] = v
            out["controller"] = str(r["controller"])
            out["observer"] = str(r["observer"])
            rows.append(out)
    return rows


def _row_label(r: dict[str, Any]) -> str:
    runs = int(r.get("training_runs", 1))
    return r["controller"] + (f" ({runs} training seeds)" if runs > 1 else "")


def markdown_table(summary: list[dict[str, Any]]) -> str:
    """The Markdown table of the summary (the README shows it)."""
    head = (
        "| controller | observer | success | overspeed trips | cost rate | trip time / oracle | energy kJ/(t km) "
        "| viol/km speed | adhesion | rollback | sway | stall | mass err % | slope err deg |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    )

    def f(x: float, nd: int = 3) -> str:
        return "n/a" if not math.isfinite(x) else f"{x:.{nd}f}"

    lines = []
    for r in summary:
        label = _row_label(r)
        lines.append(
            f"| {label} | {r['observer']} | {100 * r['success_rate']:.0f} % | {r['overspeed_trips']}/{r['episodes']} "
            f"| {r['cost_rate']:.2e} | {f(r['trip_time_vs_oracle'], 3)} | {f(r['energy_kj_per_tkm'], 0)} "
            f"| {f(r['viol_per_km/speed_limit'], 1)} | {f(r['viol_per_km/adhesion'], 1)} | {f(r['viol_per_km/rollback'], 1)} "
            f"| {f(r['viol_per_km/sway'], 1)} | {f(r['viol_per_km/stall'], 1)} | {f(r['mass_err_pct'], 1)} | {f(r['slope_err_deg'], 2)} |"
        )
    return head + "\n".join(lines) + "\n"


def markdown_ci_table(summary: list[dict[str, Any]]) -> str:
    """The compact table with 95 % intervals (:func:`summarise`'s: Wilson for the rates of one policy, a two-level
    bootstrap for pooled training seeds; bootstrap over tracks, and seeds, for the trip-time IQM)."""
    lines = ["| controller | observer | success (95 % CI) | overspeed trips (95 % CI) | trip time / oracle, IQM (95 % CI) |",
             "|---|---|---|---|---|"]

    def pct(x: float) -> str:
        return "n/a" if not math.isfinite(x) else f"{100 * x:.0f}"

    for r in summary:
        if r["controller"] == "oracle":
            continue
        t = r.get("trip_time_iqm", float("nan"))
        tt = "n/a" if not math.isfinite(t) else (
            f"{t:.3f} ({r['trip_time_iqm_lo']:.3f}–{r['trip_time_iqm_hi']:.3f})")
        label = _row_label(r)
        lines.append(
            f"| {label} | {r['observer']} | {100 * r['success_rate']:.0f} % ({pct(r['success_lo'])}–"
            f"{pct(r['success_hi'])} %) | {r['overspeed_trips']}/{r['episodes']} ({pct(r['trip_rate_lo'])}–"
            f"{pct(r['trip_rate_hi'])} %) | {tt} |")
    return "\n".join(lines) + "\n"


__all__ = ["DEFAULT_OBSERVERS", "RULES", "markdown_ci_table", "markdown_table", "pool_rows", "rate_interval",
           "read_episodes", "summarise", "write_csv"]
