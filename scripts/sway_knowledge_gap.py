#!/usr/bin/env python
"""What does knowing the load's swing buy, and how much of it does the chain-length bank get? ``fused`` and
``dffrls-aekf`` with one fixed pendulum (the vehicle file's 2 m chains, damping ratio 0.05), with their default
chain-length bank (0.7-1.4x the file's chains, weighted by the force-balance evidence; session 19), and given each
run's true chain length and damping (one pendulum: an oracle, not an estimator).

Both worlds draw the swing at random (plant 1.5-3.0 m, damping 0.03-0.10; point mass 1.5-3.5 m, 0.03-0.15; the
truth is in each trace's ``meta``). Runs: the tuning runs (plant 1000-1015) and the first random runs of both worlds
of :mod:`uuom_gym.sim.protocol_runs`.

Usage::

    python scripts/sway_knowledge_gap.py --runs 40 [--workers 2] [--figure results/estimation/chain_identification.png]

Prints, per estimator, world and swing model, the median / 90th percentile / max over runs of the maximum mass error
after 10 s and the median / 90th percentile of the train-slope RMSE; draws the bank's chain length at the end of each
run (the evidence-weighted length of the geometry bank's first member) against the true one.
"""

from __future__ import annotations

import argparse
import multiprocessing
import sys
from typing import Any

import numpy as np

from estimators.metrics import error_after_settling, train_slope_deg
from estimators.registry import get_class
from uuom_gym.sim.protocol_runs import RunSpec, make_run

MODELS = ("fixed 2 m, 0.05", "chain-length bank (default)", "true chain + damping")


def _options(model: str, meta: dict[str, str]) -> dict[str, Any]:
    if model == MODELS[0]:
        return {"chain_length_factors": ()}
    if model == MODELS[1]:
        return {}
    return {"chain_length_factors": (), "chain_length_m": float(meta["chain_m"]),
            "sway_damping_ratio": float(meta["sway_damping"])}


def _score(job: tuple[str, str, RunSpec]) -> list[tuple[str, str, str, float, float, float, float]]:
    """One row per swing model: (estimator, set, model, mass max %, slope RMSE °, true chain m, chain m at the end
    (the first member's evidence-weighted length; the told length for one pendulum))."""
    name, label, spec = job
    trace = make_run(spec)
    t = trace["t_s"]
    slope = train_slope_deg(trace)
    rows = []
    for model in MODELS:
        est = get_class(name)(**_options(model, trace.meta))
        s = est.run(trace)
        mass = error_after_settling(t, s.mass_kg, trace["mass_kg"], 10.0, relative=True).max_abs
        member = getattr(est, "members", [est])[0]
        rows.append((name, label, model, mass, error_after_settling(t, s.slope_deg, slope, 10.0).rmse,
                     float(trace.meta["chain_m"]), member.chain_length_estimate_m))
    return rows


def _figure(rows: list[tuple], path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = sorted({r[0] for r in rows})
    fig, axes = plt.subplots(1, len(names), figsize=(5.2 * len(names), 4.4), squeeze=False)
    for ax, name in zip(axes[0], names):
        for world, marker in (("plant", "s"), ("point", "o")):
            pts = np.array([(r[5], r[6]) for r in rows
                            if r[0] == name and r[2] == MODELS[1] and r[1].startswith(world)])
            if len(pts):
                ax.scatter(pts[:, 0], pts[:, 1], marker=marker, alpha=0.7, label=f"{world} runs (n={len(pts)})")
        lim = (1.3, 3.6)
        ax.plot(lim, lim, "k--", lw=0.8, label="estimate = truth")
        ax.axhspan(1.4, 2.8, color="0.9", zorder=0, label="the bank's span (1.4-2.8 m)")
        ax.set(xlim=lim, ylim=lim, xlabel="true chain length (m)", ylabel="bank's chain length at the end (m)",
               title=f"{name}: the chains from the force balance")
        ax.legend(fontsize=8, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=40, help="random runs per world (plus the 16 tuning runs)")
    ap.add_argument("--estimators", nargs="+", default=["fused", "dffrls-aekf"])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--figure", default="", help="PNG of the bank's chain length against the truth")
    args = ap.parse_args(argv)
    sets = {
        "tuning (plant 1000-1015)": [RunSpec("plant", f"plant-{i}", i, i, "plant") for i in range(1000, 1016)],
        f"plant 0-{args.runs - 1}": [RunSpec("plant", f"plant-{i:03d}", i, i, "plant") for i in range(args.runs)],
        f"point mass 0-{args.runs - 1}": [RunSpec("point", f"point-{i:03d}", i, i, "point") for i in range(args.runs)],
    }
    jobs = [(name, label, spec) for name in args.estimators for label, specs in sets.items() for spec in specs]
    with multiprocessing.Pool(max(1, args.workers)) as pool:
        rows = [r for rs in pool.map(_score, jobs) for r in rs]
    print("| estimator | runs | swing model | mass max error after 10 s %: median / p90 / max "
          "| slope RMSE °: median / p90 |")
    print("| --- | --- | --- | --- | --- |")
    for name in args.estimators:
        for label in sets:
            for model in MODELS:
                e = np.array([(r[3], r[4]) for r in rows if r[0] == name and r[1] == label and r[2] == model])
                m, sl = e[:, 0], e[:, 1]
                print(f"| `{name}` | {label} | {model} | {np.median(m):.1f} / {np.percentile(m, 90):.1f} / "
                      f"{m.max():.1f} | {np.median(sl):.2f} / {np.percentile(sl, 90):.2f} |")
    if args.figure:
        _figure([r for r in rows if not r[1].startswith("tuning")], args.figure)
    return 0


if __name__ == "__main__":
    sys.exit(main())
