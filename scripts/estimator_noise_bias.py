#!/usr/bin/env python
"""Signed mass error of an estimator on the point-mass scenarios, with chosen sensor imperfections scaled: is there a
bias that grows with the sensors' noise, and which sensor carries it?

The quick check (``scripts/estimator_quick_check.py``) scores the maximum |error|; a bias shows only in the sign. This
runs the eight point-mass scenarios × sensor seeds 0..N-1 with every imperfection times ``--sensor-scale K``, and on
top of that the named fields of :class:`uuom_gym.sim.point_mass.PointMassSensors` times their own factor
(``--scale-fields '{"speed_noise_std_mps": 3}'``), and prints the mean / median signed mass error (%) at 10, 30 and
59 s, the share of runs below the truth at 30 s, and the median / p90 / max of the max |error| after 10 s.

Usage::

    python scripts/estimator_noise_bias.py --sensor-scale 2
    python scripts/estimator_noise_bias.py --scale-fields '{"speed_noise_std_mps": 3, "speed_resolution_mps": 3}'
    python scripts/estimator_noise_bias.py --estimator dffrls-aekf --options '{"chain_length_m": 0.0}'
    python scripts/estimator_noise_bias.py --tuning-runs 100 --world plant

``--tuning-runs N`` scores the protocol's runs with seeds 1000..1000+N-1 of ``--world`` instead (none of them an
evaluation run; their sensors are drawn per run): the signed error at 30 s, split at the median of the encoder noise
read from each trace (a robust σ of consecutive-sample differences): does the noisier half sit lower?
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import sys
from typing import Any, Callable

import numpy as np

import estimators
from uuom_gym.sim.point_mass import (POINT_MASS_SCENARIOS, PointMassError, PointMassSensors, simulate_point_mass,
                                     with_options, with_sensor_scale)
from uuom_gym.sim.sensor_factors import scale_sensor_fields

TIMES_S = (10.0, 30.0, 59.0)


def signed_errors(job: tuple[str, int, float, dict[str, float], str, dict[str, Any]]) -> list[float]:
    """One scenario run: the signed mass error (%) at :data:`TIMES_S`, then the max |error| after 10 s."""
    scenario, seed, scale, per_field, name, options = job
    sc = with_sensor_scale(scenario, scale)
    sc = with_options(sc, sensors=scale_sensor_fields(sc.sensors, per_field))
    tr = simulate_point_mass(sc, seed=seed)
    s = estimators.make(name, **options).run(tr)
    t = tr["t_s"]
    err = (s.mass_kg / tr["mass_kg"] - 1.0) * 100.0
    at = [float(err[min(int(np.searchsorted(t, x)), len(t) - 1)]) for x in TIMES_S]
    return at + [float(np.max(np.abs(err[t >= 10.0])))]


def encoder_noise_mps(speed_mps: np.ndarray) -> float:
    """The encoder's white noise read from a trace: a robust σ (1.4826 × median absolute deviation) of the
    consecutive-sample differences, over √2."""
    d = np.diff(speed_mps)
    d = d[np.isfinite(d)]
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / np.sqrt(2.0))


def tuning_run_errors(job: tuple[str, int, str, dict[str, Any]]) -> list[float]:
    """One protocol run (``world``, ``seed``): the signed mass error (%) at 30 s and the encoder noise read from it."""
    from uuom_gym.sim.protocol_runs import RunSpec, make_run

    world, seed, name, options = job
    tr = make_run(RunSpec(world, f"{world}-{seed}", seed, seed, world))
    s = estimators.make(name, **options).run(tr)
    t = tr["t_s"]
    i = min(int(np.searchsorted(t, 30.0)), len(t) - 1)
    return [float((s.mass_kg[i] / tr["mass_kg"][i] - 1.0) * 100.0), encoder_noise_mps(tr["speed_mps"])]


def _map(fn: Callable[[Any], list[float]], jobs: list, workers: int) -> np.ndarray:
    """``fn`` over ``jobs``, in a pool of ``workers`` processes when more than one; rows as an array."""
    if workers > 1:
        with multiprocessing.Pool(workers) as pool:
            return np.array(pool.map(fn, jobs))
    return np.array([fn(j) for j in jobs])


def _tuning_report(args: argparse.Namespace, options: dict[str, Any]) -> None:
    jobs = [(args.world, 1000 + i, args.estimator, options) for i in range(args.tuning_runs)]
    r = _map(tuning_run_errors, jobs, args.workers)
    rows = r
    quiet = r[:, 1] <= np.median(r[:, 1])
    print(f"{args.estimator} {json.dumps(options)}, {args.world} runs 1000-{999 + len(rows)}: signed mass error % at "
          f"30 s mean {r[:, 0].mean():+.2f}, median {np.median(r[:, 0]):+.2f}; runs with the encoder noise at or "
          f"below / above its median ({np.median(r[:, 1]):.4f} m/s; range {r[:, 1].min():.4f}-{r[:, 1].max():.4f}): "
          f"mean {r[quiet, 0].mean():+.2f} / {r[~quiet, 0].mean():+.2f}, median {np.median(r[quiet, 0]):+.2f} / "
          f"{np.median(r[~quiet, 0]):+.2f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--estimator", default="dffrls-aekf")
    ap.add_argument("--options", default="{}", help="JSON object of estimator options")
    ap.add_argument("--sensor-scale", type=float, default=1.0, metavar="K", help="every imperfection times K")
    ap.add_argument("--scale-fields", default="{}", help="JSON object: PointMassSensors field -> factor (after K)")
    ap.add_argument("--seeds", type=int, default=10, help="sensor seeds 0..N-1 per scenario")
    ap.add_argument("--scenarios", nargs="*", default=None, help="default: all eight")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--tuning-runs", type=int, default=0, metavar="N",
                    help="score the protocol's runs 1000..1000+N-1 of --world instead of the scenarios")
    ap.add_argument("--world", choices=("plant", "point"), default="plant")
    args = ap.parse_args(argv)
    try:
        options = json.loads(args.options)
        per_field = json.loads(args.scale_fields)
    except json.JSONDecodeError as exc:
        ap.error(f"--options / --scale-fields must be JSON objects: {exc}")
    if not isinstance(options, dict) or not isinstance(per_field, dict):
        ap.error("--options / --scale-fields must be JSON objects")
    try:
        scale_sensor_fields(PointMassSensors(), per_field)
    except ValueError as exc:
        ap.error(f"--scale-fields: {exc}")
    try:
        with_sensor_scale(POINT_MASS_SCENARIOS["pm-section1"], args.sensor_scale)  # the runs' own check, before any run
    except PointMassError as exc:
        ap.error(f"--sensor-scale: {exc}")
    scenarios = args.scenarios or list(POINT_MASS_SCENARIOS)
    bad = sorted(set(scenarios) - set(POINT_MASS_SCENARIOS))
    if bad:
        ap.error(f"unknown scenario(s) {bad}; choose from {sorted(POINT_MASS_SCENARIOS)}")
    if args.seeds < 1:
        ap.error("--seeds must be >= 1")
    if args.tuning_runs < 0:
        ap.error("--tuning-runs must be >= 0")
    estimators.make(args.estimator, **options)  # unknown estimator or option: refused before any run
    if args.tuning_runs:
        _tuning_report(args, options)
        return 0
    jobs = [(sc, seed, args.sensor_scale, per_field, args.estimator, options)
            for sc in scenarios for seed in range(args.seeds)]
    r = _map(signed_errors, jobs, args.workers)
    rows = r
    at = " / ".join(f"{x:g}" for x in TIMES_S)
    print(f"{args.estimator} {json.dumps(options)}, sensors x{args.sensor_scale:g} {json.dumps(per_field)}, "
          f"{len(rows)} runs: signed mass error % at {at} s mean "
          f"{' / '.join(f'{x:+.2f}' for x in r[:, :3].mean(0))}, median "
          f"{' / '.join(f'{x:+.2f}' for x in np.median(r[:, :3], 0))}; below the truth at 30 s "
          f"{(r[:, 1] < 0).mean():.0%}; max |error| after 10 s median / p90 / max "
          f"{' / '.join(f'{x:.2f}' for x in np.percentile(r[:, 3], [50, 90, 100]))}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
