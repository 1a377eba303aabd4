#!/usr/bin/env python
"""Record a simulated run of the monorail plant to a trace CSV (shared/spec/trace-format.md + truth columns).

Examples
--------
    python scripts/record_trace.py section1 --seed 0 --out section1.csv
    python scripts/record_trace.py roadtest --seed 1 --out rt.csv --wet --wear-mm 3 --dropout 0.01
    python scripts/record_trace.py random --track-seed 7 --load-kg 15000 --duration-s 200 --out r.csv
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace

import numpy as np

from uuom_gym.sim import SCENARIO_NAMES, FaultConfig, PlantConfig, SensorConfig, random_track, simulate_run
from uuom_core.trace import write_trace_csv
from uuom_core.vehicle import DEFAULT_VEHICLE, VehicleFileError, VehicleParams


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenario", choices=[*SCENARIO_NAMES, "random"], help="fixed scenario, or a random track")
    ap.add_argument("--out", required=True, help="trace CSV to write (atomically)")
    ap.add_argument("--seed", type=int, default=0, help="sensor noise / bias / fault seed")
    ap.add_argument("--track-seed", type=int, default=0, help="seed of the random track (scenario 'random')")
    ap.add_argument("--load-kg", type=float, default=None, help="payload (default: the scenario's, 0 for random)")
    ap.add_argument("--duration-s", type=float, default=None, help="run time (default: the scenario's, 120 s)")
    ap.add_argument("--vehicle", default=None, help="vehicle TOML file (default: the spec's vehicle)")
    ap.add_argument("--mu", type=float, default=None, help="true running resistance of the plant")
    ap.add_argument("--wet", action="store_true", help="wet rail: adhesion = vehicle.adhesion_wet")
    ap.add_argument("--wear-mm", type=float, default=0.0, help="drive-wheel radius lost to wear (mm)")
    ap.add_argument("--ideal-sensors", action="store_true", help="no noise, bias or quantisation")
    ap.add_argument("--random-sensors", action="store_true", help="sensor noise/bias drawn around the defaults")
    ap.add_argument("--dropout", type=float, default=0.0, help="dropout probability per sample and channel")
    ap.add_argument("--spikes", type=float, default=0.0, help="spike probability per sample and channel")
    args = ap.parse_args(argv)
    for name in ("seed", "track_seed"):  # numpy's own message named neither
        if getattr(args, name) < 0:
            ap.error(f"--{name.replace('_', '-')} must be >= 0, got {getattr(args, name)}")
    try:
        vehicle = VehicleParams.from_toml(args.vehicle) if args.vehicle else DEFAULT_VEHICLE
        load = args.load_kg
        if args.scenario == "random":
            load = 0.0 if load is None else load
            target = random_track(np.random.default_rng(args.track_seed), vehicle=vehicle, load_kg=load,
                                  name=f"random{args.track_seed}")
        else:
            target = args.scenario
        pc = PlantConfig(
            running_resistance=args.mu, adhesion=vehicle.adhesion_wet if args.wet else None,
            wheel_wear_m=args.wear_mm / 1000.0,
        )
        if load is not None:
            pc = replace(pc, load_kg=load)
        if args.ideal_sensors:
            sc = SensorConfig.ideal()
        elif args.random_sensors:
            sc = SensorConfig.randomized(np.random.default_rng(args.seed + 1_000_003))
        else:
            sc = SensorConfig()
        faults = FaultConfig(dropout_prob=args.dropout, spike_prob=args.spikes)
        trace = simulate_run(target, seed=args.seed, load_kg=load, vehicle=vehicle, sensor_config=sc,
                             plant_config=pc, duration_s=args.duration_s, fault_config=faults)
        write_trace_csv(trace, args.out)
    except (VehicleFileError, ValueError, OSError) as exc:
        print(f"record_trace: error: {exc}", file=sys.stderr)
        return 2
    print(f"{args.out}: {len(trace)} samples, {trace.duration_s:.1f} s, mass {trace['mass_kg'][0]:.0f} kg, "
          f"slope {trace['slope_deg'].min():.1f}..{trace['slope_deg'].max():.1f} deg")
    return 0


if __name__ == "__main__":
    sys.exit(main())
