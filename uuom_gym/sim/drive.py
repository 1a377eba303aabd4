"""The friction drive as pure functions: motor torque limits and the drive-wheel / rail stick-slip adhesion.

The drive wheel's angular speed ``omega`` is integrated here, outside pymunk (the wheel is clamped to the rail
web, not a body of the simulation); pymunk only receives the force the contact transmits. One tick is:

1. :func:`drive_force` before the physics step: the motor torque available at ``omega`` (torque limit
   ``max_torque_nm``, power limit ``max_power_w / omega``, linear taper to zero over the last 10 % below
   ``max_omega_radps``) and the force the contact passes to the train. While the force needed to roll with the
   train (``T / r - J / r^2 * a``, the wheel's inertia with the last tick's acceleration) is within
   ``adhesion_limit_n`` the wheel sticks; beyond it the wheel slips in the direction of the excess demand and
   the contact passes exactly the adhesion limit while ``omega`` follows its own torque balance
   ``J domega/dt = T(omega) - f r`` (implicit Euler, stable at 200 Hz). In the tick in which the slip ends the
   contact passes only the force that brings the wheel to the train's speed.
2. the physics step with that force applied to the drive section;
3. :func:`drive_after_step` with the train's new speed: a sticking wheel rolls with the train (``omega r = v``);
   a slipping one re-sticks when the slip ended (predicted in step 1, or the slip velocity no longer in the slip
   direction).

Everything is plain float arithmetic on the arguments (no state, no randomness), so the functions are unit-tested
on their own (``tests/test_drive.py``) and the plant's tick loop calls them as they are. The order of the
operations is part of the contract: the plant's results are reproducible bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class DriveParams:
    """Constants of one plant's drive.

    Attributes
    ----------
    radius_m : float
        Effective (worn) drive-wheel radius ``r``.
    inertia_kgm2 : float
        Rotating inertia ``J`` of all drive wheels and motor rotors reflected to the wheel shaft.
    adhesion_limit_n : float
        Largest force the contact transmits: adhesion coefficient x clamp force.
    max_torque_nm : float
        Motor torque limit (all drive units).
    max_power_w : float
        Motor power limit (all drive units).
    max_omega_radps : float
        Wheel speed at which the motor torque has fallen to zero.
    dt_s : float
        Physics tick.
    """

    radius_m: float
    inertia_kgm2: float
    adhesion_limit_n: float
    max_torque_nm: float
    max_power_w: float
    max_omega_radps: float
    dt_s: float

    def __post_init__(self) -> None:
        for name in ("radius_m", "inertia_kgm2", "adhesion_limit_n", "max_torque_nm", "max_power_w",
                     "max_omega_radps", "dt_s"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"DriveParams.{name} must be a finite number > 0, got {value!r}")


def motor_torque_nm(command: float, omega_radps: float, p: DriveParams) -> float:
    """Motor torque at traction ``command`` (0..1; <= 0: none) and wheel speed ``omega_radps``.

    ``command`` times the cap: the torque limit, or above the corner speed the power limit ``P / |omega|``,
    tapered linearly to zero over the last 10 % below ``max_omega_radps``.
    """
    if command <= 0.0:
        return 0.0
    t_max, p_max, om_max = p.max_torque_nm, p.max_power_w, p.max_omega_radps
    om_taper = 0.1 * om_max
    aw = omega_radps if omega_radps > 0.0 else -omega_radps
    cap = t_max if aw * t_max <= p_max else p_max / aw
    if aw > om_max - om_taper:
        cap *= max(0.0, (om_max - aw) / om_taper)
    return command * cap


def drive_force(
    command: float,
    torque_nm: float,
    omega_radps: float,
    slipping: bool,
    speed_mps: float,
    accel_mps2: float,
    p: DriveParams,
) -> tuple[float, bool, float, float, bool]:
    """Force the drive-wheel contact passes to the train in the coming tick.

    Parameters
    ----------
    command : float
        Traction command (> 0 enables the power-limited branch of the slipping wheel).
    torque_nm : float
        Motor torque this tick (:func:`motor_torque_nm`).
    omega_radps : float
        Drive-wheel angular speed at the start of the tick.
    slipping : bool
        Whether the wheel slipped in the last tick.
    speed_mps, accel_mps2 : float
        The train's speed at the start of the tick and its acceleration over the last tick.
    p : DriveParams

    Returns
    -------
    force_n : float
        Force on the train along the track.
    slipping : bool
        Whether the wheel slips during this tick.
    slip_sign : float
        +1 wheel surface faster than the train, -1 slower (meaningful while slipping).
    omega_next_radps : float
        The slipping wheel's angular speed at the end of the tick (meaningful while slipping).
    restick : bool
        The slip ends within this tick.
    """
    r = p.radius_m
    jd = p.inertia_kgm2
    f_adh = p.adhesion_limit_n
    sgn = 1.0
    if slipping:
        # direction of the slip velocity; never zero while slipping (a tick that would end with it zero or
        # reversed re-sticks instead)
        sgn = 1.0 if omega_radps * r > speed_mps else -1.0
    else:
        # force that keeps the wheel rolling with the train (its inertia with last tick's accel)
        f = torque_nm / r - jd / (r * r) * accel_mps2
        # beyond the limit the wheel starts to slip in the direction of the excess demand (the slip velocity is
        # still zero here: its rounding residue must not pick the direction)
        if f > f_adh:
            slipping, sgn = True, 1.0
        elif f < -f_adh:
            slipping, sgn = True, -1.0
        else:
            return f, False, sgn, omega_radps, False
    dt = p.dt_s
    p_max = p.max_power_w
    f = sgn * f_adh
    # implicit Euler of J domega/dt = T(omega) - f r: torque-limited branch, else power branch
    om1 = omega_radps + dt * (torque_nm - f * r) / jd
    if command > 0.0 and om1 * p.max_torque_nm > p_max and om1 > 0.0:
        b = jd * omega_radps - dt * f * r
        om1 = (b + math.sqrt(b * b + 4.0 * jd * dt * command * p_max)) / (2.0 * jd)
        if om1 > p.max_omega_radps:
            om1 = p.max_omega_radps
    v_pred = speed_mps + accel_mps2 * dt
    restick = False
    if (om1 * r - v_pred) * sgn <= 0.0:
        # the slip ends within this tick: the contact passes only the force that brings the wheel to the
        # train's speed (the full adhesion force for the whole tick would hand the train more momentum than the
        # wheel had to give), then the wheel sticks
        f = (torque_nm - jd * (v_pred / r - omega_radps) / dt) / r
        if f > f_adh:
            f = f_adh
        elif f < -f_adh:
            f = -f_adh
        restick = True
    return f, slipping, sgn, om1, restick


def drive_after_step(
    speed_mps: float, slipping: bool, slip_sign: float, omega_next_radps: float, restick: bool, radius_m: float
) -> tuple[float, bool]:
    """Drive-wheel speed and slip state at the end of the tick, given the train's new speed.

    Returns ``(omega_radps, slipping)``: a sticking wheel rolls with the train; a slipping one keeps
    ``omega_next_radps`` unless the slip ended (``restick``, or the slip velocity no longer has ``slip_sign``).
    """
    if slipping:
        if restick or (omega_next_radps * radius_m - speed_mps) * slip_sign <= 0.0:
            return speed_mps / radius_m, False
        return omega_next_radps, True
    return speed_mps / radius_m, False


__all__ = ["DriveParams", "drive_after_step", "drive_force", "motor_torque_nm"]
