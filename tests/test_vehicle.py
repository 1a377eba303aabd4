"""Vehicle parameters: defaults of the spec, derived quantities, TOML loading and validation."""

from __future__ import annotations

import math

import pytest

from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2, PLAUSIBLE_RANGES, VehicleFileError, VehicleParams


def test_defaults_are_the_spec_vehicle():
    v = DEFAULT_VEHICLE
    assert v.max_traction_n == 80_000 and v.drive_unit_count == 8 and v.rated_load_kg == 20_000
    assert v.drive_wheel_radius_m == pytest.approx(0.34 / 2) and v.carrying_wheel_radius_m == pytest.approx(0.175 / 2)
    assert v.rotating_mass_kg == pytest.approx(4 * 2.0 / 0.0875**2) and 1040 < v.rotating_mass_kg < 1050
    assert v.rated_mass_kg == 36_000 and v.max_mass_kg == 16_000 + 24_000
    assert G_MPS2 == 9.81
    # spec §1: at rated load 80 kN climbs at most about 12 deg
    ratio = v.max_traction_n / (v.rated_mass_kg * G_MPS2)
    theta = math.asin(ratio / math.hypot(1, v.running_resistance)) - math.atan(v.running_resistance)
    assert 11.0 < math.degrees(theta) < 13.0


def test_with_changes_validates():
    v = DEFAULT_VEHICLE.with_changes(empty_mass_kg=18_000.0)
    assert v.empty_mass_kg == 18_000 and DEFAULT_VEHICLE.empty_mass_kg == 16_000
    with pytest.raises(VehicleFileError, match="unknown vehicle parameter"):
        DEFAULT_VEHICLE.with_changes(mass=1.0)
    with pytest.raises(VehicleFileError, match=r"drive_wheel_radius_m = 0.0 is outside the plausible range"):
        DEFAULT_VEHICLE.with_changes(drive_wheel_radius_m=0.0)
    assert DEFAULT_VEHICLE.to_dict()["clamp_force_n"] == DEFAULT_VEHICLE.clamp_force_n


@pytest.mark.parametrize(
    "kwargs, word",
    [
        (dict(empty_mass_kg=-1.0), "empty_mass_kg"),
        (dict(rated_load_kg=float("nan")), "rated_load_kg"),
        (dict(running_resistance=1.5), "running_resistance"),
        (dict(adhesion_wet=0.5), "adhesion_wet"),
        (dict(max_speed_rated_mps=3.0), "max_speed_rated_mps"),
        (dict(max_grade_deg=60.0), "max_grade_deg"),
        (dict(emergency_brake_n=100_000.0), "emergency_brake_n"),
        (dict(inertia_wheel_count=True), "inertia_wheel_count"),
    ],
)
def test_impossible_values_are_named(kwargs, word):
    with pytest.raises(VehicleFileError, match=word):
        VehicleParams(**kwargs)


def test_from_toml(tmp_path):
    p = tmp_path / "v.toml"
    p.write_text("[vehicle]\nempty_mass_kg = 17000.0\ninertia_wheel_count = 6\nrunning_resistance = 0.03\n")
    v = VehicleParams.from_toml(p)
    assert v.empty_mass_kg == 17_000 and v.inertia_wheel_count == 6 and isinstance(v.inertia_wheel_count, int)
    assert v.running_resistance == 0.03 and v.max_traction_n == DEFAULT_VEHICLE.max_traction_n
    p.write_text("")
    assert VehicleParams.from_toml(p) == DEFAULT_VEHICLE  # missing keys take the defaults


@pytest.mark.parametrize(
    "text, word",
    [
        ("[vehicle]\nmass = 1.0\n", "unknown key"),
        ("[vehicle]\ndrive_wheel_radius_m = -0.1\n", "drive_wheel_radius_m"),
        ("[vehicle]\ndrive_wheel_radius_m = 'big'\n", "must be a number"),
        ("[vehicle]\ninertia_wheel_count = 2.5\n", "whole number"),
        ("[vehicle]\nempty_mass_kg = true\n", "must be a number"),
        ("[truck]\nempty_mass_kg = 1.0\n", "unknown table"),
        ("vehicle = 3\n", "must be a table"),
        ("[vehicle\n", "not valid TOML"),
    ],
)
def test_bad_toml_is_named(tmp_path, text, word):
    p = tmp_path / "bad.toml"
    p.write_text(text)
    with pytest.raises(VehicleFileError, match=word) as err:
        VehicleParams.from_toml(p)
    assert "bad.toml" in str(err.value)


def test_missing_toml(tmp_path):
    with pytest.raises(VehicleFileError, match="no such vehicle file"):
        VehicleParams.from_toml(tmp_path / "none.toml")


@pytest.mark.parametrize(
    "key, text, message",
    [
        ("empty_mass_kg", "-5.0", r"empty_mass_kg = -5.0 is outside the plausible range \[1000, 200000\] kg"),
        ("empty_mass_kg", "0.0", r"empty_mass_kg = 0.0 is outside the plausible range \[1000, 200000\] kg"),
        ("empty_mass_kg", "1e9", r"empty_mass_kg = 1000000000.0 is outside the plausible range \[1000, 200000\] kg"),
        ("rated_load_kg", "1e12", r"rated_load_kg = 1000000000000.0 is outside the plausible range \[100, 100000\]"),
        ("drive_wheel_radius_m", "0.0", r"drive_wheel_radius_m = 0.0 is outside the plausible range \[0.05, 1\] m"),
        ("carrying_wheel_radius_m", "87.5", r"carrying_wheel_radius_m = 87.5 is outside .*\[0.02, 0.5\] m"),
        ("adhesion_dry", "1.2", r"adhesion_dry = 1.2 is outside the plausible range \[0.01, 1\]"),
        ("drive_section_mass_share", "1.5", r"drive_section_mass_share = 1.5 is outside .*\[0.05, 0.95\]"),
        ("running_resistance", "nan", r"running_resistance must be a finite number in \[0, 0.5\], got nan"),
        ("max_traction_n", "inf", r"max_traction_n must be a finite number in \[1000, 1e\+06\] N, got inf"),
        ("inertia_wheel_count", "0", r"inertia_wheel_count = 0 is outside the plausible range \[1, 64\]"),
    ],
)
def test_implausible_file_values_name_field_value_and_range(tmp_path, key, text, message):
    p = tmp_path / "veh.toml"
    p.write_text(f"[vehicle]\n{key} = {text}\n")
    with pytest.raises(VehicleFileError, match=message) as err:
        VehicleParams.from_toml(p)
    line = str(err.value)
    assert "\n" not in line and line.startswith(str(p)) and line.count(key) >= 1


def test_every_field_has_a_plausible_range_containing_its_default():
    import dataclasses

    names = [f.name for f in dataclasses.fields(VehicleParams)]
    assert sorted(PLAUSIBLE_RANGES) == sorted(names)
    for name in names:
        lo, hi, _ = PLAUSIBLE_RANGES[name]
        assert lo <= getattr(DEFAULT_VEHICLE, name) <= hi, name
        with pytest.raises(VehicleFileError, match=name):
            VehicleParams(**{name: hi * 1.5 + 1.0})


@pytest.mark.parametrize(
    "kwargs, word",
    [
        (dict(drive_wheel_base_m=12.0), "drive_wheel_base_m"),
        (dict(beam_wheel_base_m=8.0), "beam_wheel_base_m"),
        (dict(chain_spacing_m=9.0), "chain_spacing_m"),
        (dict(length_m=15.0), "length_m"),
        (dict(hook_mass_kg=5_000.0), "hook_mass_kg"),
        (dict(empty_mass_kg=2_000.0, carrying_wheel_mass_kg=300.0), "carrying_wheel_mass_kg"),
    ],
)
def test_geometry_relations_are_checked(kwargs, word):
    with pytest.raises(VehicleFileError, match=word):
        VehicleParams(**kwargs)


def test_derived_geometry():
    v = DEFAULT_VEHICLE
    assert v.carrying_wheel_offsets_m == (4.0, -4.0, -6.0, -12.0)
    assert v.beam_section_offset_m == -9.0
    # drive section (0.56 of the empty mass without wheels and hook) and its two wheels, of the empty mass
    assert v.drive_wheels_weight_share == pytest.approx((0.56 * (16_000 - 240 - 300) + 120) / 16_000)
    longer = v.with_changes(coupler_gap_m=1.5, length_m=19.0)
    assert longer.carrying_wheel_offsets_m[2:] == (-7.0, -13.0)
