"""Rendering of UUOM-Track-v0: rgb_array frames, headless human mode, RecordVideo."""

from __future__ import annotations

import os

import gymnasium as gym
import numpy as np
import pytest

import uuom_gym  # noqa: F401
from uuom_gym.envs.config import ConfigError
from uuom_gym.envs.track_env import UUOMTrackEnv


def test_rgb_array_frames_change_with_the_state():
    env = UUOMTrackEnv(render_mode="rgb_array", observer="oracle", scenario="section1", render_size=(320, 180))
    env.reset(seed=0)
    f0 = env.render()
    assert f0.shape == (180, 320, 3) and f0.dtype == np.uint8
    for _ in range(30):
        *_, term, trunc, _ = env.step(np.array([0.3], np.float32))
        if term or trunc:  # open-loop traction trips on this track; stepping on would be refused
            break
    f1 = env.render()
    assert f1.shape == f0.shape and np.any(f0 != f1)
    assert len(np.unique(f1.reshape(-1, 3), axis=0)) > 5  # a picture, not a blank
    env.close()


def test_human_mode_is_headless_safe(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    env = UUOMTrackEnv(render_mode="human", observer="oracle", render_fps=1000, render_size=(160, 90))
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.array([0.2], np.float32))
    assert env.render() is None
    env.close()


def test_bad_render_mode_and_render_without_mode():
    with pytest.raises(ConfigError, match="render_mode"):
        UUOMTrackEnv(render_mode="ascii", observer="oracle")
    env = UUOMTrackEnv(observer="oracle")
    env.reset(seed=0)
    assert env.render() is None


def test_record_video(tmp_path):
    pytest.importorskip("moviepy")
    from gymnasium.wrappers import RecordVideo

    env = gym.make("UUOM-Track-v0", render_mode="rgb_array", observer="oracle", render_size=(160, 96))
    env = RecordVideo(env, str(tmp_path), episode_trigger=lambda e: True, video_length=15, disable_logger=True)
    env.reset(seed=0)
    for _ in range(20):
        env.step(np.array([0.3], np.float32))
    env.close()
    videos = [p for p in os.listdir(tmp_path) if p.endswith(".mp4")]
    assert videos and os.path.getsize(tmp_path / videos[0]) > 1000
