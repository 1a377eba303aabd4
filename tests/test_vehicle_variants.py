"""Sister vehicles (:mod:`uuom_core.vehicle_variants`): valid, seeded, within the asked factor of the project's."""

from __future__ import annotations

import dataclasses

import pytest

from uuom_core.vehicle import DEFAULT_VEHICLE, PLAUSIBLE_RANGES, VehicleParams
from uuom_core.vehicle_variants import consistent_vehicle, sister_vehicles, vehicle_overrides

# fields a repair may move (uuom_core.vehicle_variants.consistent_vehicle), the others must stay within the factor
REPAIRED = {"adhesion_wet", "max_speed_rated_mps", "emergency_brake_n", "drive_wheel_base_m", "beam_wheel_base_m",
            "chain_spacing_m", "length_m", "drive_section_length_m", "coupler_gap_m", "beam_section_length_m",
            "hook_mass_kg", "carrying_wheel_mass_kg", "running_resistance"}


def test_same_seed_same_vehicles_other_seed_others() -> None:
    a = sister_vehicles(3, 4, 1.3)
    assert a == sister_vehicles(3, 4, 1.3)
    assert a != sister_vehicles(4, 4, 1.3)
    assert len(a) == 4 and len(set(a)) == 4


@pytest.mark.parametrize("spread", [1.1, 1.25, 1.5])
def test_every_free_field_within_the_factor_and_its_range(spread: float) -> None:
    for v in sister_vehicles(0, 12, spread):
        assert isinstance(v, VehicleParams)
        for f in dataclasses.fields(VehicleParams):
            x, x0 = getattr(v, f.name), getattr(DEFAULT_VEHICLE, f.name)
            lo, hi, _ = PLAUSIBLE_RANGES[f.name]
            assert lo <= x <= hi, f.name
            if f.name in REPAIRED or isinstance(x0, int):
                continue
            assert x0 / spread * (1 - 1e-12) <= x <= x0 * spread * (1 + 1e-12), (f.name, x, x0)


def test_a_factor_of_one_is_the_project_vehicle() -> None:
    assert sister_vehicles(0, 2, 1.0) == [DEFAULT_VEHICLE, DEFAULT_VEHICLE]
    assert vehicle_overrides(DEFAULT_VEHICLE) == {}


def test_overrides_rebuild_the_vehicle() -> None:
    for v in sister_vehicles(1, 3, 1.5):
        over = vehicle_overrides(v)
        assert over and VehicleParams(**{**dataclasses.asdict(DEFAULT_VEHICLE), **over}) == v


@pytest.mark.parametrize("kwargs, word", [
    ({"seed": -1, "count": 1, "spread": 1.2}, "seed"),
    ({"seed": 0, "count": -1, "spread": 1.2}, "count"),
    ({"seed": 0, "count": 1, "spread": 0.8}, "spread"),
    ({"seed": 0, "count": 1, "spread": float("nan")}, "spread"),
    ({"seed": 0, "count": 1, "spread": float("inf")}, "spread"),
])
def test_bad_arguments_are_named(kwargs: dict, word: str) -> None:
    with pytest.raises(ValueError, match=word):
        sister_vehicles(**kwargs)


def test_the_repair_keeps_a_valid_vehicle_and_mends_a_broken_relation() -> None:
    kw = dataclasses.asdict(DEFAULT_VEHICLE)
    assert consistent_vehicle(kw) == DEFAULT_VEHICLE
    kw.update(adhesion_wet=0.5, adhesion_dry=0.3, emergency_brake_n=1e4)
    v = consistent_vehicle(kw)
    assert v.adhesion_wet == 0.3 and v.emergency_brake_n == v.service_brake_n
