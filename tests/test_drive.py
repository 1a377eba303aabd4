"""The friction drive's pure functions (uuom_gym.sim.drive): torque limits, stick, slip, re-stick."""

from __future__ import annotations

import math

import pytest

from uuom_gym.sim.drive import DriveParams, drive_after_step, drive_force, motor_torque_nm

R = 0.17
P = DriveParams(radius_m=R, inertia_kgm2=2.0, adhesion_limit_n=91_000.0, max_torque_nm=80_000.0 * R,
                max_power_w=60_000.0, max_omega_radps=2.6 / R, dt_s=0.005)


def test_motor_torque_limits():
    assert motor_torque_nm(0.0, 3.0, P) == 0.0 and motor_torque_nm(-0.5, 3.0, P) == 0.0
    assert motor_torque_nm(1.0, 0.0, P) == P.max_torque_nm  # torque limit at standstill
    assert motor_torque_nm(0.5, 1.0, P) == 0.5 * P.max_torque_nm
    corner = P.max_power_w / P.max_torque_nm  # above it the power limit P / omega governs
    omega = 2.0 * corner
    assert motor_torque_nm(1.0, omega, P) == pytest.approx(P.max_power_w / omega)
    assert motor_torque_nm(1.0, -omega, P) == motor_torque_nm(1.0, omega, P)  # symmetric in the direction
    # linear taper over the last 10 % below the top wheel speed, zero at and beyond it
    om_max = P.max_omega_radps
    assert motor_torque_nm(1.0, 0.95 * om_max, P) == pytest.approx(0.5 * P.max_power_w / (0.95 * om_max))
    assert motor_torque_nm(1.0, om_max, P) == 0.0 and motor_torque_nm(1.0, 1.2 * om_max, P) == 0.0


def test_stick_passes_the_force_that_rolls_the_wheel_with_the_train():
    tq = 5_000.0
    f, slipping, _, _, restick = drive_force(0.5, tq, 4.0, False, 4.0 * R, 0.2, P)
    assert not slipping and not restick
    assert f == pytest.approx(tq / R - P.inertia_kgm2 / R**2 * 0.2)  # minus the wheel's own inertia
    omega, slipping = drive_after_step(0.7, False, 1.0, 123.0, False, R)
    assert omega == 0.7 / R and not slipping  # a sticking wheel rolls with the train


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_slip_starts_in_the_direction_of_the_demand_and_passes_the_adhesion_limit(sign):
    p = DriveParams(**{**{f: getattr(P, f) for f in P.__dataclass_fields__}, "inertia_kgm2": 20.0,
                       "adhesion_limit_n": 50_000.0})
    tq = sign * 1.2 * p.adhesion_limit_n * R  # demand 20 % above the limit, below the motor's torque limit
    f, slipping, sgn, omega_next, restick = drive_force(1.0 if sign > 0 else 0.0, tq, 2.0, False, 2.0 * R, 0.0, p)
    assert slipping and sgn == sign and f == sign * p.adhesion_limit_n and not restick
    # the wheel turns faster (slower) by the excess torque (implicit Euler of J domega/dt = T - f r)
    assert omega_next == pytest.approx(2.0 + p.dt_s * (tq - f * R) / p.inertia_kgm2)
    assert (omega_next - 2.0) * sign > 0
    omega, still = drive_after_step(2.0 * R, slipping, sgn, omega_next, restick, R)
    assert still and omega == omega_next


def test_slip_that_ends_within_the_tick_passes_only_the_matching_force():
    # wheel surface 1 mm/s ahead of the train, no motor torque: the adhesion force stops the slip at once
    v = 1.0
    omega = (v + 0.001) / R
    f, slipping, sgn, omega_next, restick = drive_force(0.0, 0.0, omega, True, v, 0.0, P)
    assert slipping and sgn == 1.0 and restick
    expected = (0.0 - P.inertia_kgm2 * (v / R - omega) / P.dt_s) / R  # the wheel's momentum surplus, no more
    assert f == pytest.approx(expected) and 0.0 < f < P.adhesion_limit_n
    omega_after, still = drive_after_step(v, slipping, sgn, omega_next, restick, R)
    assert not still and omega_after == v / R


def test_slip_ends_when_the_slip_velocity_reverses():
    omega, slipping = drive_after_step(1.0, True, 1.0, 0.9 / R, False, R)
    assert not slipping and omega == 1.0 / R
    omega, slipping = drive_after_step(1.0, True, -1.0, 0.9 / R, False, R)
    assert slipping and omega == 0.9 / R


def test_power_branch_of_the_slipping_wheel_respects_the_power_limit():
    p = DriveParams(**{**{f: getattr(P, f) for f in P.__dataclass_fields__}, "inertia_kgm2": 20.0,
                       "adhesion_limit_n": 20_000.0})
    omega0 = 10.0  # above the corner speed: the motor runs on the power limit
    tq = motor_torque_nm(1.0, omega0, p)
    f, slipping, sgn, om1, restick = drive_force(1.0, tq, omega0, True, 0.5, 0.0, p)
    assert slipping and sgn == 1.0 and f == p.adhesion_limit_n and not restick
    # implicit in the power: J (om1 - om0) / dt = P / om1 - f r
    assert p.inertia_kgm2 * (om1 - omega0) / p.dt_s == pytest.approx(p.max_power_w / om1 - f * R, rel=1e-9)


def test_pure_same_inputs_same_outputs():
    args = (0.8, 9_000.0, 5.0, True, 0.4, 0.1, P)
    assert drive_force(*args) == drive_force(*args)


@pytest.mark.parametrize("name", ["radius_m", "inertia_kgm2", "adhesion_limit_n", "dt_s"])
def test_bad_drive_params_are_named(name):
    kwargs = {f: getattr(P, f) for f in P.__dataclass_fields__}
    kwargs[name] = math.nan
    with pytest.raises(ValueError, match=name):
        DriveParams(**kwargs)
