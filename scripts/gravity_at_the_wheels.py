"""Where gravity acts on the plant's train: at the four wheel contacts, not at the bodies' centres.

The estimators' force model puts the whole train's weight on one grade (the drive section's pitch under the sensors,
or that pitch averaged over a window behind them). The plant hangs its bodies from wheels that roll on the rail, so
the along-track gravity force is the rail's reactions at the wheel contacts, ``sum_j W_j g sin(theta(s_j))`` with
``W_j`` the static weight each wheel bears; the hook and payload ride on the beam's two wheels, 7-10 m behind the
sensors. The trace's ``effective_slope_deg`` (the "train-averaged slope" of the estimation protocol) is the
mass-weighted slope at the bodies' *centres*, which differs from both while a wheel is on a vertical curve.

The check: the train at rest, no running resistance and no drive, its front drive wheel 1, 3 and 6 m into a 5°
down-grade, the rest level. The momentum's rate of change over the first 0.1 s is compared with the two predictions.
Then, for a heavy payload, the same with the train's payload twice its empty mass (sister vehicle 8 of the ×/÷ 1.5
studies, ``sister_vehicles(0, 10, 1.5)[7]``). docs/estimation.md, "Why the plant's trains read light".

    python scripts/gravity_at_the_wheels.py            # a few seconds
"""

from __future__ import annotations

import argparse

from uuom_core.vehicle import DEFAULT_VEHICLE
from uuom_core.vehicle_variants import sister_vehicles
from uuom_gym.sim.gravity_check import grade_entry_forces


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    heavy = sister_vehicles(0, 10, 1.5)[7]
    print("| vehicle | load | front wheel into the grade | measured | at the wheel contacts | at the bodies' centres "
          "(`effective_slope_deg`) | slope under the sensors |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for name, v, load in (("project's, 16.0 t", DEFAULT_VEHICLE, 10_000.0),
                          (f"sister 8, {heavy.empty_mass_kg / 1e3:.1f} t", heavy, 20_000.0)):
        for into in (1.0, 3.0, 6.0):
            r = grade_entry_forces(v, load, into)
            print(f"| {name} | {load / 1e3:.0f} t | {into:.0f} m | {r['measured']:.0f} N | {r['wheels']:.0f} N | "
                  f"{r['centres']:.0f} N | {r['under_sensors_deg']:+.2f}° |")


if __name__ == "__main__":
    main()
