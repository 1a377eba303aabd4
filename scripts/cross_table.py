#!/usr/bin/env python
"""The cross table of the per-observer study: a policy trained with observer A driven with observer B.

Reads the ``summary.csv`` of a ``uuom-evaluate --merge`` that holds the oracle reference and policies run under
several observers, finds each policy's training observer in its run directory's ``config.json``, and writes a
matrix (rows: trained with, columns: run with) of overspeed trips and trip time / oracle (IQM).

Usage::

    python scripts/cross_table.py runs/obs/cross/summary.csv --runs results/rl/policies/ppo_bare_span_08_13_300k_s0 \\
        runs/obs/span13_oracle_s1 --out results/agents/observer_study_ppo/cross.md \\
        --note "docs/rl.md §10 and §16; the oracle-trained policy as span13_oracle_s1, shipped as policies/oracle_s1"
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
from pathlib import Path


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("summary", type=Path, help="summary.csv of the merged evaluation")
    ap.add_argument("--runs", nargs="+", type=Path, required=True, help="the policies' run directories")
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--note", default="",
                    help="said after the source in the first line (e.g. where the policies are shipped)")
    args = ap.parse_args(argv)
    with open(args.summary) as fh:
        rows = list(csv.DictReader(fh))
    trained = {r.name: json.loads((r / "config.json").read_text())["observer"] for r in args.runs}
    observers = list(dict.fromkeys(r["observer"] for r in rows if r["controller"] in trained))
    note = f" ({args.note})" if args.note else ""
    lines = [f"Cross table from `{args.summary}`{note}: rows = the observer a policy was trained with "
             "(its run directory),",
             "columns = the observer it drives with; cells = overspeed trips / episodes, trip time / oracle IQM.", "",
             "| trained with (policy) | " + " | ".join(f"run with `{o}`" for o in observers) + " |",
             "|---|" + "---|" * len(observers)]
    for name, obs in trained.items():
        cells = []
        for o in observers:
            r = next((x for x in rows if x["controller"] == name and x["observer"] == o), None)
            if r is None:
                cells.append("–")
                continue
            iqm = float(r["trip_time_iqm"])
            mark = "**" if o == obs else ""
            cells.append(f"{mark}{r['overspeed_trips']}/{r['episodes']}, "
                         f"{'n/a' if math.isnan(iqm) else f'{iqm:.3f}'}{mark}")
        lines.append(f"| `{obs}` ({name}) | " + " | ".join(cells) + " |")
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
