"""Mechanics of PPO-Lagrangian on a tiny toy task with a cost, independent of UUOM."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch as th
from gymnasium import spaces
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env

from agents.ppo_lagrangian import PPOLagrangian

# Tiny networks: extra torch threads only fight the other test processes for the cores.
th.set_num_threads(1)


class GreedyCostEnv(gym.Env):
    """Reward grows with the action, but actions above 0.3 cost 1: the constraint fights the reward."""

    def __init__(self, horizon: int = 20) -> None:
        self.observation_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (1,), np.float32)
        self.horizon = horizon
        self._t = 0

    def _obs(self) -> np.ndarray:
        return np.array([self._t / self.horizon, 1.0], dtype=np.float32)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self._t = 0
        return self._obs(), {}

    def step(self, action):
        a = float(np.clip(action[0], -1, 1))
        self._t += 1
        cost = 1.0 if a > 0.3 else 0.0
        return self._obs(), a, False, self._t >= self.horizon, {"cost": cost}


def _make(seed: int = 0, n_envs: int = 2):
    return make_vec_env(GreedyCostEnv, n_envs=n_envs, seed=seed)


def _cost_rate(model, n_episodes: int = 10) -> float:
    env = GreedyCostEnv()
    costs = []
    for ep in range(n_episodes):
        obs, _ = env.reset(seed=ep)
        done = False
        while not done:
            act, _ = model.predict(obs, deterministic=True)
            obs, _, term, trunc, info = env.step(act)
            costs.append(info["cost"])
            done = term or trunc
    return float(np.mean(costs))


KW = dict(n_steps=128, batch_size=64, n_epochs=4, learning_rate=3e-3, seed=3, device="cpu")


def test_multiplier_rises_while_cost_exceeds_limit():
    model = PPOLagrangian("MlpPolicy", _make(), cost_limit=0.0, initial_lagrange=0.5, lagrange_lr=0.1, **KW)
    lam0 = model.lagrange_multiplier
    model.learn(512)
    assert model.last_cost_rate >= 0
    assert model.lagrange_multiplier > lam0
    assert model._cost_advantages.shape == (128, 2)
    assert np.all(np.isfinite(model._cost_returns))


def test_multiplier_falls_when_constraint_is_slack():
    model = PPOLagrangian("MlpPolicy", _make(), cost_limit=1.0, initial_lagrange=2.0, lagrange_lr=0.1, **KW)
    model.learn(512)
    # cost rate <= 1 always, so J_c - d <= 0 and lambda can only go down
    assert model.lagrange_multiplier < 2.0


def test_constraint_lowers_cost_against_plain_ppo():
    plain = PPO("MlpPolicy", _make(), **KW).learn(4096)
    lag = PPOLagrangian("MlpPolicy", _make(), cost_limit=0.05, initial_lagrange=1.0, lagrange_lr=0.2, **KW).learn(4096)
    c_plain, c_lag = _cost_rate(plain), _cost_rate(lag)
    assert c_plain > 0.5, f"plain PPO should learn the greedy costly action (cost rate {c_plain})"
    assert c_lag < c_plain - 0.3, f"PPO-Lagrangian cost rate {c_lag} not below plain PPO {c_plain}"


def test_save_load_keeps_multiplier_and_cost_critic(tmp_path):
    model = PPOLagrangian("MlpPolicy", _make(), cost_limit=0.0, initial_lagrange=0.7, **KW)
    model.learn(256)
    path = tmp_path / "lag.zip"
    model.save(path)
    loaded = PPOLagrangian.load(path, env=_make(), device="cpu")
    assert loaded.lagrange_multiplier == pytest.approx(model.lagrange_multiplier, rel=1e-6)
    assert loaded.cost_limit == model.cost_limit
    x = np.zeros((3, 2), dtype=np.float32)
    import torch as th

    with th.no_grad():
        np.testing.assert_allclose(
            loaded.cost_critic(th.as_tensor(x)).numpy(), model.cost_critic(th.as_tensor(x)).numpy(), rtol=1e-6
        )
    loaded.learn(128)  # continues training after a reload


def test_missing_cost_is_a_clear_error():
    class NoCost(GreedyCostEnv):
        def step(self, action):
            o, r, te, tr, _ = super().step(action)
            return o, r, te, tr, {}

    model = PPOLagrangian("MlpPolicy", make_vec_env(NoCost, n_envs=1, seed=0), **KW)
    with pytest.raises(KeyError, match="cost"):
        model.learn(128)


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="cost_limit"):
        PPOLagrangian("MlpPolicy", _make(), cost_limit=-1.0)
    with pytest.raises(ValueError, match="initial_lagrange"):
        PPOLagrangian("MlpPolicy", _make(), initial_lagrange=0.0)
