#!/usr/bin/env python
"""Drive every controller, unchanged, on seeded sister vehicles (each field within ×/÷ a factor of the project's) and
on the project's own vehicle: does a controller built on one vehicle hold on the next one? (:mod:`agents.vehicle_shift`)

Example (the README's table; ~25 min on 2 cores)::

    python scripts/vehicle_shift.py --vehicles 10 --spread 1.25 --episodes 20 \\
        --controllers rule-based "rule-based@overspeed_gain_per_s=2.5,k_sigma=1.0" \\
            results/rl/policies/ppo_bare_span_08_13_300k_s{0,1,2} results/rl/policies/ppo_bc_ceiling_traction_s{0,1,2} \\
        --pool "PPO span 0.8-1.3=ppo_bare_span_08_13_300k_s0,ppo_bare_span_08_13_300k_s1,ppo_bare_span_08_13_300k_s2" \\
        --pool "PPO + BC, traction=ppo_bc_ceiling_traction_s0,ppo_bc_ceiling_traction_s1,ppo_bc_ceiling_traction_s2" \\
        --out results/agents/vehicle_shift
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from agents.cli import parse_pool
from agents.evaluation import DEFAULT_SEED_BASE


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--controllers", nargs="+", help="as for uuom-evaluate (the oracle is added); required unless "
                    "--report-only")
    ap.add_argument("--observer", default="dffrls-aekf")
    ap.add_argument("--vehicles", type=int, default=10, help="sister vehicles (the project's vehicle is added)")
    ap.add_argument("--spread", type=float, default=1.25, help="each field within x/÷ this factor of the project's")
    ap.add_argument("--vehicle-seed", type=int, default=0)
    ap.add_argument("--vehicle-files", nargs="+", default=[], metavar="TOML",
                    help="drive on these vehicle files instead of drawn sister vehicles")
    ap.add_argument("--episodes", type=int, default=20, help="tracks per vehicle")
    ap.add_argument("--seed-base", type=int, default=DEFAULT_SEED_BASE)
    ap.add_argument("--pool", type=parse_pool, action="append", default=[], metavar="LABEL=CTRL,CTRL,...")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=Path("results/agents/vehicle_shift"))
    ap.add_argument("--report-only", action="store_true",
                    help="rebuild summary.md and the figure from the finished run in --out (its episodes.csv, "
                    "vehicles.json and run.json); no other option is read")
    args = ap.parse_args(argv)

    from agents.evaluation import EvalConfig, check_config
    from agents.vehicle_shift import ShiftConfig, report_vehicle_shift, run_vehicle_shift, shift_tasks

    if args.report_only:
        try:
            report_vehicle_shift(args.out)
        except FileNotFoundError as exc:
            ap.error(f"--report-only: no finished run in {args.out} ({Path(exc.filename).name} missing)")
        return 0
    if not args.controllers:
        ap.error("--controllers is required (unless --report-only)")
    try:  # the controllers and the observer checked as uuom-evaluate checks them, before anything runs
        check_config(EvalConfig(controllers=args.controllers, observers=[args.observer], episodes=args.episodes,
                                seed_base=args.seed_base, workers=args.workers, out=args.out, allow_env_shift=True))
        config = ShiftConfig(controllers=tuple(args.controllers), observer=args.observer, vehicles=args.vehicles,
                             spread=args.spread, vehicle_seed=args.vehicle_seed, episodes=args.episodes,
                             seed_base=args.seed_base, vehicle_files=tuple(args.vehicle_files), pools=dict(args.pool),
                             workers=args.workers, out=args.out,
                             command="python scripts/vehicle_shift.py " + shlex.join(sys.argv[1:] if argv is None
                                                                                       else argv))
        shift_tasks(config)  # draws the vehicles: a bad --spread or --episodes is named here
    except ValueError as exc:
        ap.error(str(exc))
    run_vehicle_shift(config)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
