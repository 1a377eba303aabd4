#!/usr/bin/env python
"""How the episodes of ``uuom-evaluate`` runs end, per controller (per training seed in a pooled merge): arrived,
overspeed trip, overrun, stopped short at the start / near the station / elsewhere, ... (:mod:`agents.episode_endings`).
``--by-mass`` adds arrivals per train-mass band, with the median trip time over the oracle's where the file holds
oracle rows.

Usage::

    python scripts/episode_endings.py results/rl/traction_exploration/eval/ppo_ceiling_5seeds/episodes.csv
    python scripts/episode_endings.py results/rl/near_tanh/eval/pooled_6seeds/episodes.csv --by-mass
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from agents.episode_endings import MASS_BAND_EDGES_T, ending_counts, endings_markdown, mass_band_markdown
from agents.evaluation_table import read_episodes


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("episodes", type=Path, nargs="+", help="episodes.csv files of uuom-evaluate runs or merges")
    ap.add_argument("--controllers", nargs="*", default=None, help="only these (controller or training run names)")
    ap.add_argument("--by-mass", action="store_true", help="also arrivals per train-mass band (and trip time / oracle)")
    ap.add_argument("--mass-edges-t", type=float, nargs="+", default=list(MASS_BAND_EDGES_T),
                    help="band edges in t for --by-mass (default: %(default)s)")
    args = ap.parse_args(argv)
    rows = []
    for path in args.episodes:
        if not path.is_file():
            ap.error(f"{path}: no such file")
        rows.extend(read_episodes(path))
    counts = ending_counts(rows)
    if args.controllers:
        missing = [c for c in args.controllers if c not in counts]
        if missing:
            ap.error(f"no episodes of {', '.join(missing)} (have: {', '.join(counts)})")
        counts = {c: counts[c] for c in args.controllers}
    print(endings_markdown(counts))
    if args.by_mass:
        try:
            print("\n" + mass_band_markdown(rows, args.mass_edges_t, names=counts))
        except ValueError as exc:
            ap.error(str(exc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
