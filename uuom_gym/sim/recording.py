"""Record a run: drive the plant with a speed-tracking driver and return a :class:`~uuom_core.trace.Trace`.

The driver is a PI speed controller with a running-resistance feed-forward computed from the *nominal* vehicle
and the (known to the driver) load, run at ``control_hz``; like a human driver it does not know the grade, the
integral action finds the force the grade needs; it follows a :class:`SpeedProfile` whose reference it
ramps at a limited rate. Its output goes to the plant as the command in [-1, 1] (traction > 0, service brake < 0).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from uuom_core.limits import load_speed_limit_mps
from uuom_gym.sim.plant import MonorailPlant, PlantConfig, PlantLog
from uuom_gym.sim.scenarios import Scenario, SpeedProfile, scenario
from uuom_gym.sim.sensors import CHANNELS, FaultConfig, SensorConfig, SensorSuite
from uuom_gym.sim.track import SCENARIO_NAMES, TrackProfile
from uuom_core.trace import Trace
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2, VehicleParams


class SpeedDriver:
    """PI speed tracking with feed-forward, output as a plant command.

    Parameters
    ----------
    vehicle : VehicleParams
    mass_kg : float
        Mass the driver assumes (vehicle + load).
    profile : SpeedProfile
    kp_per_s, ki_per_s2 : float
        Gains on the speed error, as acceleration demand per m/s (and per m) of error.
    """

    def __init__(self, vehicle: VehicleParams, mass_kg: float, profile: SpeedProfile,
                 kp_per_s: float = 2.0, ki_per_s2: float = 1.0) -> None:
        self.vehicle = vehicle
        self.mass_kg = mass_kg
        self.profile = profile
        self.kp = kp_per_s
        self.ki = ki_per_s2
        self.integral = 0.0
        self.v_ref = 0.0

    def command(self, speed_mps: float, position_m: float, slope_rad: float, dt_s: float) -> float:
        veh = self.vehicle
        target = self.profile.speed_at(position_m)
        step = self.profile.accel_limit_mps2 * dt_s
        self.v_ref = min(max(target, self.v_ref - step), self.v_ref + step)
        err = self.v_ref - speed_mps
        m_eff = self.mass_kg + veh.rotating_mass_kg
        ff = self.mass_kg * G_MPS2 * veh.running_resistance
        force = ff + m_eff * (self.kp * err + self.ki * self.integral)
        if force > 0:
            u = force / veh.max_traction_n
        else:
            u = force / veh.service_brake_n
        u_sat = min(1.0, max(-1.0, u))
        # anti-windup: integrate only while not saturated (or while the error pulls back out of saturation)
        if u == u_sat or (u > 1.0 and err < 0) or (u < -1.0 and err > 0):
            self.integral += err * dt_s
        return u_sat


def simulate_run(
    track_or_scenario: str | TrackProfile | Scenario,
    *,
    seed: int,
    load_kg: float | None = None,
    vehicle: VehicleParams | None = None,
    sensor_config: SensorConfig | None = None,
    plant_config: PlantConfig | None = None,
    speed_profile: SpeedProfile | None = None,
    duration_s: float | None = None,
    fault_config: FaultConfig | None = None,
    control_hz: float = 20.0,
    return_log: bool = False,
) -> Trace | tuple[Trace, PlantLog]:
    """Drive a plant along a track and record its sensors (and truth) at the physics rate.

    Parameters
    ----------
    track_or_scenario : str, TrackProfile or Scenario
        A scenario name (``section1``, ``section2``, ``roadtest``), a scenario, or a bare track (then the load
        defaults to 0 and the speed to 70 % of the load speed limit).
    seed : int
        Seeds the sensor noise, biases and faults. The physics is deterministic.
    load_kg : float, optional
        The payload. Default: the scenario's load; for a bare track ``plant_config.load_kg`` (0 without one).
        A scenario's load wins over ``plant_config.load_kg``; pass ``load_kg`` to change it.
    vehicle, sensor_config, plant_config, speed_profile, fault_config :
        Override the defaults / the scenario.
    duration_s : float, optional
        Run time (default: the scenario's, 120 s for a bare track). The run stops early 2 m before the track's
        end.
    control_hz : float
        Rate of the driver (the physics runs at ``plant_config.physics_hz``; must divide it).
    return_log : bool
        Also return the plant's full truth log.

    Returns
    -------
    Trace
        Columns ``t_s, torque_nm, speed_mps, accel_mps2, motor_speed_radps, gyro_radps, accel_normal_mps2`` (the
        sensors) and the truth ``mass_kg, slope_deg, slip_ratio, drive_radius_m, true_speed_mps, sway_rad,
        position_m``, plus ``effective_slope_deg`` in memory (not written to CSV).
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise ValueError(f"seed must be an integer, got {seed!r}")
    vehicle = vehicle or DEFAULT_VEHICLE
    if isinstance(track_or_scenario, str):
        if track_or_scenario not in SCENARIO_NAMES:
            raise ValueError(f"unknown scenario {track_or_scenario!r}; known: {', '.join(SCENARIO_NAMES)}")
        scen = scenario(track_or_scenario)
    elif isinstance(track_or_scenario, Scenario):
        scen = track_or_scenario
    elif isinstance(track_or_scenario, TrackProfile):
        scen = None
    else:
        raise ValueError(f"track_or_scenario must be a scenario name, Scenario or TrackProfile, "
                         f"got {type(track_or_scenario).__name__}")
    pc = plant_config or PlantConfig()
    if load_kg is None:
        load_kg = scen.load_kg if scen is not None else pc.load_kg
    pc = dataclasses.replace(pc, load_kg=float(load_kg))
    track = scen.track if scen is not None else track_or_scenario
    start = scen.start_s_m if scen is not None else 0.0
    if speed_profile is None:
        if scen is not None:
            speed_profile = scen.speed_profile
        else:
            speed_profile = SpeedProfile.constant(0.7 * load_speed_limit_mps(vehicle, vehicle.empty_mass_kg + load_kg))
    if duration_s is None:
        duration_s = scen.duration_s if scen is not None else 120.0
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration_s must be finite and > 0, got {duration_s!r}")
    if not (control_hz > 0 and abs(pc.physics_hz / control_hz - round(pc.physics_hz / control_hz)) < 1e-9):
        raise ValueError(f"control_hz must divide physics_hz={pc.physics_hz:g}, got {control_hz!r}")
    plant = MonorailPlant(vehicle, track, pc, start_s_m=start)
    rng = np.random.default_rng(seed)
    sensors = SensorSuite(sensor_config or SensorConfig(), rng, vehicle, fault_config)
    driver = SpeedDriver(vehicle, plant.total_mass_kg, speed_profile)
    ticks = int(round(pc.physics_hz / control_hz))
    dt_c = ticks / pc.physics_hz
    n_steps = int(math.ceil(duration_s * control_hz - 1e-9))
    logs: list[PlantLog] = []
    speed, pos, slope = 0.0, plant.position_m, track.slope_at(plant.position_m)
    for _ in range(n_steps):
        # the driver sees the (noise-free) ground speed; the sensors' noise is the estimators' problem
        u = driver.command(speed, pos, slope, dt_c)
        log = plant.advance(u, ticks)
        logs.append(log)
        speed, pos, slope = float(log.speed_mps[-1]), float(log.position_m[-1]), float(log.slope_rad[-1])
        if pos > track.length_m - 2.0:
            break
    full = PlantLog.concatenate(logs)
    meas = sensors.measure(full)
    cols = {"t_s": full.t_s}
    cols.update({k: meas[k] for k in CHANNELS})
    cols.update(
        mass_kg=full.total_mass_kg, slope_deg=np.degrees(full.slope_rad), slip_ratio=full.slip_ratio,
        drive_radius_m=full.drive_radius_m, true_speed_mps=full.speed_mps, sway_rad=full.sway_rad,
        position_m=full.position_m,
        # in memory only (not a trace-format column, so write_trace_csv leaves it out): the mass-weighted slope
        # under the whole 18 m train, which is what gravity acts on
        effective_slope_deg=np.degrees(full.effective_slope_rad),
    )
    name = scen.name if scen is not None else track.name
    trace = Trace(cols, source=f"simulate_run({name!r}, seed={int(seed)})",
                  meta={"scenario": name, "seed": str(int(seed)), "load_kg": f"{load_kg:g}"})
    return (trace, full) if return_log else trace


__all__ = ["SpeedDriver", "simulate_run"]
