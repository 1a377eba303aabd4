"""UUOM-Track-v0 rev. 2: potential-based shaping, the rolled-back / stopped-short endings, observation 12-15."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uuom_gym.envs.observation import OBS_NAMES
from uuom_gym.envs.reward_shaping import potential, shaping_reward, stop_speed_cap_mps
from uuom_gym.envs.track_env import UUOMTrackEnv
from uuom_gym.sim.track import profile_from_knots


def test_potential_is_zero_when_slow_and_negative_when_fast():
    assert potential(20.0, 0.0, 100.0, 1.0) == 0.0
    assert potential(20.0, 0.9, 100.0, 1.0) == 0.0  # 0.1 m/s below the limit, far from the station
    assert potential(20.0, 1.1, 100.0, 1.0) == pytest.approx(-20.0 * 0.15)
    # 1 m before the station only a creep is allowed
    assert stop_speed_cap_mps(1.0) == pytest.approx(math.sqrt(2 * 0.3 * 0.5) + 0.05)
    assert potential(20.0, 1.0, 1.0, 2.0) == pytest.approx(-20.0 * (1.0 - stop_speed_cap_mps(1.0)))
    assert potential(0.0, 5.0, 0.0, 0.1) == 0.0
    assert shaping_reward(-1.0, -3.0, 1.0, terminated=False) == pytest.approx(-2.0)
    assert shaping_reward(-1.0, -3.0, 0.9, terminated=True) == pytest.approx(1.0)  # Phi(terminal) = 0


def test_shaping_sums_to_zero_over_an_arrived_episode():
    flat = profile_from_knots([(0, 0.0), (70, 0.0)], "flat")
    env = UUOMTrackEnv(observer="oracle", track=flat, load_kg=2_000.0)
    env.reset(seed=1)
    shaping, nonzero, info = 0.0, 0, {"speed_mps": 0.0, "distance_to_go_m": 70.0}
    for _ in range(3000):
        # run at ~1 m/s, brake late and hard (above the potential's gentle stopping curve), stand
        if info["distance_to_go_m"] < 1.5:
            a = -1.0
        else:
            a = 0.3 if info["speed_mps"] < 1.0 else 0.0
        obs, r, term, trunc, info = env.step(np.array([a], np.float32))
        shaping += info["rewards"]["shaping"]
        nonzero += info["rewards"]["shaping"] != 0.0
        if term or trunc:
            break
    assert info["termination"] == "arrived", info["termination"]
    assert nonzero > 0
    assert shaping == pytest.approx(0.0, abs=1e-9)


def test_overspeed_is_announced_before_the_trip():
    down = profile_from_knots([(0, 0.0), (30, 0.0), (60, -8.0), (300, -8.0)], "down")
    env = UUOMTrackEnv(observer="oracle", track=down, load_kg=10_000.0)
    env.reset(seed=0)
    shaped_before_trip = []
    for _ in range(3000):
        obs, r, term, trunc, info = env.step(np.array([1.0], np.float32))
        if term or trunc:
            break
        shaped_before_trip.append(info["rewards"]["shaping"])
    assert info["termination"] == "overspeed_trip"
    assert min(shaped_before_trip) < -0.5  # the potential fell (limit part) on the way to the trip


def test_rolling_back_ends_the_episode_as_failure():
    grade = profile_from_knots([(0, 6.0), (300, 6.0)], "grade")
    env = UUOMTrackEnv(observer="oracle", track=grade, load_kg=5_000.0)
    env.reset(seed=0)
    for _ in range(100):
        obs, r, term, trunc, info = env.step(np.array([0.0], np.float32))  # coast: gravity pulls it back
        if term:
            break
    assert term and info["termination"] == "rolled_back" and not info["is_success"]
    assert info["rewards"]["failure"] == -10.0 and info["rewards"]["idle"] == 0.0
    assert -3.0 < info["position_m"] < -2.0


def test_standing_still_short_of_the_station_ends_the_episode():
    flat = profile_from_knots([(0, 0.0), (100, 0.0)], "flat")
    env = UUOMTrackEnv(observer="oracle", track=flat, idle_limit_s=5.0)
    env.reset(seed=0)
    n = 0
    for n in range(1, 200):
        obs, r, term, trunc, info = env.step(np.array([-1.0], np.float32))
        if term:
            break
    assert info["termination"] == "stopped_short" and info["rewards"]["failure"] == -10.0
    assert info["rewards"]["idle"] == -15.0
    assert n == 50  # 5 s at 10 Hz
    dither = UUOMTrackEnv(observer="oracle", track=flat, idle_limit_s=20.0)
    dither.reset(seed=0)
    for n in range(1, 400):  # back and forth around the start: moving, but never 1 m further
        *_, term, trunc, info = dither.step(np.array([0.15 if (n // 15) % 2 == 0 else -1.0], np.float32))
        if term:
            break
    assert info["termination"] == "stopped_short" and 200 <= n < 260, (n, info["position_m"])
    never = UUOMTrackEnv(observer="oracle", track=flat, idle_limit_s=None)
    never.reset(seed=0)
    for _ in range(100):
        *_, term, trunc, info = never.step(np.array([-1.0], np.float32))
        assert not term


def test_model_free_grade_and_cautious_limit_in_the_observation():
    down = profile_from_knots([(0, -6.0), (300, -6.0)], "down")
    env = UUOMTrackEnv(observer="oracle", track=down, load_kg=5_000.0)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (16,) and env.observation_space.contains(obs)
    for _ in range(40):  # braking on the down-grade: speed changes, the grade does not
        obs, *_ = env.step(np.array([-0.4], np.float32))
    o = dict(zip(OBS_NAMES, obs.tolist()))
    assert o["grade_mf"] * 15.0 == pytest.approx(-6.0, abs=1.0)
    assert o["cautious_limit"] <= o["est_speed_limit"] + 1e-6
    assert o["cautious_margin"] == pytest.approx(o["speed"] - o["cautious_limit"], abs=1e-5)
    none = UUOMTrackEnv(observer="none", track=down)
    obs, _ = none.reset(seed=0)
    o = dict(zip(OBS_NAMES, obs.tolist()))
    assert o["cautious_limit"] == pytest.approx(o["est_speed_limit"], abs=1e-6)  # the worst case, already
