#!/usr/bin/env python
"""Do the estimators hold on vehicles they were not tuned on? The protocol's random runs of both worlds on seeded
sister vehicles.

Every setting of ``dffrls-aekf`` and ``fused`` was chosen on plant runs of the spec's vehicle. This script draws
sister vehicles (every field of the vehicle file within ×/÷ ``--spread`` of the project's,
:func:`uuom_core.vehicle_variants.sister_vehicles`), simulates the protocol's first ``--runs`` random runs of each
world on each of them (:func:`uuom_gym.sim.protocol_runs.make_run` with the vehicle: the same draws, the load up to
that vehicle's rated load, the track capped by what it can climb and brake), gives each estimator that vehicle's
file (as ``uuom-estimate --vehicle`` does) and its default options, and prints per world the mass max error after
10 s (%) and the slope RMSE against the train-averaged slope (°), median / p90 / p95, on the project's vehicle and on
the sister vehicles pooled. No setting is re-tuned.

Usage::

    python scripts/estimator_vehicle_shift.py --vehicles 10 --spread 1.25 --runs 20 --workers 2 \\
        --out results/estimation/vehicle_shift.md
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import shlex
import sys
from pathlib import Path

from estimators.metrics import distribution


def _score(job: tuple[int, int, str, float, int, tuple[str, ...]]) -> list[tuple[int, str, str, float, float]]:
    """``(vehicle index, world, estimator, mass max %, slope train RMSE °)`` of one run on one vehicle."""
    from estimators.protocol import score_trace
    from uuom_core.vehicle import DEFAULT_VEHICLE
    from uuom_core.vehicle_variants import sister_vehicles
    from uuom_gym.sim.protocol_runs import make_run, protocol_runs

    k, index, world, spread, seed, names = job
    vehicle = DEFAULT_VEHICLE if k == 0 else sister_vehicles(seed, k, spread)[k - 1]
    spec = [s for s in protocol_runs(index + 1 if world == "plant" else 0, index + 1 if world == "point" else 0,
                                     paper_seeds=0, fault_seeds=0) if s.index == index][0]
    trace = make_run(spec, vehicle)
    out = []
    for name in names:
        row = score_trace(trace, name, vehicle=vehicle)
        out.append((k, world, name, float(row["mass_max_pct"]), float(row["slope_train_rmse_deg"])))
    return out


def _stats(x: list[float]) -> str:
    d = distribution(x)  # the protocol's statistics (nearest rank), so the rows compare with its tables
    return f"{d['median']:.2f} / {d['p90']:.2f} / {d['p95']:.2f}"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--vehicles", type=int, default=10)
    ap.add_argument("--spread", type=float, default=1.25)
    ap.add_argument("--vehicle-seed", type=int, default=0)
    ap.add_argument("--runs", type=int, default=20, help="random runs per world and vehicle (the protocol's 0..N-1)")
    ap.add_argument("--estimators", default="dffrls-aekf,fused")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", type=Path, default=None, help="also write the table here (Markdown)")
    args = ap.parse_args(argv)

    from estimators.registry import available
    from uuom_core.vehicle_variants import sister_vehicles

    names = tuple(n for n in args.estimators.split(",") if n)
    unknown = [n for n in names if n not in available()]
    if unknown or not names:
        ap.error(f"--estimators: unknown {', '.join(unknown) or '(none given)'}; known: {', '.join(available())}")
    if args.runs < 1 or args.workers < 1 or args.vehicles < 1:
        ap.error("--runs, --workers and --vehicles must be >= 1")
    try:
        vehicles = sister_vehicles(args.vehicle_seed, args.vehicles, args.spread)
    except ValueError as exc:
        ap.error(str(exc))
    jobs = [(k, i, world, args.spread, args.vehicle_seed, names)
            for k in range(len(vehicles) + 1) for world in ("plant", "point") for i in range(args.runs)]
    with mp.Pool(args.workers) as pool:
        rows = [r for rs in pool.imap(_score, jobs, chunksize=2) for r in rs]

    cmd = "python scripts/estimator_vehicle_shift.py " + shlex.join(sys.argv[1:] if argv is None else argv)
    lines = [f"{len(vehicles)} sister vehicles within ×/÷ {args.spread:g} of the project's (vehicle seed "
             f"{args.vehicle_seed}) and the project's vehicle; the protocol's random runs 0..{args.runs - 1} of each "
             f"world on each; default options, each estimator given the run's vehicle file.", f"Command: `{cmd}`", "",
             "| world | estimator | vehicles | runs | mass max error after 10 s %, median / p90 / p95 "
             "| slope RMSE (train-averaged) °, median / p90 / p95 |", "| --- | --- | --- | ---: | --- | --- |"]
    for world in ("plant", "point"):
        for name in names:
            for label, sel in (("the project's", lambda k: k == 0), ("sisters, pooled", lambda k: k > 0)):
                rs = [r for r in rows if r[1] == world and r[2] == name and sel(r[0])]
                lines.append(f"| {world} | `{name}` | {label} | {len(rs)} | {_stats([r[3] for r in rs])} | "
                             f"{_stats([r[4] for r in rs])} |")
    per = ["", "Per sister vehicle, mass max error after 10 s % (median / p95), plant · point:", "",
           "| vehicle | " + " | ".join(f"`{n}`" for n in names) + " |", "| --- |" + " --- |" * len(names)]
    for k, v in enumerate([None, *vehicles]):
        desc = "the project's" if v is None else (f"{k}: {v.empty_mass_kg / 1e3:.1f} t + {v.rated_load_kg / 1e3:.1f} t, "
                                                  f"{v.length_m:.1f} m")
        cells = []
        for name in names:
            parts = []
            for world in ("plant", "point"):
                d = distribution(r[3] for r in rows if r[0] == k and r[1] == world and r[2] == name)
                parts.append(f"{d['median']:.1f} / {d['p95']:.1f}")
            cells.append(" · ".join(parts))
        per.append(f"| {desc} | " + " | ".join(cells) + " |")
    text = "\n".join(lines + per) + "\n"
    print(text)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
