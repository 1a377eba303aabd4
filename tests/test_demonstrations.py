"""The rule-based controller on the acceleration action (``rule-based-accel``) and the demonstration-seeded replay
buffer (``uuom-train --demo-episodes``, :mod:`agents.demonstrations`)."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

import uuom_gym  # noqa: F401 - registers the env
from agents.controllers import CONTROLLERS, AccelerationRuleBased
from agents.controllers.acceleration import accel_action
from agents.demonstrations import DEMO_SEED_OFFSET, demonstrator_for, seed_replay_buffer
from agents.hyperparameters import TrainConfigError
from agents.training import TrainConfig, plan, train
from uuom_gym.envs.actions import accel_demand_mps2

ACCEL = {"action_mode": "acceleration", "track_length_m": [50.0, 70.0], "idle_clock_observation": True,
         "near_distance_observation": "tanh"}


@pytest.mark.parametrize("span", [(-0.5, 0.5), (-0.8, 0.3), (-0.2, 1.0)])
@pytest.mark.parametrize("demand", [-2.0, -0.5, -0.1, 0.0, 0.07, 0.3, 0.5, 3.0])
def test_accel_action_inverts_the_env_demand_within_the_span(span, demand):
    a = accel_action(demand, span)
    assert -1.0 <= a <= 1.0
    assert accel_demand_mps2(a, span) == pytest.approx(min(max(demand, span[0]), span[1]))


def _drive(env, ctrl, seed):
    obs, info = env.reset(seed=seed)
    ctrl.reset(env, info)
    while True:
        obs, _, term, trunc, info = env.step(ctrl.act(obs, info))
        if term or trunc:
            return info


@pytest.mark.parametrize("seed", [100000, 100001])
def test_rule_based_accel_arrives_on_short_held_out_tracks(seed):
    env = gym.make("UUOM-Track-v0", observer="dffrls-aekf", **ACCEL)
    info = _drive(env, CONTROLLERS["rule-based-accel"](env.unwrapped.vehicle), seed)
    assert info["termination"] == "arrived" and info["is_success"]
    assert info["violations"]["overspeed_trip"] == 0


def test_rule_based_accel_refuses_an_env_with_another_action():
    env = gym.make("UUOM-Track-v0", observer="oracle")
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action_mode='acceleration'.*'command'"):
        AccelerationRuleBased(env.unwrapped.vehicle).reset(env, {})


def test_demonstrator_matches_the_action_space():
    assert type(demonstrator_for(gym.make("UUOM-Track-v0", observer="oracle"))).__name__ == "RuleBasedController"
    assert isinstance(demonstrator_for(gym.make("UUOM-Track-v0", observer="oracle", **ACCEL)), AccelerationRuleBased)
    with pytest.raises(ValueError, match="no demonstrator for action_mode='speed_target'"):
        demonstrator_for(gym.make("UUOM-Track-SpeedTarget-v0", observer="oracle"))
    wide = demonstrator_for(gym.make("UUOM-Track-v0", observer="oracle"), speed_margin=0.2)
    assert wide.speed_margin == 0.2  # options reach the controller (agents.dagger's demonstrator_options)


def _sac(n_envs=2):
    from stable_baselines3 import SAC
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    venv = VecNormalize(DummyVecEnv([lambda: gym.make("UUOM-Track-v0", observer="dffrls-aekf", **ACCEL)] * n_envs),
                        norm_reward=False)
    return SAC("MlpPolicy", venv, buffer_size=20_000, seed=0, device="cpu")


def test_seeded_buffer_holds_the_demonstrator_episodes_as_the_env_gives_them():
    model = _sac()
    stats = seed_replay_buffer(model, "dffrls-aekf", ACCEL, n_episodes=2, seed=3)
    buf = model.replay_buffer
    assert stats["episodes"] == 2 and stats["arrived"] == 2
    assert stats["transitions"] == buf.pos * buf.n_envs
    # The slot whose first episode ended first, replayed: slot k's first track is DEMO_SEED_OFFSET + 1000 seed + k,
    # driven by a fresh demonstrator; its last transition holds the terminal observation.
    t_end, k = np.argwhere(buf.dones[: buf.pos] > 0)[0]
    env = gym.make("UUOM-Track-v0", observer="dffrls-aekf", **ACCEL)
    ctrl = demonstrator_for(env)
    obs, info = env.reset(seed=DEMO_SEED_OFFSET + 3000 + int(k))
    ctrl.reset(env, info)
    for t in range(t_end + 1):
        a = ctrl.act(obs, info)
        np.testing.assert_array_equal(buf.observations[t, k], obs)
        np.testing.assert_array_equal(buf.actions[t, k], a)
        obs, r, term, trunc, info = env.step(a)
        np.testing.assert_array_equal(buf.next_observations[t, k], obs)
        assert buf.rewards[t, k] == pytest.approx(r)
        assert bool(buf.dones[t, k]) == (term or trunc)
    assert info["termination"] == "arrived" and not buf.timeouts[t_end, k]
    assert np.all(np.isfinite(buf.observations[: buf.pos])) and np.all(np.abs(buf.actions[: buf.pos]) <= 1.0)
    assert model.get_env().obs_rms.count > buf.pos * buf.n_envs  # the normaliser saw the demonstrations


def test_seeded_buffer_is_deterministic():
    a, b = _sac(), _sac()
    seed_replay_buffer(a, "dffrls-aekf", ACCEL, n_episodes=1, seed=0)
    seed_replay_buffer(b, "dffrls-aekf", ACCEL, n_episodes=1, seed=0)
    n = a.replay_buffer.pos
    assert n == b.replay_buffer.pos > 0
    np.testing.assert_array_equal(a.replay_buffer.observations[:n], b.replay_buffer.observations[:n])
    np.testing.assert_array_equal(a.replay_buffer.actions[:n], b.replay_buffer.actions[:n])


@pytest.mark.parametrize("kwargs, match", [
    (dict(algo="ppo"), "ppo has no replay buffer"),
    (dict(shield=True, residual=0.0), "pass --residual 0 --no-shield"),
    (dict(residual=0.5, shield=False), "pass --residual 0 --no-shield"),
    (dict(env_kwargs={"action_mode": "speed_target"}), "no demonstrator for action_mode='speed_target'"),
    (dict(demo_episodes=-1), "demo_episodes must be a whole number >= 0"),
    (dict(demo_episodes=True), "demo_episodes must be a whole number >= 0"),
])
def test_demo_options_that_cannot_work_are_refused_before_training(tmp_path, kwargs, match):
    base = dict(algo="sac", residual=0.0, shield=False, observer="oracle", timesteps=100, demo_episodes=1,
                run_dir=tmp_path / "r", env_kwargs=dict(ACCEL))
    with pytest.raises(TrainConfigError, match=match):
        plan(TrainConfig(**{**base, **kwargs}))
    assert not (tmp_path / "r").exists()


def test_training_with_demonstrations_records_them(tmp_path):
    run = train(TrainConfig(algo="sac", residual=0.0, shield=False, observer="dffrls-aekf", timesteps=300, seed=1,
                            n_envs=2, run_dir=tmp_path / "run", eval_freq=0, checkpoint_freq=0, subproc=False,
                            progress=False, env_kwargs=dict(ACCEL), demo_episodes=1,
                            hyperparams=["buffer_size=20000", "learning_starts=100"]))
    cfg = json.loads((run / "config.json").read_text())
    demo = json.loads((run / "demonstrations.json").read_text())
    assert cfg["demo_episodes"] == 1
    assert demo["episodes"] == 1 and demo["arrived"] == 1 and demo["transitions"] > 300
    assert (run / "model.zip").is_file()


def test_evaluation_refuses_rule_based_accel_on_the_traction_action(tmp_path):
    from agents.evaluation import EvalConfig, EvalConfigError, check_config

    with pytest.raises(EvalConfigError, match="'rule-based-accel' acts on action_mode 'acceleration'.*'command'"):
        check_config(EvalConfig(controllers=["rule-based-accel"], observers=["oracle"], episodes=1, workers=1,
                                out=tmp_path / "out", quiet=True))
    check_config(EvalConfig(controllers=["rule-based-accel", "oracle"], observers=["oracle"], episodes=1, workers=1,
                            out=tmp_path / "out", quiet=True, env_kwargs={"action_mode": "acceleration"}))
