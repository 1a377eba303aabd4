"""How evaluation episodes end, counted per controller: the failures behind a success rate.

A ``stopped_short`` ending (no progress for the env's idle limit) is split by where the train stood, because the two
places mean different things for a learned policy (docs/rl.md §27, §30): at the start it never drove off (the start
trap: a mean action too weak to move the train, the exploration noise having done it in training); near the station
it stopped before the ±3 m window and did not creep on.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

START_ZONE_M = 5.0
"""A train that stopped short within this distance of its start never drove off."""
STATION_ZONE_M = 10.0
"""A train that stopped short within this distance before the station stopped too early."""
ENDINGS: tuple[str, ...] = (
    "arrived", "overspeed_trip", "overrun", "stopped_short_at_start", "stopped_short_at_station",
    "stopped_short_elsewhere", "rolled_back", "ran_off_start", "time_limit",
)


def ending(row: Mapping[str, Any]) -> str:
    """The ending of one ``episodes.csv`` row: its ``termination``, a ``stopped_short`` split by where it stood."""
    term = str(row["termination"])
    if term != "stopped_short":
        return term
    distance_m, length_m = float(row["distance_m"]), float(row["track_length_m"])
    if distance_m < START_ZONE_M:
        return "stopped_short_at_start"
    return "stopped_short_at_station" if length_m - distance_m < STATION_ZONE_M else "stopped_short_elsewhere"


def run_name(row: Mapping[str, Any]) -> str:
    """The name a row is counted under: its ``training_run`` in a pooled merge (so each seed keeps its row), else its
    ``controller``."""
    return str(row.get("training_run") or row["controller"])


def ending_counts(rows: Iterable[Mapping[str, Any]]) -> dict[str, Counter]:
    """``{controller: Counter(ending)}`` in the order controllers first appear, each row under :func:`run_name`."""
    out: dict[str, Counter] = {}
    for row in rows:
        out.setdefault(run_name(row), Counter())[ending(row)] += 1
    return out


def endings_markdown(counts: Mapping[str, Counter]) -> str:
    """A markdown table: one row per controller, one column per ending seen anywhere (in :data:`ENDINGS` order,
    unknown endings after)."""
    seen = {e for c in counts.values() for e in c}
    cols = [e for e in ENDINGS if e in seen] + sorted(seen - set(ENDINGS))
    lines = ["| controller | episodes | " + " | ".join(c.replace("_", " ") for c in cols) + " |",
             "|---|---:|" + "---:|" * len(cols)]
    for name, c in counts.items():
        lines.append(f"| {name} | {sum(c.values())} | " + " | ".join(str(c.get(e, 0)) for e in cols) + " |")
    return "\n".join(lines)


MASS_BAND_EDGES_T: tuple[float, ...] = (20.0, 25.0, 28.0, 31.0, 33.0)
"""Train-mass band edges (t) of :func:`mass_band_markdown`: the heavy trains, where bare RL fails (docs/rl.md §37-§38),
get narrow bands."""


def mass_band(mass_kg: float, edges_t: Sequence[float] = MASS_BAND_EDGES_T) -> str:
    """The label of the band ``mass_kg`` falls in: ``"< 20 t"``, ``"20-25 t"``, ..., ``">= 33 t"``."""
    t = float(mass_kg) / 1000.0
    if t < edges_t[0]:
        return f"< {edges_t[0]:g} t"
    for lo, hi in zip(edges_t, edges_t[1:]):
        if t < hi:
            return f"{lo:g}-{hi:g} t"
    return f">= {edges_t[-1]:g} t"


def mass_band_markdown(
    rows: Iterable[Mapping[str, Any]],
    edges_t: Sequence[float] = MASS_BAND_EDGES_T,
    names: Iterable[str] | None = None,
) -> str:
    """A markdown table: per controller (:func:`run_name`) and train-mass band, arrived / episodes and the median trip
    time over the oracle's on the same track (the rows of controller ``oracle``, paired by ``seed``; arrived episodes
    only, omitted without oracle rows). ``names``: only these table rows (the oracle still pairs the trip times)."""
    rows = list(rows)
    if not edges_t or any(float(edges_t[i]) >= float(edges_t[i + 1]) for i in range(len(edges_t) - 1)):
        raise ValueError(f"mass band edges must be increasing, got {list(edges_t)}")
    shown = None if names is None else set(names)
    oracle = {r["seed"]: float(r["trip_time_s"]) for r in rows
              if str(r["controller"]) == "oracle" and r["termination"] == "arrived"}
    labels = [mass_band(0.0, edges_t)] + [mass_band(e * 1000.0, edges_t) for e in edges_t]
    cells: dict[str, dict[str, list]] = {}
    for r in rows:
        name = run_name(r)
        if shown is not None and name not in shown:
            continue
        n_arrived_ratios = cells.setdefault(name, {}).setdefault(mass_band(r["mass_kg"], edges_t), [0, 0, []])
        n_arrived_ratios[0] += 1
        if r["termination"] == "arrived":
            n_arrived_ratios[1] += 1
            if r["seed"] in oracle and oracle[r["seed"]] > 0.0 and math.isfinite(float(r["trip_time_s"])):
                n_arrived_ratios[2].append(float(r["trip_time_s"]) / oracle[r["seed"]])
    lines = ["| controller | " + " | ".join(labels) + " |", "|---|" + "---:|" * len(labels)]
    for name, bands in cells.items():
        out = []
        for label in labels:
            n, arrived, ratios = bands.get(label, (0, 0, []))
            text = f"{arrived}/{n}" if n else "-"
            if ratios:
                text += f", {float(np.median(ratios)):.2f}x"
            out.append(text)
        lines.append(f"| {name} | " + " | ".join(out) + " |")
    return "\n".join(lines)


__all__ = [
    "ENDINGS",
    "MASS_BAND_EDGES_T",
    "START_ZONE_M",
    "STATION_ZONE_M",
    "ending",
    "ending_counts",
    "endings_markdown",
    "mass_band",
    "mass_band_markdown",
    "run_name",
]
