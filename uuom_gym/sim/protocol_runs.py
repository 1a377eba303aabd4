"""The runs of the estimator generalisation protocol (issue 10, item 3): which traces, drawn how, from which seed.

Four groups, every run a :class:`RunSpec` that :func:`make_run` turns into a :class:`~uuom_core.trace.Trace`
deterministically (the spec's seed is the only randomness):

``plant``   random runs of the pymunk plant (:mod:`uuom_gym.sim.plant`): random feasible track (started from
            standstill on a level stretch a few metres before a grade, so the 60 s hold a grade change), load
            0-20 t, true running resistance 0.015-0.03 (the vehicle file keeps 0.02), dry or wet rail, wheel
            wear 0-4 mm, chain length / sway damping, every sensor's noise and bias spread
            scaled by a log-uniform factor in [0.5, 2], dropouts on a quarter of the runs.
``point``   random runs of the point-mass world (:mod:`uuom_gym.sim.point_mass`): different body model,
            pendulum, PI driver without feed-forward that brakes with the motors, different sensors (vibration mode,
            quantisation); random grade knots and undulations, load 0-20 t, μ 0.015-0.03, stop-and-go on a third.
``paper``   the paper's scenarios on the plant (``section1``, ``section2``, ``roadtest``, 10 t, 120 s), the station
            runs of :mod:`uuom_gym.sim.station` (load changes at a stop), and the fixed point-mass scenarios.
``fault``   the road test in both worlds with one sensor fault each: dropouts, spikes, bias drift, a stuck sensor.

Every trace carries ``effective_slope_deg`` (the slope gravity acts on, averaged over the 18 m train; equal to
``slope_deg`` in the point-mass world) and ``meta`` describing the draw. The estimators never see the truth.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace

import numpy as np

from uuom_core.limits import load_speed_limit_mps, max_climbable_grade_rad
from uuom_core.trace import Trace
from uuom_core.vehicle import DEFAULT_VEHICLE, VehicleParams

__all__ = ["FAULT_KINDS", "RunSpec", "make_run", "protocol_runs", "runs_fingerprint", "true_running_resistance"]

PROTOCOL_SEED = 20_261_123
"""Root of every draw: run ``i`` of group ``g`` uses ``numpy.random.default_rng([PROTOCOL_SEED, g, i])``."""

FAULT_KINDS: tuple[str, ...] = ("dropouts", "spikes", "bias-drift", "stuck")
"""Sensor faults of the robustness rows."""

FAULT_START_S, FAULT_LEN_S = 30.0, 5.0
"""Window of the stuck-sensor fault (the other faults last the whole run)."""

_GROUP_INDEX = {"plant": 1, "point": 2, "paper": 3, "fault": 4}


@dataclass(frozen=True)
class RunSpec:
    """One run of the protocol.

    Attributes
    ----------
    group : str
        ``plant``, ``point``, ``paper`` or ``fault``.
    name : str
        Unique within the protocol (``plant-017``, ``paper-roadtest-s1``, ``fault-spikes-point-s0``...).
    index : int
        Run index within the group (selects the random draw).
    seed : int
        Sensor-noise seed.
    world : str
        ``plant`` (pymunk) or ``point`` (point mass).
    scenario : str
        Scenario name for the fixed runs, ``random`` otherwise.
    fault : str
        One of :data:`FAULT_KINDS`, or ``""``.
    duration_s : float
    """

    group: str
    name: str
    index: int
    seed: int
    world: str
    scenario: str = "random"
    fault: str = ""
    duration_s: float = 60.0

    def with_sensor_seed(self, seed: int) -> RunSpec:
        """The same run read by sensors drawn with ``seed`` (other noise, biases and faults on the same physics),
        named ``<name without its -s suffix>-s<seed>``; itself when ``seed`` is its own."""
        if seed == self.seed:
            return self
        base, sep, _ = self.name.rpartition("-s")
        return replace(self, name=f"{base if sep else self.name}-s{seed}", seed=seed)


def protocol_runs(
    n_plant: int = 200, n_point: int = 200, *, duration_s: float = 60.0, paper_seeds: int = 3, fault_seeds: int = 2
) -> list[RunSpec]:
    """All runs of the protocol, in a fixed order."""
    if min(n_plant, n_point, paper_seeds, fault_seeds) < 0 or not duration_s > 10.0:
        raise ValueError("run counts must be >= 0 and duration_s > 10 s (the settle time)")
    from uuom_gym.sim.point_mass import POINT_MASS_SCENARIOS

    runs = [RunSpec("plant", f"plant-{i:03d}", i, i, "plant", duration_s=duration_s) for i in range(n_plant)]
    runs += [RunSpec("point", f"point-{i:03d}", i, i, "point", duration_s=duration_s) for i in range(n_point)]
    k = 0
    for s in range(paper_seeds):
        for sc in ("section1", "section2", "roadtest"):
            runs.append(RunSpec("paper", f"paper-{sc}-s{s}", k, s, "plant", sc, duration_s=120.0))
            k += 1
    for s in range(min(paper_seeds, 1)):
        for sc in ("station-0-10t", "station-10-20t"):
            runs.append(RunSpec("paper", f"paper-{sc}-s{s}", k, s, "plant", sc, duration_s=160.0))
            k += 1
        for sc, pm in POINT_MASS_SCENARIOS.items():
            runs.append(RunSpec("paper", f"paper-{sc}-s{s}", k, s, "point", sc, duration_s=pm.duration_s))
            k += 1
    k = 0
    for s in range(fault_seeds):
        for fault in FAULT_KINDS:
            for world in ("plant", "point"):
                sc = "roadtest" if world == "plant" else "pm-roadtest"
                runs.append(RunSpec("fault", f"fault-{fault}-{world}-s{s}", k, s, world, sc, fault, 120.0))
                k += 1
    return runs


def runs_fingerprint() -> str:
    """Short hash of the sources that draw the runs (this module and the point-mass world), for result caches."""
    import hashlib
    from pathlib import Path

    from uuom_gym.sim import point_mass

    h = hashlib.sha1()
    for path in (__file__, point_mass.__file__):
        h.update(Path(path).read_bytes())
    return h.hexdigest()[:12]


def true_running_resistance(spec: RunSpec) -> float | None:
    """The true running resistance a random run draws (without simulating it); None for the fixed runs."""
    if spec.scenario != "random":
        return None
    rng = _rng(spec)
    rng.uniform(0.0, DEFAULT_VEHICLE.rated_load_kg)  # the load: drawn first by both random-run builders
    return float(rng.uniform(0.015, 0.03))


def _rng(spec: RunSpec) -> np.random.Generator:
    return np.random.default_rng([PROTOCOL_SEED, _GROUP_INDEX[spec.group], spec.index])


def make_run(spec: RunSpec, vehicle: VehicleParams | None = None) -> Trace:
    """The trace of one run (with truth columns and ``effective_slope_deg``); deterministic.

    ``vehicle``: another vehicle than the project's for a random run (its load drawn up to that vehicle's rated load,
    its track capped by what that train can climb and brake, its load's chains scaled by the vehicle's); the same
    draws otherwise, so run *i* on two vehicles differs by the vehicle. The fixed scenarios take the project's vehicle
    only.
    """
    if vehicle is not None and vehicle != DEFAULT_VEHICLE and spec.scenario != "random":
        raise ValueError(f"make_run: a vehicle other than the project's is for random runs, not {spec.scenario!r}")
    veh = DEFAULT_VEHICLE if vehicle is None else vehicle
    if spec.world == "plant":
        if spec.scenario == "random":
            tr = _random_plant(spec, veh)
        elif spec.scenario.startswith("station-"):
            tr = _station(spec)
        else:
            tr = _plant_scenario(spec)
    elif spec.world == "point":
        tr = _random_point(spec, veh) if spec.scenario == "random" else _point_scenario(spec)
    else:
        raise ValueError(f"unknown world {spec.world!r}; known: plant, point")
    tr.meta.update(run=spec.name, group=spec.group, world=spec.world, fault=spec.fault)
    if spec.fault == "stuck":
        tr.meta["fault_end_s"] = f"{FAULT_START_S + FAULT_LEN_S:g}"
    return tr


def _fault_options(kind: str) -> dict:
    """The fault of ``kind`` (one of :data:`FAULT_KINDS`) as keyword arguments, the same in both worlds."""
    options = {
        "dropouts": {"dropout_prob": 0.05},
        "spikes": {"spike_prob": 0.005},
        "bias-drift": {"bias_drift_per_s": {"accel_mps2": 0.002, "torque_nm": 5.0}},
        "stuck": {"stuck_channel": "speed_mps", "stuck_start_s": FAULT_START_S, "stuck_duration_s": FAULT_LEN_S},
    }
    if kind not in options:
        raise ValueError(f"unknown fault {kind!r}; known: {', '.join(FAULT_KINDS)}")
    return options[kind]


# --- the pymunk plant ------------------------------------------------------------------------------------------

def _plant_faults(kind: str):
    from uuom_gym.sim.sensors import FaultConfig

    if kind == "":
        return None
    options = _fault_options(kind)
    if kind == "spikes":
        options["spike_size"] = 2.0  # in units of the plant sensors' SPIKE_SCALE
    return FaultConfig(**options)


def _plant_scenario(spec: RunSpec) -> Trace:
    from uuom_gym.sim.recording import simulate_run

    return simulate_run(spec.scenario, seed=spec.seed, duration_s=spec.duration_s,
                        fault_config=_plant_faults(spec.fault))


def _station(spec: RunSpec) -> Trace:
    from uuom_gym.sim.station import station_trace

    loads = {"station-0-10t": (0.0, 10_000.0), "station-10-20t": (10_000.0, 20_000.0)}[spec.scenario]
    return station_trace(*loads, seed=spec.seed)


def _random_plant(spec: RunSpec, veh: VehicleParams = DEFAULT_VEHICLE) -> Trace:
    from uuom_gym.sim.plant import PlantConfig
    from uuom_gym.sim.recording import simulate_run
    from uuom_gym.sim.scenarios import Scenario, SpeedProfile
    from uuom_gym.sim.sensors import FaultConfig, SensorConfig
    from uuom_gym.sim.track import random_track

    rng = _rng(spec)
    load = float(rng.uniform(0.0, veh.rated_load_kg))
    mu = float(rng.uniform(0.015, 0.03))
    wet = bool(rng.random() < 0.3)
    adhesion = veh.adhesion_wet if wet else veh.adhesion_dry
    pc = PlantConfig(load_kg=load, running_resistance=mu, adhesion=adhesion,
                     wheel_wear_m=float(rng.uniform(0.0, 0.004)),
                     chain_length_m=float(rng.uniform(1.5, 3.0)) * (veh.chain_length_m / DEFAULT_VEHICLE.chain_length_m),
                     anti_sway_damping_ratio=float(rng.uniform(0.03, 0.1)))
    track = random_track(rng, length_m=(300.0, 800.0), max_grade_deg=min(15.0, veh.max_grade_deg), vehicle=veh,
                         load_kg=load, running_resistance=mu, adhesion=adhesion, name=spec.name)
    v_lim = load_speed_limit_mps(veh, veh.empty_mass_kg + load)
    # start from standstill on a near-level stretch (a stop) a few metres before a grade begins, so the 60 s
    # hold a grade change; anywhere from which the run cannot reach the track's end
    s_grid = np.asarray(track.s_m)
    level = np.abs(np.degrees(np.asarray(track.slope_rad))) < 2.0
    edges = np.flatnonzero(level[:-1] & ~level[1:])
    edges = edges[s_grid[edges] < track.length_m - v_lim * spec.duration_s]
    start = 0.0
    if edges.size:
        e = int(rng.choice(edges))
        start = float(max(0.0, s_grid[e] - rng.uniform(2.0, 15.0)))
        while start > 0.0 and not level[int(np.searchsorted(s_grid, start))]:
            start = max(0.0, start - 1.0)
    v1, v2 = (float(f) * v_lim for f in rng.uniform(0.35, 0.9, size=2))
    profile = SpeedProfile(((start, v1), (start + float(rng.uniform(5.0, 25.0)), v2)))
    sensors = SensorConfig.randomized(rng, 0.5, 2.0)
    faults = FaultConfig(dropout_prob=float(rng.uniform(0.002, 0.02))) if rng.random() < 0.25 else None
    scen = Scenario(spec.name, track, load, profile, spec.duration_s, start)
    tr = simulate_run(scen, seed=spec.seed, vehicle=veh, plant_config=pc, sensor_config=sensors, fault_config=faults)
    tr.meta.update(mu=f"{mu:.4f}", wet=str(wet), wear_mm=f"{1000 * pc.wheel_wear_m:.2f}",
                   dropouts=f"{faults.dropout_prob:.4f}" if faults else "0", chain_m=f"{pc.chain_length_m:.3f}",
                   sway_damping=f"{pc.anti_sway_damping_ratio:.3f}")
    return tr


# --- the point-mass world --------------------------------------------------------------------------------------

def _point_faults(kind: str):
    from uuom_gym.sim.point_mass import PointMassFaults

    return PointMassFaults(**_fault_options(kind))


def _point_scenario(spec: RunSpec) -> Trace:
    from uuom_gym.sim.point_mass import point_mass_scenario, simulate_point_mass, with_options

    sc = point_mass_scenario(spec.scenario)
    if spec.fault:
        sc = with_options(sc, faults=_point_faults(spec.fault), name=f"{sc.name}+{spec.fault}")
    return _with_effective_slope(simulate_point_mass(sc, seed=spec.seed))


def _with_effective_slope(tr: Trace) -> Trace:
    if "effective_slope_deg" not in tr:
        tr.columns["effective_slope_deg"] = tr["slope_deg"].copy()
    return tr


def _random_point(spec: RunSpec, veh: VehicleParams = DEFAULT_VEHICLE) -> Trace:
    from uuom_gym.sim.point_mass import (GradeProfile, PointMassFaults, PointMassScenario, PointMassSensors,
                                         SpeedPlan, simulate_point_mass)

    rng = _rng(spec)
    load = float(rng.uniform(0.0, veh.rated_load_kg))
    mu = float(rng.uniform(0.015, 0.03))
    up_cap = min(12.0, 0.85 * math.degrees(max_climbable_grade_rad(veh, veh.empty_mass_kg + load, mu)))
    s, knots = float(rng.uniform(3.0, 15.0)), [(0.0, 0.0)]
    grade = 0.0
    while s < 120.0:
        knots.append((s, grade))
        grade = float(rng.uniform(-12.0, up_cap)) if rng.random() < 0.8 else 0.0
        s += float(rng.uniform(3.0, 10.0))  # transition
        knots.append((s, grade))
        s += float(rng.uniform(5.0, 30.0))
    und = float(rng.uniform(0.3, 1.5)) if rng.random() < 0.4 else 0.0
    if und:  # keep the undulated grade climbable too
        knots = [(x, min(g, up_cap - und)) for x, g in knots]
    grade_profile = GradeProfile(tuple(_dedupe(knots)), und, float(rng.uniform(20.0, 80.0)))
    v_lim = load_speed_limit_mps(veh, veh.empty_mass_kg + load)
    if rng.random() < 1.0 / 3.0:  # stop-and-go, by time
        t, v_knots = 0.0, []
        while t < spec.duration_s:
            v = float(rng.uniform(0.4, 0.9)) * v_lim
            run, stand = float(rng.uniform(8.0, 20.0)), float(rng.uniform(2.0, 6.0))
            v_knots += [(t + 0.01, 0.0), (t + 4.0, v), (t + 4.0 + run, v), (t + 8.0 + run, 0.0)]
            t += 8.0 + run + stand
        plan = SpeedPlan(tuple(v_knots), by="time", accel_limit_mps2=0.3)
    else:
        v1, v2 = (float(f) * v_lim for f in rng.uniform(0.35, 0.9, size=2))
        plan = SpeedPlan(((0.0, v1), (float(rng.uniform(10.0, 30.0)), v2)))
    base = PointMassSensors()
    scale = np.exp(rng.uniform(math.log(0.5), math.log(2.0), size=len(fields(base))))
    sensors = replace(base, **{f.name: getattr(base, f.name) * float(k) for f, k in zip(fields(base), scale)})
    faults = PointMassFaults(dropout_prob=float(rng.uniform(0.002, 0.02))) if rng.random() < 0.25 else \
        PointMassFaults()
    sc = PointMassScenario(spec.name, grade_profile, plan, load, duration_s=spec.duration_s, running_resistance=mu,
                           chain_length_m=float(rng.uniform(1.5, 3.5)) * (veh.chain_length_m
                                                                          / DEFAULT_VEHICLE.chain_length_m),
                           sway_damping_ratio=float(rng.uniform(0.03, 0.15)), sensors=sensors, faults=faults)
    tr = _with_effective_slope(simulate_point_mass(sc, seed=spec.seed, vehicle=veh))
    tr.meta.update(mu=f"{mu:.4f}", dropouts=f"{faults.dropout_prob:.4f}", stop_and_go=str(plan.by == "time"),
                   chain_m=f"{sc.chain_length_m:.3f}", sway_damping=f"{sc.sway_damping_ratio:.3f}")
    return tr


def _dedupe(knots: list[tuple[float, float]]) -> list[tuple[float, float]]:
    out: list[tuple[float, float]] = []
    for x, g in knots:
        if out and x <= out[-1][0]:
            continue
        out.append((x, g))
    return out
