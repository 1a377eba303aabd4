#!/usr/bin/env python
"""How good must an estimator be: trip rate and trip time of a controller against an injected mass or slope error
(the oracle observer plus a set error). Logic and output files: :mod:`agents.sensitivity`.

Example::

    python scripts/sensitivity.py --episodes 100 --workers 2 --out results/sensitivity
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

from agents.sensitivity import (DEFAULT_MASS_ERRORS, DEFAULT_SLOPE_ERRORS_DEG, SensitivityConfig, markdown, rebuild,
                                run_sensitivity)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python scripts/sensitivity.py", description=__doc__.splitlines()[0])
    p.add_argument("--controller", default="rule-based", help="controller spec (default rule-based)")
    p.add_argument("--mass-errors", type=float, nargs="+", default=list(DEFAULT_MASS_ERRORS),
                   help="relative mass errors (default: ±0.05 ±0.1 ±0.2 ±0.3)")
    p.add_argument("--slope-errors-deg", type=float, nargs="+", default=list(DEFAULT_SLOPE_ERRORS_DEG),
                   help="slope errors in degrees (default: ±0.5 ±1 ±2 ±3)")
    p.add_argument("--episodes", type=int, default=100)
    p.add_argument("--workers", type=int, default=1)
    p.add_argument("--env-kwargs", type=json.loads, default={}, help="JSON dict passed to gym.make")
    p.add_argument("--out", type=Path, default=Path("results/sensitivity"))
    p.add_argument("--quiet", action="store_true")
    p.add_argument("--rebuild", action="store_true",
                   help="recompute summary and figure from OUT/episodes.csv of an earlier run (no episodes run)")
    args = p.parse_args(argv)
    if args.episodes < 1 or args.workers < 1:
        p.error("--episodes and --workers must be >= 1")
    cmd = " ".join(["python scripts/sensitivity.py"] + [shlex.quote(a) for a in (argv or sys.argv[1:])])
    config = SensitivityConfig(
        controller=args.controller, mass_errors=args.mass_errors, slope_errors_deg=args.slope_errors_deg,
        episodes=args.episodes, workers=args.workers, env_kwargs=args.env_kwargs, out=args.out, command=cmd)
    summary = rebuild(config) if args.rebuild else run_sensitivity(config, progress=not args.quiet)
    print(markdown(summary))
    return 0


if __name__ == "__main__":
    sys.exit(main())
