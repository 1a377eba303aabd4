"""Residual wrapper: a zero action reproduces the rule-based controller exactly."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import uuom_gym  # noqa: F401
from agents.controllers import RuleBasedController
from agents.residual import ResidualWrapper

KW = {"observer": "oracle", "track_length_m": (60.0, 80.0)}


def test_zero_residual_is_the_rule_based_controller():
    env_a = ResidualWrapper(gym.make("UUOM-Track-v0", **KW), scale=0.5)
    env_b = gym.make("UUOM-Track-v0", **KW)
    ctrl = RuleBasedController(env_b.unwrapped.vehicle)
    obs_a, _ = env_a.reset(seed=4)
    obs_b, info_b = env_b.reset(seed=4)
    ctrl.reset(env_b, info_b)
    for _ in range(200):
        obs_a, _, ta, tra, info_a = env_a.step(np.zeros(1, dtype=np.float32))
        obs_b, _, tb, trb, info_b = env_b.step(ctrl.act(obs_b, info_b))
        np.testing.assert_allclose(obs_a, obs_b)
        assert info_a["base_command"] == pytest.approx(info_b["command"])
        if ta or tra:
            break


def test_residual_moves_the_command_by_at_most_scale():
    env = ResidualWrapper(gym.make("UUOM-Track-v0", **KW), scale=0.3)
    env.reset(seed=1)
    _, _, _, _, info = env.step(np.array([1.0], dtype=np.float32))
    assert info["residual_command"] == pytest.approx(0.3)
    assert info["command"] == pytest.approx(min(1.0, info["base_command"] + 0.3), abs=1e-6)


def test_bad_scale_and_step_before_reset():
    with pytest.raises(ValueError, match="scale"):
        ResidualWrapper(gym.make("UUOM-Track-v0", **KW), scale=0.0)
    with pytest.raises(gym.error.ResetNeeded):
        ResidualWrapper(gym.make("UUOM-Track-v0", **KW)).step(np.zeros(1))
