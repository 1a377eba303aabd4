"""The monorail plant: tracks, the pymunk multi-body train, sensors, named scenarios and run recording."""

from uuom_gym.sim.plant import MonorailPlant, PlantConfig, PlantConfigError, PlantLog, PlantState
from uuom_gym.sim.recording import SpeedDriver, simulate_run
from uuom_gym.sim.scenarios import Scenario, SpeedProfile, scenario
from uuom_gym.sim.sensors import CHANNELS, FaultConfig, SensorConfig, SensorConfigError, SensorSuite
from uuom_gym.sim.track import (
    SCENARIO_NAMES,
    TrackError,
    TrackProfile,
    profile_from_knots,
    random_track,
    scenario_track,
)

__all__ = [
    "CHANNELS", "SCENARIO_NAMES", "FaultConfig", "MonorailPlant", "PlantConfig", "PlantConfigError", "PlantLog",
    "PlantState", "Scenario", "SensorConfig", "SensorConfigError", "SensorSuite", "SpeedDriver", "SpeedProfile",
    "TrackError", "TrackProfile", "profile_from_knots", "random_track", "scenario", "scenario_track",
    "simulate_run",
]
