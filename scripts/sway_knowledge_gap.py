#!/usr/bin/env python
"""What would knowing the load's swing buy? ``fused`` and ``dffrls-aekf`` with their fixed pendulum (2 m chains,
damping ratio 0.05) against the same estimators given each run's true chain length and damping.

Both worlds draw the swing at random (plant 1.5-3.0 m, damping 0.03-0.10; point mass 1.5-3.5 m, 0.03-0.15; the
truth is in each trace's ``meta``). The "true swing" rows are an oracle, not an estimator: they bound what an
online identification of the swing could gain. Runs: the tuning runs (plant 1000-1015) and the first random runs
of both worlds of :mod:`uuom_gym.sim.protocol_runs`.

Usage::

    python scripts/sway_knowledge_gap.py --runs 40

Prints, per estimator, world and setting, the median / 90th percentile / max over runs of the maximum mass error
after 10 s and the median / 90th percentile of the train-slope RMSE.
"""

from __future__ import annotations

import argparse
import sys

import numpy as np

from estimators.metrics import error_after_settling, train_slope_deg
from estimators.registry import get_class
from uuom_gym.sim.protocol_runs import RunSpec, make_run


def _errors(name: str, trace, true_swing: bool) -> tuple[float, float]:
    opts = {}
    if true_swing:
        opts = {"chain_length_m": float(trace.meta["chain_m"]), "sway_damping_ratio": float(trace.meta["sway_damping"])}
    s = get_class(name)(**opts).run(trace)
    t = trace["t_s"]
    slope = train_slope_deg(trace)
    mass = error_after_settling(t, s.mass_kg, trace["mass_kg"], 10.0, relative=True)
    return mass.max_abs, error_after_settling(t, s.slope_deg, slope, 10.0).rmse


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=40, help="random runs per world (plus the 16 tuning runs)")
    ap.add_argument("--estimators", nargs="+", default=["fused", "dffrls-aekf"])
    args = ap.parse_args(argv)
    sets = {
        "tuning (plant 1000-1015)": [RunSpec("plant", f"plant-{i}", i, i, "plant") for i in range(1000, 1016)],
        f"plant 0-{args.runs - 1}": [RunSpec("plant", f"plant-{i:03d}", i, i, "plant") for i in range(args.runs)],
        f"point mass 0-{args.runs - 1}": [RunSpec("point", f"point-{i:03d}", i, i, "point") for i in range(args.runs)],
    }
    traces = {k: [make_run(s) for s in specs] for k, specs in sets.items()}
    print("| estimator | runs | swing model | mass max error after 10 s %: median / p90 / max | slope RMSE °: median / p90 |")
    print("| --- | --- | --- | --- | --- |")
    for name in args.estimators:
        for label, trs in traces.items():
            for true_swing in (False, True):
                e = np.array([_errors(name, tr, true_swing) for tr in trs])
                m, sl = e[:, 0], e[:, 1]
                print(f"| `{name}` | {label} | {'true chain + damping' if true_swing else 'fixed 2 m, 0.05'} | "
                      f"{np.median(m):.1f} / {np.percentile(m, 90):.1f} / {m.max():.1f} | "
                      f"{np.median(sl):.2f} / {np.percentile(sl, 90):.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
