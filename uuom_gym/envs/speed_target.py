"""Opt-in action parameterisation ``action_mode="speed_target"`` of ``UUOM-Track-v0``.

The default action is a traction/brake command whose zero means "coast": at rest, a Gaussian policy around 0
does not move the train 1 m in 20 s and PPO never sees progress (docs/rl.md §3, "the start trap"). In this mode
the action ``a`` in ``[-1, 1]`` is a *target speed*::

    v_target = (a + 1) / 2 * cautious_limit

(``a = -1``: stop; ``a = 0``: half the cautious limit, a gentle drive; ``a = 1``: the cautious limit), and a
speed tracker inside the env turns it into the plant's command once per policy step. ``cautious_limit`` is
observation entry 13 (the speed limit at the estimate's pessimistic corner, the rated-load limit before the
estimator has converged), so the policy's zero drives gently whatever the load. The tracker uses only what the
agent's observation is built from (measured speed, estimated mass and slope, the model-free grade), never the
truth; it does not enforce the limit (no shield): a target above the true limit still trips.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from uuom_core.vehicle import VehicleParams

G_MPS2 = 9.80665

RAMP_WINDOW_MPS = 0.3
"""``action_mode="acceleration"``: the ramped target stays within this much of the measured speed (anti-windup: a
train that cannot follow the demand does not run up a hidden backlog)."""

ENVELOPE_DECEL_MPS2 = 0.3
"""``speed_target_cap="station"``: deceleration of the braking envelope to the station (the shaping's stop curve,
:data:`uuom_gym.envs.reward_shaping.STOP_DECEL_MPS2`; the service brake gives 3-7 m/s^2 on the level)."""

ENVELOPE_STOP_OFFSET_M = 0.5
"""``speed_target_cap="station"``: the envelope reaches 0 this far before the station (odometry): the tracker's
lag carries the train a little further."""


def station_envelope_mps(distance_to_go_m: float) -> float:
    """``sqrt(2 a (d - d0)+)``: the highest speed from which the train still stops ``d0`` before the station."""
    d = max(float(distance_to_go_m) - ENVELOPE_STOP_OFFSET_M, 0.0)
    return math.sqrt(2.0 * ENVELOPE_DECEL_MPS2 * d)


def ramp_target_mps(target_mps: float, accel_mps2: float, step_s: float, speed_mps: float) -> float:
    """``action_mode="acceleration"``: the target speed moved by ``accel * step``, kept within
    :data:`RAMP_WINDOW_MPS` of the measured speed and at or above 0."""
    lo = max(float(speed_mps) - RAMP_WINDOW_MPS, 0.0)
    hi = max(float(speed_mps) + RAMP_WINDOW_MPS, 0.0)
    return min(max(float(target_mps) + float(accel_mps2) * float(step_s), lo), hi)


def target_speed_mps(action: float, cautious_limit_mps: float, span: tuple[float, float] = (0.0, 1.0)) -> float:
    """Target speed for an action in ``[-1, 1]``: ``(lo + (a + 1) / 2 (hi - lo)) * cautious_limit``.

    ``span = (lo, hi)`` is config ``speed_target_range``; the default ``(0, 1)`` gives ``(a + 1) / 2 * limit``
    (``a = -1`` stops). A span centred near 1 makes the policy's zero drive at the cautious limit and lets it learn
    to go above it where the estimate can be trusted (``hi > 1``: no shield, a target above the true limit trips).
    """
    a = min(max(float(action), -1.0), 1.0)
    lo, hi = float(span[0]), float(span[1])
    return (lo + 0.5 * (a + 1.0) * (hi - lo)) * max(float(cautious_limit_mps), 0.0)


@dataclass
class SpeedTracker:
    """PI speed tracker with a grade/resistance feed-forward, run at the policy rate.

    Parameters
    ----------
    vehicle : VehicleParams
        Force limits, running resistance and rotating mass.
    step_s : float
        Policy step (s): the command is held this long.
    gain_per_s : float
        Force per m/s of speed error, as ``gain * (M + m_rot)`` (1/s).
    integral_gain_per_s2 : float
        Integral gain (1/s^2); the integral is clamped to ``integral_clamp_m`` (anti-windup).
    """

    vehicle: VehicleParams
    step_s: float
    gain_per_s: float = 3.0
    integral_gain_per_s2: float = 0.5
    integral_clamp_m: float = 0.3
    integral_m: float = 0.0

    def reset(self) -> None:
        """Forget the integral (each episode starts at rest)."""
        self.integral_m = 0.0

    def command(self, target_mps: float, speed_mps: float, mass_kg: float, slope_rad: float,
                accel_mps2: float = 0.0) -> float:
        """Plant command in ``[-1, 1]`` that drives the measured speed toward ``target_mps``.

        ``mass_kg`` and ``slope_rad`` are the estimates used for the feed-forward (mass clamped to the
        vehicle's empty..max range); ``accel_mps2`` is the target's own rate of change, fed forward as a force.
        Positive force maps to a fraction of the traction available at this speed (torque and power limits),
        negative to a fraction of the service brake.
        """
        v = self.vehicle
        m = min(max(float(mass_kg), v.empty_mass_kg), v.max_mass_kg)
        th = min(max(float(slope_rad), -1.2), 1.2)
        err = float(target_mps) - float(speed_mps)
        self.integral_m = min(max(self.integral_m + err * self.step_s, -self.integral_clamp_m), self.integral_clamp_m)
        inertia = m + v.rotating_mass_kg
        force = m * G_MPS2 * (math.sin(th) + v.running_resistance * math.cos(th)) + inertia * (
            accel_mps2 + self.gain_per_s * err + self.integral_gain_per_s2 * self.integral_m
        )
        if target_mps <= 0.0 and speed_mps <= 0.05:
            # Stop requested and (nearly) reached: hold with the brake instead of creeping on the integral.
            return -1.0
        if force >= 0.0:
            available = min(v.max_traction_n, v.motor_power_w / max(abs(float(speed_mps)), 0.05))
            cmd = force / available
        else:
            cmd = force / v.service_brake_n
        return min(max(cmd, -1.0), 1.0)


__all__ = [
    "ENVELOPE_DECEL_MPS2", "ENVELOPE_STOP_OFFSET_M", "RAMP_WINDOW_MPS", "SpeedTracker", "ramp_target_mps",
    "station_envelope_mps", "target_speed_mps",
]
