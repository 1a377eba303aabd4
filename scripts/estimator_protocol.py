#!/usr/bin/env python
"""Generalisation protocol of the estimators (issue 10, item 3): tuned on the plant, judged on other worlds.

Every registered mass/slope estimator runs with its default settings (no re-tuning) on
(a) random runs of the pymunk plant, (b) random runs of the point-mass world, (c) the paper's scenarios, the
station runs and the fixed point-mass scenarios, and the fault runs (:mod:`uuom_gym.sim.protocol_runs`); scores
come from :mod:`estimators.metrics` via :mod:`estimators.protocol`, the tables and figures from
:mod:`estimators.protocol_report`. Deterministic from seeds; per-run rows are cached (``--cache``), so a re-run
only scores estimators whose source changed or that are new.

Usage::

    python scripts/estimator_protocol.py                      # 200 + 200 random runs, paper and fault runs
    python scripts/estimator_protocol.py --quick              # 4 + 4 runs, 1 paper seed, 1 fault seed
    python scripts/estimator_protocol.py --report-only        # tables and figures from the cache (for each
                                                              # estimator the code version with the most runs)

Every estimator is scored on every run (since round 2, session 29: ``ekf``, ``imu-ukf`` and ``mmae`` had been scored
on 50 random runs per world to save CPU; the other 150 per world took them 10 min on 2 cores). ``--slow NAMES``
still scores the named estimators on the first ``--slow-runs`` random runs of each world only (and on all the
fixed and fault runs), for a quick look; the report gives the number of runs behind every row.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

from estimators.protocol import cached_rows, fingerprint, run_protocol, usable_estimators
from estimators.protocol_report import write_report
from uuom_core.vehicle import DEFAULT_VEHICLE
from uuom_gym.sim.protocol_runs import make_run, protocol_runs, runs_fingerprint, true_running_resistance


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plant-runs", type=int, default=200)
    ap.add_argument("--point-runs", type=int, default=200)
    ap.add_argument("--duration-s", type=float, default=60.0, help="length of a random run")
    ap.add_argument("--paper-seeds", type=int, default=3)
    ap.add_argument("--fault-seeds", type=int, default=2)
    ap.add_argument("--settle-s", type=float, default=10.0)
    ap.add_argument("--estimators", default=None, help="comma-separated names (default: every registered one)")
    ap.add_argument("--slow", default="",
                    help="estimators scored on only the first --slow-runs random runs of each world (CPU budget)")
    ap.add_argument("--slow-runs", type=int, default=50)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--cache", default="runs/estimation_protocol/rows.jsonl")
    ap.add_argument("--out", default="results/estimation")
    ap.add_argument("--quick", action="store_true", help="4 + 4 random runs, 1 paper and 1 fault seed")
    ap.add_argument("--report-only", action="store_true", help="no new runs: report what the cache holds")
    args = ap.parse_args(argv)
    if args.quick:
        args.plant_runs, args.point_runs, args.paper_seeds, args.fault_seeds = 4, 4, 1, 1
    os.nice(10)
    names, skipped = usable_estimators(args.estimators.split(",") if args.estimators else None)
    for name in names:
        fingerprint(name)  # now, with the import: describes the code this run uses
    for name, why in skipped.items():
        print(f"# not scored: {name}: {why}", file=sys.stderr)
    specs = protocol_runs(args.plant_runs, args.point_runs, duration_s=args.duration_s,
                          paper_seeds=args.paper_seeds, fault_seeds=args.fault_seeds)
    Path(args.cache).parent.mkdir(parents=True, exist_ok=True)
    slow = [n for n in names if n in set(args.slow.split(","))] if args.slow else []
    fast = [n for n in names if n not in slow]
    few = [s for s in specs if s.group not in ("plant", "point") or s.index < args.slow_runs]
    rows = []
    if args.report_only:
        rows = cached_rows(args.cache, specs, names)
    else:
        for subset, group in ((specs, fast), (few, slow)):
            if group:
                rows += run_protocol(subset, make_run, group, settle_s=args.settle_s, workers=args.workers,
                                     cache=args.cache, world_version=runs_fingerprint(),
                                     progress=lambda m: print(m, flush=True))
    command = "python scripts/estimator_protocol.py " + " ".join(argv if argv is not None else sys.argv[1:])
    if args.report_only:
        command = (f"python scripts/estimator_protocol.py` (rows cached in `{args.cache}`), redrawn with "
                   f"`{command.strip()}")
    paths = write_report(rows, args.out, command=command.strip(), skipped=skipped, settle_s=args.settle_s,
                         mu_by_run={s.name: true_running_resistance(s) for s in specs},
                         mu_file=DEFAULT_VEHICLE.running_resistance)
    for p in paths:
        print(f"wrote {p}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
