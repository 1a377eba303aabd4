"""``idle_clock_observation=True``: a 17th observation entry, how close the ``stopped_short`` ending is."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import uuom_gym  # noqa: F401 - registers the env
from uuom_gym.envs.config import ConfigError, make_config
from uuom_gym.envs.observation import (
    IDLE_CLOCK_NAME,
    OBS_NAMES,
    decode_observation,
    observation_by_name,
    observation_names,
)
from uuom_core.vehicle import VehicleParams


def _episode(actions, **kwargs):
    env = gym.make("UUOM-Track-v0", action_mode="acceleration", **kwargs)
    obs, _ = env.reset(seed=7)
    out = [obs]
    info: dict = {}
    for a in actions:
        obs, _, terminated, truncated, info = env.step(np.array([a], dtype=np.float32))
        out.append(obs)
        if terminated or truncated:
            break
    env.close()
    return np.array(out), info


def test_off_by_default_and_named_when_on():
    assert make_config()["idle_clock_observation"] is False
    assert gym.make("UUOM-Track-v0").observation_space.shape == (16,)
    env = gym.make("UUOM-Track-v0", idle_clock_observation=True)
    assert env.observation_space.shape == (17,)
    assert env.unwrapped.observation_names == OBS_NAMES + (IDLE_CLOCK_NAME,)
    assert observation_names(True)[-1] == "idle_clock" and observation_names() == OBS_NAMES
    with pytest.raises(ConfigError, match="idle_clock_observation"):
        make_config(idle_clock_observation=1)


def test_check_env_passes_with_the_clock():
    env = gym.make("UUOM-Track-v0", action_mode="acceleration", idle_clock_observation=True)
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped, warn=False)
    env.close()


def test_clock_runs_while_standing_and_reads_one_at_the_ending():
    # a = 0 at rest holds the brake: the train never moves, the ending comes after idle_limit_s = 20 s.
    obs, info = _episode([0.0] * 400, idle_clock_observation=True)
    assert info["termination"] == "stopped_short"
    clock = obs[:, 16]
    assert clock[0] == 0.0 and clock[-1] == pytest.approx(1.0)
    assert np.all(np.diff(clock) > 0.0)
    assert clock[100] == pytest.approx(100 * 0.1 / 20.0, abs=1e-4)


def test_clock_restarts_when_the_train_moves_on_and_changes_nothing_else():
    actions = [0.4] * 10 + [0.0] * 190  # up to ~0.2 m/s, then hold it: ~4 m in 20 s
    with_clock, info = _episode(actions, idle_clock_observation=True)
    without, info_off = _episode(actions)
    assert info["termination"] == "" and info["position_m"] > 3.0
    assert info["position_m"] == info_off["position_m"]
    np.testing.assert_array_equal(with_clock[:, :16], without)
    clock = with_clock[:, 16]
    assert np.any(np.diff(clock) < 0.0)  # reset at each metre of progress
    assert clock.max() < 0.5  # a moving train is never near the ending


def test_clock_is_zero_without_the_idle_rule():
    obs, _ = _episode([0.0] * 50, idle_clock_observation=True, idle_limit_s=None)
    assert np.all(obs[:, 16] == 0.0)


def test_observation_helpers_take_the_longer_vector():
    obs, _ = _episode([0.4] * 20, idle_clock_observation=True)
    named = observation_by_name(obs[-1])
    assert list(named) == list(OBS_NAMES) + ["idle_clock"]
    assert decode_observation(obs[-1], VehicleParams(), 200.0) == decode_observation(obs[-1][:16], VehicleParams(),
                                                                                     200.0)
    with pytest.raises(ValueError, match="16"):
        observation_by_name(np.zeros(20))


def test_a_policy_trained_with_the_clock_names_a_missing_clock(tmp_path):
    import json

    from stable_baselines3 import SAC

    from agents.evaluation import ModelPolicy

    env = gym.make("UUOM-Track-v0", action_mode="acceleration", idle_clock_observation=True)
    SAC("MlpPolicy", env, learning_starts=0, buffer_size=100, seed=0).save(tmp_path / "model.zip")
    (tmp_path / "config.json").write_text(json.dumps(
        {"algo": "sac", "env_kwargs": {"action_mode": "acceleration", "idle_clock_observation": True}}))
    policy = ModelPolicy(tmp_path)
    obs, info = env.reset(seed=0)
    assert policy.act(obs, info).shape == (1,)
    with pytest.raises(ValueError, match=r"shape \(17,\), the env gives \(16,\).*idle_clock_observation"):
        policy.act(obs[:16], info)
