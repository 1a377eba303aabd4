"""Plant runs the estimator tests and evaluation scripts share, beyond the named scenarios of ``uuom_gym.sim``.

The plant is imported on first use, so importing this module does not need it (tests skip when it is missing).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from uuom_core.trace import Trace

__all__ = ["station_trace"]


def station_trace(load1_kg: float, load2_kg: float, seed: int) -> Trace:
    """``section1`` driven as two plant runs joined at a station stop.

    The train carries ``load1_kg``, stops on the level (speed profile 1 m/s to 25 s, standing from 36 s; 70 s in
    all), is loaded to ``load2_kg`` while it stands and drives on up the grade for 90 s from where it stopped. Both
    runs use ``seed``; the second run's time stamps continue the first's. Only the columns both runs have are kept.
    """
    from uuom_gym.sim.recording import simulate_run
    from uuom_gym.sim.scenarios import SpeedProfile, scenario

    base = scenario("section1")
    stop = SpeedProfile(((0.0, 1.0), (25.0, 1.0), (36.0, 0.0)))
    first = simulate_run(replace(base, load_kg=load1_kg, speed_profile=stop, duration_s=70.0), seed=seed)
    second = simulate_run(
        replace(base, load_kg=load2_kg, start_s_m=float(first["position_m"][-1]), duration_s=90.0), seed=seed
    )
    dt = first["t_s"][1] - first["t_s"][0]
    cols = {}
    for key in first.columns:
        if key in second.columns:
            tail = second[key] + (first["t_s"][-1] + dt if key == "t_s" else 0.0)
            cols[key] = np.concatenate([first[key], tail])
    return Trace(cols, source="plant: loading at a station")
