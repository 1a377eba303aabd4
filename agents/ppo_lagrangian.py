"""PPO-Lagrangian: PPO with a cost critic and a learned Lagrange multiplier (stable-baselines3 has none).

The constrained problem ``max_pi J_r(pi)  s.t.  J_c(pi) <= d`` is solved through its Lagrangian
``min_{lambda >= 0} max_pi J_r - lambda (J_c - d)`` (Ray, Achiam & Amodei 2019, "Benchmarking Safe Exploration"):

- every step's cost is read from ``info["cost"]`` (what ``UUOM-Track-v0`` reports; any env that puts a
  non-negative float there works);
- a separate cost critic ``V_c(s)`` is fitted to the discounted cost returns, and cost advantages ``A_c`` come
  from GAE exactly like the reward advantages;
- the policy is trained by the ordinary PPO clipped loss on the combined advantage
  ``(A_r - lambda A_c) / (1 + lambda)`` (the ``1 + lambda`` keeps the scale bounded as lambda grows);
- ``lambda = softplus(xi)`` is learned by gradient ascent on ``lambda (J_c - d)``, with ``J_c`` the mean cost per
  step of the latest rollout and ``d = cost_limit`` (a cost *rate*, the quantity the evaluation reports).

Everything else (clipping, GAE, entropy, VecNormalize, callbacks, save/load) is SB3's PPO.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import PPO
from stable_baselines3.common.torch_layers import FlattenExtractor
from stable_baselines3.common.utils import obs_as_tensor
from torch import nn


class CostCritic(nn.Module):
    """MLP ``V_c(s)`` on the flattened observation."""

    def __init__(self, observation_space: spaces.Space, net_arch: list[int] | tuple[int, ...] = (64, 64)) -> None:
        super().__init__()
        self.extractor = FlattenExtractor(observation_space)
        layers: list[nn.Module] = []
        last = self.extractor.features_dim
        for width in net_arch:
            layers += [nn.Linear(last, width), nn.Tanh()]
            last = width
        layers.append(nn.Linear(last, 1))
        self.net = nn.Sequential(*layers)

    def forward(self, obs: th.Tensor) -> th.Tensor:
        return self.net(self.extractor(obs.float())).squeeze(-1)


class PPOLagrangian(PPO):
    """PPO constrained by ``info["cost"]`` through a learned Lagrange multiplier.

    Parameters
    ----------
    policy, env : as for :class:`stable_baselines3.PPO`
    cost_limit : float
        Allowed mean cost per step ``d``.
    lagrange_lr : float
        Learning rate of the multiplier's parameter ``xi`` (Adam).
    initial_lagrange : float
        Starting multiplier value (> 0).
    cost_gamma, cost_gae_lambda : float, optional
        Discount and GAE parameter of the cost returns (default: ``gamma`` and ``gae_lambda``).
    cost_vf_lr : float
        Learning rate of the cost critic.
    cost_vf_epochs : int
        Passes over the rollout used to fit the cost critic per update.
    cost_net_arch : list of int
        Hidden layers of the cost critic.
    **kwargs
        Passed to :class:`stable_baselines3.PPO`.

    Attributes
    ----------
    lagrange_multiplier : float
        Current ``lambda``.
    last_cost_rate : float
        Mean cost per step of the latest rollout.
    """

    def __init__(
        self,
        policy: Any,
        env: Any,
        *,
        cost_limit: float = 0.0,
        lagrange_lr: float = 0.05,
        initial_lagrange: float = 1.0,
        cost_gamma: float | None = None,
        cost_gae_lambda: float | None = None,
        cost_vf_lr: float = 1e-3,
        cost_vf_epochs: int = 5,
        cost_net_arch: list[int] | tuple[int, ...] = (64, 64),
        **kwargs: Any,
    ) -> None:
        if not (math.isfinite(cost_limit) and cost_limit >= 0):
            raise ValueError(f"cost_limit must be a finite number >= 0, got {cost_limit!r}")
        if not (initial_lagrange > 0 and math.isfinite(initial_lagrange)):
            raise ValueError(f"initial_lagrange must be a positive finite number, got {initial_lagrange!r}")
        if not lagrange_lr > 0:
            raise ValueError(f"lagrange_lr must be > 0, got {lagrange_lr!r}")
        self.cost_limit = float(cost_limit)
        self.lagrange_lr = float(lagrange_lr)
        self.initial_lagrange = float(initial_lagrange)
        self.cost_gamma = cost_gamma
        self.cost_gae_lambda = cost_gae_lambda
        self.cost_vf_lr = float(cost_vf_lr)
        self.cost_vf_epochs = int(cost_vf_epochs)
        self.cost_net_arch = list(cost_net_arch)
        self._step_costs: list[np.ndarray] = []
        self._recording_costs = False
        self.last_cost_rate = float("nan")
        super().__init__(policy, env, **kwargs)

    # --- setup ----------------------------------------------------------------------------------------------
    def _setup_model(self) -> None:
        super()._setup_model()
        self.cost_critic = CostCritic(self.observation_space, self.cost_net_arch).to(self.device)
        self.cost_critic_optimizer = th.optim.Adam(self.cost_critic.parameters(), lr=self.cost_vf_lr)
        # softplus^-1(lambda0) so that softplus(xi) starts at lambda0
        xi0 = math.log(math.expm1(self.initial_lagrange))
        self.lagrange_param = nn.Parameter(th.tensor(xi0, dtype=th.float32, device=self.device))
        self.lagrange_optimizer = th.optim.Adam([self.lagrange_param], lr=self.lagrange_lr)

    @property
    def lagrange_multiplier(self) -> float:
        return float(nn.functional.softplus(self.lagrange_param).detach().cpu())

    def _get_torch_save_params(self) -> tuple[list[str], list[str]]:
        state_dicts, variables = super()._get_torch_save_params()
        return state_dicts + ["cost_critic", "cost_critic_optimizer", "lagrange_optimizer"], variables

    def _excluded_save_params(self) -> list[str]:
        return super()._excluded_save_params() + ["_step_costs", "lagrange_param"]

    def get_parameters(self) -> dict[str, dict]:
        params = super().get_parameters()
        params["lagrange"] = {"xi": self.lagrange_param.detach().cpu().clone()}
        return params

    def set_parameters(self, load_path_or_dict: Any, exact_match: bool = True, device: Any = "auto") -> None:
        if isinstance(load_path_or_dict, dict) and "lagrange" in load_path_or_dict:
            params = dict(load_path_or_dict)
            xi = params.pop("lagrange")["xi"]
            with th.no_grad():
                self.lagrange_param.copy_(xi.to(self.device))
            super().set_parameters(params, exact_match=False, device=device)
            return
        super().set_parameters(load_path_or_dict, exact_match=exact_match, device=device)

    # --- rollouts -------------------------------------------------------------------------------------------
    def collect_rollouts(self, env, callback, rollout_buffer, n_rollout_steps) -> bool:  # type: ignore[override]
        self._step_costs = []
        self._recording_costs = True
        try:
            ok = super().collect_rollouts(env, callback, rollout_buffer, n_rollout_steps)
        finally:
            self._recording_costs = False
        if ok:
            self._compute_cost_advantages()
        return ok

    def _update_info_buffer(self, infos: list[dict[str, Any]], dones: np.ndarray | None = None) -> None:
        # SB3 calls this once per env step inside collect_rollouts, in step order: the one hook that sees infos.
        if self._recording_costs:
            costs = np.empty(len(infos), dtype=np.float32)
            for i, info in enumerate(infos):
                c = info.get("cost")
                if c is None:
                    raise KeyError("PPOLagrangian needs info['cost'] from the environment at every step")
                c = float(c)
                if not math.isfinite(c) or c < 0:
                    raise ValueError(f"info['cost'] must be a finite number >= 0, got {c!r}")
                costs[i] = c
            self._step_costs.append(costs)
        super()._update_info_buffer(infos, dones)

    def _compute_cost_advantages(self) -> None:
        buf = self.rollout_buffer
        costs = np.stack(self._step_costs[: buf.buffer_size])  # (n_steps, n_envs)
        gamma = self.gamma if self.cost_gamma is None else self.cost_gamma
        lam = self.gae_lambda if self.cost_gae_lambda is None else self.cost_gae_lambda
        with th.no_grad():
            obs = th.as_tensor(buf.observations.reshape(-1, *buf.obs_shape), device=self.device)
            values = self.cost_critic(obs).cpu().numpy().reshape(buf.buffer_size, buf.n_envs)
            last = self.cost_critic(obs_as_tensor(self._last_obs, self.device)).cpu().numpy()
        dones_last = np.asarray(self._last_episode_starts, dtype=np.float32)
        adv = np.zeros_like(costs)
        gae = np.zeros(buf.n_envs, dtype=np.float32)
        for t in reversed(range(buf.buffer_size)):
            if t == buf.buffer_size - 1:
                non_terminal = 1.0 - dones_last
                next_v = last
            else:
                non_terminal = 1.0 - buf.episode_starts[t + 1]
                next_v = values[t + 1]
            delta = costs[t] + gamma * next_v * non_terminal - values[t]
            gae = delta + gamma * lam * non_terminal * gae
            adv[t] = gae
        self._cost_advantages = adv
        self._cost_returns = adv + values
        self.last_cost_rate = float(costs.mean())

    # --- update ---------------------------------------------------------------------------------------------
    def train(self) -> None:
        # 1. multiplier: ascend lambda (J_c - d), i.e. descend -softplus(xi) (J_c - d)
        violation = self.last_cost_rate - self.cost_limit
        self.lagrange_optimizer.zero_grad()
        loss_lambda = -nn.functional.softplus(self.lagrange_param) * float(violation)
        loss_lambda.backward()
        self.lagrange_optimizer.step()
        lam = self.lagrange_multiplier

        # 2. combined advantage for the PPO policy loss (the reward critic keeps its own returns)
        buf = self.rollout_buffer
        a_r = buf.advantages
        a_c = self._cost_advantages
        # Scale the cost advantage like the reward one so lambda is comparable across tasks.
        a_c_n = (a_c - a_c.mean()) / (a_c.std() + 1e-8) * (a_r.std() + 1e-8)
        buf.advantages = ((a_r - lam * a_c_n) / (1.0 + lam)).astype(np.float32)

        # 3. cost critic regression on the discounted cost returns
        obs = th.as_tensor(buf.observations.reshape(-1, *buf.obs_shape), device=self.device)
        target = th.as_tensor(self._cost_returns.reshape(-1), device=self.device)
        n = obs.shape[0]
        losses = []
        for _ in range(self.cost_vf_epochs):
            perm = th.randperm(n, device=self.device)
            for start in range(0, n, self.batch_size):
                idx = perm[start : start + self.batch_size]
                loss = nn.functional.mse_loss(self.cost_critic(obs[idx]), target[idx])
                self.cost_critic_optimizer.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(self.cost_critic.parameters(), self.max_grad_norm)
                self.cost_critic_optimizer.step()
                losses.append(loss.item())

        self.logger.record("lagrangian/lambda", lam)
        self.logger.record("lagrangian/cost_rate", self.last_cost_rate)
        self.logger.record("lagrangian/cost_limit", self.cost_limit)
        self.logger.record("lagrangian/cost_value_loss", float(np.mean(losses)) if losses else 0.0)
        super().train()


__all__ = ["CostCritic", "PPOLagrangian"]
