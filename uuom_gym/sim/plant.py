"""The monorail plant: a pymunk multi-body simulation of the train on its rail in the vertical plane.

Bodies (all in the vertical plane of the track, x forward, y up):

* the rail: static pymunk segments along the track's polyline (:meth:`TrackProfile.polyline`);
* four carrying wheels (circles of the carrying-wheel radius, moment ``inertia_wheel_count * J / 4`` each, so the
  rotating-mass term ``m_rot = n_w J / r_carry**2`` of the estimator model is physically present) rolling on the
  rail by contact friction;
* the *drive section* (front cab, the drive units and the brake car) hanging from the front two wheels by pivots,
  so it pitches with the rail; the accelerometer, IMU and drive act on it;
* the *lifting-beam section* (lifting beams and rear cab) hanging from the rear two wheels, joined to the drive
  section by a compliant coupler (:class:`pymunk.DampedSpring` along the track);
* the *load* (hook block + payload) hanging from the lifting beam on two parallel chains (:class:`pymunk.PinJoint`
  of ``chain_length_m``) - a parallelogram, so the load swings without turning, a simple pendulum of the chain
  length - with an anti-sway damper (:class:`pymunk.DampedSpring` of zero stiffness) along the track.

Running resistance and brakes are Coulomb friction on the carrying wheels' rotation (:class:`pymunk.SimpleMotor`
with rate 0 and ``max_force`` = the friction torque): they cannot reverse motion and do not jitter at standstill.
The friction drive is a drive-wheel angular speed ``omega`` integrated here with stick/slip logic: while the force
needed to roll with the train is below ``adhesion * clamp_force_n`` the wheel sticks (``omega r = v``), otherwise
it slips, in the direction of the excess demand, and transmits exactly the adhesion limit while ``omega`` follows
its own torque balance (implicit Euler, stable at 200 Hz); in the tick the slip ends the contact passes only the
force that brings the wheel to the train's speed. Motor torque limit ``max_traction_n * r`` and power limit
``motor_power_w / omega``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np
import pymunk
import pymunk.batch as pbatch

try:  # Chipmunk bindings behind pymunk's API, for the fast per-tick path (see MonorailPlant._primitives)
    from pymunk._chipmunk import ffi as _ffi
    from pymunk._chipmunk import lib as _lib

    _lib.cpSpaceStep, _lib.cpSpaceEachBody, _lib.pmSpaceBodyGetIteratorFuncBatched  # noqa: B018
    _lib.cpBodyGetPosition, _lib.cpConstraintSetMaxForce, _lib.cpBodyApplyForceAtLocalPoint  # noqa: B018
except (ImportError, AttributeError):  # pragma: no cover - other pymunk builds
    _ffi = _lib = None

from uuom_gym.sim.track import TrackProfile
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2, VehicleParams


class PlantConfigError(ValueError):
    """A plant configuration (or command) that is out of its valid range."""


@dataclass(frozen=True)
class PlantConfig:
    """Configuration of one plant: what the vehicle file does not fix.

    Attributes
    ----------
    load_kg : float
        Payload hanging on the chains (kg), 0 .. 1.5 x rated load.
    running_resistance : float or None
        True running-resistance coefficient mu of this plant; None = the vehicle's nominal value.
    adhesion : float or None
        Drive-wheel / rail adhesion coefficient; None = ``vehicle.adhesion_dry``.
    wheel_wear_m : float
        Radius lost to wear by the drive wheels; effective drive radius = nominal - wear.
    physics_hz : float
        Physics rate (>= 100 Hz; default 200 Hz).
    chain_length_m : float
        Length of the load chains (pendulum length of the swinging load).
    anti_sway_damping_ratio : float
        Damping ratio of the load swing given by the anti-sway damper (with the train held).
    coupler_stiffness_npm, coupler_damping_nspm : float
        Compliant coupler between the drive section and the lifting-beam section.
    drive_inertia_kgm2 : float
        Rotating inertia of all drive wheels plus motor rotors reflected to the wheel shaft (downstream of the
        torque transducer, so in stick it adds ``J/r^2`` of inertia the estimator model does not have).
    max_drive_speed_mps : float
        Drive-wheel surface speed at which the motors' torque has fallen to zero (linear taper over the last 10 %).
    hook_mass_kg : float
        Hook block / spreader that always hangs on the chains (part of the empty mass).
    rail_friction : float
        Contact friction of the carrying wheels on the rail flange. High, because the brake force (clamped brake
        shoes in the real brake car) is routed through these wheels.
    solver_iterations : int
        pymunk solver iterations.
    settle_s : float
        Time the train is held by the brake at construction so couplers and contacts settle; then t = 0.
    track_energy : bool
        Keep the energy books (:attr:`MonorailPlant.energy`): traction work and the work dissipated by running
        resistance, brakes and dampers. Costs about twice the per-tick time; for tests and analysis.
    """

    load_kg: float = 0.0
    running_resistance: float | None = None
    adhesion: float | None = None
    wheel_wear_m: float = 0.0
    physics_hz: float = 200.0
    chain_length_m: float = 2.0
    anti_sway_damping_ratio: float = 0.05
    coupler_stiffness_npm: float = 2.0e7
    coupler_damping_nspm: float = 2.0e5
    drive_inertia_kgm2: float = 2.0
    max_drive_speed_mps: float = 2.6
    hook_mass_kg: float = 300.0
    rail_friction: float = 3.0
    solver_iterations: int = 20
    settle_s: float = 1.0
    track_energy: bool = False

    def validate(self, vehicle: VehicleParams) -> None:
        """Raise :class:`PlantConfigError` naming the first impossible value."""
        def bad(name: str, why: str) -> None:
            raise PlantConfigError(f"PlantConfig.{name} {why}, got {getattr(self, name)!r}")

        for f in fields(self):
            v = getattr(self, f.name)
            if v is None or f.name == "track_energy":
                continue
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                bad(f.name, "must be a finite number")
        if not 0.0 <= self.load_kg <= 1.5 * max(vehicle.rated_load_kg, 1.0):
            bad("load_kg", f"must be in [0, 1.5 x rated load = {1.5 * vehicle.rated_load_kg:g}]")
        if self.running_resistance is not None and not 0.0 <= self.running_resistance < 0.5:
            bad("running_resistance", "must be in [0, 0.5)")
        if self.adhesion is not None and not 0.0 < self.adhesion <= 1.0:
            bad("adhesion", "must be in (0, 1]")
        if not 0.0 <= self.wheel_wear_m < 0.5 * vehicle.drive_wheel_radius_m:
            bad("wheel_wear_m", "must be in [0, half the drive-wheel radius)")
        if not 100.0 <= self.physics_hz <= 5000.0:
            bad("physics_hz", "must be in [100, 5000]")
        for name in ("chain_length_m", "coupler_stiffness_npm", "drive_inertia_kgm2", "max_drive_speed_mps",
                     "hook_mass_kg", "rail_friction", "solver_iterations"):
            if getattr(self, name) <= 0:
                bad(name, "must be > 0")
        for name in ("anti_sway_damping_ratio", "coupler_damping_nspm", "settle_s"):
            if getattr(self, name) < 0:
                bad(name, "must be >= 0")
        if self.hook_mass_kg >= 0.2 * vehicle.empty_mass_kg:
            bad("hook_mass_kg", "must be below 20 % of the empty mass")


@dataclass
class PlantState:
    """Snapshot of the plant's true state (see :class:`PlantLog` for the meaning of each field)."""

    t_s: float
    position_m: float
    speed_mps: float
    accel_mps2: float
    slope_rad: float
    specific_force_mps2: float
    drive_torque_nm: float
    traction_force_n: float
    wheel_speed_radps: float
    slip_ratio: float
    drive_radius_m: float
    sway_rad: float
    sway_rate_radps: float
    pitch_rad: float
    pitch_rate_radps: float
    normal_specific_force_mps2: float
    total_mass_kg: float
    slipping: bool
    brake_force_n: float
    carry_wheel_speed_radps: float
    effective_slope_rad: float


LOG_FIELDS: tuple[str, ...] = tuple(f.name for f in fields(PlantState))


@dataclass
class PlantLog:
    """Per-tick truth arrays of a block of physics ticks (one row per tick, at the end of the tick).

    Attributes
    ----------
    t_s : time at the end of the tick.
    position_m : arc length of the drive section's reference point (mid-way between its wheels).
    speed_mps : true ground speed along the track. accel_mps2 : its time derivative (finite difference).
    slope_rad : track slope at ``position_m``.
    specific_force_mps2 : what an ideal along-track accelerometer at the drive section's centre of mass reads:
        ``(a_body - g) . e_x`` - includes pitching, coupler and load-sway vibration.
    normal_specific_force_mps2 : the same on the body's normal axis (about ``g cos slope``).
    drive_torque_nm : total motor torque applied to the drive wheels. traction_force_n : force transmitted to
        the rail through adhesion. wheel_speed_radps : drive-wheel angular speed.
    slip_ratio : ``(omega r - v) / max(|omega r|, |v|, 0.01)``. drive_radius_m : effective (worn) drive radius.
    sway_rad, sway_rate_radps : load chain angle from the vertical (positive = load ahead of its hanger).
    pitch_rad, pitch_rate_radps : drive section attitude (equals the rail chord slope).
    total_mass_kg : vehicle + load. slipping : drive in slip. brake_force_n : commanded brake force.
    carry_wheel_speed_radps : angular speed of the front carrying wheel (ground-speed encoder source).
    effective_slope_rad : the slope gravity acts on: ``asin(sum m_i sin(slope_i) / M)`` over the bodies
        (the train is 18 m long, so on short grade features it differs from ``slope_rad`` at the reference point).
    """

    t_s: np.ndarray
    position_m: np.ndarray
    speed_mps: np.ndarray
    accel_mps2: np.ndarray
    slope_rad: np.ndarray
    specific_force_mps2: np.ndarray
    drive_torque_nm: np.ndarray
    traction_force_n: np.ndarray
    wheel_speed_radps: np.ndarray
    slip_ratio: np.ndarray
    drive_radius_m: np.ndarray
    sway_rad: np.ndarray
    sway_rate_radps: np.ndarray
    pitch_rad: np.ndarray
    pitch_rate_radps: np.ndarray
    normal_specific_force_mps2: np.ndarray
    total_mass_kg: np.ndarray
    slipping: np.ndarray
    brake_force_n: np.ndarray
    carry_wheel_speed_radps: np.ndarray
    effective_slope_rad: np.ndarray

    def __len__(self) -> int:
        return len(self.t_s)

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in LOG_FIELDS:
            raise KeyError(f"no plant log field {name!r}; fields: {', '.join(LOG_FIELDS)}")
        return getattr(self, name)

    def as_dict(self) -> dict[str, np.ndarray]:
        return {k: getattr(self, k) for k in LOG_FIELDS}

    def row(self, i: int) -> PlantState:
        """The state at tick ``i`` of the block."""
        vals = [float(getattr(self, k)[i]) for k in LOG_FIELDS]
        state = PlantState(*vals)
        state.slipping = bool(state.slipping)
        return state

    @classmethod
    def concatenate(cls, logs: list["PlantLog"]) -> "PlantLog":
        if not logs:
            raise ValueError("concatenate needs at least one PlantLog")
        return cls(**{k: np.concatenate([getattr(g, k) for g in logs]) for k in LOG_FIELDS})


# Geometry of the train (m). Each section hangs below its wheels; offsets are from its centre of mass.
_D_HALF_SPAN = 4.0  # drive section: wheels 8 m apart
_D_HANG = 0.6  # pivot line above the drive section's CoM
_D_LEN = 10.0
_L_HALF_SPAN = 3.0
_L_HANG = 0.5
_L_LEN = 7.0
_GAP = 0.5  # coupler length
_CHAIN_DX = 1.0  # chains at +-1 m along the beam
_LOAD_H = 1.0  # load block height
_WHEEL_MASS = 60.0
_D_MASS_SHARE = 0.56  # of the empty mass without wheels and hook


class MonorailPlant:
    """pymunk multi-body monorail train on a track (see the module docstring for the bodies).

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle (masses, radii, limits).
    track : TrackProfile
        The rail's grade profile.
    config : PlantConfig, optional
        Load, true resistance/adhesion/wear, physics rate, ...
    start_s_m : float
        Arc length of the train's reference point (drive-section centre) at t = 0.

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
    ) -> None:
        if not isinstance(vehicle, VehicleParams):
            raise PlantConfigError(f"vehicle must be a VehicleParams, got {type(vehicle).__name__}")
        if not isinstance(track, TrackProfile):
            raise PlantConfigError(f"track must be a TrackProfile, got {type(track).__name__}")
        config = config or PlantConfig()
        if not isinstance(config, PlantConfig):
            raise PlantConfigError(f"config must be a PlantConfig, got {type(config).__name__}")
        config.validate(vehicle)
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
        self._omega_max = config.max_drive_speed_mps / self.drive_radius_m
        self._start_s = float(start_s_m)
        self._build()
        self._t = 0.0
        self._omega = 0.0
        self._slipping = False
        self._emergency = False
        self._brake_n = 0.0
        self._last_torque = 0.0
        self._last_force = 0.0
        self._last_row: PlantState | None = None
        self._prims: tuple | None = None
        self.energy = {"traction_work_j": 0.0, "friction_j": 0.0, "damper_j": 0.0}
        self._settle()

    # ------------------------------------------------------------------------------------------------ build
    def _rail_point(self, s: float) -> tuple[float, float, float]:
        th = self.track.slope_at(s)
        return float(self.track.x_at(s)), float(self.track.elevation_at(s)), float(th)

    def _build(self) -> None:
        v, c = self.vehicle, self.config
        space = pymunk.Space()
        space.gravity = (0.0, -G_MPS2)
        space.iterations = int(c.solver_iterations)
        # Allowed wheel/rail overlap. Chipmunk's default (0.1 length units) would be 10 cm in metres; with much
        # less than 1 mm the wheels lose contact for a tick at every convex polyline vertex (the rail drops away by
        # v * turn * dt) and land with a knock that shows as +-1 m/s^2 accelerometer spikes.
        space.collision_slop = 1e-3
        self.space = space
        pts = self.track.polyline()
        segs = []
        for i in range(len(pts) - 1):
            seg = pymunk.Segment(space.static_body, tuple(pts[i]), tuple(pts[i + 1]), 0.0)
            seg.friction = 1.0
            segs.append(seg)
        for i, seg in enumerate(segs):
            # neighbours stop wheels from catching on the vertices between segments
            prev = tuple(pts[i - 1]) if i > 0 else tuple(pts[i])
            nxt = tuple(pts[i + 2]) if i + 2 < len(pts) else tuple(pts[i + 1])
            seg.set_neighbors(prev, nxt)
        # buffer stops at both ends of the rail (40 m beyond the track): a train driven off the end stops there
        # instead of falling
        for x, z in (pts[0], pts[-1]):
            stop = pymunk.Segment(space.static_body, (x, z - 0.2), (x, z + 1.0), 0.05)
            stop.friction = 0.0
            segs.append(stop)
        space.add(*segs)

        r_c = v.carrying_wheel_radius_m
        j_w = v.inertia_wheel_count * v.wheel_inertia_kgm2 / 4.0
        hook = c.hook_mass_kg
        body_mass = v.empty_mass_kg - 4 * _WHEEL_MASS - hook
        m_d = _D_MASS_SHARE * body_mass
        m_l = body_mass - m_d
        m_p = hook + c.load_kg
        self.masses = {"drive": m_d, "beam": m_l, "load": m_p, "wheels": 4 * _WHEEL_MASS}

        s_ref = self._start_s
        s_l = s_ref - _D_LEN / 2 - _GAP - _L_LEN / 2
        wheel_s = [s_ref + _D_HALF_SPAN, s_ref - _D_HALF_SPAN, s_l + _L_HALF_SPAN, s_l - _L_HALF_SPAN]
        wheels = []
        centres = []
        for s in wheel_s:
            x, z, th = self._rail_point(s)
            cx, cz = x - r_c * math.sin(th), z + r_c * math.cos(th)
            b = pymunk.Body(_WHEEL_MASS, j_w)
            b.position = (cx, cz)
            shape = pymunk.Circle(b, r_c)
            shape.friction = c.rail_friction
            space.add(b, shape)
            wheels.append(b)
            centres.append((cx, cz))
        self.wheels = wheels

        def section(m: float, length: float, hang: float, ca: tuple, cb: tuple) -> pymunk.Body:
            ang = math.atan2(cb[1] - ca[1], cb[0] - ca[0])
            mx, mz = (ca[0] + cb[0]) / 2, (ca[1] + cb[1]) / 2
            b = pymunk.Body(m, m * (length**2 + 1.0) / 12.0)
            b.angle = ang
            b.position = (mx + hang * math.sin(ang), mz - hang * math.cos(ang))
            space.add(b)
            return b

        # wheel order along the track: front of drive (0), rear of drive (1), front of beam (2), rear of beam (3)
        d = section(m_d, _D_LEN, _D_HANG, centres[1], centres[0])
        beam = section(m_l, _L_LEN, _L_HANG, centres[3], centres[2])
        self.drive_body, self.beam_body = d, beam
        cons: list[pymunk.Constraint] = []
        for w, b in ((wheels[0], d), (wheels[1], d), (wheels[2], beam), (wheels[3], beam)):
            cons.append(pymunk.PivotJoint(w, b, w.position))
        # coupler: a damped spring between the sections' ends on the pivot lines
        a_d = (-_D_LEN / 2, _D_HANG)
        a_b = (_L_LEN / 2, _L_HANG)
        rest = (d.local_to_world(a_d) - beam.local_to_world(a_b)).length
        self.coupler = pymunk.DampedSpring(d, beam, a_d, a_b, rest, c.coupler_stiffness_npm, c.coupler_damping_nspm)
        cons.append(self.coupler)
        # load on two parallel chains (parallelogram): hangs plumb, swings without turning
        top = [(-_CHAIN_DX, -_L_HANG), (_CHAIN_DX, -_L_HANG)]
        ang = beam.angle
        ey = (-math.sin(ang), math.cos(ang))
        tw = [beam.local_to_world(p) for p in top]
        mid = ((tw[0][0] + tw[1][0]) / 2, (tw[0][1] + tw[1][1]) / 2)
        load = pymunk.Body(m_p, m_p * (2.0**2 + _LOAD_H**2) / 12.0)
        load.angle = ang
        load.position = (mid[0] - ey[0] * _LOAD_H / 2, mid[1] - c.chain_length_m - ey[1] * _LOAD_H / 2)
        space.add(load)
        self.load_body = load
        self._chain_top = top
        self._chain_bot = [(-_CHAIN_DX, _LOAD_H / 2), (_CHAIN_DX, _LOAD_H / 2)]
        for a, bpt in zip(top, self._chain_bot):
            cons.append(pymunk.PinJoint(beam, load, a, bpt))
        # anti-sway damper: a zero-stiffness damped spring whose line runs along the track at the load's height,
        # so it damps the load's along-track motion relative to the beam
        omega_p = math.sqrt(G_MPS2 / c.chain_length_m)
        self.sway_damping_nspm = 2.0 * c.anti_sway_damping_ratio * m_p * omega_p
        far = (-30.0, -_L_HANG - c.chain_length_m - _LOAD_H / 2)
        far_w = beam.local_to_world(far)
        self.sway_damper = pymunk.DampedSpring(
            beam, load, far, (0.0, 0.0), (far_w - load.position).length, 0.0, self.sway_damping_nspm
        )
        cons.append(self.sway_damper)
        # resistance + brakes: Coulomb friction on each carrying wheel's rotation relative to its section
        self.friction_motors = []
        for w, b in ((wheels[0], d), (wheels[1], d), (wheels[2], beam), (wheels[3], beam)):
            m = pymunk.SimpleMotor(w, b, 0.0)
            m.max_force = 0.0
            self.friction_motors.append(m)
            cons.append(m)
        space.add(*cons)
        # static weight carried by each wheel (for the resistance mu N): half a section each, the load on the beam
        mw = _WHEEL_MASS
        self._wheel_weight_kg = [mw + m_d / 2, mw + m_d / 2, mw + (m_l + m_p) / 2, mw + (m_l + m_p) / 2]
        # body order in the batch buffer
        buf = pbatch.Buffer()
        pbatch.get_space_bodies(space, pbatch.BodyFields.BODY_ID, buf)
        ids = list(memoryview(buf.int_buf()).cast("P"))
        self._n_bodies = len(ids)
        by_id = {b.id: b for b in space.bodies}
        masses = np.array([by_id[i].mass if i in by_id else 0.0 for i in ids])  # (the static rail body: 0)
        self._body_mass_share = masses / masses.sum()
        self._idx = {name: ids.index(b.id) for name, b in
                     (("drive", d), ("beam", beam), ("load", load), ("w0", wheels[0]))}
        self._sel_bodies = [self._idx["drive"], self._idx["beam"], self._idx["load"]]
        # chain points in body coordinates, as columns for (beam, load): top of the front chain, its bottom
        self._chain_pts = (np.array([[self._chain_top[1][0]], [self._chain_bot[1][0]]]),
                           np.array([[self._chain_top[1][1]], [self._chain_bot[1][1]]]))
        self._track_x_range = (float(self.track.x_m[0]), float(self.track.x_m[-1]))
        self._tick_offsets_s: dict[int, np.ndarray] = {}
        self._friction_c: tuple | None = None  # Chipmunk handles for _set_friction (built on first use)
        self._fields = (
            pbatch.BodyFields.POSITION | pbatch.BodyFields.ANGLE | pbatch.BodyFields.VELOCITY
            | pbatch.BodyFields.ANGULAR_VELOCITY
        )
        self._prev_v = 0.0
        self._prev_vel = (0.0, 0.0)
        self._prev_sway = 0.0

    # --------------------------------------------------------------------------------------------- helpers
    def _set_friction(self, brake_n: float) -> None:
        """Resistance mu N at each wheel from the local slope, plus the brake force shared over the wheels."""
        r_c = self.vehicle.carrying_wheel_radius_m
        if self._friction_c is None or self._friction_mu != self.mu:  # (mu is a public attribute)
            mu_g = self.mu * G_MPS2
            self._friction_mu = self.mu
            self._friction_mu_w = [mu_g * kg for kg in self._wheel_weight_kg]  # mu g m_i, same product order
            if _lib is not None:
                self._friction_c = ([w._body for w in self.wheels], [m._constraint for m in self.friction_motors])
            else:
                self._friction_c = ((), ())
        wheel_c, motor_c = self._friction_c
        if _lib is not None:
            get_pos, set_max = _lib.cpBodyGetPosition, _lib.cpConstraintSetMaxForce
            xs = [get_pos(w).x for w in wheel_c]
        else:
            xs = [w.position.x for w in self.wheels]
        # the rail never turns back, so the slope is a function of x; np.interp clamps to the end slopes
        cos_th = np.cos(np.interp(xs, self.track.x_m, self.track.slope_rad)).tolist()
        brake_share = brake_n / 4.0
        if _lib is not None:
            for m, mu_w, c in zip(motor_c, self._friction_mu_w, cos_th):
                set_max(m, (mu_w * c + brake_share) * r_c)
        else:
            for m, mu_w, c in zip(self.friction_motors, self._friction_mu_w, cos_th):
                m.max_force = (mu_w * c + brake_share) * r_c

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
        self._t = 0.0
        self._prev_v = 0.0
        self._prev_vel = (0.0, 0.0)
        self._prev_sway = self._sway_now()
        self._accel = 0.0
        self._last_row = None

    def _sway_now(self) -> float:
        top = self.beam_body.local_to_world(self._chain_top[1])
        bot = self.load_body.local_to_world(self._chain_bot[1])
        return math.atan2(bot.x - top.x, top.y - bot.y)

    def _speed_now(self) -> float:
        d = self.drive_body
        vx, vy = d.velocity
        ang = d.angle
        return vx * math.cos(ang) + vy * math.sin(ang) - d.angular_velocity * _D_HANG

    # --------------------------------------------------------------------------------------------- public
    @property
    def t_s(self) -> float:
        return self._t

    @property
    def position_m(self) -> float:
        d = self.drive_body
        ang = d.angle
        r_c = self.vehicle.carrying_wheel_radius_m
        x = d.position.x - _D_HANG * math.sin(ang) + r_c * math.sin(ang)
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
        self._prev_sway = self._sway_now()
        self._last_row = None

    def step(self, command: float) -> PlantState:
        """Advance one physics tick (``1 / physics_hz`` s) at ``command``; return the new state."""
        return self.advance(command, 1).row(0)

    @property
    def state(self) -> PlantState:
        """The true state now: the last tick's log row, or (before any tick) the state at rest."""
        if self._last_row is not None:
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
        return PlantState(
            t_s=self._t, position_m=pos, speed_mps=v, accel_mps2=self._accel, slope_rad=float(slope),
            specific_force_mps2=fx, drive_torque_nm=self._last_torque, traction_force_n=self._last_force,
            wheel_speed_radps=self._omega, slip_ratio=(wr - v) / max(abs(wr), abs(v), 0.01),
            drive_radius_m=r, sway_rad=sway, sway_rate_radps=0.0, pitch_rad=ang,
            pitch_rate_radps=d.angular_velocity, normal_specific_force_mps2=fz,
            total_mass_kg=self.total_mass_kg, slipping=self._slipping, brake_force_n=self._brake_n,
            carry_wheel_speed_radps=-self.wheels[0].angular_velocity,
            effective_slope_rad=float(np.arcsin(np.sin(np.interp(
                [b.position.x for b in self.space.bodies], self.track.x_m, self.track.slope_rad)) @ np.array(
                [b.mass for b in self.space.bodies]) / sum(b.mass for b in self.space.bodies))),
        )

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
        """
        if isinstance(command, bool) or not isinstance(command, (int, float, np.floating, np.integer)):
            raise PlantConfigError(f"command must be a number in [-1, 1], got {command!r}")
        command = float(command)
        if not (math.isfinite(command) and -1.0 <= command <= 1.0):
            raise PlantConfigError(f"command must be finite and in [-1, 1], got {command!r}")
        if isinstance(n_ticks, bool) or not isinstance(n_ticks, (int, np.integer)) or n_ticks < 1:
            raise PlantConfigError(f"n_ticks must be an integer >= 1, got {n_ticks!r}")
        n = int(n_ticks)
        veh = self.vehicle
        brake = 0.0 if command >= 0 else -command * veh.service_brake_n
        if self._emergency:
            brake = max(brake, veh.emergency_brake_n)
        self._brake_n = brake
        c_trac = command if command > 0 else 0.0

        dt = self.dt_s
        r = self.drive_radius_m
        jd = self.config.drive_inertia_kgm2
        jr2 = jd / (r * r)
        f_adh = self.adhesion_limit_n
        t_max = self.max_torque_nm
        p_max = veh.motor_power_w
        om_max = self._omega_max
        om_taper = 0.1 * om_max
        if self._prims is None:
            self._prims = self._primitives()
        push, cbody, zero, cstep, cspace, each, it, data, vel_fn, ang_fn, angvel_fn, buf = self._prims
        buf.clear()  # reuse the batch arrays; _finish_log copies what it keeps
        # the drive section's [angle, vx, vy, w] of tick k are read back from the batch log when it is reachable
        # (cheaper than three getter calls, the same doubles): at arr[o + 2 .. o + 5], o = k * stride + off
        farr = buf._float_arr if data is not None else None
        stride = 6 * self._n_bodies
        off = 6 * self._idx["drive"]
        torque = [0.0] * n
        force = [0.0] * n
        omega_log = [0.0] * n
        slip_log = [False] * n
        omega = self._omega
        slipping = self._slipping
        omega_new = omega
        v_prev = self._prev_v
        a_prev = self._accel
        cos = math.cos
        sin = math.sin
        hang = _D_HANG
        energy = self.config.track_energy
        chunk = 20  # ticks between updates of the slope-dependent resistance
        for k0 in range(0, n, chunk):
            self._set_friction(brake)
            for k in range(k0, min(n, k0 + chunk)):
                # motor torque available at this drive-wheel speed: torque limit, power limit, taper at top speed
                if c_trac > 0.0:
                    aw = omega if omega > 0.0 else -omega
                    cap = t_max if aw * t_max <= p_max else p_max / aw
                    if aw > om_max - om_taper:
                        cap *= max(0.0, (om_max - aw) / om_taper)
                    tq = c_trac * cap
                else:
                    tq = 0.0
                if slipping:
                    # direction of the slip velocity; never zero while slipping (a tick that would end with it
                    # zero or reversed re-sticks instead)
                    sgn = 1.0 if omega * r > v_prev else -1.0
                else:
                    # force that keeps the wheel rolling with the train (its inertia with last tick's accel)
                    f = tq / r - jr2 * a_prev
                    # beyond the limit the wheel starts to slip in the direction of the excess demand (the slip
                    # velocity is still zero here: its rounding residue must not pick the direction)
                    if f > f_adh:
                        slipping, sgn = True, 1.0
                    elif f < -f_adh:
                        slipping, sgn = True, -1.0
                restick = False
                if slipping:
                    f = sgn * f_adh
                    # implicit Euler of J domega/dt = T(omega) - f r: torque-limited branch, else power branch
                    om1 = omega + dt * (tq - f * r) / jd
                    if c_trac > 0.0 and om1 * t_max > p_max and om1 > 0.0:
                        b = jd * omega - dt * f * r
                        om1 = (b + math.sqrt(b * b + 4.0 * jd * dt * c_trac * p_max)) / (2.0 * jd)
                        if om1 > om_max:
                            om1 = om_max
                    v_pred = v_prev + a_prev * dt
                    if (om1 * r - v_pred) * sgn <= 0.0:
                        # the slip ends within this tick: the contact passes only the force that brings the wheel
                        # to the train's speed (the full adhesion force for the whole tick would hand the train
                        # more momentum than the wheel had to give), then the wheel sticks
                        f = (tq - jd * (v_pred / r - omega) / dt) / r
                        if f > f_adh:
                            f = f_adh
                        elif f < -f_adh:
                            f = -f_adh
                        restick = True
                    omega_new = om1
                push(cbody, (f, 0.0), zero)
                if energy:
                    e_pre = self._energy_pre()
                cstep(cspace, dt)
                if energy:
                    self._energy_tick(f, e_pre)
                each(cspace, it, data)
                if farr is not None:
                    arr = farr.arr  # (re-read: the log may have grown and moved)
                    o = k * stride + off
                    ang = arr[o + 2]
                    v = arr[o + 3] * cos(ang) + arr[o + 4] * sin(ang) - arr[o + 5] * hang
                else:
                    vel = vel_fn(cbody)
                    ang = ang_fn(cbody)
                    v = vel.x * cos(ang) + vel.y * sin(ang) - angvel_fn(cbody) * hang
                a_prev = (v - v_prev) / dt
                if slipping:
                    # re-stick when the slip ends: predicted above, or the slip velocity not in the slip direction
                    if restick or (omega_new * r - v) * sgn <= 0.0:
                        slipping = False
                        omega = v / r
                    else:
                        omega = omega_new
                else:
                    omega = v / r
                v_prev = v
                torque[k] = tq
                force[k] = f
                omega_log[k] = omega
                slip_log[k] = slipping
        v_start = self._prev_v
        self._prev_v = v_prev
        self._omega = omega
        self._slipping = slipping
        self._accel = a_prev
        self._last_torque = float(torque[-1])
        self._last_force = float(force[-1])
        log = self._finish_log(
            buf, n, np.array(torque), np.array(force), np.array(omega_log), np.array(slip_log, dtype=bool), brake,
            v_start,
        )
        self._last_row = log.row(n - 1)
        return log

    def _primitives(self) -> tuple:
        """Per-tick operations as bare callables with their arguments, called straight from the tick loop.

        Where pymunk's Chipmunk bindings are reachable these are Chipmunk's own functions (a 2-3x cheaper tick:
        no Vec2d objects, no Python-side step bookkeeping we do not use - post-step callbacks, deferred adds -
        and no Python frame between the loop and C); otherwise wrappers of pymunk's public API with the same
        signatures, with identical results.

        Returns ``(push, body, zero, step, space, each, iterator, data, velocity, angle, angular_velocity,
        buffer)``: the loop calls ``push(body, (f, 0.0), zero)``, ``step(space, dt)``,
        ``each(space, iterator, data)`` (logs all bodies into ``buffer``) and ``velocity(body)`` etc.
        """
        space, d, dt = self.space, self.drive_body, self.dt_s
        buf = pbatch.Buffer()
        fields_ = self._fields
        if _lib is not None:
            lib = _lib
            data = _ffi.new("pmBatchedData *")
            data.fields = fields_.value
            data.floatArray = buf._float_arr
            data.intArray = buf._int_arr
            it = _ffi.addressof(lib, "pmSpaceBodyGetIteratorFuncBatched")
            return (
                lib.cpBodyApplyForceAtLocalPoint, d._body, (0.0, 0.0), lib.cpSpaceStep, space._space,
                lib.cpSpaceEachBody, it, data, lib.cpBodyGetVelocity, lib.cpBodyGetAngle,
                lib.cpBodyGetAngularVelocity, buf,
            )

        def push(_body, force: tuple[float, float], point: tuple[float, float]) -> None:
            d.apply_force_at_local_point(force, point)

        def step(_space, _dt: float) -> None:
            space.step(dt)

        def each(_space, _it, _data) -> None:
            pbatch.get_space_bodies(space, fields_, buf)

        return (
            push, None, (0.0, 0.0), step, None, each, None, None, lambda _b: d.velocity, lambda _b: d.angle,
            lambda _b: d.angular_velocity, buf,
        )

    # ------------------------------------------------------------------------------------------ energy books
    def _energy_pre(self) -> tuple[float, list[float]]:
        d = self.drive_body
        ang = d.angle
        vx, vy = d.velocity
        rel = [m.a.angular_velocity - m.b.angular_velocity for m in self.friction_motors]
        return vx * math.cos(ang) + vy * math.sin(ang), rel

    @staticmethod
    def _spring_rate(sp: pymunk.DampedSpring) -> float:
        a, b = sp.a, sp.b
        pa = a.local_to_world(sp.anchor_a)
        pb = b.local_to_world(sp.anchor_b)
        n = (pb - pa).normalized()
        return (b.velocity_at_world_point(pb) - a.velocity_at_world_point(pa)).dot(n)

    def _energy_tick(self, f: float, pre: tuple[float, list[float]]) -> None:
        """Work of this tick, with mid-point (average of before/after) velocities."""
        dt = self.dt_s
        e = self.energy
        v_pre, rel_pre = pre
        v_post, rel_post = self._energy_pre()
        e["traction_work_j"] += f * 0.5 * (v_pre + v_post) * dt
        for m, r0, r1 in zip(self.friction_motors, rel_pre, rel_post):
            e["friction_j"] += abs(m.impulse * 0.5 * (r0 + r1))
        for sp in (self.coupler, self.sway_damper):
            e["damper_j"] += sp.damping * self._spring_rate(sp) ** 2 * dt

    def centre_of_mass_speed_mps(self) -> float:
        """Horizontal speed of the centre of mass of all bodies (the momentum: free of the load-sway exchange)."""
        bodies = self.space.bodies
        return sum(b.mass * b.velocity.x for b in bodies) / sum(b.mass for b in bodies)

    def mechanical_energy_j(self) -> float:
        """Kinetic (translation and rotation of every body) + gravitational + coupler-spring energy (J)."""
        total = 0.0
        for b in self.space.bodies:
            vx, vy = b.velocity
            total += 0.5 * b.mass * (vx * vx + vy * vy) + 0.5 * b.moment * b.angular_velocity**2
            total += b.mass * G_MPS2 * b.position.y
        sp = self.coupler
        dist = (sp.b.local_to_world(sp.anchor_b) - sp.a.local_to_world(sp.anchor_a)).length
        total += 0.5 * sp.stiffness * (dist - sp.rest_length) ** 2
        return total

    def _finish_log(self, buf: pbatch.Buffer, n: int, torque: np.ndarray, force: np.ndarray,
                    omega: np.ndarray, slipping: np.ndarray, brake: float, v_start: float) -> PlantLog:
        """Derive the truth columns from the raw body states of the block (vectorised over its ticks).

        Each numpy call costs about a microsecond whatever its size, so the columns of the three bodies we read
        are handled together (one copy, one cos, one sin); the arithmetic and its order are those of the
        per-body formulas, so the results do not change by a bit.
        """
        raw = np.frombuffer(buf.float_buf(), dtype=np.float64).reshape(n, self._n_bodies, 6)
        dt = self.dt_s
        t_offsets = self._tick_offsets_s.get(n)
        if t_offsets is None:
            t_offsets = self._tick_offsets_s[n] = dt * np.arange(1, n + 1)
        t = self._t + t_offsets
        self._t = float(t[-1])
        # one copy of what we need: S[field, body, tick], fields [x, y, angle, vx, vy, w], bodies drive/beam/load
        S = raw[:, self._sel_bodies, :].transpose(2, 1, 0).copy()
        cos3 = np.cos(S[2])
        sin3 = np.sin(S[2])
        ang = S[2, 0]
        ca, sa = cos3[0], sin3[0]
        w0 = -raw[:, self._idx["w0"], 5]  # rolling forward turns the wheel clockwise
        speed = S[3, 0] * ca + S[4, 0] * sa - S[5, 0] * _D_HANG
        prev = np.empty((3, n + 1))
        prev[:, 0] = (v_start, self._prev_vel[0], self._prev_vel[1])
        prev[0, 1:] = speed
        prev[1:, 1:] = S[3:5, 0]
        d_all = (prev[:, 1:] - prev[:, :-1]) / dt
        accel, ax, ay = d_all[0], d_all[1], d_all[2] + G_MPS2
        fx = ax * ca + ay * sa
        fz = ay * ca - ax * sa
        self._prev_vel = (float(prev[1, -1]), float(prev[2, -1]))
        tr = self.track
        x_rail = S[0, 0] + (self.vehicle.carrying_wheel_radius_m - _D_HANG) * sa
        x_lo, x_hi = self._track_x_range
        if n * dt <= 0.5:
            # both ends of the block 1 m inside the track: no tick in between left it (going 1 m beyond an end
            # and back within 0.5 s would take more than 16 m/s^2), so the cheap test of the ends is exact
            x_first, x_last = float(x_rail[0]), float(x_rail[-1])
            on_track = x_lo + 1.0 <= x_first <= x_hi - 1.0 and x_lo + 1.0 <= x_last <= x_hi - 1.0
        else:
            on_track = x_rail.min() >= x_lo and x_rail.max() <= x_hi
        if on_track:  # s_at_x is this interpolation on the track; beyond its ends it extrapolates
            pos = np.interp(x_rail, tr.x_m, tr.s_m)
        else:
            pos = np.asarray(tr.s_at_x(x_rail), dtype=np.float64).reshape(n)
        slope = np.interp(pos, tr.s_m, tr.slope_rad)
        # front chain: from its top on the beam to its bottom on the load (rows: beam point, load point)
        ox, oz = self._chain_pts
        px = S[0, 1:] + ox * cos3[1:] - oz * sin3[1:]
        py = S[1, 1:] + ox * sin3[1:] + oz * cos3[1:]
        sway = np.arctan2(px[1] - px[0], py[0] - py[1])
        sway_rate = np.empty(n)
        sway_rate[0] = sway[0] - self._prev_sway
        sway_rate[1:] = sway[1:] - sway[:-1]
        sway_rate /= dt
        self._prev_sway = float(sway[-1])
        # gravity over the whole train: mass-weighted sine of the rail slope under each body
        body_x = raw[:, :, 0]
        sin_eff = np.sin(np.interp(body_x, tr.x_m, tr.slope_rad)) @ self._body_mass_share
        eff_slope = np.arcsin(sin_eff)
        r = self.drive_radius_m
        wr = omega * r
        slip = (wr - speed) / np.maximum(np.maximum(np.abs(wr), np.abs(speed)), 0.01)
        const = np.empty((3, n))
        const[0] = r
        const[1] = self.total_mass_kg
        const[2] = brake
        return PlantLog(
            t_s=t, position_m=pos, speed_mps=speed, accel_mps2=accel, slope_rad=slope, specific_force_mps2=fx,
            drive_torque_nm=torque, traction_force_n=force, wheel_speed_radps=omega, slip_ratio=slip,
            drive_radius_m=const[0], sway_rad=sway, sway_rate_radps=sway_rate, pitch_rad=ang,
            pitch_rate_radps=S[5, 0], normal_specific_force_mps2=fz, total_mass_kg=const[1], slipping=slipping,
            brake_force_n=const[2], carry_wheel_speed_radps=w0, effective_slope_rad=eff_slope,
        )


__all__ = ["LOG_FIELDS", "MonorailPlant", "PlantConfig", "PlantConfigError", "PlantLog", "PlantState"]
