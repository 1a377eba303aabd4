"""The plant's fast path (Chipmunk's C functions, uuom_gym.sim.fast_path) against pymunk's public API."""

from __future__ import annotations

import numpy as np
import pytest

from uuom_core.vehicle import DEFAULT_VEHICLE as V
from uuom_gym.sim import MonorailPlant, PlantConfig, random_track, scenario_track
from uuom_gym.sim.fast_path import CHIPMUNK_AVAILABLE, FrictionMotors, tick_ops


def _seeded_run(fast: bool, config: PlantConfig, track, seed: int) -> tuple[dict, dict, list]:
    rng = np.random.default_rng(seed)
    plant = MonorailPlant(V, track, config, start_s_m=30.0, fast_path=fast)
    plant.displace_load(0.05)
    logs = []
    for _ in range(120):
        u = float(rng.choice([-1.0, 0.0, 1.0])) if rng.random() < 0.2 else float(rng.uniform(-1.0, 1.0))
        if rng.random() < 0.03:
            plant.emergency_brake()
        elif rng.random() < 0.05:
            plant.reset_emergency_brake()
        logs.append(plant.advance(u, int(rng.choice([1, 7, 20, 33]))))
    cols = type(logs[0]).concatenate(logs).as_dict()
    state = plant.state
    return cols, dict(plant.energy), [float(getattr(state, k)) for k in state.__dataclass_fields__]


@pytest.mark.skipif(not CHIPMUNK_AVAILABLE, reason="this pymunk build does not expose Chipmunk's functions")
@pytest.mark.parametrize(
    "config, track",
    [
        (PlantConfig(load_kg=10_000, track_energy=True), scenario_track("roadtest")),
        (PlantConfig(load_kg=20_000, adhesion=0.06, wheel_wear_m=0.01), scenario_track("section2")),
        (PlantConfig(load_kg=5_000, physics_hz=400.0, running_resistance=0.03),
         random_track(np.random.default_rng(3), load_kg=5_000)),
    ],
)
def test_fast_and_public_paths_agree_bit_for_bit(config, track):
    fast = _seeded_run(True, config, track, seed=11)
    public = _seeded_run(False, config, track, seed=11)
    for name, col in fast[0].items():
        assert np.array_equal(col, public[0][name]), name
    assert fast[1] == public[1]
    assert fast[2] == public[2]
    assert np.any(fast[0]["slipping"]) or config.adhesion is None  # the slip branch was exercised where meant


def test_the_plant_uses_the_path_it_was_asked_for():
    plant = MonorailPlant(V, scenario_track("section1"), PlantConfig(load_kg=1_000), fast_path=False)
    plant.advance(0.3, 2)
    assert plant._ops.raw_log is None and not plant._friction.fast
    plant = MonorailPlant(V, scenario_track("section1"), PlantConfig(load_kg=1_000), fast_path=True)
    plant.advance(0.3, 2)
    assert (plant._ops.raw_log is not None) == CHIPMUNK_AVAILABLE and plant._friction.fast == CHIPMUNK_AVAILABLE


def test_friction_motors_read_and_write_the_same_on_both_paths():
    plant = MonorailPlant(V, scenario_track("section1"), PlantConfig(load_kg=1_000))
    fast = FrictionMotors(plant.wheels, plant.friction_motors, fast=True)
    public = FrictionMotors(plant.wheels, plant.friction_motors, fast=False)
    assert fast.wheel_x_m() == public.wheel_x_m() == [w.position.x for w in plant.wheels]
    fast.set_max_forces([1.0, 2.0, 3.0, 4.0])
    assert [m.max_force for m in plant.friction_motors] == [1.0, 2.0, 3.0, 4.0]
    public.set_max_forces([5.0, 6.0, 7.0, 8.0])
    assert [m.max_force for m in plant.friction_motors] == [5.0, 6.0, 7.0, 8.0]
    ops = tick_ops(plant.space, plant.drive_body, plant.dt_s, fast=False)
    ops.push(ops.body, (10.0, 0.0), ops.zero)
    assert plant.drive_body.force.x == pytest.approx(10.0)
