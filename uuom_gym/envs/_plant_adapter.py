"""The environment's bridge to the plant (:mod:`uuom_gym.sim`): drawing the episode's conditions, building the
plant and sensors, and reading the per-tick truth log.

Kept apart from ``track_env`` so the env stays independent of how the plant names its internals.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from uuom_core.vehicle import VehicleParams

TICK_FIELDS: tuple[str, ...] = (
    "position_m",
    "speed_mps",
    "slope_rad",
    "sway_rad",
    "slipping",
    "drive_torque_nm",
    "wheel_speed_radps",
)


@dataclass(frozen=True)
class Conditions:
    """What one ``reset`` drew (or the scenario fixed)."""

    track: Any
    load_kg: float
    running_resistance: float
    adhesion: float
    wet: bool
    wheel_wear_m: float
    sensor_noise_scale: float
    sensor_bias_scale: float
    sensor_seed: int
    scenario: str | None = None


def draw_conditions(cfg: Mapping[str, Any], vehicle: VehicleParams, rng: np.random.Generator) -> Conditions:
    """Draw the episode's conditions from ``rng`` in a fixed order (so a seed fixes the episode)."""
    from uuom_gym.sim.track import random_track, scenario_track

    lo, hi = cfg["load_fraction_range"]
    beta = cfg.get("load_fraction_beta")
    # None keeps the one uniform draw, so every seed of earlier revisions draws the same episode; a share of 0
    # keeps rev. 19's one Beta draw.
    share = cfg.get("load_fraction_uniform_share", 0.0)
    if beta is None or (share > 0.0 and rng.random() < share):
        fraction = float(rng.uniform(lo, hi))
    else:
        fraction = lo + (hi - lo) * float(rng.beta(*beta))
    load_draw = fraction * vehicle.rated_load_kg
    mu = float(rng.uniform(*cfg["running_resistance_range"]))
    wet = bool(rng.random() < cfg["wet_probability"])
    adhesion = float(rng.uniform(*(cfg["adhesion_wet_range"] if wet else cfg["adhesion_dry_range"])))
    wear = float(rng.uniform(*cfg["wheel_wear_range_m"]))
    noise = float(rng.uniform(*cfg["sensor_noise_scale_range"]))
    bias = float(rng.uniform(*cfg["sensor_bias_scale_range"]))
    sensor_seed = int(rng.integers(0, 2**63 - 1))
    scenario = cfg["scenario"]
    if scenario is not None:
        # The paper's runs: fixed track and load, nominal conditions (dry rail, nominal mu, new wheels).
        load = _scenario_load_kg(scenario, vehicle)
        if cfg["load_kg"] is not None:
            load = float(cfg["load_kg"])
        return Conditions(
            track=scenario_track(scenario),
            load_kg=load,
            running_resistance=vehicle.running_resistance,
            adhesion=vehicle.adhesion_dry,
            wet=False,
            wheel_wear_m=0.0,
            sensor_noise_scale=1.0,
            sensor_bias_scale=1.0,
            sensor_seed=sensor_seed,
            scenario=scenario,
        )
    load = float(cfg["load_kg"]) if cfg["load_kg"] is not None else load_draw
    if cfg["track"] is not None:
        track = cfg["track"]
    else:
        track = random_track(
            rng,
            length_m=cfg["track_length_m"],
            # never steeper than the vehicle is specified for: the observation scales the grade by it and the 'none'
            # observer's worst case assumes it (a 12 deg vehicle had met 15 deg tracks; session 59)
            max_grade_deg=min(cfg["max_grade_deg"], vehicle.max_grade_deg),
            vehicle=vehicle,
            load_kg=load,
            running_resistance=mu,
            adhesion=adhesion,
            feasible=not cfg["allow_infeasible"],
            feasibility_margin=cfg["feasibility_margin"],
        )
    return Conditions(track, load, mu, adhesion, wet, wear, noise, bias, sensor_seed, None)


def _scenario_load_kg(name: str, vehicle: VehicleParams) -> float:
    from uuom_gym.sim.scenarios import scenario

    return float(scenario(name).load_kg)


def build_plant(vehicle: VehicleParams, cfg: Mapping[str, Any], cond: Conditions, rng: np.random.Generator):
    """The plant and the sensor suite of one episode."""
    from uuom_gym.sim.plant import MonorailPlant, PlantConfig
    from uuom_gym.sim.sensors import SensorConfig, SensorSuite

    plant_cfg = PlantConfig(
        load_kg=cond.load_kg,
        running_resistance=cond.running_resistance,
        adhesion=cond.adhesion,
        wheel_wear_m=cond.wheel_wear_m,
        physics_hz=cfg["physics_hz"],
    )
    plant = MonorailPlant(vehicle, cond.track, plant_cfg, start_s_m=0.0)
    base = SensorConfig()
    scaled = {}
    for f in dataclasses.fields(base):
        if "_noise_std" in f.name:
            scaled[f.name] = getattr(base, f.name) * cond.sensor_noise_scale
        elif "_bias_std" in f.name:
            scaled[f.name] = getattr(base, f.name) * cond.sensor_bias_scale
    sensor_cfg = dataclasses.replace(base, **scaled)
    sensors = SensorSuite(
        sensor_cfg, np.random.default_rng(cond.sensor_seed), vehicle=vehicle, faults=cfg["sensor_faults"]
    )
    return plant, sensors


def _getter(obj: Any) -> Any:
    # one isinstance per call, not per field: the typing.Mapping check costs microseconds every time
    return obj.__getitem__ if isinstance(obj, Mapping) else obj.__getattribute__


def log_arrays(log: Any) -> dict[str, np.ndarray]:
    """The per-tick truth fields the env uses, as arrays."""
    get = _getter(log)
    return {k: np.asarray(get(k)) for k in TICK_FIELDS}


def state_arrays(plant: Any) -> dict[str, float]:
    """Position, speed and sway of the plant's current state, as floats."""
    st = plant.state
    get = _getter(st)
    return {k: float(get(k)) for k in ("position_m", "speed_mps", "sway_rad")}


__all__ = ["Conditions", "TICK_FIELDS", "build_plant", "draw_conditions", "log_arrays", "state_arrays"]
