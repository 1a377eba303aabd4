"""The safe operating envelope of the train as functions of mass and grade (spec §6 rules 1 and 6).

Pure functions of the vehicle parameters, used three ways: by the environment's safety rules with the *true*
mass and slope, by the observation layer and the controllers with the *estimated* ones, and by the track
generator to keep random tracks feasible for their load.
"""

from __future__ import annotations

import math

from uuom_core.vehicle import G_MPS2, VehicleParams

STOP_DISTANCE_M = 1.5
"""Distance within which the guaranteed (service) brake must stop the train from the speed limit."""

BRAKE_DELAY_S = 0.6
"""Time from the brake command until the brake force is fully applied (travelled at constant speed)."""


def load_speed_limit_mps(vehicle: VehicleParams, mass_kg: float) -> float:
    """Load-dependent limit: 2.0 m/s empty falling linearly to 0.5 m/s at rated load (Table 3), flat beyond."""
    load = mass_kg - vehicle.empty_mass_kg
    frac = min(max(load / vehicle.rated_load_kg, 0.0), 1.0) if vehicle.rated_load_kg > 0 else 0.0
    return vehicle.max_speed_empty_mps + frac * (vehicle.max_speed_rated_mps - vehicle.max_speed_empty_mps)


def brake_deceleration_mps2(
    vehicle: VehicleParams, mass_kg: float, slope_rad: float, running_resistance: float | None = None
) -> float:
    """Deceleration of the train under the guaranteed brake force on a grade (positive = slowing down).

    Uphill (slope > 0) gravity helps; downhill the brake must first beat ``M g sin|slope|``. The result can be
    negative: the brake cannot hold the train on that grade.
    """
    mu = vehicle.running_resistance if running_resistance is None else running_resistance
    force = vehicle.service_brake_n + mass_kg * G_MPS2 * (math.sin(slope_rad) + mu * math.cos(slope_rad))
    return force / (mass_kg + vehicle.rotating_mass_kg)


def stopping_speed_limit_mps(
    vehicle: VehicleParams,
    mass_kg: float,
    slope_rad: float,
    stop_distance_m: float = STOP_DISTANCE_M,
    brake_delay_s: float = BRAKE_DELAY_S,
    running_resistance: float | None = None,
) -> float:
    """Highest speed from which the service brake stops the train within ``stop_distance_m`` on this grade.

    Solves ``v t_d + v^2 / (2 a) = d`` for v; 0 when the brake cannot hold the train on the grade.
    """
    a = brake_deceleration_mps2(vehicle, mass_kg, slope_rad, running_resistance)
    if a <= 0.0:
        return 0.0
    # v^2/(2a) + t_d v - d = 0
    b = brake_delay_s
    return (-b + math.sqrt(b * b + 2.0 * stop_distance_m / a)) * a


def speed_limit_mps(
    vehicle: VehicleParams,
    mass_kg: float,
    slope_rad: float,
    stop_distance_m: float = STOP_DISTANCE_M,
    brake_delay_s: float = BRAKE_DELAY_S,
) -> float:
    """Speed limit ``v_lim(M, slope) = min(v_load(M), v_stop(M, slope))`` (spec §6 rule 1)."""
    return min(
        load_speed_limit_mps(vehicle, mass_kg),
        stopping_speed_limit_mps(vehicle, mass_kg, slope_rad, stop_distance_m, brake_delay_s),
    )


def max_traction_force_n(vehicle: VehicleParams, adhesion: float | None = None) -> float:
    """Traction the drive can transmit: the motor limit or the adhesion limit, whichever is lower."""
    adh = vehicle.adhesion_dry if adhesion is None else adhesion
    return min(vehicle.max_traction_n, adh * vehicle.clamp_force_n)


def max_climbable_grade_rad(
    vehicle: VehicleParams,
    mass_kg: float,
    running_resistance: float | None = None,
    adhesion: float | None = None,
) -> float:
    """Steepest grade the train can climb at constant speed: ``sin t + mu cos t = F_max / (M g)``.

    Returns ``pi/2`` when even a vertical rail would do (never for real vehicles) and 0 when the train cannot move
    on the level.
    """
    mu = vehicle.running_resistance if running_resistance is None else running_resistance
    ratio = max_traction_force_n(vehicle, adhesion) / (mass_kg * G_MPS2)
    amp = math.sqrt(1.0 + mu * mu)
    if ratio >= amp:
        return math.pi / 2
    if ratio <= mu:
        return 0.0
    return math.asin(ratio / amp) - math.atan(mu)


def max_descendable_grade_rad(vehicle: VehicleParams, mass_kg: float, running_resistance: float | None = None) -> float:
    """Steepest down-grade on which the service brake still decelerates the train: ``sin t − mu cos t = F_b / (M g)``.

    Returns ``pi/2`` when the brake holds the train on any grade. Beyond it no controller keeps the speed limit, so
    a random track for this train does not hold it (:func:`uuom_gym.sim.track.random_track`).
    """
    mu = vehicle.running_resistance if running_resistance is None else running_resistance
    ratio = vehicle.service_brake_n / (mass_kg * G_MPS2)
    amp = math.sqrt(1.0 + mu * mu)
    if ratio >= amp:
        return math.pi / 2
    return min(math.pi / 2, math.asin(ratio / amp) + math.atan(mu))


def speed_limit_mps_array(
    vehicle: VehicleParams,
    mass_kg: float,
    slope_rad: "np.ndarray",
    stop_distance_m: float = STOP_DISTANCE_M,
    brake_delay_s: float = BRAKE_DELAY_S,
) -> "np.ndarray":
    """:func:`speed_limit_mps` for one mass and an array of slopes (vectorised; same formula, same result).

    Added for the environment, which evaluates the limit at every physics tick of a policy step.
    """
    import numpy as np

    slope = np.asarray(slope_rad, dtype=float)
    mu = vehicle.running_resistance
    force = vehicle.service_brake_n + mass_kg * G_MPS2 * (np.sin(slope) + mu * np.cos(slope))
    a = force / (mass_kg + vehicle.rotating_mass_kg)
    b = brake_delay_s
    a_pos = np.maximum(a, 1e-300)
    v_stop = np.where(a > 0.0, (-b + np.sqrt(b * b + 2.0 * stop_distance_m / a_pos)) * a_pos, 0.0)
    return np.minimum(load_speed_limit_mps(vehicle, mass_kg), v_stop)


__all__ = [
    "BRAKE_DELAY_S",
    "STOP_DISTANCE_M",
    "brake_deceleration_mps2",
    "load_speed_limit_mps",
    "max_climbable_grade_rad",
    "max_descendable_grade_rad",
    "max_traction_force_n",
    "speed_limit_mps",
    "speed_limit_mps_array",
    "stopping_speed_limit_mps",
]
