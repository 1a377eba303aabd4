#!/usr/bin/env python
"""Paired comparison of trip times on the same held-out tracks: controller(s) against a reference controller.

Reads the ``episodes.csv`` of a ``uuom-evaluate`` run or merge (or several, e.g. the reference's and the policies'), takes for every track (episode seed) the ratio of
trip times ``controller / reference`` (both arrived), one row per controller (several controllers = training seeds
of one policy), and prints on how many tracks the seeds' mean ratio is below 1, the mean and median ratio with a
95 % bootstrap interval over seeds and tracks (:func:`agents.statistics.bootstrap_ci`), and the mean ratio on heavy
trains.

``--reference-from FILE`` reads the reference controller from that file only, and the controllers from the others:
for the same controller run under two env configurations (e.g. other observer options), whose rows carry the same
name.

Usage::

    python scripts/paired_ratio.py runs/span_now_merged/episodes.csv --reference rule-based \\
        --controllers ppo_bare_span_08_13_300k_s0 ppo_bare_span_08_13_300k_s1 ppo_bare_span_08_13_300k_s2
    python scripts/paired_ratio.py results/rl/offline_observer_in_loop/rb_offline/episodes.csv \\
        --reference-from results/rl/offline_observer_in_loop/rb_env/episodes.csv --controllers rule-based
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from agents.evaluation_table import read_episodes
from agents.statistics import bootstrap_ci


def _is(r: dict, name: str) -> bool:
    # a pooled merge keeps each seed's run name in training_run; otherwise the controller's basename
    return name in (Path(str(r["controller"])).name, str(r.get("training_run") or ""))


def _trip_times(rows: list[dict], name: str) -> dict[int, tuple[float, float]]:
    """``seed -> (trip time s, mass kg)`` of the arrived episodes of controller (or training run) ``name``."""
    mine = [r for r in rows if _is(r, name)]
    if not mine:
        raise SystemExit(f"no episodes of controller {name!r}")
    return {int(r["seed"]): (float(r["trip_time_s"]), float(r["mass_kg"])) for r in mine if r["success"]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("episodes", type=Path, nargs="+", help="episodes.csv of an evaluation or merge (several: concatenated)")
    ap.add_argument("--reference", default="rule-based")
    ap.add_argument("--reference-from", type=Path, default=None, metavar="FILE",
                    help="read the reference from this episodes.csv only (the controllers from the others)")
    ap.add_argument("--controllers", nargs="+", required=True, help="one controller, or its training seeds")
    ap.add_argument("--heavy-kg", type=float, default=28_000.0, help="mass above which a train counts as heavy")
    args = ap.parse_args(argv)
    missing = [str(p) for p in [*args.episodes, *([args.reference_from] if args.reference_from else [])] if not p.is_file()]
    if missing:
        ap.error(f"no such episodes file: {', '.join(missing)}")
    rows = [r for path in args.episodes for r in read_episodes(path)]
    ref = _trip_times(read_episodes(args.reference_from) if args.reference_from else rows, args.reference)
    runs = [_trip_times(rows, c) for c in args.controllers]
    tracks = sorted(set(ref).intersection(*runs))
    ratio = np.array([[run[k][0] / ref[k][0] for k in tracks] for run in runs])  # (seeds, tracks)
    heavy = np.array([ref[k][1] > args.heavy_kg for k in tracks])
    per_track = ratio.mean(axis=0)
    lo, hi = bootstrap_ci(ratio, np.mean)
    mlo, mhi = bootstrap_ci(ratio, np.median)
    where = f" of {args.reference_from}" if args.reference_from else ""
    print(f"{len(runs)} run(s) vs {args.reference}{where} on {len(tracks)} tracks both arrived")
    print(f"  faster on {int((per_track < 1).sum())}/{len(tracks)} tracks (mean over runs)")
    print(f"  mean ratio {ratio.mean():.3f} (95 % CI {lo:.3f}-{hi:.3f}), median {np.median(ratio):.3f} "
          f"({mlo:.3f}-{mhi:.3f})")
    if heavy.any():
        print(f"  trains above {args.heavy_kg / 1000:g} t ({int(heavy.sum())} tracks): mean ratio "
              f"{ratio[:, heavy].mean():.3f}; per run " + ", ".join(f"{r[heavy].mean():.3f}" for r in ratio))
    return 0


if __name__ == "__main__":
    sys.exit(main())
