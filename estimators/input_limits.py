"""Physical plausibility limits of the sensor inputs: a value no monorail sensor can read is a fault, not data.

A finite but absurd sample (a torque of 1e300 N m, a speed of 1e9 m/s: a corrupted log, a unit mix-up, a bit flip)
would otherwise enter the filters' arithmetic, overflow to inf and leave NaN behind for good, or drive a loop whose
length depends on the value (the slope history of ``mmae`` walks the distance travelled). The estimators that use
these limits (``mmae``, ``aupf``, ``imu-ukf``) treat such a value exactly like a missing one (``NaN``): predict
without correcting. The limits are an order of magnitude beyond what the vehicle's own parameters allow (traction force, top
speed), so a working sensor never reaches them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from uuom_core.vehicle import G_MPS2, VehicleParams


@dataclass(frozen=True, slots=True)
class InputLimits:
    """Largest plausible magnitude of each input; beyond it the sample counts as missing.

    Attributes
    ----------
    torque_nm : float
        10 x the vehicle's maximum traction force times the drive radius.
    speed_mps : float
        10 x the vehicle's empty top speed, at least 20 m/s (ground speed and rim speed).
    accel_mps2 : float
        5 g, for both accelerometer axes (a spike of the swinging load is below 1 g).
    gyro_radps : float
        20 rad/s (the drive unit pitches by degrees per second).
    motor_speed_radps : float
        ``speed_mps`` over the drive radius, times 100 (room for a gearbox).
    """

    torque_nm: float
    speed_mps: float
    accel_mps2: float
    gyro_radps: float
    motor_speed_radps: float

    @classmethod
    def for_vehicle(cls, vehicle: VehicleParams) -> InputLimits:
        r = vehicle.drive_wheel_radius_m
        speed = max(10.0 * vehicle.max_speed_empty_mps, 20.0)
        return cls(
            torque_nm=10.0 * vehicle.max_traction_n * r,
            speed_mps=speed,
            accel_mps2=5.0 * G_MPS2,
            gyro_radps=20.0,
            motor_speed_radps=100.0 * speed / r,
        )


def plausible(value: float, limit: float) -> float:
    """``value`` if ``|value| <= limit``, else ``NaN`` (missing); NaN and +-inf give NaN."""
    return value if -limit <= value <= limit else math.nan


__all__ = ["InputLimits", "plausible"]
