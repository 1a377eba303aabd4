"""The oracle minimum-time controller: perfect knowledge, the reference for trip time."""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from agents.control_input import ControlInput, ControlInputError, info_value
from agents.controllers.base import SpeedController, _creep_mps, _station_hold, check_settings, force_to_command
from agents.speed_profile import MinTimeProfile, effective_slope_rad, min_time_profile
from uuom_core.vehicle import G_MPS2, VehicleParams


class OracleController(SpeedController):
    """Minimum-time controller with perfect knowledge (true mass, mu, adhesion, track and position).

    Follows the profile of :func:`agents.speed_profile.min_time_profile` with a feed-forward force (planned
    acceleration, grade and running resistance at the true values) plus proportional speed feedback.

    Parameters
    ----------
    vehicle : VehicleParams
    speed_margin, traction_fraction, brake_fraction : float
        Passed to :func:`min_time_profile` (room for tracking errors; rules are breached at ``v > v_lim``).
    gain_per_s : float
        Speed feedback gain (1/s): the force asked per m/s of speed error is ``gain * (M + m_rot)``.
    """

    name = "oracle"

    def __init__(
        self,
        vehicle: VehicleParams,
        dt_s: float = 0.1,
        *,
        speed_margin: float = 0.02,
        speed_margin_mps: float = 0.035,
        stop_offset_m: float = 1.0,
        traction_fraction: float = 0.95,
        brake_fraction: float = 0.5,
        accel_limit_mps2: float = 0.25,
        gain_per_s: float = 3.0,
        integral_gain_per_s2: float = 0.5,
    ) -> None:
        check_settings(dict(traction_fraction=traction_fraction, brake_fraction=brake_fraction),
                       dict(dt_s=dt_s, accel_limit_mps2=accel_limit_mps2),
                       dict(speed_margin=speed_margin, speed_margin_mps=speed_margin_mps, stop_offset_m=stop_offset_m,
                            gain_per_s=gain_per_s, integral_gain_per_s2=integral_gain_per_s2))
        super().__init__(vehicle, dt_s)
        self.speed_margin = speed_margin
        self.speed_margin_mps = speed_margin_mps
        self.stop_offset_m = stop_offset_m
        self.traction_fraction = traction_fraction
        self.brake_fraction = brake_fraction
        self.accel_limit_mps2 = accel_limit_mps2
        self.gain_per_s = gain_per_s
        self.integral_gain_per_s2 = integral_gain_per_s2
        self._integral = 0.0
        self.profile: MinTimeProfile | None = None
        self.mass_kg = vehicle.empty_mass_kg
        self.mu = vehicle.running_resistance
        self.track: Any = None
        self.stop_s_m = 0.0

    def plan(
        self,
        track: Any,
        mass_kg: float,
        *,
        stop_s_m: float | None = None,
        running_resistance: float | None = None,
        adhesion: float | None = None,
    ) -> MinTimeProfile:
        """Plan the trip (called by :meth:`reset` from the env's truth; usable directly)."""
        self.track = track
        self.mass_kg = float(mass_kg)
        self.mu = self.vehicle.running_resistance if running_resistance is None else float(running_resistance)
        station = float(track.length_m if stop_s_m is None else stop_s_m)
        # Aim a little short of the station: the stop tolerance allows it and a gentle final stop needs room.
        self.stop_s_m = max(station - self.stop_offset_m, 0.5 * station)
        self.profile = min_time_profile(
            self.vehicle,
            self.mass_kg,
            track,
            stop_s_m=self.stop_s_m,
            speed_margin=self.speed_margin,
            speed_margin_mps=self.speed_margin_mps,
            traction_fraction=self.traction_fraction,
            brake_fraction=self.brake_fraction,
            accel_limit_mps2=self.accel_limit_mps2,
            running_resistance=self.mu,
            adhesion=adhesion,
        )
        self._integral = 0.0
        return self.profile

    def reset(self, env: Any = None, info: Mapping[str, Any] | None = None) -> None:
        super().reset(env, info)
        if env is None:
            return
        base = getattr(env, "unwrapped", env)
        track = getattr(base, "track", None)
        if track is None:
            raise ControlInputError("the oracle controller needs the env's track (env.unwrapped.track)")
        info = info or {}
        mass = info.get("true_mass_kg", getattr(base, "true_mass_kg", None))
        if mass is None:
            raise ControlInputError("the oracle controller needs the true mass (info['true_mass_kg'])")
        self.plan(
            track,
            float(mass),
            stop_s_m=getattr(base, "station_m", None),
            running_resistance=info.get("running_resistance"),
            adhesion=info.get("adhesion"),
        )

    def act(self, obs: Any, info: Mapping[str, Any]) -> np.ndarray:
        pos = info_value(info, "true_position_m", "position_m")
        speed = info_value(info, "true_speed_mps", "speed_mps")
        return np.array([self.command_at(pos, speed)], dtype=np.float32)

    def command(self, x: ControlInput) -> float:
        return self.command_at(x.position_m, x.speed_mps)

    def command_at(self, position_m: float, speed_mps: float) -> float:
        """Command from the true position and speed."""
        if self.profile is None:
            raise ControlInputError("OracleController.plan()/reset(env) must be called before acting")
        v = self.vehicle
        dist = self.stop_s_m - position_m
        slope = float(effective_slope_rad(self.track.slope_at, position_m, v, self.mass_kg))
        hold = _station_hold(v, dist, speed_mps, self.mass_kg, slope, self.mu)
        if hold is not None:
            return hold
        # Aim at the speed planned where the train will be at the end of this step.
        s_next = position_m + max(speed_mps, 0.0) * self.dt_s
        v_ref = float(self.profile.speed_at(s_next))
        a_ref = float(self.profile.accel_at(s_next))
        v_ref = max(v_ref, _creep_mps(dist))
        err = v_ref - speed_mps
        # Integral action absorbs what the rigid-body feed-forward misses (coupler, sway, wear); anti-windup clamp.
        self._integral = float(np.clip(self._integral + err * self.dt_s, -0.3, 0.3))
        inertia = self.mass_kg + v.rotating_mass_kg
        force = (
            inertia * a_ref
            + self.mass_kg * G_MPS2 * (math.sin(slope) + self.mu * math.cos(slope))
            + inertia * (self.gain_per_s * err + self.integral_gain_per_s2 * self._integral)
        )
        return force_to_command(v, force, speed_mps)


__all__ = ["OracleController"]
