"""The observer's extra estimates (e.g. the AUPF's slip ratio) reach `info` and, on request, the observation."""

import gymnasium as gym
import numpy as np
import pytest

import uuom_gym  # noqa: F401
from uuom_gym.envs.config import ConfigError
from uuom_gym.envs.observation import OBS_NAMES

SLIP = OBS_NAMES.index("wheel_slip")


def _drive(env, steps=30):
    env.reset(seed=3)
    for _ in range(steps):
        obs, _, term, trunc, info = env.step(np.array([1.0], dtype=np.float32))
        if term or trunc:  # full traction ends in an overspeed trip; the env refuses steps after it
            break
    return obs, info


def test_aupf_slip_estimate_is_the_observation_when_asked():
    # rated load, wet rail, full traction from rest: the drive spins
    kw = dict(observer="aupf", load_kg=20_000.0, wet_probability=1.0)
    # two steps: the spin is largest at the start, and full traction trips the overspeed rule by step 4
    obs, info = _drive(gym.make("UUOM-Track-v0", slip_observation="estimator", **kw), 2)
    slip = info["est_extras"]["slip_ratio"]
    assert slip > 0.5
    assert obs[SLIP] == pytest.approx(slip, rel=1e-6)
    # the default keeps the sensors' apparent slip velocity, which is a different number
    obs_s, info_s = _drive(gym.make("UUOM-Track-v0", **kw), 2)
    assert info_s["est_extras"]["slip_ratio"] == pytest.approx(slip)
    assert obs_s[SLIP] != pytest.approx(slip, rel=1e-3)


def test_observers_without_extras_fall_back_to_the_sensors():
    obs_a, info = _drive(gym.make("UUOM-Track-v0", observer="oracle", slip_observation="estimator"), 10)
    obs_b, _ = _drive(gym.make("UUOM-Track-v0", observer="oracle"), 10)
    assert info["est_extras"] == {}
    np.testing.assert_array_equal(obs_a, obs_b)


def test_bad_slip_observation_is_named():
    with pytest.raises(ConfigError, match="slip_observation"):
        gym.make("UUOM-Track-v0", slip_observation="wheels")
