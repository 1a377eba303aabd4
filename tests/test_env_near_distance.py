"""``near_distance_observation="tanh"``: entry 10 without the clip corner at 30 m (docs/rl.md §37)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import uuom_gym  # noqa: F401 - registers the env
from agents.controllers import FullThrottleController, RuleBasedController
from agents.metrics import drive_episode
from agents.shield import ShieldWrapper
from uuom_core.vehicle import VehicleParams
from uuom_gym.envs.config import ConfigError, make_config
from uuom_gym.envs.observation import NEAR_SCALE_M, ObservationBuilder, decode_observation

SHORT = {"track_length_m": (60.0, 120.0)}
NEAR = 10


def _rollout(shape: str, seed: int = 5):
    """One episode driven by the rule-based controller: its observations, the odometry distance to go at each,
    the last info and the track length."""
    env = gym.make("UUOM-Track-v0", near_distance_observation=shape, **SHORT)
    ctrl = RuleBasedController(env.unwrapped.vehicle)
    obs, info = env.reset(seed=seed)
    ctrl.reset(env, info)
    out, to_go = [obs], [env.unwrapped.station_m - env.unwrapped.obs_builder.odometry_m]
    while True:
        obs, _, term, trunc, info = env.step(ctrl.act(obs, info))
        out.append(obs)
        to_go.append(env.unwrapped.station_m - env.unwrapped.obs_builder.odometry_m)
        if term or trunc:
            break
    length = env.unwrapped.track.length_m
    env.close()
    return np.array(out), np.array(to_go), info, length


def test_clip_by_default_and_bad_values_named():
    assert make_config()["near_distance_observation"] == "clip"
    with pytest.raises(ConfigError, match="near_distance_observation.*'tanh'"):
        make_config(near_distance_observation="sigmoid")
    with pytest.raises(ValueError, match="near_shape"):
        ObservationBuilder(VehicleParams(), 100.0, 100.0, near_shape="linear")
    with pytest.raises(ValueError, match="near_shape"):
        decode_observation(np.zeros(16), VehicleParams(), 100.0, near_shape="linear")


def test_check_env_passes_with_tanh():
    env = gym.make("UUOM-Track-v0", action_mode="acceleration", idle_clock_observation=True,
                   near_distance_observation="tanh")
    assert env.observation_space.shape == (17,)
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped, warn=False)
    env.close()


def test_only_entry_10_differs_and_it_is_the_tanh_of_the_distance():
    clip, to_go, info_c, _ = _rollout("clip")
    tanh, to_go_t, info_t, _ = _rollout("tanh")
    # The controller decodes either shape to the same distance (to float32 rounding, ~1e-5 m in the last metres),
    # so it drives the same episode.
    assert info_c["termination"] == info_t["termination"] == "arrived"
    assert clip.shape == tanh.shape
    np.testing.assert_allclose(np.delete(clip, NEAR, axis=1), np.delete(tanh, NEAR, axis=1), atol=1e-4)
    np.testing.assert_allclose(to_go, to_go_t, atol=1e-3)
    np.testing.assert_allclose(tanh[:, NEAR], np.tanh(to_go / NEAR_SCALE_M), atol=1e-6)
    np.testing.assert_allclose(clip[:, NEAR], np.clip(to_go / NEAR_SCALE_M, -1, 1), atol=1e-6)
    # The point of the shape: it still changes where the clipped channel is flat (30-60 m from the station).
    far = (to_go > 35.0) & (to_go < 60.0)
    assert far.sum() > 10
    assert np.all(clip[far, NEAR] == 1.0) and np.ptp(tanh[far, NEAR]) > 0.1


@pytest.mark.parametrize("shape", ["clip", "tanh"])
def test_decoding_recovers_the_odometry_distance(shape):
    obs, to_go, _, length = _rollout(shape)
    decoded = np.array([decode_observation(o, VehicleParams(), length, shape).distance_to_go_m for o in obs])
    near = np.abs(to_go) < 25.0  # both shapes decode the fine channel here
    np.testing.assert_allclose(decoded[near], to_go[near], atol=1e-3)
    # elsewhere the coarse channel (float32 of distance / track length) decides
    np.testing.assert_allclose(decoded, to_go, atol=length * 1e-6 + 1e-3)


def test_shield_and_controller_read_the_env_shape():
    # Decoding a tanh channel as if it were clipped would put the station ~18 m nearer at 45 m: the shield and the
    # controller must take the shape from the env's config, so the same seed gives the same episode.
    # Full throttle behind the shield: the shield alone brakes for the station.
    summaries = []
    for shape in ("clip", "tanh"):
        env = ShieldWrapper(gym.make("UUOM-Track-v0", near_distance_observation=shape, **SHORT))
        summary, info = drive_episode(env, FullThrottleController(env.unwrapped.vehicle), 11)
        summaries.append((summary.success, summary.trip_time_s, info["termination"], info["position_m"]))
        env.close()
    (ok_c, time_c, end_c, pos_c), (ok_t, time_t, end_t, pos_t) = summaries
    assert ok_c and ok_t and end_c == end_t == "arrived"
    assert time_t == pytest.approx(time_c, abs=1e-6) and pos_t == pytest.approx(pos_c, abs=1e-4)
    # the wrong decoding is far off, so the equality above is not an accident
    d = 45.0
    assert abs(decode_observation(_obs_with_near(math.tanh(d / NEAR_SCALE_M)), VehicleParams(), 100.0,
                                  "clip").distance_to_go_m - d) > 5.0


def _obs_with_near(value: float) -> np.ndarray:
    o = np.zeros(16)
    o[NEAR] = value
    o[9] = 0.2
    return o


def test_controllers_and_shield_read_the_envs_decoding_settings():
    """One reader of the env's policy step and near shape serves the controllers and the shield."""
    from agents.control_input import observation_settings

    env = gym.make("UUOM-Track-v0", policy_hz=5.0, physics_hz=100.0, near_distance_observation="tanh", **SHORT)
    assert observation_settings(env) == (0.2, "tanh")
    ctrl = RuleBasedController(env.unwrapped.vehicle)
    _, info = env.reset(seed=1)
    ctrl.reset(env, info)
    assert (ctrl.dt_s, ctrl.near_shape) == (0.2, "tanh")
    shielded = ShieldWrapper(env)
    assert (shielded._dt_s, shielded._near_shape) == (0.2, "tanh")
    assert observation_settings(gym.make("CartPole-v1")) is None
    env.close()
