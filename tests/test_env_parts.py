"""Config, reward, observation builder and wrapper of UUOM-Track-v0, tested with constructed inputs."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from uuom_gym.envs.config import CONFIG_DOCS, REWARD_TERMS, ConfigError, default_config, make_config
from uuom_gym.envs.observation import (
    OBS_HIGH,
    OBS_LOW,
    OBS_NAMES,
    POSITION_MARKER_SPACING_M,
    ObservationBuilder,
    OracleObserver,
    PriorObserver,
    UnknownObserverError,
    make_observer,
    observation_space,
    worst_case_speed_limit_mps,
)
from uuom_gym.envs.reward import reward_terms, traction_energy_j
from uuom_gym.envs.wrappers import SafetyGymnasiumStep
from uuom_core.limits import speed_limit_mps
from uuom_core.vehicle import DEFAULT_VEHICLE as V


# --- config -----------------------------------------------------------------------------------------------------
def test_every_default_key_is_documented():
    assert set(default_config()) == set(CONFIG_DOCS)


def test_overrides_merge_and_validate():
    cfg = make_config({"policy_hz": 5}, observer="oracle", reward_weights={"time": 0.5})
    assert cfg["policy_hz"] == 5.0 and cfg["observer"] == "oracle"
    assert cfg["reward_weights"]["time"] == 0.5 and cfg["reward_weights"]["progress"] == 10.0
    assert default_config()["reward_weights"]["time"] == 0.01  # defaults untouched


def test_unknown_keys_are_named():
    with pytest.raises(ConfigError, match=r"unknown config key\(s\): bogus, frobnicate"):
        make_config(bogus=1, frobnicate=2)
    with pytest.raises(ConfigError, match="unknown term"):
        make_config(cost_weights={"speeding": 1.0})


@pytest.mark.parametrize(
    "key, value, fragment",
    [
        ("policy_hz", 0, "policy_hz"),
        ("policy_hz", 7, "whole number"),
        ("physics_hz", float("nan"), "physics_hz"),
        ("scenario", "section9", "scenario"),
        ("track_length_m", (300, 100), "track_length_m"),
        ("track_length_m", 100, "track_length_m"),
        ("load_fraction_range", (0.0, 3.0), "load_fraction_range"),
        ("wet_probability", 1.5, "wet_probability"),
        ("allow_infeasible", "yes", "allow_infeasible"),
        ("render_size", (10, 10), "render_size"),
        ("reward_weights", {"time": -1.0}, "time"),
        ("track", "flat", "track"),
        ("stop_tolerance_m", 0.0, "stop_tolerance_m"),
    ],
)
def test_bad_values_name_their_key(key, value, fragment):
    with pytest.raises(ConfigError, match=fragment):
        make_config(**{key: value})


# --- reward -----------------------------------------------------------------------------------------------------
def test_reward_terms_signs_and_sums():
    w = default_config()["reward_weights"]
    t = reward_terms(w, progress_m=2.0, track_length_m=200.0, step_s=0.1, energy_j=5e5, cost=0.3,
                     arrived=False, stop_error_m=50.0, stop_tolerance_m=3.0, failed=False)
    assert tuple(t) == REWARD_TERMS
    assert t["progress"] == pytest.approx(10.0 * 2.0 / 200.0)
    assert t["time"] == pytest.approx(-0.001)
    assert t["energy"] == pytest.approx(-0.1)
    assert t["safety"] == pytest.approx(-0.3)
    assert t["arrival"] == 0.0 and t["failure"] == 0.0
    arr = reward_terms(w, progress_m=0.0, track_length_m=200.0, step_s=0.1, energy_j=0.0, cost=0.0,
                       arrived=True, stop_error_m=1.5, stop_tolerance_m=3.0, failed=False)
    assert arr["arrival"] == pytest.approx(10.0 * 0.75)
    fail = reward_terms(w, progress_m=0.0, track_length_m=200.0, step_s=0.1, energy_j=0.0, cost=0.0,
                        arrived=False, stop_error_m=1.5, stop_tolerance_m=3.0, failed=True)
    assert fail["failure"] == -10.0


def test_traction_energy_counts_motoring_only():
    assert traction_energy_j(np.array([100.0, -100.0]), np.array([10.0, 10.0]), 0.5) == pytest.approx(500.0)


# --- observation ------------------------------------------------------------------------------------------------
def meas(n=20, speed=1.0, accel=0.2, motor=None):
    motor = speed / V.drive_wheel_radius_m if motor is None else motor
    return {
        "torque_nm": np.full(n, 1000.0),
        "speed_mps": np.full(n, speed),
        "accel_mps2": np.full(n, accel),
        "motor_speed_radps": np.full(n, motor),
        "gyro_radps": np.zeros(n),
        "accel_normal_mps2": np.full(n, 9.81),
    }


def test_observation_layout_and_bounds():
    sp = observation_space()
    assert sp.shape == (len(OBS_NAMES),) and sp.dtype == np.float32
    assert np.all(np.isfinite(sp.low)) and np.all(np.isfinite(sp.high)) and np.all(OBS_LOW < OBS_HIGH)
    b = ObservationBuilder(V, 200.0, 200.0)
    b.absorb(meas(speed=1.0, accel=0.5), 0.005, 0.1)
    lim = speed_limit_mps(V, 26_000.0, 0.05)
    obs = b.build(0.3, 26_000.0, 0.05, 1000.0, 0.01, lim)
    assert obs.dtype == np.float32 and sp.contains(obs)
    named = dict(zip(OBS_NAMES, obs.tolist()))
    assert named["speed"] == pytest.approx(0.5)
    assert named["accel"] == pytest.approx(0.2)
    assert named["last_command"] == pytest.approx(0.3)
    assert named["est_load"] == pytest.approx(0.5)
    assert named["est_slope"] == pytest.approx(0.05 / math.radians(15.0), rel=1e-6)
    assert named["est_speed_limit"] == pytest.approx(lim / 2.0, rel=1e-6)
    assert named["distance_to_go"] == pytest.approx((200.0 - 0.1) / 200.0, rel=1e-6)
    assert named["wheel_slip"] == pytest.approx(0.0, abs=1e-6)
    # absurd inputs are clipped, never NaN/inf
    obs = b.build(0.0, float("nan"), 1e9, float("inf"), 0.0, 99.0)
    assert sp.contains(obs) and np.all(np.isfinite(obs))


def test_odometry_bridges_dropouts_and_resets_at_markers():
    b = ObservationBuilder(V, 200.0, 200.0)
    m = meas(speed=1.0)
    m["speed_mps"][5:15] = np.nan  # dropouts bridged with the last valid speed
    b.absorb(m, 0.005, 0.1)
    assert b.odometry_m == pytest.approx(0.1)
    b.absorb(meas(speed=1.0), 0.005, POSITION_MARKER_SPACING_M + 0.3)  # passes a marker: reset to truth
    assert b.odometry_m == pytest.approx(POSITION_MARKER_SPACING_M + 0.3)
    nan = meas()
    for k in nan:
        nan[k][:] = np.nan
    b.absorb(nan, 0.005, POSITION_MARKER_SPACING_M + 0.4)  # all dropouts: keep the last values
    assert b.speed_mps == pytest.approx(1.0)


def test_wheel_slip_entry_sees_a_spinning_drive():
    b = ObservationBuilder(V, 200.0, 200.0)
    b.absorb(meas(speed=0.5, motor=1.0 / V.drive_wheel_radius_m), 0.005, 0.0)
    named = dict(zip(OBS_NAMES, b.build(1.0, 26e3, 0, 0, 0, 1.0).tolist()))
    assert named["wheel_slip"] == pytest.approx(1.0)


def test_oracle_and_none_observers():
    o = make_observer("oracle", V)
    assert isinstance(o, OracleObserver)
    assert o.observe(meas(), 0.005, 30_000.0, 0.1) == (30_000.0, 0.1, 0.0, 0.0)
    n = make_observer("none", V)
    assert isinstance(n, PriorObserver)
    m, s, ms, ss = n.observe(meas(), 0.005, 30_000.0, 0.1)
    assert m == V.empty_mass_kg + V.rated_load_kg / 2 and s == 0.0 and ms > 0 and ss > 0
    assert worst_case_speed_limit_mps(V) <= speed_limit_mps(V, 26_000.0, 0.0)


def test_unknown_observer_lists_names():
    with pytest.raises(UnknownObserverError, match="oracle.*none.*dffrls-aekf"):
        make_observer("kalman-magic", V)


# --- wrapper ----------------------------------------------------------------------------------------------------
class _CostEnv(gym.Env):
    observation_space = gym.spaces.Box(-1, 1, (1,), np.float32)
    action_space = gym.spaces.Box(-1, 1, (1,), np.float32)

    def __init__(self, cost=0.25):
        self.cost = cost

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return np.zeros(1, np.float32), {}

    def step(self, action):
        return np.zeros(1, np.float32), 1.0, False, False, {"cost": self.cost}


def test_safety_gymnasium_six_value_step():
    env = SafetyGymnasiumStep(_CostEnv())
    env.reset(seed=0)
    obs, reward, cost, terminated, truncated, info = env.step(np.zeros(1, np.float32))
    assert (reward, cost, terminated, truncated) == (1.0, 0.25, False, False) and info["cost"] == 0.25
    with pytest.raises(ValueError, match="not finite"):
        SafetyGymnasiumStep(_CostEnv(float("nan"))).step(np.zeros(1))


def test_caution_term_charges_speed_above_the_cautious_limit_shown():
    """Off by default (the reward is unchanged); with a weight, each step pays ``w`` per m/s above the cautious limit
    of the observation the action was chosen on, per second, and nothing below it."""
    def run(weight):
        env = gym.make("UUOM-Track-v0", reward_weights={"caution": weight}, track_length_m=(200.0, 200.0))
        obs, _ = env.reset(seed=3)
        base = env.unwrapped
        out = []
        for _ in range(60):  # full traction: past the 0.5 m/s the prior's pessimistic corner allows at the start
            shown_mps = float(obs[13]) * base.obs_builder.v_max
            obs, reward, term, trunc, info = env.step(np.array([1.0], dtype=np.float32))
            out.append((base.speed_mps - shown_mps, info["rewards"]["caution"], reward))
            if term or trunc:
                break
        env.close()
        return out

    off, on = run(0.0), run(10.0)
    assert all(c == 0.0 for _, c, _ in off)
    assert any(over > 0.05 for over, _, _ in on) and any(over < 0 for over, _, _ in on)
    for (over, caution, reward), (_, _, reward_off) in zip(on, off):
        assert caution == pytest.approx(-10.0 * max(over, 0.0) * 0.1, abs=1e-12)
        assert reward == pytest.approx(reward_off + caution, abs=1e-9)  # the same run, one more term
