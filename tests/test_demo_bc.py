"""SAC with a Q-filtered behaviour-cloning term on its demonstrations (``uuom-train --demo-bc``,
:mod:`agents.demo_bc`)."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from stable_baselines3 import SAC
from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

import uuom_gym  # noqa: F401 - registers the env
from agents.cli import train_config, train_parser
from agents.demo_bc import SACWithDemoBC
from agents.demonstrations import seed_replay_buffer
from agents.hyperparameters import TrainConfigError
from agents.training import TrainConfig, plan, train

ACCEL = {"action_mode": "acceleration", "track_length_m": [50.0, 70.0], "idle_clock_observation": True,
         "near_distance_observation": "tanh"}


def _venv():
    return VecNormalize(DummyVecEnv([lambda: gym.make("UUOM-Track-v0", observer="dffrls-aekf", **ACCEL)] * 2),
                        norm_reward=False)


def _model(cls=SACWithDemoBC, **kw):
    return cls("MlpPolicy", _venv(), buffer_size=20_000, learning_starts=0, seed=0, device="cpu", **kw)


def _fill(model, n_episodes=1):
    return seed_replay_buffer(model, "dffrls-aekf", ACCEL, n_episodes=n_episodes, seed=0)


def _params(model):
    return [p.detach().clone() for p in model.policy.parameters()]


def test_weight_zero_is_sac_step_for_step():
    plain, bc = _model(SAC), _model(bc_weight=0.0)
    for a, b in zip(_params(plain), _params(bc)):
        assert th.equal(a, b)
    _fill(plain), _fill(bc)
    assert bc.demo_buffer.size() == bc.replay_buffer.size() > 0
    for m in (plain, bc):
        m._setup_learn(1000)  # the logger train() records to
        m.set_random_seed(0)  # the buffers sample from numpy's and torch's global generators
        m.train(gradient_steps=6, batch_size=64)
    for a, b in zip(_params(plain), _params(bc)):
        assert th.equal(a, b)


class _Critic:
    """A stand-in for SAC's twin critic that rates the demonstrated actions (the first query of each BC step, see
    ``SACWithDemoBC._bc_step``) ``q_demo`` and the policy's own (the second) ``q_pi``, on every state."""

    def __init__(self, q_demo, q_pi):
        self.values, self.calls = (q_demo, q_pi), 0

    def __call__(self, obs, actions):
        q = th.full((obs.shape[0], 1), float(self.values[self.calls % 2]))
        self.calls += 1
        return q, q


def _demo_batch(model):
    d = model.demo_buffer
    obs = model._vec_normalize_env.normalize_obs(d.observations[: d.pos].reshape(-1, d.obs_shape[0]))
    return th.as_tensor(obs, dtype=th.float32), th.as_tensor(d.actions[: d.pos].reshape(-1, 1))


def test_q_filter_pulls_the_mean_action_to_the_demonstrations_only_where_the_critic_prefers_them():
    model = _model(bc_weight=1.0, learning_rate=3e-3)
    _fill(model)
    obs, acts = _demo_batch(model)
    with th.no_grad():
        gap0 = float(((model.actor(obs, deterministic=True) - acts) ** 2).mean())
    model.critic = _Critic(q_demo=-2.0, q_pi=-1.0)  # the policy's own action rated above the demonstrator's
    before = _params(model)
    for _ in range(20):
        model._bc_step(256)
    assert model.bc_stats["kept_fraction"] == 0.0
    assert all(th.equal(a, b) for a, b in zip(before, _params(model)))
    model.critic = _Critic(q_demo=-1.0, q_pi=-2.0)  # ... now below it
    for _ in range(200):
        model._bc_step(256)
    assert model.bc_stats["kept_fraction"] == 1.0
    with th.no_grad():
        gap = float(((model.actor(obs, deterministic=True) - acts) ** 2).mean())
    assert gap < 0.3 * gap0


def test_saved_model_loads_as_plain_sac_without_the_demonstrations(tmp_path):
    model = _model(bc_weight=0.4)
    _fill(model)
    model.save(tmp_path / "m.zip")
    loaded = SAC.load(tmp_path / "m.zip", device="cpu")
    obs = np.zeros((3, model.observation_space.shape[0]), dtype=np.float32)
    np.testing.assert_array_equal(loaded.predict(obs, deterministic=True)[0], model.predict(obs, deterministic=True)[0])
    again = SACWithDemoBC.load(tmp_path / "m.zip", env=_venv(), device="cpu")
    assert again.bc_weight == 0.4 and again.demo_buffer.size() == 0


@pytest.mark.parametrize("kw, match", [(dict(bc_weight=-1.0), "bc_weight must be"),
                                       (dict(bc_weight=float("nan")), "bc_weight must be"),
                                       (dict(demo_buffer_size=0), "demo_buffer_size must be"),
                                       (dict(target_update_interval=2), "target_update_interval must be 1")])
def test_constructor_refuses_what_cannot_work(kw, match):
    with pytest.raises(ValueError, match=match):
        _model(**kw)


@pytest.mark.parametrize("kwargs, match", [
    (dict(demo_episodes=0), r"--demo-episodes N > 0\); got --algo sac, --demo-episodes 0"),
    (dict(algo="td3"), "got --algo td3"),
    (dict(demo_bc_weight=-0.1), "demo_bc_weight must be a finite number >= 0"),
    (dict(demo_bc_weight=float("inf")), "demo_bc_weight must be a finite number >= 0"),
    (dict(demo_bc_weight=True), "demo_bc_weight must be a finite number >= 0"),
])
def test_demo_bc_options_that_cannot_work_are_refused_before_training(tmp_path, kwargs, match):
    base = dict(algo="sac", residual=0.0, shield=False, observer="oracle", timesteps=100, demo_episodes=1,
                demo_bc_weight=0.4, run_dir=tmp_path / "r", env_kwargs=dict(ACCEL))
    with pytest.raises(TrainConfigError, match=match):
        plan(TrainConfig(**{**base, **kwargs}))
    assert not (tmp_path / "r").exists()


def test_cli_passes_the_weight():
    args = train_parser().parse_args(["--algo", "sac", "--demo-episodes", "5", "--demo-bc", "0.4"])
    cfg = train_config(args)
    assert cfg.demo_bc_weight == 0.4 and cfg.demo_episodes == 5
    assert train_config(train_parser().parse_args([])).demo_bc_weight == 0.0


def test_training_records_the_weight_and_a_resume_rebuilds_the_demonstrations(tmp_path):
    kw = dict(algo="sac", residual=0.0, shield=False, observer="dffrls-aekf", seed=1, n_envs=2,
              run_dir=tmp_path / "run", eval_freq=0, checkpoint_freq=200, subproc=False, progress=False,
              env_kwargs=dict(ACCEL), demo_episodes=1, demo_bc_weight=0.4,
              hyperparams=["buffer_size=20000", "learning_starts=100"])
    run = train(TrainConfig(timesteps=200, **kw))
    assert json.loads((run / "config.json").read_text())["demo_bc_weight"] == 0.4
    first = json.loads((run / "demonstrations.json").read_text())
    with pytest.raises(TrainConfigError, match="different demo_bc_weight"):
        train(TrainConfig(timesteps=400, resume=True, **{**kw, "demo_bc_weight": 0.0}))
    (run / "demonstrations.json").unlink()
    train(TrainConfig(timesteps=400, resume=True, **kw))
    again = json.loads((run / "demonstrations.json").read_text())
    assert {k: again[k] for k in ("episodes", "transitions")} == {k: first[k] for k in ("episodes", "transitions")}
    assert SAC.load(run / "model.zip", device="cpu").num_timesteps >= 400
