"""The controllers' base class and what they share: force-to-command conversion, the station stop."""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from agents.control_input import ControlInput, control_input_from_info, control_input_from_obs, observation_settings
from uuom_core.units import clamp
from uuom_core.vehicle import G_MPS2, VehicleParams


def force_to_command(vehicle: VehicleParams, force_n: float, speed_mps: float = 0.0) -> float:
    """Convert a wanted along-track force to the plant's command.

    Traction: the plant scales the motor torque available at the current speed (torque limit ``F_max r``,
    power limit ``P / omega``) by the command, so ``cmd = F / min(F_max, P / v)``. Braking: ``cmd = F / F_brake``.
    """
    if force_n >= 0.0:
        available = min(vehicle.max_traction_n, vehicle.motor_power_w / max(abs(speed_mps), 0.05))
        cmd = force_n / available
    else:
        cmd = force_n / vehicle.service_brake_n
    return float(clamp(cmd, -1.0, 1.0))


def _creep_mps(dist_m: float) -> float:
    # The braking curve reaches 0 exactly at the stop, which a drive never does: creep the last metres slowly.
    return 0.08 if dist_m > 0.3 else 0.0


STOP_DECEL_MPS2 = 0.3
"""Deceleration of the final stop: gentle, because a hard stop makes the cars and the load rebound backwards."""


def _station_hold(
    vehicle: VehicleParams, dist_m: float, speed_mps: float, mass_kg: float, slope_rad: float, mu: float
) -> float | None:
    """Command at the stop, or None while the train is still short of it.

    Rolling slowly: the force that decelerates at :data:`STOP_DECEL_MPS2` on this grade (traction on a steep
    up-grade, where gravity alone would stop the train abruptly; brake elsewhere). Standing, or 0.7 m past the
    aimed stop (the grade was misjudged): full brake.
    """
    if dist_m > 0.3:
        return None
    if abs(speed_mps) < 0.03:
        return -1.0
    if speed_mps < 0.12 and dist_m > -0.7:
        force = mass_kg * G_MPS2 * (math.sin(slope_rad) + mu * math.cos(slope_rad)) - mass_kg * STOP_DECEL_MPS2
        return force_to_command(vehicle, force, speed_mps)
    if dist_m <= -0.7:
        # The gentle stop did not work (wrong slope estimate, slippery rail): the station is close, brake fully.
        return -1.0
    return None


def check_settings(fractions: dict[str, float], positive: dict[str, float], non_negative: dict[str, float]) -> None:
    """Raise ``ValueError`` naming the first controller setting that is not a finite number in its range:
    ``fractions`` in (0, 1], ``positive`` > 0, ``non_negative`` >= 0 (a margin of -5 or a gain of NaN had driven)."""
    for group, ok, text in ((fractions, lambda x: 0.0 < x <= 1.0, "in (0, 1]"),
                            (positive, lambda x: x > 0.0, "> 0"), (non_negative, lambda x: x >= 0.0, ">= 0")):
        for name, value in group.items():
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) \
                    or not ok(value):
                raise ValueError(f"{name} must be a finite number {text}, got {value!r}")


def episode_vehicle(env: Any, current: VehicleParams) -> VehicleParams:
    """The vehicle a controller or shield built for ``env`` drives this episode: ``env.unwrapped.vehicle`` when the
    env draws its vehicle per reset (config ``vehicle_spread`` > 1), otherwise ``current`` -- the vehicle it was built
    with, which a study may set apart from the env's on purpose."""
    base = getattr(env, "unwrapped", env)
    config = getattr(base, "config", None)
    vehicle = getattr(base, "vehicle", None)
    if isinstance(config, Mapping) and config.get("vehicle_spread", 1.0) > 1.0 and isinstance(vehicle, VehicleParams):
        return vehicle
    return current


class SpeedController:
    """Base class: ``reset(env, info)`` at the start of an episode, ``act(obs, info) -> ndarray (1,)``."""

    name = "controller"
    action_modes: tuple[str, ...] | None = None
    """The env ``action_mode`` values whose action this controller computes (None: it is not checked)."""

    def __init__(self, vehicle: VehicleParams, dt_s: float = 0.1) -> None:
        self.vehicle = vehicle
        self.dt_s = float(dt_s)
        self.track_length_m: float | None = None
        self.near_shape = "clip"

    def reset(self, env: Any = None, info: Mapping[str, Any] | None = None) -> None:
        """Start an episode (subclasses read what they may know from the env / the reset info).

        An env that draws its vehicle at every reset (config ``vehicle_spread`` > 1) hands the episode's vehicle
        file to the controller here, as a monorail's controller reads the file of the train it drives.
        """
        if env is not None:
            base = getattr(env, "unwrapped", env)
            config = getattr(base, "config", None)
            self.vehicle = episode_vehicle(base, self.vehicle)
            if self.action_modes is not None and isinstance(config, Mapping) \
                    and config.get("action_mode") not in self.action_modes:
                raise ValueError(f"controller {self.name!r} acts on action_mode="
                                 f"{' or '.join(map(repr, self.action_modes))}, the env has "
                                 f"action_mode={config.get('action_mode')!r}")
            settings = observation_settings(base)
            if settings is not None:
                self.dt_s, self.near_shape = settings
            track = getattr(base, "track", None)
            if track is not None:
                self.track_length_m = float(track.length_m)

    def command(self, x: ControlInput) -> float:  # pragma: no cover - abstract
        raise NotImplementedError

    def control_input(self, obs: Any, info: Mapping[str, Any]) -> ControlInput:
        """What the controller knows now: decoded from the observation (preferred: what an agent sees) or the info."""
        if obs is not None and self.track_length_m is not None:
            return control_input_from_obs(obs, self.vehicle, self.track_length_m, self.dt_s, self.near_shape)
        return control_input_from_info(info, self.dt_s)

    def act(self, obs: Any, info: Mapping[str, Any]) -> np.ndarray:
        """Action for ``env.step`` from the latest observation (preferred: what an agent sees) or the info."""
        cmd = self.command(self.control_input(obs, info))
        if not math.isfinite(cmd):  # defensive: never send NaN to the plant
            cmd = -1.0
        return np.array([cmd], dtype=np.float32)


class FullThrottleController(SpeedController):
    """Always asks for full traction: unsafe alone; behind :class:`agents.shield.SafetyShield`
    (``full-throttle+shield`` in ``scripts/evaluate.py``) it shows what the shield by itself guarantees."""

    name = "full-throttle"

    def act(self, obs: Any, info: Mapping[str, Any]) -> np.ndarray:
        return np.array([1.0], dtype=np.float32)

    def command(self, x: ControlInput) -> float:
        return 1.0


__all__ = ["FullThrottleController", "STOP_DECEL_MPS2", "SpeedController", "episode_vehicle", "force_to_command"]
