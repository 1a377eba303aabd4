#!/usr/bin/env python
"""Do the estimators hold on other vehicles? The point-mass scenarios with a lighter and a heavier train.

Every setting of ``dffrls-aekf`` and ``fused`` was tuned on the spec's vehicle (16 t empty, 20 t rated load, 0.17 m
drive wheels). This script simulates the fault-free point-mass scenarios (:mod:`uuom_gym.sim.point_mass`) on two other
vehicles -- 10 t empty + 12 t rated on 0.2 m wheels, and 22 t + 28 t with 1.4x the traction and power -- with each
scenario's load scaled to the vehicle's rated load, gives each estimator that vehicle (as ``uuom-estimate --vehicle``
does), and prints the pooled median / p90 / max over scenarios x sensor seeds of the mass max error after 10 s.

Usage::

    python scripts/vehicle_variation_check.py --seeds 3
"""

from __future__ import annotations

import argparse
import dataclasses
import sys

import numpy as np

from estimators.registry import make
from uuom_core.vehicle import VehicleParams
from uuom_gym.sim.point_mass import POINT_MASS_SCENARIOS, point_mass_scenario, simulate_point_mass

DEFAULT = VehicleParams()
VEHICLES: dict[str, tuple[str, VehicleParams]] = {
    "spec": ("the spec's (16 t + 20 t)", DEFAULT),
    "light": ("light (10 t + 12 t, 0.2 m wheels)", dataclasses.replace(DEFAULT, empty_mass_kg=10_000.0, rated_load_kg=12_000.0,
                                                             drive_wheel_radius_m=0.2)),
    "heavy": ("heavy (22 t + 28 t, 1.4x traction and power)", dataclasses.replace(
        DEFAULT, empty_mass_kg=22_000.0, rated_load_kg=28_000.0, max_traction_n=1.4 * DEFAULT.max_traction_n,
        motor_power_w=1.4 * DEFAULT.motor_power_w)),
}


def mass_max_errors(vehicle: VehicleParams, estimator: str, seeds: int) -> np.ndarray:
    """Mass max error after 10 s (%) per fault-free scenario and sensor seed."""
    out = []
    for name in POINT_MASS_SCENARIOS:
        if name == "pm-sensor-faults":
            continue
        base = point_mass_scenario(name)
        sc = dataclasses.replace(base, load_kg=min(base.load_kg * vehicle.rated_load_kg / DEFAULT.rated_load_kg,
                                                   vehicle.rated_load_kg))
        for seed in range(seeds):
            tr = simulate_point_mass(sc, seed=seed, vehicle=vehicle)
            s = make(estimator, vehicle=vehicle).run(tr)
            after = tr["t_s"] >= 10.0
            m = tr["mass_kg"][after]
            out.append(float(np.max(np.abs(s.mass_kg[after] - m) / m) * 100.0))
    return np.array(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3, help="sensor seeds 0..N-1 per scenario")
    ap.add_argument("--estimators", default="dffrls-aekf,fused")
    ap.add_argument("--vehicles", default="spec,light,heavy", help="comma-separated subset of: spec, light, heavy")
    args = ap.parse_args(argv)
    keys = args.vehicles.split(",")
    unknown = [k for k in keys if k not in VEHICLES]
    if unknown:
        ap.error(f"unknown vehicle(s) {', '.join(unknown)}; known: {', '.join(VEHICLES)}")
    print(f"fault-free point-mass scenarios x {args.seeds} sensor seed(s); mass max error after 10 s, %")
    print("| vehicle | estimator | median / p90 / max |")
    print("| --- | --- | --- |")
    for key in keys:
        label, vehicle = VEHICLES[key]
        for est in args.estimators.split(","):
            e = mass_max_errors(vehicle, est, args.seeds)
            print(f"| {label} | `{est}` | {np.median(e):.2f} / {np.percentile(e, 90):.2f} / {e.max():.2f} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
