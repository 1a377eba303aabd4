"""Configuration of ``UUOM-Track-v0``: the documented defaults, and merging/validation of user overrides.

Every key of :func:`default_config` can be overridden through ``gym.make("UUOM-Track-v0", key=value)`` (or the
``config=`` dict). Unknown keys raise :class:`ConfigError` naming them; a value of the wrong kind or out of its
range raises :class:`ConfigError` naming the key. :data:`CONFIG_DOCS` holds one line per key (used by the docs).
"""

from __future__ import annotations

import copy
import math
from typing import Any, Mapping

from uuom_gym.envs.actions import ACTION_MODES
from uuom_gym.envs.observation import NEAR_SHAPES
from uuom_gym.sim.track import SCENARIO_NAMES as SCENARIOS
"""The paper's fixed runs (spec §3): the track, the load and the nominal conditions are fixed."""

RULES: tuple[str, ...] = ("speed_limit", "adhesion", "rollback", "sway", "overspeed_trip", "stall")
"""Safety rules of spec §6, the keys of ``info["violations"]`` and of ``cost_weights``."""

REWARD_TERMS: tuple[str, ...] = ("progress", "arrival", "time", "energy", "safety", "failure", "idle", "shaping",
                                 "caution")
"""Reward terms, the keys of ``info["rewards"]``."""


class ConfigError(ValueError):
    """A configuration key that does not exist, or a value it cannot take."""


def default_config() -> dict[str, Any]:
    """The default configuration of ``UUOM-Track-v0`` (a fresh dict each call; see :data:`CONFIG_DOCS`)."""
    return {
        # --- vehicle and timing -----------------------------------------------------------------------------
        "vehicle": None,
        "policy_hz": 10.0,
        "physics_hz": 200.0,
        # --- observation layer --------------------------------------------------------------------------------
        "observer": "dffrls-aekf",
        "observer_options": {},
        "slip_observation": "sensors",
        "idle_clock_observation": False,
        "vehicle_observation": False,
        "near_distance_observation": "clip",
        # --- task -------------------------------------------------------------------------------------------
        "scenario": None,
        "track_length_m": (100.0, 300.0),
        "max_grade_deg": 15.0,
        "allow_infeasible": False,
        "feasibility_margin": 0.85,
        "track": None,
        "stop_tolerance_m": 3.0,
        "stop_speed_mps": 0.05,
        "max_episode_s": None,
        "rollback_trip_m": 2.0,
        "idle_limit_s": 20.0,
        "action_mode": "command",
        "speed_target_cap": "cautious",
        "speed_target_range": (0.0, 1.0),
        "speed_tracker": {},
        "accel_demand_mps2": (-0.5, 0.5),
        # --- randomisation per reset(seed) ------------------------------------------------------------------
        "vehicle_spread": 1.0,
        "load_kg": None,
        "load_fraction_range": (0.0, 1.0),
        "load_fraction_beta": None,
        "load_fraction_uniform_share": 0.0,
        "running_resistance_range": (0.015, 0.03),
        "wet_probability": 0.3,
        "adhesion_dry_range": (0.30, 0.40),
        "adhesion_wet_range": (0.15, 0.20),
        "wheel_wear_range_m": (0.0, 0.006),
        "sensor_noise_scale_range": (0.5, 1.5),
        "sensor_bias_scale_range": (0.0, 1.0),
        "sensor_faults": None,
        # --- safety rules (spec §6) ---------------------------------------------------------------------------
        "overspeed_trip_margin_mps": 0.2,
        "slip_grace_s": 0.5,
        "rollback_speed_mps": 0.02,
        "sway_limit_deg": 10.0,
        "stall_speed_mps": 0.05,
        "cost_weights": {
            "speed_limit": 10.0,
            "adhesion": 1.0,
            "rollback": 10.0,
            "sway": 10.0,
            "overspeed_trip": 10.0,
            "stall": 1.0,
        },
        # --- reward -----------------------------------------------------------------------------------------
        "reward_weights": {
            "progress": 10.0,
            "arrival": 10.0,
            "time": 0.01,
            "energy": 0.2,
            "safety": 1.0,
            "failure": 10.0,
            "idle": 15.0,
            "shaping": 20.0,
            "caution": 0.0,
        },
        "shaping_gamma": 1.0,
        # --- rendering --------------------------------------------------------------------------------------
        "render_fps": 30,
        "render_size": (800, 450),
        "render_window_m": 60.0,
    }


CONFIG_DOCS: dict[str, str] = {
    "vehicle": "VehicleParams, a dict of VehicleParams field overrides, the path of a TOML vehicle file (the trace "
               "format's [vehicle] table), or None for the spec's DX80/176Y.",
    "policy_hz": "Agent decisions per second, in [0.5, 1000]; the action is held for physics_hz/policy_hz physics ticks.",
    "physics_hz": "Plant, sensor and estimator rate (Hz), in [100, 5000]; must be an integer multiple of policy_hz.",
    "observer": "What the agent is told about mass and slope: 'dffrls-aekf', any registered estimator name, "
    "'oracle' (true values) or 'none' (the prior only).",
    "observer_options": "Keyword options passed to estimators.make(observer, vehicle, **options); for 'oracle': "
    "mass_error (relative) and slope_error_deg, errors added to the truth (sensitivity studies).",
    "slip_observation": "Observation entry 11: 'sensors' (apparent slip velocity from the motor and ground-speed "
    "encoders / 0.5 m/s) or 'estimator' (the observer's estimated slip ratio, e.g. observer='aupf'; falls back to "
    "the sensors when the observer gives none).",
    "vehicle_observation": "If True, two observation entries after all others (and after idle_clock): "
    "'traction_accel' and 'brake_accel', the acceleration that a full traction command at the measured speed and a "
    "full brake command give the train at its estimated mass, / 2.5 m/s^2, in [0, 4]. A command is a fraction of the "
    "vehicle's force; with vehicle_spread a policy needs them to know what it does (docs/rl.md §54).",
    "idle_clock_observation": "If True, a 17th observation entry 'idle_clock': seconds since the train last got 1 m "
    "further / idle_limit_s (0..1; 0 with idle_limit_s=None). The 'stopped_short' ending is a clock the policy "
    "could not see; with it, the ending is a function of the observation (docs/rl.md §34). Off by default: "
    "policies trained on 16 entries keep their input.",
    "near_distance_observation": "Shape of observation entry 10, distance_to_go_near: 'clip' (distance / 30 m "
    "clipped to +-1: flat beyond 30 m, with a corner there) or 'tanh' (tanh(distance / 30 m): the same slope at the "
    "station, no corner; docs/rl.md §37). Default 'clip': policies trained on it keep their input.",
    "scenario": "None for a random track per reset, or 'section1' | 'section2' | 'roadtest' (paper's fixed runs).",
    "track_length_m": "(low, high) length of random tracks in metres (the spec's roadways allow 200-1500 m; the "
    "default is shorter so episodes last a few hundred to a few thousand policy steps).",
    "max_grade_deg": "Steepest grade of random tracks (deg), in (0, 30]; never above the vehicle file's max_grade_deg.",
    "allow_infeasible": "If True, random tracks may hold grades the drawn load cannot climb (the stall case).",
    "feasibility_margin": "Feasible random tracks keep every up-grade below this fraction of the steepest grade the "
    "drawn load can climb (with the drawn mu and adhesion).",
    "track": "A uuom_gym.sim.track.TrackProfile to drive instead of a random one (overrides track_length_m).",
    "stop_tolerance_m": "Success: standing still within this distance of the far station (m).",
    "stop_speed_mps": "Speed below which the train counts as standing still (m/s).",
    "max_episode_s": "Simulated-time limit (truncation); None = 2 x length / (rated-load speed limit, 0.5 m/s) "
    "+ 120 s, "
    "so a train that keeps half the most conservative limit still arrives.",
    "rollback_trip_m": "Terminate as a failure ('rolled_back') once the train is this far behind the furthest "
    "point it reached (m): the anti-rollback device has caught it; a policy that lets the train roll back on an "
    "up-grade learns it from one clear failure instead of hundreds of seconds of rollback cost.",
    "idle_limit_s": "Terminate as a failure ('stopped_short') when the train has not got 1 m further than its last "
    "mark for this long (s) without arriving (standing, or dithering back and forth); None disables it. Short, "
    "because PPO's gamma = 0.995 discounts a penalty 60 s (600 steps) ahead to 5 %: with 60 s it did not stop "
    "the policy from learning to hold the brake at the start (docs/rl.md).",
    "action_mode": "'command' (default: the action is the traction/brake fraction), 'speed_target' (the action "
    "a is a target speed (a + 1) / 2 x the cautious limit, observation 13, tracked by a PI controller inside the "
    "env, uuom_gym.envs.speed_target): its zero drives gently instead of coasting (docs/rl.md), or 'acceleration' "
    "(the action is an acceleration demand, see accel_demand_mps2, that ramps the same tracker's target and is fed "
    "forward with the estimated mass and slope, uuom_gym.envs.speed_target.ramp_target_mps: no dead zone below the "
    "breakaway force; docs/rl.md §32).",
    "speed_target_cap": "action_mode='speed_target' only: what a = +1 asks for. 'cautious' (default, rev. 3): the "
    "cautious limit; 'station': min(cautious limit, braking envelope to the station), the envelope being "
    "sqrt(2 x 0.3 m/s^2 x (odometry distance to go - 0.5 m)), so every action a > -1 stops at the station "
    "(a meta-action over a low-level tracker, as in HighwayEnv: the env gives the policy the station envelope; "
    "docs/rl.md §7).",
    "speed_target_range": "action_mode='speed_target' only: (lo, hi) fractions of the cautious limit that a = -1 "
    "and a = +1 ask for, linear between (default (0, 1): a = -1 stops). With speed_target_cap='station' the braking "
    "envelope is divided by max(hi, 1) first, so no action asks for more than the envelope. A span around 1, e.g. "
    "(0.7, 1.2), makes the policy's zero drive near the cautious limit and lets it learn where to go above it (rev. 5).",
    "speed_tracker": "action_mode='speed_target' or 'acceleration' only: overrides of the PI tracker's gains, keys gain_per_s, "
    "integral_gain_per_s2, integral_clamp_m (uuom_gym.envs.speed_target.SpeedTracker; {} keeps its defaults).",
    "accel_demand_mps2": "action_mode='acceleration' only: (lo, hi) accelerations (m/s^2) that a = -1 and a = +1 "
    "ask for, lo < 0 < hi, piecewise linear with a = 0 asking for 0 (hold the speed; at rest, hold the brake).",
    "vehicle_spread": "Domain randomisation of the vehicle: a factor >= 1. Above 1, every reset draws a *sister "
    "vehicle* of the `vehicle` entry from the env's np_random, every field log-uniform within x/÷ this factor "
    "(uuom_core.vehicle_variants.draw_sister_vehicle), and the plant, the observer, the safety rules, the action "
    "scaling and the observation scaling all use it for that episode (env.vehicle). 1 (default): the `vehicle` entry "
    "itself. A training option (docs/rl.md §54): policies trained on one vehicle do not transfer (§53).",
    "load_kg": "Fixed load (kg) instead of a random one; None draws it from load_fraction_range.",
    "load_fraction_range": "(low, high) load as a fraction of the rated load, drawn uniformly.",
    "load_fraction_beta": "None (uniform in load_fraction_range) or (a, b): the fraction is low + (high - low) x "
    "Beta(a, b) instead; a > b weights heavy trains (a training curriculum; docs/rl.md §38).",
    "load_fraction_uniform_share": "With load_fraction_beta set: the share of episodes whose fraction is still drawn "
    "uniformly (a mixture of the two draws, which keeps the light trains that Beta(a, b) makes rare; docs/rl.md §39). "
    "0 (default) is the pure Beta draw.",
    "running_resistance_range": "(low, high) true running-resistance coefficient mu, drawn uniformly.",
    "wet_probability": "Probability that the rail is wet/greasy (adhesion from adhesion_wet_range).",
    "adhesion_dry_range": "(low, high) drive-wheel adhesion coefficient on dry rail.",
    "adhesion_wet_range": "(low, high) drive-wheel adhesion coefficient on wet, greasy rail.",
    "wheel_wear_range_m": "(low, high) drive-wheel radius lost to wear (m).",
    "sensor_noise_scale_range": "(low, high) factor on every sensor's nominal noise level, drawn per reset.",
    "sensor_bias_scale_range": "(low, high) factor on every sensor's nominal bias spread, drawn per reset (the "
    "biases themselves are drawn from N(0, spread) by the sensor suite).",
    "sensor_faults": "None, or a uuom_gym.sim.sensors.FaultConfig (dropouts, spikes, stuck channel, bias drift).",
    "overspeed_trip_margin_mps": "Overspeed trip (rule 5): true speed above v_lim + this margin drops the "
    "emergency brake and ends the episode as a failure (m/s).",
    "slip_grace_s": "Adhesion (rule 2): continuous drive slip longer than this is a breach (s).",
    "rollback_speed_mps": "Rollback (rule 3): moving backwards faster than this is a breach (m/s).",
    "sway_limit_deg": "Load sway (rule 4): swing angle beyond this is a breach (deg).",
    "stall_speed_mps": "Stall (rule 6): slower than this on a grade the load cannot climb is a breach (m/s).",
    "cost_weights": "Weights of each rule's cost term in info['cost'] (see the cost table).",
    "reward_weights": "Weights of each reward term (see the reward table); 'shaping' scales the potential of "
    "uuom_gym.envs.reward_shaping (0 switches shaping off); 'caution' (default 0, off) charges each second spent "
    "above the cautious limit of observation 13, per m/s above it (a training option: docs/rl.md §29).",
    "shaping_gamma": "Discount in the potential-based shaping term gamma*Phi(s') - Phi(s). 1 (default): the "
    "shaping sums to exactly 0 over every episode (returns comparable with the unshaped reward); for an agent "
    "discounting with gamma < 1 it then adds (1 - gamma) Phi(s') <= 0 per step, a small extra penalty near the "
    "limit. Set it to the agent's gamma for strict policy invariance (Ng et al. 1999).",
    "render_fps": "Frames per second of render_mode='human' (and metadata['render_fps'] for videos).",
    "render_size": "(width, height) of rendered frames in pixels.",
    "render_window_m": "Length of track shown around the train in the side view (m).",
}


def _is_number(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(float(x))


def _check_range(cfg: dict[str, Any], key: str, lo: float, hi: float) -> None:
    value = cfg[key]
    if (
        not isinstance(value, (tuple, list))
        or len(value) != 2
        or not all(_is_number(v) for v in value)
    ):
        raise ConfigError(f"config key '{key}' must be a (low, high) pair of finite numbers, got {value!r}")
    a, b = float(value[0]), float(value[1])
    if a > b:
        raise ConfigError(f"config key '{key}': low {a} is greater than high {b}")
    if a < lo or b > hi:
        raise ConfigError(f"config key '{key}' must lie within [{lo}, {hi}], got {value!r}")
    cfg[key] = (a, b)


def _check_beta(cfg: dict[str, Any], key: str) -> None:
    value = cfg[key]
    if value is None:
        return
    if (
        not isinstance(value, (tuple, list))
        or len(value) != 2
        or not all(_is_number(v) and 0.0 < float(v) <= 100.0 for v in value)
    ):
        raise ConfigError(f"config key '{key}' must be None or an (a, b) pair of numbers in (0, 100], got {value!r}")
    cfg[key] = (float(value[0]), float(value[1]))


def _check_number(cfg: dict[str, Any], key: str, lo: float, hi: float = math.inf, *, open_lo: bool = False) -> None:
    value = cfg[key]
    if not _is_number(value):
        raise ConfigError(f"config key '{key}' must be a finite number, got {value!r}")
    v = float(value)
    if v < lo or v > hi or (open_lo and v == lo):
        bound = f"({lo}, {hi}]" if open_lo else f"[{lo}, {hi}]"
        raise ConfigError(f"config key '{key}' must lie within {bound}, got {value!r}")
    cfg[key] = v


def _check_weights(cfg: dict[str, Any], key: str, names: tuple[str, ...], defaults: Mapping[str, float]) -> None:
    value = cfg[key]
    if not isinstance(value, Mapping):
        raise ConfigError(f"config key '{key}' must be a dict with keys {', '.join(names)}, got {value!r}")
    unknown = sorted(set(value) - set(names))
    if unknown:
        raise ConfigError(f"config key '{key}': unknown term(s) {', '.join(unknown)}; known: {', '.join(names)}")
    merged = dict(defaults)
    for name, w in value.items():
        if not _is_number(w) or float(w) < 0:
            raise ConfigError(f"config key '{key}': weight '{name}' must be a finite number >= 0, got {w!r}")
        merged[name] = float(w)
    cfg[key] = merged


TRACKER_KEYS: tuple[str, ...] = ("gain_per_s", "integral_gain_per_s2", "integral_clamp_m")
"""Keys of the config ``speed_tracker`` (fields of :class:`uuom_gym.envs.speed_target.SpeedTracker`)."""


def _check_tracker(cfg: dict[str, Any]) -> None:
    value = cfg["speed_tracker"]
    if not isinstance(value, Mapping):
        raise ConfigError(f"config key 'speed_tracker' must be a dict with keys {', '.join(TRACKER_KEYS)}, got {value!r}")
    unknown = sorted(set(value) - set(TRACKER_KEYS))
    if unknown:
        raise ConfigError(
            f"config key 'speed_tracker': unknown key(s) {', '.join(unknown)}; known: {', '.join(TRACKER_KEYS)}"
        )
    out = {}
    for name, w in value.items():
        if not _is_number(w) or float(w) < 0:
            raise ConfigError(f"config key 'speed_tracker': '{name}' must be a finite number >= 0, got {w!r}")
        out[name] = float(w)
    cfg["speed_tracker"] = out


def make_config(overrides: Mapping[str, Any] | None = None, **kwargs: Any) -> dict[str, Any]:
    """Merge overrides into :func:`default_config` and validate the result.

    Parameters
    ----------
    overrides : mapping, optional
        Keys to override (e.g. the ``config=`` argument of the environment).
    **kwargs
        More overrides; these win over ``overrides``.

    Returns
    -------
    dict
        The complete, validated configuration. ``cost_weights`` / ``reward_weights`` given partially are merged
        with the defaults.

    Raises
    ------
    ConfigError
        Unknown keys (all of them named) or invalid values (the key named).
    """
    cfg = default_config()
    given: dict[str, Any] = {}
    if overrides is not None:
        if not isinstance(overrides, Mapping):
            raise ConfigError(f"config must be a dict, got {type(overrides).__name__}")
        given.update(overrides)
    given.update(kwargs)
    unknown = sorted(set(given) - set(cfg))
    if unknown:
        raise ConfigError(
            f"unknown config key(s): {', '.join(unknown)}; known keys: {', '.join(sorted(cfg))}"
        )
    defaults = default_config()
    for key, value in given.items():
        cfg[key] = copy.deepcopy(value)

    # the plant's own range (PlantConfig), checked here so make() refuses what reset() would; and a decision at
    # least every 2 s: 1e-9 Hz had asked for 2e11 physics ticks per step (MemoryError; session 59's config fuzz)
    _check_number(cfg, "policy_hz", 0.5, 1000.0)
    _check_number(cfg, "physics_hz", 100.0, 5000.0)
    ratio = cfg["physics_hz"] / cfg["policy_hz"]
    if abs(ratio - round(ratio)) > 1e-9 or round(ratio) < 1:
        raise ConfigError(
            f"config keys 'physics_hz' ({cfg['physics_hz']}) / 'policy_hz' ({cfg['policy_hz']}) must be a whole "
            "number >= 1"
        )
    if not isinstance(cfg["observer"], str):
        raise ConfigError(f"config key 'observer' must be a string, got {cfg['observer']!r}")
    if not isinstance(cfg["observer_options"], Mapping):
        raise ConfigError(f"config key 'observer_options' must be a dict, got {cfg['observer_options']!r}")
    if cfg["slip_observation"] not in ("sensors", "estimator"):
        raise ConfigError(
            f"config key 'slip_observation' must be 'sensors' or 'estimator', got {cfg['slip_observation']!r}"
        )
    if cfg["scenario"] is not None and cfg["scenario"] not in SCENARIOS:
        raise ConfigError(
            f"config key 'scenario' must be None or one of {', '.join(SCENARIOS)}, got {cfg['scenario']!r}"
        )
    _check_range(cfg, "track_length_m", 50.0, 5000.0)
    _check_number(cfg, "max_grade_deg", 0.0, 30.0, open_lo=True)  # 0 had passed here and failed in the track
    if not isinstance(cfg["allow_infeasible"], bool):
        raise ConfigError(f"config key 'allow_infeasible' must be True or False, got {cfg['allow_infeasible']!r}")
    _check_number(cfg, "feasibility_margin", 0.0, 1.0, open_lo=True)
    if cfg["track"] is not None and not (hasattr(cfg["track"], "length_m") and hasattr(cfg["track"], "slope_at")):
        raise ConfigError(f"config key 'track' must be None or a TrackProfile, got {type(cfg['track']).__name__}")
    if cfg["track"] is not None and cfg["scenario"] is not None:
        raise ConfigError("config keys 'track' and 'scenario' cannot both be given")
    _check_number(cfg, "stop_tolerance_m", 0.0, 100.0, open_lo=True)
    _check_number(cfg, "stop_speed_mps", 0.0, 1.0, open_lo=True)
    if cfg["max_episode_s"] is not None:
        _check_number(cfg, "max_episode_s", 0.0, 1e6, open_lo=True)
    _check_number(cfg, "rollback_trip_m", 0.0, 1e6, open_lo=True)
    if cfg["idle_limit_s"] is not None:
        _check_number(cfg, "idle_limit_s", 0.0, 1e6, open_lo=True)
    if not isinstance(cfg["vehicle_observation"], bool):
        raise ConfigError(f"config key 'vehicle_observation' must be True or False, got {cfg['vehicle_observation']!r}")
    if not isinstance(cfg["idle_clock_observation"], bool):
        raise ConfigError(f"config key 'idle_clock_observation' must be True or False, "
                          f"got {cfg['idle_clock_observation']!r}")
    if cfg["near_distance_observation"] not in NEAR_SHAPES:
        raise ConfigError(
            f"config key 'near_distance_observation' must be one of {', '.join(map(repr, NEAR_SHAPES))}, "
            f"got {cfg['near_distance_observation']!r}"
        )
    _check_number(cfg, "shaping_gamma", 0.0, 1.0)
    if cfg["action_mode"] not in ACTION_MODES:
        raise ConfigError(
            f"config key 'action_mode' must be one of {', '.join(map(repr, ACTION_MODES))}, got {cfg['action_mode']!r}"
        )
    if cfg["speed_target_cap"] not in ("cautious", "station"):
        raise ConfigError(
            f"config key 'speed_target_cap' must be 'cautious' or 'station', got {cfg['speed_target_cap']!r}"
        )
    _check_range(cfg, "speed_target_range", 0.0, 2.0)
    _check_tracker(cfg)
    _check_range(cfg, "accel_demand_mps2", -5.0, 5.0)
    if not cfg["accel_demand_mps2"][0] < 0.0 < cfg["accel_demand_mps2"][1]:
        raise ConfigError(
            f"config key 'accel_demand_mps2' must be (lo, hi) with lo < 0 < hi, got {cfg['accel_demand_mps2']!r}"
        )
    _check_number(cfg, "vehicle_spread", 1.0, 3.0)
    if cfg["load_kg"] is not None:
        _check_number(cfg, "load_kg", 0.0, 1e6)
    _check_range(cfg, "load_fraction_range", 0.0, 1.2)
    _check_beta(cfg, "load_fraction_beta")
    _check_number(cfg, "load_fraction_uniform_share", 0.0, 1.0)
    if cfg["load_fraction_uniform_share"] > 0.0 and cfg["load_fraction_beta"] is None:
        raise ConfigError(
            "config key 'load_fraction_uniform_share' needs load_fraction_beta: without it every draw is uniform"
        )
    _check_range(cfg, "running_resistance_range", 0.0, 0.5)
    _check_number(cfg, "wet_probability", 0.0, 1.0)
    _check_range(cfg, "adhesion_dry_range", 0.01, 1.0)
    _check_range(cfg, "adhesion_wet_range", 0.01, 1.0)
    _check_range(cfg, "wheel_wear_range_m", 0.0, 0.05)
    _check_range(cfg, "sensor_noise_scale_range", 0.0, 10.0)
    _check_range(cfg, "sensor_bias_scale_range", 0.0, 10.0)
    if cfg["sensor_faults"] is not None:
        from uuom_gym.sim.sensors import FaultConfig

        if not isinstance(cfg["sensor_faults"], FaultConfig):
            raise ConfigError(
                f"config key 'sensor_faults' must be None or a FaultConfig, got {type(cfg['sensor_faults']).__name__}"
            )
    _check_number(cfg, "overspeed_trip_margin_mps", 0.0, 5.0)
    _check_number(cfg, "slip_grace_s", 0.0, 60.0)
    _check_number(cfg, "rollback_speed_mps", 0.0, 1.0)
    _check_number(cfg, "sway_limit_deg", 0.0, 90.0, open_lo=True)
    _check_number(cfg, "stall_speed_mps", 0.0, 1.0)
    _check_weights(cfg, "cost_weights", RULES, defaults["cost_weights"])
    _check_weights(cfg, "reward_weights", REWARD_TERMS, defaults["reward_weights"])
    fps = cfg["render_fps"]
    if not isinstance(fps, int) or isinstance(fps, bool) or fps <= 0:
        raise ConfigError(f"config key 'render_fps' must be a positive integer, got {fps!r}")
    size = cfg["render_size"]
    if (
        not isinstance(size, (tuple, list))
        or len(size) != 2
        or not all(isinstance(v, int) and not isinstance(v, bool) and 64 <= v <= 4096 for v in size)
    ):
        raise ConfigError(f"config key 'render_size' must be (width, height) integers in [64, 4096], got {size!r}")
    cfg["render_size"] = (int(size[0]), int(size[1]))
    _check_number(cfg, "render_window_m", 5.0, 10_000.0)
    return cfg


__all__ = ["CONFIG_DOCS", "ConfigError", "REWARD_TERMS", "RULES", "SCENARIOS", "default_config", "make_config"]
