#!/usr/bin/env python
"""Which sensor fault costs an estimator what: the point-mass fault trace taken apart, one fault kind and one
channel at a time, over several sensor seeds.

``pm-sensor-faults`` is the road test with 2 % dropouts, 0.2 % spikes (±4000 N·m, ±0.6 m/s, ±4 m/s²) and the
accelerometer frozen for 3 s. Each variant below keeps the road test's physics and sensor draws (noise, biases: the
fault draws come after them in the simulator) and adds only some of the faults:

``none`` no fault; ``drop:<ch>`` the dropouts of one channel (the other channels' samples restored); ``spike:<ch>``
spikes on one channel only; ``stuck`` the frozen accelerometer; ``all`` the scenario as the protocol runs it.

Usage::

    python scripts/fault_breakdown.py --seeds 10
    python scripts/fault_breakdown.py --configs '[["gates off", "dffrls-aekf", {"accel_jump_mps2": 0}]]'
    python scripts/fault_breakdown.py --protocol-fault spikes --seeds 6

Prints, per configuration and variant, the median and maximum over the seeds of the max |mass error| after 10 s
and each seed's signed error at that maximum (a fault that biases the mass shows as one sign across seeds).

``--protocol-fault KIND`` instead runs the protocol's fault runs of that kind (``dropouts``, ``spikes``,
``bias-drift``, ``stuck``: the road test in both worlds, fault seeds 0..N-1) next to the same runs without the fault,
and prints each one's mass RMSE after 10 s in % per configuration: a fault handled well gives back the clean run.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import sys
from dataclasses import replace
from typing import Any

import numpy as np

from estimators.metrics import error_after_settling
from estimators.registry import get_class
from uuom_core.trace import Trace
from uuom_gym.sim.point_mass import (SENSOR_CHANNELS, PointMassFaults, point_mass_scenario, simulate_point_mass,
                                     with_options)
from uuom_gym.sim.protocol_runs import FAULT_KINDS, make_run, protocol_runs

SCENARIO = "pm-sensor-faults"
DEFAULT_CONFIGS = [["dffrls-aekf", "dffrls-aekf", {}]]


def variants() -> dict[str, PointMassFaults | str]:
    """Variant name -> the faults to simulate (a string ``drop:<ch>``: the dropouts of that channel alone)."""
    full = point_mass_scenario(SCENARIO).faults
    out: dict[str, PointMassFaults | str] = {"none": PointMassFaults()}
    out.update({f"drop:{ch}": f"drop:{ch}" for ch in SENSOR_CHANNELS})
    for ch in SENSOR_CHANNELS:
        scale = {c: (full.spike_scale[c] if c == ch else 0.0) for c in SENSOR_CHANNELS}
        out[f"spike:{ch}"] = PointMassFaults(spike_prob=full.spike_prob, spike_scale=scale)
    out["stuck"] = PointMassFaults(stuck_channel=full.stuck_channel, stuck_start_s=full.stuck_start_s,
                                   stuck_duration_s=full.stuck_duration_s)
    out["all"] = full
    return out


def variant_trace(name: str, seed: int) -> Trace:
    base = point_mass_scenario(SCENARIO)
    v = variants()[name]
    if isinstance(v, PointMassFaults):
        return simulate_point_mass(with_options(base, faults=v), seed=seed)
    channel = v.split(":", 1)[1]
    clean = simulate_point_mass(with_options(base, faults=PointMassFaults()), seed=seed)
    drop = simulate_point_mass(with_options(base, faults=PointMassFaults(dropout_prob=base.faults.dropout_prob)),
                               seed=seed)
    cols = dict(clean.columns)
    cols[channel] = drop[channel]
    return Trace(cols, source=f"{SCENARIO} seed {seed}, {name}", meta=dict(clean.meta))


def _score(job: tuple[str, int, list[list[Any]]]) -> list[float]:
    name, seed, configs = job
    tr = variant_trace(name, seed)
    t, m = tr["t_s"], tr["mass_kg"]
    k = t >= 10.0
    out = []
    for _, est, options in configs:
        err = 100.0 * (get_class(est)(**options).run(tr).mass_kg[k] / m[k] - 1.0)
        out.append(float(err[np.argmax(np.abs(err))]))
    return out


def _score_protocol_fault(job: tuple[Any, list[list[Any]]]) -> tuple[str, list[float], list[float]]:
    spec, configs = job
    rmse: dict[bool, list[float]] = {}
    for faulty in (False, True):
        tr = make_run(spec if faulty else replace(spec, fault=""))
        rmse[faulty] = [error_after_settling(tr["t_s"], get_class(est)(**options).run(tr).mass_kg, tr["mass_kg"],
                                             10.0, relative=True).rmse for _, est, options in configs]
    return spec.name, rmse[False], rmse[True]


def _protocol_fault(kind: str, seeds: int, configs: list[list[Any]], workers: int) -> None:
    specs = [s for s in protocol_runs(0, 0, paper_seeds=0, fault_seeds=seeds) if s.fault == kind]
    with multiprocessing.Pool(max(1, workers)) as pool:
        rows = pool.map(_score_protocol_fault, [(s, configs) for s in specs], chunksize=1)
    for name, clean, faulty in rows:
        print(f"{name:26s} mass RMSE % without the fault / with it: " + " | ".join(
            f"{label} {c:5.2f} / {f:5.2f}" for (label, _, _), c, f in zip(configs, clean, faulty)))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10, help="sensor seeds 0..N-1 (default 10)")
    ap.add_argument("--configs", type=json.loads, default=DEFAULT_CONFIGS,
                    help="JSON list of [label, estimator, {options}] (default: dffrls-aekf)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--protocol-fault", choices=FAULT_KINDS, metavar="KIND",
                    help="the protocol's fault runs of this kind against the same runs without it")
    args = ap.parse_args(argv)
    if args.seeds < 1:
        ap.error(f"--seeds must be >= 1, got {args.seeds}")
    configs = args.configs
    if not isinstance(configs, list) or not all(isinstance(c, list) and len(c) == 3 for c in configs):
        ap.error("--configs must be a JSON list of [label, estimator, {options}]")
    for _, est, options in configs:
        get_class(est)(**options)  # an unknown estimator or option fails here, before any run
    if args.protocol_fault:
        _protocol_fault(args.protocol_fault, args.seeds, configs, args.workers)
        return 0
    names = list(variants())
    jobs = [(n, s, configs) for n in names for s in range(args.seeds)]
    with multiprocessing.Pool(max(1, args.workers)) as pool:
        res = np.array(pool.map(_score, jobs, chunksize=1)).reshape(len(names), args.seeds, len(configs))
    for j, (label, _, _) in enumerate(configs):
        for i, n in enumerate(names):
            e = res[i, :, j]
            print(f"{label:24s} {n:18s} max |mass error| % median {np.median(np.abs(e)):5.2f} max "
                  f"{np.abs(e).max():5.2f} | signed: " + " ".join(f"{x:+5.1f}" for x in e))
        print()
    return 0


if __name__ == "__main__":
    sys.exit(main())
