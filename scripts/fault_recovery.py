"""How far each estimator is from its own clean run 12-27 s after a 3 s sensor fault (table of docs/robustness.md).

Usage::

    python scripts/fault_recovery.py [--estimators mmae aupf ...]

Replays :func:`estimators.fault_injection.seven_channel_rows` (40 s, 26 t, varying grade) clean and with each fault
of :mod:`estimators.fault_injection` from 10 s to 13 s, and prints, per estimator and fault, the mean absolute
difference of every declared output from the clean run over 25-40 s (mass in kg, slope in degrees, slip ratio,
radius in mm). ``mmae`` runs with ``rear_offset_m=0`` (the trace is a point mass), as in the test.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import estimators
from estimators.fault_injection import FAULTS, RECOVERY_OPTIONS, inject, run_outputs, seven_channel_rows

SCALE = {"mass": (1.0, "kg"), "slope": (math.degrees(1.0), "deg"), "slip_ratio": (1.0, ""),
         "drive_radius_m": (1e3, "mm")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--estimators", nargs="+", default=estimators.available())
    args = parser.parse_args()
    dt = 0.005
    rows = seven_channel_rows(26_000.0, 40.0, dt, seed=3)
    start, stop, scored = int(10.0 / dt), int(13.0 / dt), slice(int(25.0 / dt), None)
    print("| estimator | output | " + " | ".join(FAULTS) + " |")
    print("| --- | --- | " + " | ".join("---" for _ in FAULTS) + " |")
    for name in args.estimators:
        opts = RECOVERY_OPTIONS.get(name, {})
        clean = run_outputs(name, rows, **opts)
        diffs = {k: [] for k in clean}
        for kind in FAULTS:
            bad = run_outputs(name, inject(rows, kind, start, stop), **opts)
            for k in clean:
                d = np.abs(bad[k][scored] - clean[k][scored])
                diffs[k].append(float(np.mean(d)) if np.all(np.isfinite(bad[k])) else math.nan)
        for k, values in diffs.items():
            scale, unit = SCALE.get(k, (1.0, ""))
            label = f"{k} ({unit})" if unit else k
            print(f"| `{name}` | {label} | " + " | ".join(f"{v * scale:.3g}" for v in values) + " |")


if __name__ == "__main__":
    main()
