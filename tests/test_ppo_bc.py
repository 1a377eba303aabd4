"""PPO with a behaviour-cloning term on online demonstrator labels (``uuom-train --algo ppo --demo-bc W``,
:mod:`agents.ppo_bc`, :class:`agents.demonstrations.DemonstratorLabels`)."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import DummyVecEnv

import uuom_gym  # noqa: F401 - registers the env
from agents.cli import train_config, train_parser
from agents.dagger import _rollout
from agents.demonstrations import DemonstratorLabels, demonstrator_for
from agents.hyperparameters import TrainConfigError
from agents.ppo_bc import PPOWithDemoBC
from agents.training import TrainConfig, plan, train

SHORT = {"track_length_m": [50.0, 60.0]}
PPO_KW = dict(n_steps=64, batch_size=32, n_epochs=2, seed=0, device="cpu")


def _venv(labels: bool = True, **options):
    def make():
        env = gym.make("UUOM-Track-v0", observer="dffrls-aekf", **SHORT)
        return DemonstratorLabels(env, **options) if labels else env

    return DummyVecEnv([make, make])


def _params(model):
    return [p.detach().clone() for p in model.policy.parameters()]


def test_labels_are_the_demonstrators_action_at_the_state_acted_on():
    """Driven by anything, the wrapper's label of step t is what the demonstrator following the same episode commands
    at observation t: the labels DAgger's own rollout writes for the same episode and actions."""
    rng = np.random.default_rng(3)
    actions = np.clip(rng.normal(0.15, 0.2, size=(4000, 1)), -1, 1).astype(np.float32)
    k = iter(range(len(actions)))

    def act(_obs):
        return actions[next(k)]

    env = gym.make("UUOM-Track-v0", observer="dffrls-aekf", **SHORT)
    _, want, _, _ = _rollout(env, demonstrator_for(env, speed_margin=0.2), 7, act)
    wrapped = DemonstratorLabels(gym.make("UUOM-Track-v0", observer="dffrls-aekf", **SHORT), speed_margin=0.2)
    wrapped.reset(seed=7)
    got = []
    for a in actions:
        _, _, term, trunc, info = wrapped.step(a)
        got.append(info["demo_action"])
        if term or trunc:
            break
    assert len(got) == len(want) > 50
    np.testing.assert_allclose(np.asarray(got), np.clip(want, -1, 1).reshape(len(want), -1), atol=1e-6)
    assert np.ptp(np.asarray(got)) > 0.5  # the labels move: the demonstrator drives and brakes


def test_step_before_reset_is_refused():
    env = DemonstratorLabels(gym.make("UUOM-Track-v0", observer="oracle", **SHORT))
    with pytest.raises(RuntimeError, match="before reset"):
        env.step(np.zeros(1, dtype=np.float32))


def test_weight_zero_is_ppo_step_for_step():
    plain = PPO("MlpPolicy", _venv(labels=False), **PPO_KW)
    bc = PPOWithDemoBC("MlpPolicy", _venv(), bc_weight=0.0, **PPO_KW)
    for a, b in zip(_params(plain), _params(bc)):
        assert th.equal(a, b)
    for m in (plain, bc):
        m.set_random_seed(0)  # the rollouts' noise comes from torch's global generator, shared by the two models
        m.learn(256)
    for a, b in zip(_params(plain), _params(bc)):
        assert th.equal(a, b)
    assert np.isnan(bc.bc_stats["bc_loss"]) and bc.bc_stats["label_gap"] > 0


def _label_mse(model) -> float:
    buf = model.rollout_buffer
    obs = th.as_tensor(buf.observations.reshape(-1, *buf.obs_shape))
    with th.no_grad():
        mean = model.policy.get_distribution(obs).distribution.mean.numpy()
    return float(np.mean((mean - np.clip(buf.demo_actions.reshape(mean.shape), -1, 1)) ** 2))


def test_the_term_pulls_the_mean_action_to_the_labels():
    """On the same rollouts, a large weight leaves the policy's mean far nearer the labels than PPO alone does."""
    gaps = {}
    for w in (0.0, 50.0):
        model = PPOWithDemoBC("MlpPolicy", _venv(), bc_weight=w, learning_rate=3e-3, **{**PPO_KW, "n_epochs": 10})
        model.learn(128 * 6)
        gaps[w] = _label_mse(model)
        assert np.abs(model.rollout_buffer.demo_actions).max() > 0.1  # the labels reached the buffer
    assert gaps[50.0] < 0.5 * gaps[0.0], gaps
    assert gaps[50.0] < 0.05, gaps


def test_pg_coef_zero_leaves_the_actor_to_the_labels():
    """``pg_coef=0`` (the ablation): with no BC term either the actor does not move at all, the critic still learns."""
    model = PPOWithDemoBC("MlpPolicy", _venv(), bc_weight=0.0, pg_coef=0.0, **PPO_KW)
    actor = [p.detach().clone() for p in model.policy.mlp_extractor.policy_net.parameters()]
    critic = [p.detach().clone() for p in model.policy.value_net.parameters()]
    model.learn(256)
    assert all(th.equal(a, b) for a, b in zip(actor, model.policy.mlp_extractor.policy_net.parameters()))
    assert not all(th.equal(a, b) for a, b in zip(critic, model.policy.value_net.parameters()))


@pytest.mark.parametrize("pg", [-0.1, 1.5, True, float("nan")])
def test_bad_pg_coef_is_refused(pg):
    with pytest.raises(ValueError, match="pg_coef must be"):
        PPOWithDemoBC("MlpPolicy", _venv(), pg_coef=pg, **PPO_KW)


def test_pg_coef_is_a_hyperparameter_of_the_bc_learner_only(tmp_path):
    base = dict(algo="ppo", residual=0.0, shield=False, observer="oracle", timesteps=100, run_dir=tmp_path / "r",
                env_kwargs=dict(SHORT), hyperparams=["pg_coef=0"])
    assert plan(TrainConfig(demo_bc_weight=1.0, **base)).hp["pg_coef"] == 0
    with pytest.raises(TrainConfigError, match="ppo has no hyperparameter 'pg_coef'"):
        plan(TrainConfig(**base))


def test_std_referenced_weight_is_the_weight_scaled_by_ref_over_sigma():
    """``bc_std_ref``: one update at action std 1 with ``W = 1, ref = 2`` is the update of ``W = 2``, step for step;
    at std 0.1 the same options give ``W = 20``."""
    a = PPOWithDemoBC("MlpPolicy", _venv(), bc_weight=1.0, bc_std_ref=2.0, **PPO_KW)
    b = PPOWithDemoBC("MlpPolicy", _venv(), bc_weight=2.0, **PPO_KW)
    assert float(th.exp(a.policy.log_std.detach()).mean()) == 1.0  # SB3's log_std_init = 0
    for m in (a, b):
        m.set_random_seed(0)
        m.learn(128)  # one rollout of 64 steps x 2 envs: one update
    for x, y in zip(_params(a), _params(b)):
        assert th.equal(x, y)
    assert a.bc_stats["bc_weight"] == b.bc_stats["bc_weight"] == 2.0
    with th.no_grad():
        a.policy.log_std.fill_(np.log(0.1))
    assert a.current_bc_weight() == pytest.approx(20.0, rel=1e-5)
    b.bc_weight = 0.0
    assert b.current_bc_weight() == 0.0


@pytest.mark.parametrize("ref", [0.0, -1.0, float("inf"), True, "0.3"])
def test_bad_bc_std_ref_is_refused(ref):
    with pytest.raises(ValueError, match="bc_std_ref must be"):
        PPOWithDemoBC("MlpPolicy", _venv(), bc_std_ref=ref, **PPO_KW)


def test_bc_std_ref_is_refused_with_state_dependent_noise():
    with pytest.raises(ValueError, match="use_sde"):
        PPOWithDemoBC("MlpPolicy", _venv(), bc_std_ref=0.37, use_sde=True, **PPO_KW)


def test_bc_std_ref_is_a_hyperparameter_of_the_bc_learner(tmp_path):
    base = dict(algo="ppo", residual=0.0, shield=False, observer="oracle", timesteps=100, run_dir=tmp_path / "r",
                env_kwargs=dict(SHORT), hyperparams=["bc_std_ref=0.37"])
    assert plan(TrainConfig(demo_bc_weight=100.0, **base)).hp["bc_std_ref"] == 0.37


def test_missing_labels_are_named():
    model = PPOWithDemoBC("MlpPolicy", _venv(labels=False), bc_weight=1.0, **PPO_KW)
    with pytest.raises(KeyError, match="DemonstratorLabels"):
        model.learn(64)


@pytest.mark.parametrize("w", [-1.0, float("nan"), True, "1"])
def test_bad_weight_is_refused(w):
    with pytest.raises(ValueError, match="bc_weight must be"):
        PPOWithDemoBC("MlpPolicy", _venv(), bc_weight=w, **PPO_KW)


def test_saved_model_loads_as_plain_ppo(tmp_path):
    model = PPOWithDemoBC("MlpPolicy", _venv(), bc_weight=2.0, **PPO_KW)
    model.learn(128)
    model.save(tmp_path / "m.zip")
    loaded = PPO.load(tmp_path / "m.zip", device="cpu")
    obs = np.zeros((3, model.observation_space.shape[0]), dtype=np.float32)
    np.testing.assert_array_equal(loaded.predict(obs, deterministic=True)[0], model.predict(obs, deterministic=True)[0])
    again = PPOWithDemoBC.load(tmp_path / "m.zip", env=_venv(), device="cpu")
    assert again.bc_weight == 2.0
    again.learn(64)  # its rollout buffer has the labels again


@pytest.mark.parametrize("kwargs, match", [
    (dict(residual=0.5), "labels the bare env's action"),
    (dict(shield=True), "labels the bare env's action"),
    (dict(demonstrator_options={"no_such_option": 1}), "demonstrator_options"),
    (dict(demonstrator_options=[1]), "demonstrator_options must be a JSON object"),
    (dict(demo_bc_weight=0.0, demonstrator_options={}), "the only demonstrator it sets"),
    (dict(algo="td3"), "got --algo td3"),
    (dict(env_kwargs={"action_mode": "speed_target"}), "no demonstrator for action_mode"),
])
def test_options_that_cannot_work_are_refused_before_training(tmp_path, kwargs, match):
    base = dict(algo="ppo", residual=0.0, shield=False, observer="oracle", timesteps=100, demo_bc_weight=1.0,
                run_dir=tmp_path / "r", env_kwargs=dict(SHORT))
    with pytest.raises(TrainConfigError, match=match):
        plan(TrainConfig(**{**base, **kwargs}))
    assert not (tmp_path / "r").exists()


def test_cli_passes_the_weight_and_the_demonstrator():
    args = train_parser().parse_args(["--demo-bc", "5", "--demonstrator-options", '{"speed_margin": 0.1}'])
    cfg = train_config(args)
    assert cfg.demo_bc_weight == 5.0 and cfg.demonstrator_options == {"speed_margin": 0.1}
    assert train_config(train_parser().parse_args([])).demonstrator_options is None


def test_training_from_a_ppo_run_records_the_labeller_and_resumes(tmp_path):
    kw = dict(algo="ppo", residual=0.0, shield=False, observer="dffrls-aekf", seed=1, n_envs=2, eval_freq=0,
              checkpoint_freq=0, subproc=False, progress=False, env_kwargs=dict(SHORT),
              hyperparams=["n_steps=64", "batch_size=64"])
    source = train(TrainConfig(timesteps=128, run_dir=tmp_path / "src", **kw))
    bc = dict(kw, checkpoint_freq=128, demo_bc_weight=3.0)
    run = train(TrainConfig(timesteps=256, run_dir=tmp_path / "bc", init_from=source, **bc))
    rec = json.loads((run / "config.json").read_text())
    assert rec["demo_bc_weight"] == 3.0 and rec["demonstrator_options"] == {"speed_margin": 0.2}
    with pytest.raises(TrainConfigError, match="different demonstrator_options"):
        train(TrainConfig(timesteps=384, run_dir=tmp_path / "bc", init_from=source, resume=True,
                          **{**bc, "demonstrator_options": {}}))
    train(TrainConfig(timesteps=384, run_dir=tmp_path / "bc", init_from=source, resume=True, **bc))
    assert PPO.load(run / "model.zip", device="cpu").num_timesteps >= 384
