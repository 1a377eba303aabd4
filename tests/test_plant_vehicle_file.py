"""A vehicle file's values reach the plant: loading different values gives a different, predictable simulation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2, VehicleParams
from uuom_gym.sim import MonorailPlant, PlantConfig, profile_from_knots

LEVEL = profile_from_knots([(0.0, 0.0), (400.0, 0.0)])


def _load(tmp_path, text: str) -> VehicleParams:
    p = tmp_path / "veh.toml"
    p.write_text("[vehicle]\n" + text)
    return VehicleParams.from_toml(p)


def _accel(vehicle: VehicleParams, force_n: float) -> tuple[float, float]:
    """Centre-of-mass acceleration and the mean traction force at a constant command on the level, mu = 0."""
    plant = MonorailPlant(vehicle, LEVEL, PlantConfig(load_kg=0.0, running_resistance=0.0), start_s_m=20.0)
    u = force_n / vehicle.max_traction_n
    plant.advance(u, 200)
    v0, t0 = plant.centre_of_mass_speed_mps(), plant.t_s
    log = plant.advance(u, 600)
    return (plant.centre_of_mass_speed_mps() - v0) / (plant.t_s - t0), float(np.mean(log.traction_force_n))


def test_mass_and_wheel_inertia_in_the_file_change_the_acceleration(tmp_path):
    heavy = _load(tmp_path, "empty_mass_kg = 24000.0\n")
    light_wheels = _load(tmp_path, "wheel_inertia_kgm2 = 0.5\n")
    assert heavy.empty_mass_kg == 24_000 and light_wheels.wheel_inertia_kgm2 == 0.5
    accel = {}
    for veh in (DEFAULT_VEHICLE, heavy, light_wheels):
        a, f = _accel(veh, 3_000.0)
        # a = F / (M + m_rot): the file's mass and its rotating-mass term both show in the simulated train
        assert a == pytest.approx(f / (veh.empty_mass_kg + veh.rotating_mass_kg), rel=2e-3)
        accel[veh] = a
    assert accel[heavy] < 0.75 * accel[DEFAULT_VEHICLE] < accel[light_wheels]


def test_drive_wheel_radius_in_the_file_changes_the_wheel_speed(tmp_path):
    big = _load(tmp_path, "drive_wheel_radius_m = 0.25\n")
    speeds = {}
    for veh in (DEFAULT_VEHICLE, big):
        plant = MonorailPlant(veh, LEVEL, PlantConfig(load_kg=0.0), start_s_m=20.0)
        log = plant.advance(0.3, 600)
        assert not log.slipping[-1]
        speeds[veh.drive_wheel_radius_m] = (log.wheel_speed_radps[-1], log.speed_mps[-1])
    for r, (omega, v) in speeds.items():
        assert omega * r == pytest.approx(v, rel=1e-9)  # omega r = v while the wheel sticks
    assert speeds[0.25][0] < 0.8 * speeds[0.17][0]


def test_chain_length_in_the_file_changes_the_load_swing(tmp_path):
    long_chain = _load(tmp_path, "chain_length_m = 4.0\n")
    periods = {}
    for veh in (DEFAULT_VEHICLE, long_chain):
        plant = MonorailPlant(veh, LEVEL, PlantConfig(load_kg=10_000, anti_sway_damping_ratio=0.0), start_s_m=20.0)
        assert plant.config.chain_length_m == veh.chain_length_m
        plant.emergency_brake()
        plant.displace_load(0.05)
        x = plant.advance(0.0, 3000).sway_rad
        up = np.where((x[:-1] < 0) & (x[1:] >= 0))[0]
        periods[veh.chain_length_m] = float(np.mean(np.diff(up))) * plant.dt_s
    for length, period in periods.items():
        assert period == pytest.approx(2 * math.pi * math.sqrt(length / G_MPS2), rel=0.01)


def test_geometry_in_the_file_moves_the_wheels(tmp_path):
    veh = _load(tmp_path, "drive_wheel_base_m = 6.0\ncoupler_gap_m = 1.0\nlength_m = 19.0\n")
    plant = MonorailPlant(veh, LEVEL, PlantConfig(load_kg=0.0), start_s_m=50.0)
    xs = [w.position.x for w in plant.wheels]
    expected = [50.0 + off for off in veh.carrying_wheel_offsets_m]
    assert xs == pytest.approx(expected, abs=2e-3)  # (settling moves them by the slop of the contacts)
    assert veh.carrying_wheel_offsets_m == (3.0, -3.0, -6.5, -12.5)
