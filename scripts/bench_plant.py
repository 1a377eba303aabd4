#!/usr/bin/env python
"""Speed of the monorail plant: simulated seconds per wall-clock second, full train at the physics rate.

Runs the plant with per-tick truth logging (``MonorailPlant.advance``) at a held traction command on the
``section2`` track with a 10 t load, in control blocks of ``--block`` ticks (the environment's control step),
and reports the best of ``--repeat`` runs. Single process, so one core.

    python scripts/bench_plant.py --sim-s 100 --block 20
    python scripts/bench_plant.py --checks      # also print the physics checks of tests/test_plant.py as numbers
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from uuom_gym.sim import MonorailPlant, PlantConfig, profile_from_knots, scenario_track
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2

V = DEFAULT_VEHICLE


def _straight(deg: float):
    return profile_from_knots([(0.0, deg), (400.0, deg)])


def physics_checks() -> None:
    """The quantities the physics tests assert, printed."""
    mu = 0.02
    for load in (0.0, 10_000.0, 20_000.0):
        mass = V.empty_mass_kg + load
        plant = MonorailPlant(V, _straight(0.0), PlantConfig(load_kg=load, running_resistance=mu), start_s_m=20.0)
        u = (0.05 * (mass + V.rotating_mass_kg) + mu * mass * G_MPS2) / V.max_traction_n
        plant.advance(u, 400)
        v0, t0 = plant.centre_of_mass_speed_mps(), plant.t_s
        log = plant.advance(u, 2000)
        a = (plant.centre_of_mass_speed_mps() - v0) / (plant.t_s - t0)
        f = float(np.mean(log.traction_force_n))
        model = (f - mu * mass * G_MPS2) / (mass + V.rotating_mass_kg)
        print(f"level, load {load / 1000:4.0f} t, F {f / 1000:5.2f} kN: a = {a:.5f} m/s^2, "
              f"(F - mu M g)/(M + m_rot) = {model:.5f}  ({100 * (a / model - 1):+.2f} %)")
    for deg, load, u in ((13.0, V.rated_load_kg, 1.0), (13.0, V.rated_load_kg, 0.8), (11.0, V.rated_load_kg, 1.0),
                         (15.0, 0.0, 1.0)):
        plant = MonorailPlant(V, _straight(deg), PlantConfig(load_kg=load), start_s_m=50.0)
        log = plant.advance(u, 1600)
        print(f"{deg:4.1f} deg, load {load / 1000:2.0f} t, command {u}: moved {log.position_m[-1] - 50.0:+.3f} m "
              f"in 8 s, final speed {log.speed_mps[-1]:+.3f} m/s")
    expected = 2 * math.pi * math.sqrt(2.0 / G_MPS2)
    for zeta in (0.0, 0.05):
        plant = MonorailPlant(V, _straight(0.0), PlantConfig(load_kg=10_000, anti_sway_damping_ratio=zeta),
                              start_s_m=20.0)
        plant.emergency_brake()
        plant.displace_load(0.05)
        x = plant.advance(0.0, 4000).sway_rad
        up = np.where((x[:-1] < 0) & (x[1:] >= 0))[0]
        period = float(np.mean(np.diff(up))) / 200.0
        peaks = [x[i:j].max() for i, j in zip(up[:-1], up[1:])]
        zeta_meas = math.log(peaks[0] / peaks[-1]) / (len(peaks) - 1) / (2 * math.pi)
        print(f"sway (train held, chain 2 m, damping ratio {zeta}): period {period:.4f} s vs 2 pi sqrt(L/g) = "
              f"{expected:.4f} s ({100 * (period / expected - 1):+.2f} %), measured damping ratio {zeta_meas:.4f}")
    plant = MonorailPlant(V, scenario_track("roadtest"), PlantConfig(load_kg=10_000, track_energy=True))
    e0 = plant.mechanical_energy_j()
    for u in [0.4] * 30 + [0.1] * 30 + [-0.3] * 10 + [0.5] * 30 + [0.0] * 20 + [-1.0] * 20:
        plant.advance(u, 20)
    e = plant.energy
    de = plant.mechanical_energy_j() - e0
    res = e["traction_work_j"] - de - e["friction_j"] - e["damper_j"]
    print(f"energy (roadtest, 14 s): traction work {e['traction_work_j'] / 1e3:.1f} kJ = dE_mech {de / 1e3:.1f} + "
          f"resistance/brake {e['friction_j'] / 1e3:.1f} + dampers {e['damper_j'] / 1e3:.1f} kJ; residual "
          f"{res / 1e3:+.2f} kJ ({100 * res / e['traction_work_j']:+.2f} %)")
    plant = MonorailPlant(V, _straight(0.0), PlantConfig(load_kg=20_000, adhesion=0.06), start_s_m=20.0)
    log = plant.advance(1.0, 400)
    print(f"slip (adhesion 0.06 -> limit {0.06 * V.clamp_force_n / 1000:.1f} kN, 36 t, full command, 2 s): "
          f"traction {log.traction_force_n[-1] / 1000:.1f} kN, wheel surface "
          f"{log.wheel_speed_radps[-1] * log.drive_radius_m[-1]:.2f} m/s vs ground {log.speed_mps[-1]:.2f} m/s, "
          f"slip ratio {log.slip_ratio[-1]:.2f}")


def run_once(sim_s: float, block: int, hz: float) -> tuple[float, float, float]:
    """Wall time of the run, build time, and the CPU time of the run (``time.process_time``: on a shared,
    loaded machine the wall time mostly measures the other processes; the CPU time does not)."""
    track = scenario_track("section2")
    t0 = time.perf_counter()
    plant = MonorailPlant(DEFAULT_VEHICLE, track, PlantConfig(load_kg=10_000, physics_hz=hz))
    t_build = time.perf_counter() - t0
    n_blocks = int(round(sim_s * hz / block))
    t0 = time.perf_counter()
    c0 = time.process_time()
    for i in range(n_blocks):
        plant.advance(0.35 if i % 50 < 40 else -0.1, block)
    return time.perf_counter() - t0, t_build, time.process_time() - c0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sim-s", type=float, default=100.0, help="simulated seconds per run")
    ap.add_argument("--block", type=int, default=20, help="physics ticks per advance() call")
    ap.add_argument("--hz", type=float, default=200.0, help="physics rate")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--checks", action="store_true", help="also print the physics checks")
    args = ap.parse_args()
    if args.checks:
        physics_checks()
    runs = [run_once(args.sim_s, args.block, args.hz) for _ in range(args.repeat)]
    wall, build, _ = min(runs)
    cpu = min(r[2] for r in runs)
    n_ticks = args.sim_s * args.hz
    print(f"plant: {args.sim_s:g} s simulated at {args.hz:g} Hz in blocks of {args.block} ticks")
    print(f"  wall {wall:.3f} s  ->  {args.sim_s / wall:.0f}x real time  ({wall / n_ticks * 1e6:.1f} us per tick,"
          f" build {build * 1e3:.1f} ms)")
    print(f"  cpu  {cpu:.3f} s  ->  {args.sim_s / cpu:.0f}x real time  ({cpu / n_ticks * 1e6:.1f} us per tick;"
          f" process CPU time, best of {args.repeat})")


if __name__ == "__main__":
    main()
