"""docs/estimation.md's "gravity acts at the wheel contacts" (scripts/gravity_at_the_wheels.py): on the plant, the
along-track gravity force on a train whose front wheel alone is on a grade is what the wheel contacts' slope
(``MonorailPlant.wheel_contact_slope_rad``) gives, not the bodies' centres' (the log's ``effective_slope_rad``)."""

from __future__ import annotations

import math

import pytest

from uuom_core.units import G_MPS2
from uuom_core.vehicle import DEFAULT_VEHICLE
from uuom_gym.sim.plant import MonorailPlant, PlantConfig
from uuom_gym.sim.track import profile_from_knots


def _front_wheel_on_a_grade(load_kg: float, into_m: float = 1.0) -> tuple[float, float, float, float]:
    """The train at rest, mu = 0, no drive, its front drive wheel ``into_m`` into a 5° down-grade: the measured
    along-track force over 0.1 s, the wheel-contact and body-centre predictions, and the slope under the sensors."""
    track = profile_from_knots([(0.0, 0.0), (100.0, 0.0), (100.5, -5.0), (400.0, -5.0)], "grade entry")
    start = 100.0 + into_m - DEFAULT_VEHICLE.drive_wheel_base_m / 2.0
    plant = MonorailPlant(DEFAULT_VEHICLE, track, PlantConfig(load_kg=load_kg, running_resistance=0.0),
                          start_s_m=start)
    bodies = plant.space.bodies
    p0 = sum(b.mass * b.velocity.x for b in bodies)
    wheels = -plant.total_mass_kg * G_MPS2 * math.sin(plant.wheel_contact_slope_rad())
    log = plant.advance(0.0, 20)
    measured = (sum(b.mass * b.velocity.x for b in bodies) - p0) / (20 * plant.dt_s)
    centres = -plant.total_mass_kg * G_MPS2 * math.sin(float(log.effective_slope_rad[0]))
    return measured, wheels, centres, float(log.slope_rad[0])


@pytest.mark.parametrize("load_kg", [0.0, 10_000.0, 20_000.0])
def test_only_the_front_wheel_on_the_grade_pulls_as_its_contact_predicts(load_kg: float) -> None:
    measured, wheels, centres, under_sensors = _front_wheel_on_a_grade(load_kg)
    assert under_sensors == pytest.approx(0.0, abs=1e-9)
    assert measured > 0.0
    assert measured == pytest.approx(wheels, rel=0.12)
    assert abs(centres) < 0.1 * measured  # the body-centre truth misses it


def test_the_wheel_weights_carry_the_whole_train_and_read_a_constant_grade() -> None:
    track = profile_from_knots([(0.0, 3.0), (200.0, 3.0)], "constant")
    plant = MonorailPlant(DEFAULT_VEHICLE, track, PlantConfig(load_kg=7_000.0), start_s_m=50.0)
    assert len(plant.wheel_weight_kg) == len(plant.wheels) == 4
    assert sum(plant.wheel_weight_kg) == pytest.approx(plant.total_mass_kg)
    assert math.degrees(plant.wheel_contact_slope_rad()) == pytest.approx(3.0, abs=1e-6)
