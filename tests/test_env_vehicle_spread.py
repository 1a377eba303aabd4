"""Domain randomisation over the vehicle: config ``vehicle_spread`` draws a sister vehicle at every reset, and the
controllers, the shield and the demonstrator built for the env follow it (docs/rl.md §54)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import uuom_gym  # noqa: F401  (registers the env ids)
from agents.controllers import RuleBasedController
from agents.demonstrations import DemonstratorLabels
from agents.evaluation import env_shift
from agents.shield import ShieldWrapper
from uuom_core.vehicle import DEFAULT_VEHICLE
from uuom_core.vehicle_variants import draw_sister_vehicle, sister_vehicles
from uuom_gym.envs.config import ConfigError


def _episode(env: gym.Env, seed: int, steps: int = 60) -> tuple[list[np.ndarray], float]:
    ctrl = RuleBasedController(env.unwrapped.vehicle)
    obs, info = env.reset(seed=seed)
    ctrl.reset(env, info)
    out = [obs]
    for _ in range(steps):
        obs, _, term, trunc, info = env.step(ctrl.act(obs, info))
        out.append(obs)
        if term or trunc:
            break
    return out, info["true_mass_kg"]


def test_the_default_draws_no_vehicle_and_keeps_the_random_stream() -> None:
    plain = gym.make("UUOM-Track-v0")
    one = gym.make("UUOM-Track-v0", vehicle_spread=1.0)
    a, ma = _episode(plain, 7)
    b, mb = _episode(one, 7)
    assert plain.unwrapped.vehicle is plain.unwrapped.base_vehicle == DEFAULT_VEHICLE
    assert ma == mb and all(np.array_equal(x, y) for x, y in zip(a, b))


def test_each_reset_draws_a_sister_vehicle_that_everything_uses() -> None:
    env = gym.make("UUOM-Track-v0", vehicle_spread=1.5, action_mode="speed_target")
    u = env.unwrapped
    seen = set()
    for seed in range(6):
        _, info = env.reset(seed=seed)
        v = u.vehicle
        seen.add(v.empty_mass_kg)
        assert v is not u.base_vehicle
        # every drawn field within the factor (the consistency repair only moves fields down, or to the base's)
        for name in ("empty_mass_kg", "rated_load_kg", "max_traction_n", "length_m"):
            ratio = getattr(v, name) / getattr(DEFAULT_VEHICLE, name)
            assert 1 / 1.5 - 1e-9 <= ratio <= 1.5 + 1e-9, name
        assert u.safety.vehicle is v and u._tracker.vehicle is v
        assert u.obs_builder.vehicle is v
        assert v.empty_mass_kg <= info["true_mass_kg"] <= v.empty_mass_kg + v.rated_load_kg + 1e-6
    assert len(seen) == 6


def test_the_draw_is_seeded_and_is_the_sister_vehicle_draw() -> None:
    env = gym.make("UUOM-Track-v0", vehicle_spread=1.25)
    a, _ = _episode(env, 3)
    va = env.unwrapped.vehicle
    env.reset(seed=4)
    b, _ = _episode(env, 3)
    assert env.unwrapped.vehicle == va and all(np.array_equal(x, y) for x, y in zip(a, b))
    # the env's first draw from a fresh generator is draw_sister_vehicle's, as sister_vehicles' is
    rng = np.random.default_rng(11)
    assert draw_sister_vehicle(rng, 1.5) == sister_vehicles(11, 1, 1.5)[0]


@pytest.mark.parametrize("bad", [0.5, math.nan, math.inf, 5.0, "1.5", True])
def test_a_bad_spread_is_a_config_error_naming_the_key(bad: object) -> None:
    with pytest.raises(ConfigError, match="vehicle_spread"):
        gym.make("UUOM-Track-v0", vehicle_spread=bad)


def test_check_env_passes_with_a_drawn_vehicle() -> None:
    env = gym.make("UUOM-Track-v0", vehicle_spread=1.5)
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped, warn=False)


def test_controller_shield_and_demonstrator_follow_the_episode_vehicle() -> None:
    env = DemonstratorLabels(gym.make("UUOM-Track-v0", vehicle_spread=1.5))
    shielded = ShieldWrapper(env)
    ctrl = RuleBasedController(shielded.unwrapped.vehicle)
    for seed in (0, 1):
        obs, info = shielded.reset(seed=seed)
        ctrl.reset(shielded, info)
        v = shielded.unwrapped.vehicle
        assert ctrl.vehicle is v and shielded.shield.vehicle is v and env.demonstrator.vehicle is v
        for _ in range(30):
            action = ctrl.act(obs, info)
            obs, _, _, _, info = shielded.step(action)
            # the label is this vehicle's rule-based command (the same settings, state and input as ctrl's)
            assert info["demo_action"] == pytest.approx(np.clip(action, -1, 1), abs=1e-6)


def test_a_controller_keeps_its_own_vehicle_when_the_env_draws_none() -> None:
    other = sister_vehicles(0, 1, 1.5)[0]
    env = gym.make("UUOM-Track-v0")
    ctrl = RuleBasedController(other)  # a study may drive one vehicle's controller on another on purpose
    _, info = env.reset(seed=0)
    ctrl.reset(env, info)
    assert ctrl.vehicle is other


def test_the_spread_is_not_a_shift_of_the_evaluated_task() -> None:
    assert env_shift({"vehicle_spread": 1.5}, {}) == []
    assert env_shift({"vehicle_spread": 1.5, "idle_clock_observation": True}, {}) != []


def test_the_rule_based_controller_arrives_on_drawn_vehicles() -> None:
    env = gym.make("UUOM-Track-v0", vehicle_spread=1.5, track_length_m=(60.0, 80.0))
    ctrl = RuleBasedController(env.unwrapped.vehicle)
    for seed in (0, 1):
        obs, info = env.reset(seed=seed)
        ctrl.reset(env, info)
        term = trunc = False
        while not (term or trunc):
            obs, _, term, trunc, info = env.step(ctrl.act(obs, info))
        assert info["termination"] == "arrived" and info["episode_cost"] == 0.0


# --- the opt-in vehicle entries (config vehicle_observation) -----------------------------------------------------
def test_the_vehicle_entries_are_what_a_command_does_to_this_train() -> None:
    from uuom_gym.envs.observation import VEHICLE_OBS_NAMES, observation_by_name

    env = gym.make("UUOM-Track-v0", vehicle_spread=1.5, vehicle_observation=True, observer="oracle")
    assert env.observation_space.shape == (18,)
    assert env.unwrapped.observation_names[-2:] == VEHICLE_OBS_NAMES
    for seed in (0, 1):
        obs, info = env.reset(seed=seed)
        v, m = env.unwrapped.vehicle, info["true_mass_kg"]
        named = observation_by_name(obs)
        # at rest the torque limit binds: full traction accelerates the train by F_max / m
        assert named["traction_accel"] * 2.5 == pytest.approx(v.max_traction_n / m, rel=1e-5)
        assert named["brake_accel"] * 2.5 == pytest.approx(min(v.service_brake_n / m, 10.0), rel=1e-5)
    plain = gym.make("UUOM-Track-v0", vehicle_spread=1.5, observer="oracle")
    a, _ = plain.reset(seed=0)
    b, _ = env.reset(seed=0)
    assert np.array_equal(a, b[:16])  # appended: the other entries are unchanged


def test_the_vehicle_entries_with_the_idle_clock_and_check_env() -> None:
    from uuom_gym.envs.observation import observation_by_name

    env = gym.make("UUOM-Track-v0", vehicle_observation=True, idle_clock_observation=True)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (19,) and list(observation_by_name(obs))[-3:] == ["idle_clock", "traction_accel",
                                                                         "brake_accel"]
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped, warn=False)
    with pytest.raises(ConfigError, match="vehicle_observation"):
        gym.make("UUOM-Track-v0", vehicle_observation="yes")


def test_the_controllers_read_an_observation_with_the_vehicle_entries() -> None:
    episodes = []
    for kw in ({}, {"vehicle_observation": True}):
        env = gym.make("UUOM-Track-v0", track_length_m=(60.0, 80.0), **kw)
        episodes.append(_episode(env, 1, steps=200)[0])
    assert all(np.array_equal(x, y[:16]) for x, y in zip(*episodes))
