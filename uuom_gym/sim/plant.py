"""The monorail plant: a pymunk multi-body simulation of the train on its rail in the vertical plane.

:class:`MonorailPlant` ties together the parts, each in its own module:

* :mod:`uuom_gym.sim.plant_config` - :class:`PlantConfig`, what the vehicle file does not fix (load, true
  resistance and adhesion, wheel wear, physics rate, ...);
* :mod:`uuom_gym.sim.train_body` - the pymunk space: rail, four carrying wheels, drive section, lifting-beam
  section on a compliant coupler, the load on two chains with an anti-sway damper, friction motors;
* :mod:`uuom_gym.sim.drive` - the friction drive as pure functions (motor torque and power limits, stick/slip
  adhesion of the drive wheel, whose angular speed is integrated here, outside pymunk);
* :mod:`uuom_gym.sim.energy` - the energy books;
* :mod:`uuom_gym.sim.fast_path` - the per-tick pymunk operations, through Chipmunk's C functions where reachable;
* :mod:`uuom_gym.sim.plant_log` - the truth log (:class:`PlantLog`) derived from the bodies' states.

Running resistance and brakes are Coulomb friction on the carrying wheels' rotation (:class:`pymunk.SimpleMotor`
with rate 0 and ``max_force`` = the friction torque): they cannot reverse motion and do not jitter at standstill.
"""

from __future__ import annotations

import math

import numpy as np

from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2, VehicleParams
from uuom_gym.sim.drive import DriveParams, drive_after_step, drive_force, motor_torque_nm
from uuom_gym.sim.energy import EnergyBooks, centre_of_mass_speed_mps, mechanical_energy_j
from uuom_gym.sim.fast_path import FrictionMotors, TickOps, tick_ops
from uuom_gym.sim.plant_config import PlantConfig, PlantConfigError
from uuom_gym.sim.plant_log import LOG_FIELDS, PlantLog, PlantState, TruthLogBuilder
from uuom_gym.sim.track import TrackProfile
from uuom_gym.sim.train_body import build_train

# ticks between updates of the slope-dependent running resistance (the wheels move < 2 cm in 0.1 s)
_FRICTION_UPDATE_TICKS = 20


class MonorailPlant:
    """pymunk multi-body monorail train on a track (see :mod:`uuom_gym.sim.train_body` for the bodies).

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle (masses, radii, limits, geometry).
    track : TrackProfile
        The rail's grade profile.
    config : PlantConfig, optional
        Load, true resistance/adhesion/wear, physics rate, ...
    start_s_m : float
        Arc length of the train's reference point (drive-section centre) at t = 0.
    fast_path : bool
        Call Chipmunk's C functions directly in the tick loop where pymunk's bindings expose them
        (:mod:`uuom_gym.sim.fast_path`); False: pymunk's public API only. Both give identical results.

    Examples
    --------
    >>> from uuom_gym.sim import MonorailPlant, PlantConfig, scenario_track
    >>> plant = MonorailPlant(DEFAULT_VEHICLE, scenario_track("section1"), PlantConfig(load_kg=10_000))
    >>> log = plant.advance(0.5, 200)      # 1 s at half traction
    >>> bool(log.speed_mps[-1] > 0)
    True
    """

    def __init__(
        self,
        vehicle: VehicleParams = DEFAULT_VEHICLE,
        track: TrackProfile | None = None,
        config: PlantConfig | None = None,
        start_s_m: float = 0.0,
        *,
        fast_path: bool = True,
    ) -> None:
        if not isinstance(vehicle, VehicleParams):
            raise PlantConfigError(f"vehicle must be a VehicleParams, got {type(vehicle).__name__}")
        if not isinstance(track, TrackProfile):
            raise PlantConfigError(f"track must be a TrackProfile, got {type(track).__name__}")
        config = config or PlantConfig()
        if not isinstance(config, PlantConfig):
            raise PlantConfigError(f"config must be a PlantConfig, got {type(config).__name__}")
        config.validate(vehicle)
        config = config.resolved(vehicle)
        if not (isinstance(start_s_m, (int, float)) and math.isfinite(start_s_m)) or not (
            0.0 <= start_s_m <= track.length_m
        ):
            raise PlantConfigError(f"start_s_m must be within the track [0, {track.length_m:g}], got {start_s_m!r}")
        self.vehicle = vehicle
        self.track = track
        self.config = config
        self.dt_s = 1.0 / config.physics_hz
        self.mu = vehicle.running_resistance if config.running_resistance is None else config.running_resistance
        self.adhesion = vehicle.adhesion_dry if config.adhesion is None else config.adhesion
        self.drive_radius_m = vehicle.drive_wheel_radius_m - config.wheel_wear_m
        self.total_mass_kg = vehicle.empty_mass_kg + config.load_kg
        self.adhesion_limit_n = self.adhesion * vehicle.clamp_force_n
        self.max_torque_nm = vehicle.max_traction_n * vehicle.drive_wheel_radius_m
        self._fast = bool(fast_path)
        self._hang = vehicle.drive_hang_m
        self._build(float(start_s_m))
        self._omega = 0.0
        self._slipping = False
        self._emergency = False
        self._brake_n = 0.0
        self._last_torque = 0.0
        self._last_force = 0.0
        self._last_row: PlantState | None = None
        self._last_log: PlantLog | None = None
        self._ops: TickOps | None = None
        self._settle()

    # ------------------------------------------------------------------------------------------------ build
    def _build(self, start_s_m: float) -> None:
        v, c = self.vehicle, self.config
        tb = build_train(v, c, self.track, start_s_m)
        self.space = tb.space
        self.wheels = tb.wheels
        self.drive_body, self.beam_body, self.load_body = tb.drive_body, tb.beam_body, tb.load_body
        self.coupler, self.sway_damper = tb.coupler, tb.sway_damper
        self.sway_damping_nspm = tb.sway_damping_nspm
        self.friction_motors = tb.friction_motors
        self.masses = tb.masses
        self._wheel_weight_kg = tb.wheel_weight_kg
        self._chain_top, self._chain_bot = tb.chain_top, tb.chain_bottom
        self._n_bodies = tb.n_bodies
        self._idx = tb.index
        self._friction = FrictionMotors(tb.wheels, tb.friction_motors, fast=self._fast)
        self._friction_mu: float | None = None
        self._books = EnergyBooks(tb.drive_body, tb.friction_motors, (tb.coupler, tb.sway_damper), self.dt_s)
        self.energy = self._books.totals
        self._drive = DriveParams(
            radius_m=self.drive_radius_m, inertia_kgm2=c.drive_inertia_kgm2, adhesion_limit_n=self.adhesion_limit_n,
            max_torque_nm=self.max_torque_nm, max_power_w=v.motor_power_w,
            max_omega_radps=c.max_drive_speed_mps / self.drive_radius_m, dt_s=self.dt_s,
        )
        self._truth = TruthLogBuilder(
            self.track, self.dt_s, tb.n_bodies, tb.index, tb.body_mass_share, tb.chain_top[1], tb.chain_bottom[1],
            v.drive_hang_m, v.carrying_wheel_radius_m, self.drive_radius_m, self.total_mass_kg,
        )
        self._prev_v = 0.0

    # --------------------------------------------------------------------------------------------- helpers
    def _set_friction(self, brake_n: float) -> None:
        """Resistance mu N at each wheel from the local slope, plus the brake force shared over the wheels."""
        r_c = self.vehicle.carrying_wheel_radius_m
        if self._friction_mu != self.mu:  # (mu is a public attribute)
            mu_g = self.mu * G_MPS2
            self._friction_mu = self.mu
            self._friction_mu_w = [mu_g * kg for kg in self._wheel_weight_kg]  # mu g m_i, same product order
        # the rail never turns back, so the slope is a function of x; np.interp clamps to the end slopes
        xs = self._friction.wheel_x_m()
        cos_th = np.cos(np.interp(xs, self.track.x_m, self.track.slope_rad)).tolist()
        brake_share = brake_n / 4.0
        self._friction.set_max_forces([(mu_w * c + brake_share) * r_c for mu_w, c in zip(self._friction_mu_w, cos_th)])

    def _settle(self) -> None:
        """Hold the train by the brake until it is at rest, then zero the clock and the velocities."""
        n = int(round(self.config.settle_s / self.dt_s))
        self._set_friction(self.vehicle.emergency_brake_n)
        for _ in range(n):
            self.space.step(self.dt_s)
        for b in self.space.bodies:
            b.velocity = (0.0, 0.0)
            b.angular_velocity = 0.0
        self._set_friction(0.0)
        self._truth.t_s = 0.0
        self._prev_v = 0.0
        self._truth.prev_vel = (0.0, 0.0)
        self._truth.prev_sway = self._sway_now()
        self._accel = 0.0
        self._last_row = None
        self._last_log = None

    def _sway_now(self) -> float:
        top = self.beam_body.local_to_world(self._chain_top[1])
        bot = self.load_body.local_to_world(self._chain_bot[1])
        return math.atan2(bot.x - top.x, top.y - bot.y)

    def _speed_now(self) -> float:
        d = self.drive_body
        vx, vy = d.velocity
        ang = d.angle
        return vx * math.cos(ang) + vy * math.sin(ang) - d.angular_velocity * self._hang

    # --------------------------------------------------------------------------------------------- public
    @property
    def t_s(self) -> float:
        return self._truth.t_s

    @property
    def position_m(self) -> float:
        d = self.drive_body
        ang = d.angle
        r_c = self.vehicle.carrying_wheel_radius_m
        x = d.position.x - self._hang * math.sin(ang) + r_c * math.sin(ang)
        return float(self.track.s_at_x(x))

    @property
    def emergency(self) -> bool:
        """True while the emergency brake is down."""
        return self._emergency

    def emergency_brake(self) -> None:
        """Drop the emergency brake (``vehicle.emergency_brake_n``) until :meth:`reset_emergency_brake`."""
        self._emergency = True

    def reset_emergency_brake(self) -> None:
        self._emergency = False

    def displace_load(self, sway_rad: float) -> None:
        """Put the load at chain angle ``sway_rad`` from the vertical, at rest (for swing tests / initial state)."""
        if not (math.isfinite(sway_rad) and abs(sway_rad) < 1.2):
            raise PlantConfigError(f"sway_rad must be finite and below 1.2 rad, got {sway_rad!r}")
        beam, load = self.beam_body, self.load_body
        top = beam.local_to_world(self._chain_top[1])
        lc = self.config.chain_length_m
        bot = (top.x + lc * math.sin(sway_rad), top.y - lc * math.cos(sway_rad))
        off = load.local_to_world(self._chain_bot[1]) - load.position
        load.position = (bot[0] - off.x, bot[1] - off.y)
        load.velocity = (0.0, 0.0)
        load.angular_velocity = 0.0
        self._truth.prev_sway = self._sway_now()
        self._last_row = None
        self._last_log = None

    def step(self, command: float) -> PlantState:
        """Advance one physics tick (``1 / physics_hz`` s) at ``command``; return the new state."""
        return self.advance(command, 1).row(0)

    @property
    def state(self) -> PlantState:
        """The true state now: the last tick's log row, or (before any tick) the state at rest."""
        if self._last_row is not None:
            return self._last_row
        if self._last_log is not None:  # built on demand: most callers read the log, not the state
            self._last_row = self._last_log.row(len(self._last_log) - 1)
            return self._last_row
        d = self.drive_body
        v = self._speed_now()
        pos = self.position_m
        slope = self.track.slope_at(pos)
        r = self.drive_radius_m
        ang = d.angle
        fx = self._accel + G_MPS2 * math.sin(ang)
        fz = G_MPS2 * math.cos(ang)
        sway = self._sway_now()
        wr = self._omega * r
        bodies = self.space.bodies
        masses = np.array([b.mass for b in bodies])
        sin_eff = np.sin(np.interp([b.position.x for b in bodies], self.track.x_m, self.track.slope_rad)) @ masses
        return PlantState(
            t_s=self.t_s, position_m=pos, speed_mps=v, accel_mps2=self._accel, slope_rad=float(slope),
            specific_force_mps2=fx, drive_torque_nm=self._last_torque, traction_force_n=self._last_force,
            wheel_speed_radps=self._omega, slip_ratio=(wr - v) / max(abs(wr), abs(v), 0.01),
            drive_radius_m=r, sway_rad=sway, sway_rate_radps=0.0, pitch_rad=ang,
            pitch_rate_radps=d.angular_velocity, normal_specific_force_mps2=fz,
            total_mass_kg=self.total_mass_kg, slipping=self._slipping, brake_force_n=self._brake_n,
            carry_wheel_speed_radps=-self.wheels[0].angular_velocity,
            effective_slope_rad=float(np.arcsin(sin_eff / sum(b.mass for b in bodies))),
        )

    @property
    def wheel_weight_kg(self) -> tuple[float, ...]:
        """Static weight each carrying wheel bears (kg, wheel order of :attr:`wheels`): half a section each, the hook
        and payload on the beam's two. The rail's reactions at these contacts are where gravity reaches the track
        (``scripts/gravity_at_the_wheels.py``)."""
        return tuple(self._wheel_weight_kg)

    def wheel_contact_slope_rad(self) -> float:
        """The slope the train's weight acts on now: ``asin(sum_j W_j sin theta(x_j) / sum_j W_j)`` over the carrying
        wheels' contacts, ``W_j`` their static weights. Gravity reaches the rail there, so on a vertical curve this,
        not the log's body-centre ``effective_slope_rad``, gives the along-track gravity force
        (``scripts/gravity_at_the_wheels.py``, docs/estimation.md)."""
        x = np.array([w.position.x for w in self.wheels])
        theta = np.interp(x, self.track.x_m, self.track.slope_rad)
        w = np.asarray(self._wheel_weight_kg)
        return float(np.arcsin(np.dot(w, np.sin(theta)) / w.sum()))

    def centre_of_mass_speed_mps(self) -> float:
        """Horizontal speed of the centre of mass of all bodies (the momentum: free of the load-sway exchange)."""
        return centre_of_mass_speed_mps(self.space)

    def mechanical_energy_j(self) -> float:
        """Kinetic (translation and rotation of every body) + gravitational + coupler-spring energy (J)."""
        return mechanical_energy_j(self.space, self.coupler)

    def advance(self, command: float, n_ticks: int) -> PlantLog:
        """Run ``n_ticks`` physics ticks at a held ``command`` and return their truth log.

        Parameters
        ----------
        command : float
            In [-1, 1]: > 0 traction as a fraction of the available motor torque (torque and power limits
            applied; the adhesion limit makes the drive slip), < 0 service braking as a fraction of
            ``vehicle.service_brake_n``.
        n_ticks : int
            Number of ticks (>= 1).

        Returns
        -------
        PlantLog
            One row per tick. :attr:`state` is read from its last row when asked for, so modify a copy of its
            arrays, not the arrays themselves.
        """
        command, n = _checked_command(command, n_ticks)
        veh = self.vehicle
        brake = 0.0 if command >= 0 else -command * veh.service_brake_n
        if self._emergency:
            brake = max(brake, veh.emergency_brake_n)
        self._brake_n = brake
        v_start = self._prev_v
        torque, force, omega_log, slip_log = self._run_ticks(command if command > 0 else 0.0, brake, n)
        self._last_torque = float(torque[-1])
        self._last_force = float(force[-1])
        raw = np.frombuffer(self._ops.buffer.float_buf(), dtype=np.float64).reshape(n, self._n_bodies, 6)
        log = self._truth.build(
            raw, np.array(torque), np.array(force), np.array(omega_log), np.array(slip_log, dtype=bool), brake,
            v_start,
        )
        self._last_row = None
        self._last_log = log
        return log

    def _run_ticks(self, c_trac: float, brake: float, n: int) -> tuple[list, list, list, list]:
        """The tick loop: drive force, physics step, body log, drive-wheel update; returns the drive's columns
        (motor torque, contact force, wheel speed, slipping) and leaves the bodies' states in the batch buffer."""
        if self._ops is None:
            self._ops = tick_ops(self.space, self.drive_body, self.dt_s, fast=self._fast)
        ops = self._ops
        ops.buffer.clear()  # reuse the batch arrays; the log builder copies what it keeps
        push, cbody, zero, cstep, cspace = ops.push, ops.body, ops.zero, ops.step, ops.space
        each, it, data, raw_log = ops.each, ops.iterator, ops.data, ops.raw_log
        vel_fn, ang_fn, angvel_fn = ops.velocity, ops.angle, ops.angular_velocity
        # the drive section's [angle, vx, vy, w] of tick k are read back from the batch log when it is reachable
        # (cheaper than three getter calls, the same doubles): at arr[o + 2 .. o + 5], o = k * stride + off
        stride = 6 * self._n_bodies
        off = 6 * self._idx["drive"]
        dp = self._drive
        dt = self.dt_s
        r = self.drive_radius_m
        torque = [0.0] * n
        force = [0.0] * n
        omega_log = [0.0] * n
        slip_log = [False] * n
        omega = self._omega
        slipping = self._slipping
        v_prev = self._prev_v
        a_prev = self._accel
        cos = math.cos
        sin = math.sin
        hang = self._hang
        books = self._books if self.config.track_energy else None
        for k0 in range(0, n, _FRICTION_UPDATE_TICKS):
            self._set_friction(brake)
            for k in range(k0, min(n, k0 + _FRICTION_UPDATE_TICKS)):
                tq = motor_torque_nm(c_trac, omega, dp) if c_trac > 0.0 else 0.0
                f, slipping, sgn, omega_next, restick = drive_force(c_trac, tq, omega, slipping, v_prev, a_prev, dp)
                push(cbody, (f, 0.0), zero)
                if books is not None:
                    e_pre = books.before_step()
                cstep(cspace, dt)
                if books is not None:
                    books.add_tick(f, e_pre)
                each(cspace, it, data)
                if raw_log is not None:
                    arr = raw_log.arr  # (re-read: the log may have grown and moved)
                    o = k * stride + off
                    ang = arr[o + 2]
                    v = arr[o + 3] * cos(ang) + arr[o + 4] * sin(ang) - arr[o + 5] * hang
                else:
                    vel = vel_fn(cbody)
                    ang = ang_fn(cbody)
                    v = vel.x * cos(ang) + vel.y * sin(ang) - angvel_fn(cbody) * hang
                a_prev = (v - v_prev) / dt
                omega, slipping = drive_after_step(v, slipping, sgn, omega_next, restick, r)
                v_prev = v
                torque[k] = tq
                force[k] = f
                omega_log[k] = omega
                slip_log[k] = slipping
        self._prev_v = v_prev
        self._omega = omega
        self._slipping = slipping
        self._accel = a_prev
        return torque, force, omega_log, slip_log


def _checked_command(command: float, n_ticks: int) -> tuple[float, int]:
    """``(command, n_ticks)`` as float and int, or :class:`PlantConfigError` naming the bad one."""
    if isinstance(command, bool) or not isinstance(command, (int, float, np.floating, np.integer)):
        raise PlantConfigError(f"command must be a number in [-1, 1], got {command!r}")
    command = float(command)
    if not (math.isfinite(command) and -1.0 <= command <= 1.0):
        raise PlantConfigError(f"command must be finite and in [-1, 1], got {command!r}")
    if isinstance(n_ticks, bool) or not isinstance(n_ticks, (int, np.integer)) or n_ticks < 1:
        raise PlantConfigError(f"n_ticks must be an integer >= 1, got {n_ticks!r}")
    return command, int(n_ticks)


__all__ = ["LOG_FIELDS", "MonorailPlant", "PlantConfig", "PlantConfigError", "PlantLog", "PlantState"]
