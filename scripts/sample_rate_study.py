#!/usr/bin/env python
"""Are the estimators the same filter at every sample rate? The point-mass scenarios recorded at several rates.

Every per-sample setting of ``dffrls-aekf`` and ``fused`` was tuned on 200 Hz traces, and a logger may record at
100 Hz or 400 Hz. This script records the fixed point-mass scenarios (:mod:`uuom_gym.sim.point_mass`; the fault
trace is left out) at each rate with the sensors' **noise density** held (each channel's per-sample noise sigma times
``sqrt(rate / 200)``: the same sensor read more or less often; bias, quantisation and vibration as they are), runs
each estimator on the same traces twice -- with the settings for the trace's own step (``rate_from_trace=True``,
opt-in since session 48) and with the 200 Hz ones (``rate_from_trace=False``, the default) -- and prints,
per estimator, rate and variant, the pooled median / p90 / max over scenarios x seeds of the mass max error after
10 s and the median / p95 of the slope RMSE. ``--perfect`` records with perfect sensors instead (no noise, bias,
quantisation or vibration): what is left then is the filter's own dependence on the rate.

Usage::

    python scripts/sample_rate_study.py --rates 100,200,400 --seeds 6 [--perfect] [--estimators dffrls-aekf,fused]
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import replace

import numpy as np

from estimators.registry import make
from uuom_core.trace import Trace
from uuom_gym.sim.point_mass import (POINT_MASS_SCENARIOS, PointMassSensors, point_mass_scenario,
                                     simulate_point_mass, with_options)

SETTLE_S = 10.0
REFERENCE_HZ = 200.0


def record(name: str, rate_hz: float, seed: int, perfect: bool) -> Trace:
    """Scenario ``name`` at ``rate_hz`` with the sensors' noise density of the 200 Hz scenario (or perfect)."""
    sc = point_mass_scenario(name)
    if perfect:
        sens = PointMassSensors.perfect()
    else:
        k = math.sqrt(rate_hz / REFERENCE_HZ)
        s = sc.sensors
        sens = replace(s, torque_noise_std_nm=k * s.torque_noise_std_nm, speed_noise_std_mps=k * s.speed_noise_std_mps,
                       accel_noise_std_mps2=k * s.accel_noise_std_mps2)
    return simulate_point_mass(with_options(sc, sensors=sens), seed=seed, sample_hz=rate_hz)


def errors(trace: Trace, estimator: str, from_trace: bool) -> tuple[float, float]:
    """(mass max error %, slope RMSE deg) after :data:`SETTLE_S`."""
    s = make(estimator, rate_from_trace=from_trace).run(trace)
    after = trace["t_s"] >= trace["t_s"][0] + SETTLE_S
    m = trace["mass_kg"][after]
    mass_max = float(np.max(np.abs(s.mass_kg[after] - m) / m) * 100.0)
    slope_rmse = float(np.sqrt(np.mean((np.degrees(s.slope_rad[after]) - trace["slope_deg"][after]) ** 2)))
    return mass_max, slope_rmse


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rates", default="100,200,400", help="sample rates in Hz, comma-separated")
    ap.add_argument("--seeds", type=int, default=6, help="sensor seeds 0..N-1 per scenario and rate")
    ap.add_argument("--estimators", default="dffrls-aekf,fused")
    ap.add_argument("--perfect", action="store_true", help="perfect sensors (the filter's own rate dependence)")
    ap.add_argument("--scenarios", default=None, help="comma-separated subset of the point-mass scenarios")
    args = ap.parse_args(argv)
    rates = [float(r) for r in args.rates.split(",")]
    names = (args.scenarios.split(",") if args.scenarios
             else [n for n in POINT_MASS_SCENARIOS if n != "pm-sensor-faults"])
    rows: dict[tuple[str, bool, float], list[tuple[float, float]]] = {}
    for hz in rates:
        for name in names:
            for seed in range(args.seeds):
                tr = record(name, hz, seed, args.perfect)
                for est in args.estimators.split(","):
                    for from_trace in (True, False):
                        rows.setdefault((est, from_trace, hz), []).append(errors(tr, est, from_trace))
    print(f"{len(names)} point-mass scenario(s) x {args.seeds} sensor seed(s), "
          f"{'perfect sensors' if args.perfect else 'noise density of the 200 Hz sensors'}")
    print("| estimator | settings | rate | mass max error % median / p90 / max | slope RMSE deg median / p95 |")
    print("| --- | --- | ---: | --- | --- |")
    for (est, from_trace, hz), v in rows.items():
        a = np.array(v)
        label = "the trace's step" if from_trace else "200 Hz (default)"
        print(f"| `{est}` | {label} | {hz:g} Hz | {np.median(a[:, 0]):.2f} / {np.percentile(a[:, 0], 90):.2f} / "
              f"{a[:, 0].max():.2f} | {np.median(a[:, 1]):.3f} / {np.percentile(a[:, 1], 95):.3f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
