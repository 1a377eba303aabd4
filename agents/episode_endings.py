"""How evaluation episodes end, counted per controller: the failures behind a success rate.

A ``stopped_short`` ending (no progress for the env's idle limit) is split by where the train stood, because the two
places mean different things for a learned policy (docs/rl.md §27, §30): at the start it never drove off (the start
trap: a mean action too weak to move the train, the exploration noise having done it in training); near the station
it stopped before the ±3 m window and did not creep on.
"""

from __future__ import annotations

from collections import Counter
from typing import Any, Iterable, Mapping

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


def ending_counts(rows: Iterable[Mapping[str, Any]]) -> dict[str, Counter]:
    """``{controller: Counter(ending)}`` in the order controllers first appear; the rows of a pooled merge count
    under their own training run (``training_run``), so each seed keeps its row."""
    out: dict[str, Counter] = {}
    for row in rows:
        name = str(row.get("training_run") or row["controller"])
        out.setdefault(name, Counter())[ending(row)] += 1
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


__all__ = ["ENDINGS", "START_ZONE_M", "STATION_ZONE_M", "ending", "ending_counts", "endings_markdown"]
