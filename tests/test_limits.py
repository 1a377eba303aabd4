"""The safe operating envelope (uuom_core.limits) against hand-computed physics."""

import math

import pytest

from uuom_core.limits import (
    brake_deceleration_mps2,
    load_speed_limit_mps,
    max_climbable_grade_rad,
    max_traction_force_n,
    speed_limit_mps,
    stopping_speed_limit_mps,
)
from uuom_core.vehicle import DEFAULT_VEHICLE as V
from uuom_core.vehicle import G_MPS2


def test_load_limit_interpolates_table3():
    assert load_speed_limit_mps(V, V.empty_mass_kg) == pytest.approx(2.0)
    assert load_speed_limit_mps(V, V.rated_mass_kg) == pytest.approx(0.5)
    assert load_speed_limit_mps(V, V.empty_mass_kg + V.rated_load_kg / 2) == pytest.approx(1.25)
    # overload does not raise the limit, and below empty is treated as empty
    assert load_speed_limit_mps(V, V.rated_mass_kg + 5000) == pytest.approx(0.5)
    assert load_speed_limit_mps(V, 1000.0) == pytest.approx(2.0)


def test_rated_load_climbs_about_12_degrees_and_empty_climbs_15():
    # spec §1: sin t + mu cos t = 80 000 / (36 000 g) -> about 12 degrees
    theta = max_climbable_grade_rad(V, V.rated_mass_kg)
    assert math.sin(theta) + 0.02 * math.cos(theta) == pytest.approx(80_000 / (36_000 * G_MPS2), rel=1e-9)
    assert 11.5 < math.degrees(theta) < 12.5
    assert math.degrees(max_climbable_grade_rad(V, V.empty_mass_kg)) > 15.0


def test_wet_rail_adhesion_limits_traction_and_grade():
    assert max_traction_force_n(V, V.adhesion_dry) == pytest.approx(80_000)
    wet = max_traction_force_n(V, V.adhesion_wet)
    assert wet == pytest.approx(V.adhesion_wet * V.clamp_force_n)
    assert max_climbable_grade_rad(V, V.rated_mass_kg, adhesion=V.adhesion_wet) < max_climbable_grade_rad(
        V, V.rated_mass_kg
    )


def test_brake_deceleration_downhill_is_weaker_and_can_fail():
    up = brake_deceleration_mps2(V, 30_000, math.radians(10))
    level = brake_deceleration_mps2(V, 30_000, 0.0)
    down = brake_deceleration_mps2(V, 30_000, math.radians(-10))
    assert up > level > down > 0
    # a brake weaker than the downhill force cannot hold the train: no safe speed at all
    weak = V.with_changes(service_brake_n=10_000.0)
    assert brake_deceleration_mps2(weak, 36_000, math.radians(-15)) < 0
    assert stopping_speed_limit_mps(weak, 36_000, math.radians(-15)) == 0.0


def test_stopping_limit_solves_the_stopping_distance():
    m, th = 20_000.0, math.radians(-12)
    v = stopping_speed_limit_mps(V, m, th, stop_distance_m=1.5, brake_delay_s=0.6)
    a = brake_deceleration_mps2(V, m, th)
    assert v * 0.6 + v * v / (2 * a) == pytest.approx(1.5, rel=1e-9)


def test_speed_limit_depends_on_load_and_grade():
    assert speed_limit_mps(V, V.empty_mass_kg, math.radians(-15)) < speed_limit_mps(V, V.empty_mass_kg, 0.0)
    assert speed_limit_mps(V, V.rated_mass_kg, 0.0) < speed_limit_mps(V, V.empty_mass_kg, 0.0)
