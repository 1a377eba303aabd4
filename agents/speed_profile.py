"""Minimum-time speed profile over a known track (the oracle's plan).

The fastest trip the safety rules allow is found the classical way (time-optimal train control): a forward pass
accelerates with all the traction the drive can transmit (motor force and power limits, adhesion), a backward
pass brakes with the guaranteed service brake so that every later speed cap and the stop at the far station are
reached, and the profile is the pointwise minimum of both and of the speed limit ``v_lim(M, theta(s))`` of
:mod:`uuom_core.limits`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Protocol

import numpy as np

from uuom_core.limits import speed_limit_mps
from uuom_core.vehicle import G_MPS2, VehicleParams


class ProfileError(ValueError):
    """Inputs that cannot describe a trip (non-positive mass or length, bad fractions...)."""


class TrackLike(Protocol):
    """What the profile needs from a track: its length and the slope along it."""

    length_m: float

    def slope_at(self, s_m: float | np.ndarray) -> float | np.ndarray: ...


def traction_force_limit_n(
    vehicle: VehicleParams, speed_mps: float | np.ndarray, adhesion: float | None = None
) -> float | np.ndarray:
    """Traction the drive can transmit at a speed: ``min(F_max, P / v, mu_adh N_clamp)``.

    The speed is floored at 0.05 m/s so that the power limit stays finite at standstill (where the torque
    limit governs anyway).
    """
    adh = vehicle.adhesion_dry if adhesion is None else adhesion
    v = np.maximum(np.asarray(speed_mps, dtype=float), 0.05)
    force = np.minimum(np.minimum(vehicle.max_traction_n, vehicle.motor_power_w / v), adh * vehicle.clamp_force_n)
    return float(force) if np.ndim(force) == 0 else force


def resistance_force_n(
    mass_kg: float, slope_rad: float | np.ndarray, running_resistance: float
) -> float | np.ndarray:
    """Grade plus running resistance ``M g (sin theta + mu cos theta)`` (negative downhill when gravity pulls)."""
    return mass_kg * G_MPS2 * (np.sin(slope_rad) + running_resistance * np.cos(slope_rad))


# Share of the empty train's weight on the drive section's wheels, as the plan assumes it. The plant's geometry
# gives VehicleParams.drive_wheels_weight_share (0.5486 for the default vehicle); the plan keeps its older 0.53
# so that the oracle's profiles, and the results built on them, stay as published (switching moves the trip
# times of 23 tracks by at most 0.03 s).
_DRIVE_SHARE_OF_EMPTY = 0.53


def effective_slope_rad(
    slope_fn: Callable[[np.ndarray], np.ndarray],
    s_m: float | np.ndarray,
    vehicle: VehicleParams,
    mass_kg: float,
) -> np.ndarray:
    """Weight-averaged slope under the train's wheels (what gravity pulls with), for reference positions ``s_m``.

    The train is 18 m long; on a grade change its sections stand on different grades. Positions before the
    track start take the slope at 0 (the level run-in).
    """
    s = np.asarray(s_m, dtype=float)
    w_drive = min(_DRIVE_SHARE_OF_EMPTY * vehicle.empty_mass_kg / mass_kg, 1.0)
    out = np.zeros_like(s)
    # where the weight rests, relative to the reference point: the drive section's wheels, then the lifting-beam
    # section's (with the hook and the load) - the plant's geometry, from the vehicle parameters
    wheels = vehicle.carrying_wheel_offsets_m
    for off in wheels[:2]:
        out = out + 0.5 * w_drive * np.asarray(slope_fn(np.maximum(s + off, 0.0)), dtype=float)
    for off in wheels[2:]:
        out = out + 0.5 * (1.0 - w_drive) * np.asarray(slope_fn(np.maximum(s + off, 0.0)), dtype=float)
    return out


@dataclass(frozen=True)
class MinTimeProfile:
    """A minimum-time speed-vs-position plan on a grid (not the driver knots of :class:`uuom_gym.sim.SpeedProfile`).

    Attributes
    ----------
    s_m : ndarray
        Grid of positions from 0 to the stop position.
    speed_mps : ndarray
        Planned speed at each grid point (0 at both ends).
    cap_mps : ndarray
        Speed cap used (the safety limit times ``1 - speed_margin``).
    accel_mps2 : ndarray
        Planned dv/dt at each grid point (``v dv/ds``), the controller's feed-forward.
    trip_time_s : float
        Time to drive the profile exactly.
    feasible : bool
        False when the train cannot climb some grade of the track (forward pass stalls).
    """

    s_m: np.ndarray
    speed_mps: np.ndarray
    cap_mps: np.ndarray
    accel_mps2: np.ndarray
    trip_time_s: float
    feasible: bool

    def speed_at(self, s_m: float | np.ndarray) -> float | np.ndarray:
        """Planned speed at a position (linear interpolation; 0 beyond the stop)."""
        out = np.interp(s_m, self.s_m, self.speed_mps, left=self.speed_mps[0], right=0.0)
        return float(out) if np.ndim(out) == 0 else out

    def accel_at(self, s_m: float | np.ndarray) -> float | np.ndarray:
        """Planned dv/dt at a position."""
        out = np.interp(s_m, self.s_m, self.accel_mps2, left=self.accel_mps2[0], right=0.0)
        return float(out) if np.ndim(out) == 0 else out


def min_time_profile(
    vehicle: VehicleParams,
    mass_kg: float,
    track: TrackLike | None = None,
    *,
    slope_fn: Callable[[np.ndarray], np.ndarray] | None = None,
    length_m: float | None = None,
    stop_s_m: float | None = None,
    ds_m: float = 0.25,
    speed_margin: float = 0.03,
    speed_margin_mps: float = 0.0,
    traction_fraction: float = 0.9,
    brake_fraction: float = 0.6,
    accel_limit_mps2: float = 0.4,
    running_resistance: float | None = None,
    adhesion: float | None = None,
    limit_fn: Callable[[float, float], float] | None = None,
) -> MinTimeProfile:
    """Fastest speed profile from standstill at s = 0 to standstill at ``stop_s_m``.

    Parameters
    ----------
    vehicle : VehicleParams
        The train.
    mass_kg : float
        True total mass.
    track : TrackLike, optional
        Track with ``length_m`` and ``slope_at(s)``; or give ``slope_fn`` and ``length_m``.
    stop_s_m : float, optional
        Where the train must stand still (default: the track end).
    ds_m : float
        Grid step of the integration.
    speed_margin : float
        The plan stays ``speed_margin * v_lim`` below the limit, room for the tracking error of a real
        controller (the rules are breached at ``v > v_lim``, not at a margin).
    speed_margin_mps : float
        Absolute margin below the limit on top of the relative one (the multi-body plant's speed ripples by a
        few cm/s at constant command: couplers, wheel contact, sway).
    traction_fraction, brake_fraction : float
        Fractions of the available traction / guaranteed service brake the plan uses; the rest is the tracking
        controller's authority to correct disturbances (sway, couplers, slip).
    accel_limit_mps2 : float
        Largest planned |dv/dt|. The load hangs on 2 m chains with little damping: a step of acceleration ``a``
        swings it up to ``2 a / g`` rad, so the sway rule (8 deg) bounds the usable acceleration and braking.
    running_resistance, adhesion : float, optional
        The plant's true values (default: the vehicle's nominal running resistance and dry adhesion).
    limit_fn : callable, optional
        ``limit_fn(mass_kg, slope_rad) -> v_lim``; default :func:`uuom_core.limits.speed_limit_mps` for the
        vehicle, i.e. the environment's rule 1.

    Returns
    -------
    MinTimeProfile
    """
    if track is not None:
        slope_fn = track.slope_at  # type: ignore[assignment]
        length_m = float(track.length_m)
    if slope_fn is None or length_m is None:
        raise ProfileError("min_time_profile needs a track, or slope_fn and length_m")
    if not (math.isfinite(mass_kg) and mass_kg > 0):
        raise ProfileError(f"mass_kg must be a positive finite number, got {mass_kg!r}")
    if not (math.isfinite(length_m) and length_m > 0):
        raise ProfileError(f"length_m must be positive, got {length_m!r}")
    stop = length_m if stop_s_m is None else float(stop_s_m)
    if not (0 < stop <= length_m):
        raise ProfileError(f"stop_s_m must lie in (0, length_m={length_m}], got {stop_s_m!r}")
    if not (0 < ds_m <= 5.0):
        raise ProfileError(f"ds_m must lie in (0, 5], got {ds_m!r}")
    for name, val in (("traction_fraction", traction_fraction), ("brake_fraction", brake_fraction)):
        if not (0 < val <= 1):
            raise ProfileError(f"{name} must lie in (0, 1], got {val!r}")
    if not (accel_limit_mps2 > 0):
        raise ProfileError(f"accel_limit_mps2 must be > 0, got {accel_limit_mps2!r}")
    if not (0 <= speed_margin < 1):
        raise ProfileError(f"speed_margin must lie in [0, 1), got {speed_margin!r}")
    mu = vehicle.running_resistance if running_resistance is None else float(running_resistance)
    limit = limit_fn or (lambda m, th: speed_limit_mps(vehicle, m, th))

    n = max(int(math.ceil(stop / ds_m)), 2) + 1
    s = np.linspace(0.0, stop, n)
    h = s[1] - s[0]
    slope = np.asarray(slope_fn(s), dtype=float)
    inertia = mass_kg + vehicle.rotating_mass_kg
    # Gravity acts on the whole train, spread over its wheels; the rule's limit uses the reference point's slope.
    resist = resistance_force_n(mass_kg, effective_slope_rad(slope_fn, s, vehicle, mass_kg), mu)
    lim = np.array([limit(mass_kg, float(th)) for th in slope])
    cap = np.maximum(lim * (1.0 - speed_margin) - speed_margin_mps, 0.2 * lim)
    cap[0] = 0.0
    cap[-1] = 0.0

    # Backward pass: braking decel with the service brake (gravity helps uphill, hinders downhill).
    # On a steep down-grade with a heavy load a fraction of the brake may not beat gravity; then half of what the
    # full brake leaves over gravity is planned with (still > 0 wherever the speed limit allows motion at all).
    net = np.maximum(brake_fraction * vehicle.service_brake_n + resist, 0.5 * (vehicle.service_brake_n + resist))
    brake_decel = np.minimum(net / inertia, accel_limit_mps2)
    back = np.empty(n)
    back[-1] = 0.0
    for i in range(n - 2, -1, -1):
        a = brake_decel[i]
        # A grade the brake cannot hold leaves cap 0 there (speed_limit is 0); keep the recursion defined.
        back[i] = min(cap[i] if i > 0 else math.inf, math.sqrt(max(back[i + 1] ** 2 + 2.0 * max(a, 0.0) * h, 0.0)))

    # Forward pass: full available traction, capped by the backward profile.
    fwd = np.empty(n)
    fwd[0] = 0.0
    feasible = True
    for i in range(n - 1):
        v = fwd[i]
        f_tr = traction_fraction * traction_force_limit_n(vehicle, v, adhesion)
        a = min((f_tr - resist[i]) / inertia, accel_limit_mps2)
        v2 = v * v + 2.0 * a * h
        if v2 <= 0.0 and i < n - 2:
            # Cannot climb here: the train would stall; keep a crawl so the plan stays defined.
            feasible = False
            v2 = (0.05) ** 2
        fwd[i + 1] = min(math.sqrt(max(v2, 0.0)), back[i + 1])
    speed = fwd
    speed[-1] = 0.0
    # Time: trapezoid in 1/v; the first and last cells (v=0 at an end) use constant acceleration.
    vm = speed[:-1] + speed[1:]
    with np.errstate(divide="ignore"):
        dt = np.where(vm > 1e-9, 2.0 * h / np.maximum(vm, 1e-9), 0.0)
    trip = float(dt.sum())
    dv2 = np.gradient(speed**2, s)
    accel = 0.5 * dv2
    return MinTimeProfile(s_m=s, speed_mps=speed, cap_mps=cap, accel_mps2=accel, trip_time_s=trip, feasible=feasible)


__all__ = [
    "ProfileError",
    "MinTimeProfile",
    "TrackLike",
    "effective_slope_rad",
    "min_time_profile",
    "resistance_force_n",
    "traction_force_limit_n",
]
