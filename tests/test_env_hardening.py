"""Issue 12, environment items: step order after the episode ends, and real-number-only actions."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import uuom_gym  # noqa: F401 - registers the ids
from uuom_gym.envs.track_env import InvalidActionError, ResetNeeded, UUOMTrackEnv
from uuom_gym.registration import ENV_IDS


def _env(**kw):
    # A very short time limit ends the episode in a few steps (truncation) without driving anywhere.
    return UUOMTrackEnv(observer="oracle", max_episode_s=0.3, **kw)


def test_step_after_truncation_raises_until_reset():
    env = _env()
    env.reset(seed=0)
    done = False
    for _ in range(10):
        _, _, term, trunc, _ = env.step(np.zeros(1, np.float32))
        if term or trunc:
            done = True
            break
    assert done
    with pytest.raises(ResetNeeded, match=r"after the episode ended \(truncated: time_limit\).*reset"):
        env.step(np.zeros(1, np.float32))
    # still refused: the error does not clear itself
    with pytest.raises(gym.error.ResetNeeded):
        env.step(np.zeros(1, np.float32))
    env.reset(seed=1)
    env.step(np.zeros(1, np.float32))


def test_step_after_termination_raises():
    # Full brake forever is never a success; full traction on a short track ends as overrun or overspeed trip.
    env = UUOMTrackEnv(observer="oracle", track_length_m=(50.0, 50.0))
    env.reset(seed=2)
    term = trunc = False
    for _ in range(5000):
        _, _, term, trunc, info = env.step(np.ones(1, np.float32))
        if term or trunc:
            break
    assert term, info["termination"]
    with pytest.raises(ResetNeeded, match="terminated"):
        env.step(np.ones(1, np.float32))


def test_reset_needed_is_also_a_runtime_error():
    with pytest.raises(RuntimeError, match="before reset"):
        UUOMTrackEnv(observer="oracle").step(0.0)


@pytest.mark.parametrize(
    "action, type_name",
    [
        (0.5 + 1j, "complex"),
        (np.complex64(0.5), "complex"),
        (np.array([0.5 + 1j]), "complex128"),
        ("0.5", "str"),
        (b"0.5", "bytes"),
        (True, "bool"),
        (np.bool_(False), "bool"),
        (np.array([True]), "bool"),
        (None, "NoneType"),
        ({"a": 1}, "dict"),
        (object(), "object"),
        ([None], "object"),
    ],
)
def test_non_real_actions_are_refused_with_their_type(action, type_name):
    env = _env()
    env.reset(seed=0)
    with pytest.raises(InvalidActionError, match=type_name) as err:
        env.step(action)
    assert "\n" not in str(err.value)
    assert "nan" not in str(err.value).lower()


@pytest.mark.parametrize(
    "action",
    [0.5, 1, np.float32(0.5), np.float64(0.5), np.int64(1), np.array(0.5), np.array([0.5], np.float32),
     np.array([1], np.int32), [0.5], (0.5,)],
)
def test_real_actions_are_accepted(action):
    env = _env()
    env.reset(seed=0)
    env.step(action)


def test_int_and_float_actions_give_the_same_step():
    a, b = _env(), _env()
    a.reset(seed=4)
    b.reset(seed=4)
    oa, ra, *_ = a.step(1)
    ob, rb, *_ = b.step(np.array([1.0], np.float32))
    np.testing.assert_array_equal(oa, ob)
    assert ra == rb


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_checkers_still_pass_with_order_enforcement(env_id):
    from gymnasium.utils.env_checker import check_env as gym_check
    from stable_baselines3.common.env_checker import check_env as sb3_check

    env = gym.make(env_id)  # as registered: default observer and config
    gym_check(env.unwrapped, skip_render_check=True)
    sb3_check(env, warn=True)
    env.close()
