"""docs/estimation.md's "gravity acts at the wheel contacts" (scripts/gravity_at_the_wheels.py): on the plant, the
along-track gravity force on a train whose front wheel alone is on a grade is what the wheel contacts' slope
(``MonorailPlant.wheel_contact_slope_rad``) gives, not the bodies' centres' (the log's ``effective_slope_rad``)."""

from __future__ import annotations

import math

import pytest

from uuom_core.vehicle import DEFAULT_VEHICLE
from uuom_gym.sim.gravity_check import grade_entry_forces
from uuom_gym.sim.plant import MonorailPlant, PlantConfig
from uuom_gym.sim.track import profile_from_knots


@pytest.mark.parametrize("load_kg", [0.0, 10_000.0, 20_000.0])
def test_only_the_front_wheel_on_the_grade_pulls_as_its_contact_predicts(load_kg: float) -> None:
    r = grade_entry_forces(DEFAULT_VEHICLE, load_kg, 1.0)
    assert r["under_sensors_deg"] == pytest.approx(0.0, abs=1e-9)
    assert r["measured"] > 0.0
    assert r["measured"] == pytest.approx(r["wheels"], rel=0.12)
    assert abs(r["centres"]) < 0.1 * r["measured"]  # the body-centre truth misses it


def test_the_wheel_weights_carry_the_whole_train_and_read_a_constant_grade() -> None:
    track = profile_from_knots([(0.0, 3.0), (200.0, 3.0)], "constant")
    plant = MonorailPlant(DEFAULT_VEHICLE, track, PlantConfig(load_kg=7_000.0), start_s_m=50.0)
    assert len(plant.wheel_weight_kg) == len(plant.wheels) == 4
    assert sum(plant.wheel_weight_kg) == pytest.approx(plant.total_mass_kg)
    assert math.degrees(plant.wheel_contact_slope_rad()) == pytest.approx(3.0, abs=1e-6)
