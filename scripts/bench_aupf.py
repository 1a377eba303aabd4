"""Time the AUPF slip/radius filter per sensor sample.

Usage::

    python scripts/bench_aupf.py [--particles 32 64 128] [--samples 10000] [--repeat 3]

Feeds a seeded input stream (a train at ~1 m/s on worn wheels with a little creep slip and encoder noise) through
``AUPFEstimator.update`` one sample at a time, as the environment does, and reports the best of ``--repeat`` runs as
CPU microseconds per sample (``time.process_time``) and the real-time factor at 200 Hz. Run it with
``OMP_NUM_THREADS=1`` for one core.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from estimators.aupf import AUPFEstimator
from uuom_core.vehicle import DEFAULT_VEHICLE


def input_stream(n: int, seed: int = 0) -> tuple[list[float], list[float], list[float]]:
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 200.0
    speed = 1.0 + 0.1 * np.sin(0.3 * t)
    radius = DEFAULT_VEHICLE.drive_wheel_radius_m - 0.004
    slip = 0.003 + 0.002 * np.sin(0.1 * t)
    omega = speed / (radius * (1.0 - slip))
    torque = 4000.0 + 500.0 * np.sin(0.2 * t) + 20.0 * rng.standard_normal(n)
    return (
        torque.tolist(),
        (speed + 0.01 * rng.standard_normal(n)).tolist(),
        (omega + 0.02 * rng.standard_normal(n)).tolist(),
    )


def time_filter(n_particles: int, n_samples: int, repeat: int) -> float:
    tq, sp, om = input_stream(n_samples)
    best = math.inf
    for _ in range(repeat):
        est = AUPFEstimator(n_particles=n_particles)
        update = est.update
        nan = math.nan
        t0 = time.process_time()
        for i in range(n_samples):
            update(tq[i], sp[i], nan, 0.005, om[i])
        best = min(best, time.process_time() - t0)
    return best / n_samples


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--particles", type=int, nargs="+", default=[32, 64, 128])
    parser.add_argument("--samples", type=int, default=10_000)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    print(f"{'particles':>9} {'us/sample':>10} {'x real time @200 Hz':>20}")
    for m in args.particles:
        per = time_filter(m, args.samples, args.repeat)
        print(f"{m:>9d} {per * 1e6:>10.1f} {1.0 / (200.0 * per):>20.1f}")


if __name__ == "__main__":
    main()
