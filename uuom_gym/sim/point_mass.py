"""A second, deliberately different simulator: point-mass vehicle + load on a damped pendulum (no pymunk).

Written so that estimators tuned on the pymunk plant (:mod:`uuom_gym.sim.plant`) can be scored on a world they
were not tuned on (issue 10, item 3b). What differs from the plant on purpose:

- the vehicle body is a **point**: the slope acts at one point, so the slope under the sensors and the
  train-averaged slope are the same (no 18 m train);
- the load hangs from the body on a rigid, damped pendulum (cart-pendulum equations on the local grade), not on
  pymunk chains and couplers;
- the driver is a time- or position-scheduled **PI** speed controller on force without any feed-forward, that
  uses the motors in both directions (negative torque = electric braking, recorded by the torque transducer) and
  the mechanical brake only to hold the train at standstill;
- no adhesion limit, no wheel slip, no compliant couplers; an extra body vibration mode (speed-dependent
  ~7 Hz) on the accelerometer;
- sensors: torque transducer (noise, bias, quantisation), carrying-wheel encoder (quantised, noisy), along-track
  accelerometer giving the **specific force** ``f = dv/dt + g sin(theta)`` of the body (noise, bias,
  quantisation, the load's sway reaction and the vibration mode).

Physics (x along the track, phi the absolute pendulum angle from the vertical, theta the local slope)::

    (M_b + m_rot + m) x'' + m L (phi'' cos(phi - theta) - phi'^2 sin(phi - theta))
                                             = F_motor - F_brake - mu (M_b + m) g cos(theta) s(v) - (M_b + m) g sin(theta)
    m L^2 phi'' + m L x'' cos(phi - theta) + m g L sin(phi) = -c phi'

integrated with semi-implicit Euler at ``substeps`` x the 200 Hz sample rate. Everything is seeded and
deterministic; the module depends only on :mod:`uuom_core` and numpy. It is one module (a little over 400 lines)
on purpose: the whole second world -- model, driver, sensors, faults, scenarios -- reads top to bottom in one file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from uuom_core.trace import Trace
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2, VehicleParams

SENSOR_CHANNELS: tuple[str, ...] = ("torque_nm", "speed_mps", "accel_mps2")
"""The channels this simulator records."""


class PointMassError(ValueError):
    """An impossible point-mass scenario or sensor configuration."""


@dataclass(frozen=True)
class GradeProfile:
    """Slope as a function of distance: piecewise linear through ``(s_m, slope_deg)`` knots plus undulations.

    Parameters
    ----------
    knots : tuple of (float, float)
        Increasing positions (m) and the slope there (deg). Constant beyond the ends.
    undulation_deg, undulation_wavelength_m : float
        Optional sinusoid added to the whole profile (continuously varying grade).
    """

    knots: tuple[tuple[float, float], ...]
    undulation_deg: float = 0.0
    undulation_wavelength_m: float = 50.0

    def __post_init__(self) -> None:
        s = [k[0] for k in self.knots]
        if len(s) < 1 or any(b <= a for a, b in zip(s, s[1:])):
            raise PointMassError(f"grade knots must have strictly increasing positions, got {s}")
        if any(abs(k[1]) + abs(self.undulation_deg) >= 30.0 for k in self.knots):
            raise PointMassError("grade must stay below 30 deg")

    def slope_rad(self, s_m: float) -> float:
        s = [k[0] for k in self.knots]
        d = [k[1] for k in self.knots]
        deg = float(np.interp(s_m, s, d))
        if self.undulation_deg:
            deg += self.undulation_deg * math.sin(2.0 * math.pi * s_m / self.undulation_wavelength_m)
        return math.radians(deg)


@dataclass(frozen=True)
class SpeedPlan:
    """The driver's reference speed: piecewise linear in time (``by="time"``) or distance (``by="position"``)."""

    knots: tuple[tuple[float, float], ...]
    by: str = "position"
    accel_limit_mps2: float = 0.2

    def __post_init__(self) -> None:
        if self.by not in ("time", "position"):
            raise PointMassError(f"SpeedPlan.by must be 'time' or 'position', got {self.by!r}")
        xs = [k[0] for k in self.knots]
        if len(xs) < 1 or any(b <= a for a, b in zip(xs, xs[1:])):
            raise PointMassError("SpeedPlan knots must increase strictly")
        if any(k[1] < 0 or not math.isfinite(k[1]) for k in self.knots):
            raise PointMassError("SpeedPlan speeds must be finite and >= 0")

    def target(self, t_s: float, s_m: float) -> float:
        x = t_s if self.by == "time" else s_m
        return float(np.interp(x, [k[0] for k in self.knots], [k[1] for k in self.knots]))


@dataclass(frozen=True)
class PointMassSensors:
    """Noise (1 sigma), bias spread, quantisation step of each sensor, and the body vibration mode."""

    torque_noise_std_nm: float = 80.0
    torque_bias_std_nm: float = 30.0
    torque_resolution_nm: float = 10.0
    speed_noise_std_mps: float = 0.008
    speed_resolution_mps: float = 0.004
    accel_noise_std_mps2: float = 0.06
    accel_bias_std_mps2: float = 0.012
    accel_resolution_mps2: float = 0.005
    vibration_mps2_per_mps: float = 0.05
    vibration_hz: float = 7.0

    @classmethod
    def perfect(cls) -> PointMassSensors:
        """Sensors that read the simulated truth: no noise, bias, quantisation or vibration (what is left of an
        estimator's error on them is its model's)."""
        return cls().scaled(0.0)

    def scaled(self, k: float) -> PointMassSensors:
        """These sensors with every imperfection (noise, bias spread, quantisation, vibration amplitude) times
        ``k``; the vibration's frequency kept."""
        return replace(self, **{f.name: k * getattr(self, f.name) for f in fields(self) if f.name != "vibration_hz"})


@dataclass(frozen=True)
class PointMassFaults:
    """Sensor faults on :data:`SENSOR_CHANNELS`: dropouts (NaN), spikes, a stuck channel, bias drift.

    ``bias_drift_per_s`` maps a channel to a drift rate (channel units per second) accumulating from t = 0.
    """

    dropout_prob: float = 0.0
    spike_prob: float = 0.0
    spike_scale: dict[str, float] = field(
        default_factory=lambda: {"torque_nm": 4000.0, "speed_mps": 0.6, "accel_mps2": 4.0}
    )
    stuck_channel: str | None = None
    stuck_start_s: float = 0.0
    stuck_duration_s: float = 0.0
    bias_drift_per_s: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for k, v in self.bias_drift_per_s.items():
            if k not in SENSOR_CHANNELS or not math.isfinite(v):
                raise PointMassError(f"PointMassFaults.bias_drift_per_s: bad entry {k!r}: {v!r}")
        for name in ("dropout_prob", "spike_prob"):
            v = getattr(self, name)
            if not 0.0 <= v <= 1.0:
                raise PointMassError(f"PointMassFaults.{name} must be in [0, 1], got {v!r}")
        if self.stuck_channel is not None and self.stuck_channel not in SENSOR_CHANNELS:
            raise PointMassError(f"unknown stuck channel {self.stuck_channel!r}; known: {SENSOR_CHANNELS}")


@dataclass(frozen=True)
class PointMassScenario:
    """One point-mass test case.

    ``running_resistance`` is the *true* mu of this world; the vehicle file keeps its nominal value, so a value
    different from ``vehicle.running_resistance`` is a model mismatch for the estimators.
    """

    name: str
    grade: GradeProfile
    speed: SpeedPlan
    load_kg: float
    duration_s: float = 120.0
    running_resistance: float | None = None
    chain_length_m: float = 2.5
    sway_damping_ratio: float = 0.08
    hook_mass_kg: float = 250.0
    sensors: PointMassSensors = PointMassSensors()
    faults: PointMassFaults = PointMassFaults()
    description: str = ""


def _scenarios() -> dict[str, PointMassScenario]:
    s1 = GradeProfile(((0, 0.0), (45, 0.0), (65, 8.0), (400, 8.0)))
    road = GradeProfile(((0, 0.0), (10, 0.0), (16, 0.6), (24, 0.6), (30, -0.5), (36, -0.5), (41, 0.3), (44, 0.3),
                         (51, 11.0), (54, 11.0), (57, 7.0), (58, 7.0), (63, 0.8), (400, 0.8)))
    road_speed = SpeedPlan(((0.0, 1.0), (40.0, 1.0), (43.0, 0.5), (60.0, 0.5), (63.0, 0.7)))
    out = [
        PointMassScenario("pm-section1", s1, SpeedPlan(((0.0, 1.0), (40.0, 1.0), (48.0, 0.8))), 10_000.0,
                          description="level 45 m, 20 m transition, 8 deg up-grade, 10 t"),
        PointMassScenario("pm-section2", GradeProfile(((0, 0.0), (20, 3.5), (400, 3.5)), 3.0, 70.0),
                          SpeedPlan(((0.0, 0.8),)), 10_000.0,
                          description="continuously varying grade 0.5..6.5 deg, 10 t, 0.8 m/s"),
        PointMassScenario("pm-roadtest", road, road_speed, 10_000.0,
                          description="paper's road test profile, 10 t, 1.0 / 0.5 / 0.7 m/s"),
        PointMassScenario("pm-heavy-downhill", GradeProfile(((0, 0.0), (30, 0.0), (70, -10.0), (400, -10.0))),
                          SpeedPlan(((0.0, 0.5),)), 20_000.0,
                          description="rated load 20 t down a 10 deg grade at 0.5 m/s (electric braking)"),
        PointMassScenario("pm-steep-empty-climb", GradeProfile(((0, 0.0), (25, 0.0), (75, 14.0), (400, 14.0))),
                          SpeedPlan(((0.0, 1.5),)), 0.0, duration_s=100.0,
                          description="empty train up a 14 deg grade at 1.5 m/s"),
        PointMassScenario("pm-stop-and-go", GradeProfile(((0, 0.0), (20, 2.0), (400, 2.0)), 1.5, 40.0),
                          SpeedPlan(((0, 0.0), (3, 0.0), (10, 1.0), (22, 1.0), (27, 0.0), (33, 0.0), (40, 1.0),
                                     (55, 1.0), (60, 0.0), (66, 0.0), (73, 0.8), (90, 0.8), (95, 0.0),
                                     (101, 0.0), (108, 1.0)), by="time", accel_limit_mps2=0.3),
                          5_000.0, description="5 t, mild undulating grade, stop / go every ~30 s"),
        PointMassScenario("pm-sensor-faults", road, road_speed, 10_000.0,
                          faults=PointMassFaults(dropout_prob=0.02, spike_prob=0.002, stuck_channel="accel_mps2",
                                                 stuck_start_s=30.0, stuck_duration_s=3.0),
                          description="road test with 2 % dropouts, spikes, accelerometer stuck 3 s at 30 s"),
        PointMassScenario("pm-resistance-mismatch", s1, SpeedPlan(((0.0, 1.0), (40.0, 1.0), (48.0, 0.8))),
                          15_000.0, running_resistance=1.3 * DEFAULT_VEHICLE.running_resistance,
                          description="section 1 with 15 t, true running resistance 30 % above the vehicle file"),
    ]
    return {s.name: s for s in out}


POINT_MASS_SCENARIOS: dict[str, PointMassScenario] = _scenarios()
"""The fixed scenario set, by name."""


def point_mass_scenario(name: str) -> PointMassScenario:
    """The scenario called ``name`` (see :data:`POINT_MASS_SCENARIOS`)."""
    try:
        return POINT_MASS_SCENARIOS[name]
    except KeyError:
        raise PointMassError(f"unknown point-mass scenario {name!r}; known: {', '.join(POINT_MASS_SCENARIOS)}") \
            from None


@dataclass(frozen=True)
class PointMassModel:
    """The equations of motion: body (point) + rotating mass + load on a damped rigid pendulum, on a local grade.

    Exposed so the physics can be checked on its own (energy balance) apart from the driver and the sensors.
    """

    body_kg: float
    rotating_kg: float
    pendulum_kg: float
    length_m: float
    damping_nms: float
    running_resistance: float

    @property
    def total_kg(self) -> float:
        """Mass gravity and running resistance act on (the rotating mass is an inertia only)."""
        return self.body_kg + self.pendulum_kg

    def accelerations(self, slope_rad: float, v: float, phi: float, w: float, force_n: float) -> tuple[float, float]:
        """``(x'', phi'')`` for the motor force ``force_n`` (the 2x2 mass matrix solved in closed form)."""
        m, L = self.pendulum_kg, self.length_m
        d = phi - slope_rad
        cd, sd = math.cos(d), math.sin(d)
        res_max = self.running_resistance * self.total_kg * G_MPS2 * math.cos(slope_rad)
        # smooth Coulomb resistance: opposes motion, fades to zero through standstill
        resist = res_max * math.tanh(v / 0.005)
        rhs_x = force_n - resist - self.total_kg * G_MPS2 * math.sin(slope_rad) + m * L * w * w * sd
        rhs_p = -m * G_MPS2 * L * math.sin(phi) - self.damping_nms * w
        a11, a12 = self.body_kg + self.rotating_kg + m, m * L * cd
        a22 = m * L * L
        det = a11 * a22 - a12 * a12
        return (rhs_x * a22 - a12 * rhs_p) / det, (a11 * rhs_p - a12 * rhs_x) / det

    def energy_j(self, x: float, slope_rad: float, v: float, phi: float, w: float) -> float:
        """Kinetic + potential energy on a constant grade ``slope_rad`` (body at ``x`` along it)."""
        m, L = self.pendulum_kg, self.length_m
        kin = 0.5 * (self.body_kg + self.rotating_kg) * v * v
        kin += 0.5 * m * (v * v + L * L * w * w + 2.0 * v * L * w * math.cos(phi - slope_rad))
        pot = self.total_kg * G_MPS2 * x * math.sin(slope_rad) - m * G_MPS2 * L * math.cos(phi)
        return kin + pot


class _PIDriver:
    """PI on the speed error giving a force demand; no feed-forward; gains scaled by the mass it assumes."""

    def __init__(self, plan: SpeedPlan, mass_kg: float, kp_per_s: float = 1.2, ki_per_s2: float = 0.35,
                 max_force_n: float = 80_000.0) -> None:
        self.plan, self.mass, self.kp, self.ki, self.fmax = plan, mass_kg, kp_per_s, ki_per_s2, max_force_n
        self.v_ref = 0.0
        self.integral = 0.0

    def force(self, t_s: float, s_m: float, v: float, dt: float) -> float:
        target = self.plan.target(t_s, s_m)
        step = self.plan.accel_limit_mps2 * dt
        self.v_ref = min(max(target, self.v_ref - step), self.v_ref + step)
        err = self.v_ref - v
        f = self.mass * (self.kp * err + self.ki * self.integral)
        f_sat = min(self.fmax, max(-self.fmax, f))
        if f == f_sat or (f > self.fmax and err < 0) or (f < -self.fmax and err > 0):
            self.integral += err * dt
        return f_sat


def simulate_point_mass(
    scenario: str | PointMassScenario,
    *,
    seed: int,
    vehicle: VehicleParams | None = None,
    sample_hz: float = 200.0,
    substeps: int = 5,
) -> Trace:
    """Simulate one point-mass scenario and record its sensors at ``sample_hz``.

    Parameters
    ----------
    scenario : str or PointMassScenario
    seed : int
        Seeds sensor biases, noise and faults (the physics is deterministic).
    vehicle : VehicleParams, optional
        Empty mass, radius, rotating mass, motor limits. Its ``running_resistance`` is the true one unless the
        scenario sets another.

    Returns
    -------
    Trace
        ``t_s, torque_nm, speed_mps, accel_mps2`` and the truth ``mass_kg, slope_deg, effective_slope_deg``
        (identical to ``slope_deg``: the slope acts at one point), ``true_speed_mps, sway_rad, position_m``.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise PointMassError(f"seed must be an integer, got {seed!r}")
    sc = point_mass_scenario(scenario) if isinstance(scenario, str) else scenario
    veh = vehicle or DEFAULT_VEHICLE
    if not (0.0 <= sc.load_kg <= 1.5 * veh.rated_load_kg):
        raise PointMassError(f"load_kg must be in [0, 1.5 x rated], got {sc.load_kg!r}")
    if not (sample_hz > 0 and substeps >= 1 and sc.duration_s > 0):
        raise PointMassError("sample_hz, substeps and duration_s must be positive")
    rng = np.random.default_rng(int(seed))
    mu = veh.running_resistance if sc.running_resistance is None else float(sc.running_resistance)
    m_pend = sc.hook_mass_kg + sc.load_kg  # the hanging mass (hook block always hangs)
    L = sc.chain_length_m
    model = PointMassModel(
        body_kg=veh.empty_mass_kg - sc.hook_mass_kg, rotating_kg=veh.rotating_mass_kg, pendulum_kg=m_pend,
        length_m=L, damping_nms=2.0 * sc.sway_damping_ratio * m_pend * L * L * math.sqrt(G_MPS2 / L),
        running_resistance=mu,
    )
    m_tot = model.total_kg
    driver = _PIDriver(sc.speed, veh.rated_mass_kg * 0.75, max_force_n=veh.max_traction_n)
    n = int(round(sc.duration_s * sample_hz))
    dt = 1.0 / sample_hz
    h = dt / substeps
    out = {k: np.empty(n) for k in ("t_s", "torque_nm", "accel", "speed", "slope", "sway", "pos", "force")}
    x = v = 0.0
    phi = 0.0
    w = 0.0
    held = True  # the brake holds the train until the driver pulls away
    for i in range(n):
        t = (i + 1) * dt
        f_cmd = driver.force(t, x, v, dt)
        # motor power limit: the electric drive gives at most P / |v| at speed
        p_lim = veh.motor_power_w / max(abs(v), 0.1)
        f_motor = min(max(f_cmd, -p_lim), p_lim)
        acc_sum = 0.0
        for _ in range(substeps):
            th = sc.grade.slope_rad(x)
            res_max = mu * m_tot * G_MPS2 * math.cos(th)
            grav = m_tot * G_MPS2 * math.sin(th)
            # standstill: brake + static resistance hold the train while the driver asks for little or nothing
            if held or (abs(v) < 1e-3 and abs(f_motor - grav) <= res_max and driver.v_ref < 0.02):
                held = driver.v_ref < 0.02 and f_motor - grav < res_max + 0.2 * veh.max_traction_n
                if held:
                    # train fixed: only the pendulum moves (x'' = 0)
                    phi_dd = (-m_pend * G_MPS2 * L * math.sin(phi) - model.damping_nms * w) / (m_pend * L * L)
                    w += h * phi_dd
                    phi += h * w
                    v = 0.0
                    continue
            x_dd, phi_dd = model.accelerations(th, v, phi, w, f_motor)
            v += h * x_dd
            w += h * phi_dd
            x += h * v
            phi += h * w
            acc_sum += x_dd
        th = sc.grade.slope_rad(x)
        out["t_s"][i] = t
        out["force"][i] = f_motor
        out["accel"][i] = acc_sum / substeps
        out["speed"][i] = v
        out["slope"][i] = th
        out["sway"][i] = phi - th
        out["pos"][i] = x
    return _record(sc, veh, out, rng, m_tot)


def _record(sc: PointMassScenario, veh: VehicleParams, out: dict[str, np.ndarray], rng: np.random.Generator,
            m_tot: float) -> Trace:
    c = sc.sensors
    n = len(out["t_s"])
    t = out["t_s"]

    def q(x: np.ndarray, step: float) -> np.ndarray:
        return np.round(x / step) * step if step > 0 else x

    b_t = rng.normal(0.0, c.torque_bias_std_nm)
    b_a = rng.normal(0.0, c.accel_bias_std_mps2)
    vib_phase = rng.uniform(0.0, 2 * math.pi)
    torque = q(out["force"] * veh.drive_wheel_radius_m + b_t + rng.normal(0.0, c.torque_noise_std_nm, n),
               c.torque_resolution_nm)
    speed = q(out["speed"] + rng.normal(0.0, c.speed_noise_std_mps, n), c.speed_resolution_mps)
    vib = c.vibration_mps2_per_mps * np.abs(out["speed"]) * np.sin(2 * math.pi * c.vibration_hz * t + vib_phase)
    f_true = out["accel"] + G_MPS2 * np.sin(out["slope"])
    accel = q(f_true + vib + b_a + rng.normal(0.0, c.accel_noise_std_mps2, n), c.accel_resolution_mps2)
    meas = {"torque_nm": torque, "speed_mps": speed, "accel_mps2": accel}
    f = sc.faults
    for k, rate in f.bias_drift_per_s.items():
        meas[k] = meas[k] + rate * t
    if f.spike_prob > 0:
        for k in SENSOR_CHANNELS:
            hit = rng.random(n) < f.spike_prob
            sign = np.where(rng.random(n) < 0.5, -1.0, 1.0)
            meas[k] = np.where(hit, meas[k] + sign * f.spike_scale.get(k, 1.0), meas[k])
    if f.stuck_channel is not None and f.stuck_duration_s > 0:
        stuck = (t >= f.stuck_start_s) & (t < f.stuck_start_s + f.stuck_duration_s)
        if np.any(stuck):
            first = int(np.argmax(stuck))
            meas[f.stuck_channel] = np.where(stuck, meas[f.stuck_channel][max(first - 1, 0)], meas[f.stuck_channel])
    if f.dropout_prob > 0:
        for k in SENSOR_CHANNELS:
            meas[k] = np.where(rng.random(n) < f.dropout_prob, np.nan, meas[k])
    slope_deg = np.degrees(out["slope"])
    cols = {
        "t_s": t, **meas,
        "mass_kg": np.full(n, m_tot), "slope_deg": slope_deg, "effective_slope_deg": slope_deg.copy(),
        "true_speed_mps": out["speed"], "sway_rad": out["sway"], "position_m": out["pos"],
    }
    return Trace(cols, source=f"simulate_point_mass({sc.name!r})",
                 meta={"scenario": sc.name, "simulator": "point_mass", "load_kg": f"{sc.load_kg:g}"})


def with_options(scenario: str | PointMassScenario, **changes) -> PointMassScenario:
    """A copy of a scenario with fields replaced (e.g. ``load_kg``, ``faults``, ``running_resistance``)."""
    sc = point_mass_scenario(scenario) if isinstance(scenario, str) else scenario
    return replace(sc, **changes)


def with_sensor_scale(scenario: str | PointMassScenario, scale: float) -> PointMassScenario:
    """A copy of a scenario whose sensors' noise, bias spreads, quantisation and vibration amplitude are all
    multiplied by ``scale`` (0: perfect sensors; the vibration's frequency and any faults kept): the same physics
    read by better or worse sensors (``scripts/estimator_quick_check.py --sensor-scale``)."""
    if not (isinstance(scale, (int, float)) and not isinstance(scale, bool) and 0.0 <= scale < math.inf):
        raise PointMassError(f"sensor scale must be a finite number >= 0, got {scale!r}")
    sc = point_mass_scenario(scenario) if isinstance(scenario, str) else scenario
    return replace(sc, sensors=sc.sensors.scaled(scale))


__all__ = [
    "POINT_MASS_SCENARIOS", "SENSOR_CHANNELS", "GradeProfile", "PointMassError", "PointMassFaults",
    "PointMassScenario", "PointMassSensors", "SpeedPlan", "point_mass_scenario", "simulate_point_mass",
    "with_options", "with_sensor_scale",
]
