"""Where gravity reaches the rail: the along-track force on a train whose front wheel alone is on a grade, measured on
the plant and predicted two ways (docs/estimation.md, "Why the plant's trains read light";
``scripts/gravity_at_the_wheels.py``)."""

from __future__ import annotations

import math

from uuom_core.units import G_MPS2
from uuom_core.vehicle import VehicleParams
from uuom_gym.sim.plant import MonorailPlant, PlantConfig
from uuom_gym.sim.track import profile_from_knots

GRADE_START_M = 100.0
"""Where the 5° down-grade of the check's track begins (level before)."""

__all__ = ["GRADE_START_M", "grade_entry_forces"]


def grade_entry_forces(vehicle: VehicleParams, load_kg: float, into_m: float) -> dict[str, float]:
    """Along-track force (N) on the train at rest, no running resistance and no drive, with its front drive wheel
    ``into_m`` into a 5° down-grade and the rest level.

    Returns ``measured`` (the momentum's rate over the first 0.1 s), ``wheels`` (the weight on the wheel contacts'
    slope, :meth:`MonorailPlant.wheel_contact_slope_rad`), ``centres`` (on the log's body-centre
    ``effective_slope_rad``, the protocol's train-averaged truth) and ``under_sensors_deg`` (the slope under the
    sensors).
    """
    track = profile_from_knots([(0.0, 0.0), (GRADE_START_M, 0.0), (GRADE_START_M + 0.5, -5.0), (400.0, -5.0)],
                               "grade entry")
    start = GRADE_START_M + into_m - vehicle.drive_wheel_base_m / 2.0
    plant = MonorailPlant(vehicle, track, PlantConfig(load_kg=load_kg, running_resistance=0.0), start_s_m=start)
    body_mass_kg = sum(b.mass for b in plant.space.bodies)
    weight_n = plant.total_mass_kg * G_MPS2
    v0 = plant.centre_of_mass_speed_mps()
    wheels = -weight_n * math.sin(plant.wheel_contact_slope_rad())
    log = plant.advance(0.0, 20)
    measured = body_mass_kg * (plant.centre_of_mass_speed_mps() - v0) / (20 * plant.dt_s)
    return {"measured": measured, "wheels": wheels,
            "centres": -weight_n * math.sin(float(log.effective_slope_rad[0])),
            "under_sensors_deg": math.degrees(float(log.slope_rad[0]))}
