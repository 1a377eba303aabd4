"""PPO with a behaviour-cloning term on the demonstrator's labels of its own rollouts (``uuom-train --algo ppo
--demo-bc W``).

Why: a PPO policy started from a DAgger fit of the rule-based controller (:mod:`agents.dagger`, docs/rl.md §46)
drives on day one, but PPO at ``ppo.yml``'s learning rate undoes the fit within 100 000 steps (54-83 % arrivals
from 89-97 %), and at a tenth of it keeps the fit and removes its trips on three seeds of three while two seeds end
short of the station more often. Nothing in PPO's loss remembers what the demonstrator showed. DAPG (Rajeswaran et
al. 2018, "Learning complex dexterous manipulation with deep reinforcement learning and demonstrations") adds a
behaviour-cloning term to the policy gradient; here the term is taken on the states of PPO's own rollouts, each
labelled with what the demonstrator, following the same episode, would have commanded
(:class:`agents.demonstrations.DemonstratorLabels`: DAgger's labelling, done online), so it keeps the policy near the
demonstrator exactly where the policy goes, and the RL term moves it from there:

``L = L_PPO + W * mean_batch ||mu(s) - a_d(s)||^2``

with ``mu(s)`` the Gaussian policy's mean and ``a_d`` the label, clipped to the action box. ``W = 0`` is PPO, step for
step (the same minibatches, the same gradients).

``bc_std_ref`` (optional) makes ``W`` the weight at that action std: each update uses ``W * bc_std_ref / sigma`` with
``sigma`` the policy's current (state-independent) action std. Why: PPO's gradient on the mean grows as ``1/sigma``
(``d log pi / d mu = (a - mu) / sigma^2`` with ``a - mu ~ sigma``) while the squared-distance term's does not, so
under a falling std ceiling a fixed ``W`` loses its hold just as the policy settles (docs/rl.md §49: the last
updates at ``sigma = 0.05`` undid the policy on four seeds of five); the scaled weight keeps the two in proportion.
Measured (docs/rl.md §50) it does not help: the late jumps are the BC term's own large steps at a small ``sigma``
(approximate KL ~5 nats per update), which a larger weight makes larger; the option stays so that probe can be rebuilt.
The labels live in the rollout buffer beside the observations
(:class:`DemoLabelRolloutBuffer`) and are read from ``info["demo_action"]``; the saved model loads as plain PPO.
"""

from __future__ import annotations

import math
from typing import Any, Generator, NamedTuple

import numpy as np
import torch as th
from gymnasium import spaces
from stable_baselines3 import PPO
from stable_baselines3.common.buffers import RolloutBuffer
from stable_baselines3.common.utils import explained_variance
from torch.nn import functional as F

__all__ = ["DemoLabelRolloutBuffer", "DemoLabelSamples", "PPOWithDemoBC"]


class DemoLabelSamples(NamedTuple):
    """SB3's ``RolloutBufferSamples`` plus the demonstrator's labels of the same states."""

    observations: th.Tensor
    actions: th.Tensor
    old_values: th.Tensor
    old_log_prob: th.Tensor
    advantages: th.Tensor
    returns: th.Tensor
    demo_actions: th.Tensor


class DemoLabelRolloutBuffer(RolloutBuffer):
    """SB3's rollout buffer with one more array, ``demo_actions`` ``(n_steps, n_envs, action_dim)``, written by
    :class:`PPOWithDemoBC` at the slot the step's transition goes to and shuffled with the others."""

    demo_actions: np.ndarray

    def reset(self) -> None:
        super().reset()
        self.demo_actions = np.zeros((self.buffer_size, self.n_envs, self.action_dim), dtype=np.float32)

    def get(self, batch_size: int | None = None) -> Generator[DemoLabelSamples, None, None]:  # type: ignore[override]
        if not self.generator_ready:
            self.demo_actions = self.swap_and_flatten(self.demo_actions)
        yield from super().get(batch_size)  # type: ignore[misc]

    def _get_samples(self, batch_inds: np.ndarray, env: Any = None) -> DemoLabelSamples:  # type: ignore[override]
        base = super()._get_samples(batch_inds, env)
        return DemoLabelSamples(*base, demo_actions=self.to_torch(self.demo_actions[batch_inds]))


class PPOWithDemoBC(PPO):
    """PPO plus ``W`` times the squared distance of its mean action to the demonstrator's labels of its rollouts.

    Parameters
    ----------
    policy, env : as for :class:`stable_baselines3.PPO`
        ``env``'s steps must carry ``info["demo_action"]`` (:class:`agents.demonstrations.DemonstratorLabels`).
    bc_weight : float
        ``W`` of the module's loss, >= 0 (0: plain PPO).
    pg_coef : float
        Factor on PPO's clipped policy-gradient loss, in [0, 1] (1: PPO's own; 0: the policy learns from the labels
        alone, online DAgger with PPO's critic still fitted -- the ablation that says what the RL term adds).
    bc_std_ref : float or None
        ``None``: the weight is ``W`` throughout. A number > 0: ``W`` is the weight at this action std and each update
        uses ``W * bc_std_ref / sigma`` (``sigma``: the mean of the policy's action std at the update's start). Needs
        a state-independent std (``use_sde=False``).
    **kwargs
        Everything else of :class:`stable_baselines3.PPO`.

    Attributes
    ----------
    bc_stats : dict
        The last update's mean behaviour-cloning loss (unweighted), the mean |label - action taken| and the weight
        the update used.
    """

    def __init__(self, policy: Any, env: Any, bc_weight: float = 1.0, pg_coef: float = 1.0,
                 bc_std_ref: float | None = None, **kwargs: Any) -> None:
        self.bc_weight = self.check_weight(bc_weight)
        self.pg_coef = pg_coef
        self.bc_std_ref = bc_std_ref
        self.bc_stats: dict[str, float] = {}
        self._labelling = False
        super().__init__(policy, env, **kwargs)

    @staticmethod
    def check_weight(bc_weight: Any) -> float:
        if isinstance(bc_weight, bool) or not isinstance(bc_weight, (int, float)) or not math.isfinite(bc_weight) \
                or bc_weight < 0:
            raise ValueError(f"bc_weight must be a finite number >= 0, got {bc_weight!r}")
        return float(bc_weight)

    def _setup_model(self) -> None:
        if not isinstance(self.action_space, spaces.Box):
            raise ValueError(f"PPOWithDemoBC: a Box action space is needed, got {self.action_space}")
        self.check_weight(self.bc_weight)  # load() sets the attributes without __init__
        pg = self.pg_coef
        if isinstance(pg, bool) or not isinstance(pg, (int, float)) or not 0.0 <= pg <= 1.0:
            raise ValueError(f"pg_coef must be a number in [0, 1], got {pg!r}")
        ref = getattr(self, "bc_std_ref", None)  # absent from a model saved before the option existed
        self.bc_std_ref = ref
        if ref is not None:
            if isinstance(ref, bool) or not isinstance(ref, (int, float)) or not math.isfinite(ref) or ref <= 0:
                raise ValueError(f"bc_std_ref must be None or a finite number > 0, got {ref!r}")
            if self.use_sde:
                raise ValueError("bc_std_ref scales the weight by the policy's state-independent action std: "
                                 "not with use_sde=True")
        self.rollout_buffer_class = DemoLabelRolloutBuffer  # also for a model loaded from a plain PPO zip
        self._labelling = False
        super()._setup_model()

    def _excluded_save_params(self) -> list[str]:
        # the saved model loads as plain PPO (its rollout buffer class is this module's business)
        return [*super()._excluded_save_params(), "rollout_buffer_class", "_labelling"]

    # --- rollouts -------------------------------------------------------------------------------------------
    def collect_rollouts(self, env, callback, rollout_buffer, n_rollout_steps) -> bool:  # type: ignore[override]
        self._labelling = True
        try:
            return super().collect_rollouts(env, callback, rollout_buffer, n_rollout_steps)
        finally:
            self._labelling = False

    def _update_info_buffer(self, infos: list[dict[str, Any]], dones: np.ndarray | None = None) -> None:
        # SB3 calls this once per env step inside collect_rollouts, just before rollout_buffer.add(): the label of
        # the state this step's transition stores goes to the same slot
        if self._labelling:
            buf = self.rollout_buffer
            for i, info in enumerate(infos):
                label = info.get("demo_action")
                if label is None:
                    raise KeyError("PPOWithDemoBC needs info['demo_action'] at every step: wrap the env in "
                                   "agents.demonstrations.DemonstratorLabels")
                label = np.asarray(label, dtype=np.float32).reshape(-1)
                if label.shape != (buf.action_dim,) or not np.all(np.isfinite(label)):
                    raise ValueError(f"info['demo_action'] must be {buf.action_dim} finite numbers, got {label!r}")
                buf.demo_actions[buf.pos, i] = label
        super()._update_info_buffer(infos, dones)

    # --- update ---------------------------------------------------------------------------------------------
    def current_bc_weight(self) -> float:
        """The weight the next update uses: ``W``, or ``W * bc_std_ref / sigma`` with ``bc_std_ref`` set."""
        if self.bc_std_ref is None or self.bc_weight == 0:
            return self.bc_weight
        sigma = float(th.exp(self.policy.log_std.detach()).mean())  # type: ignore[operator]
        return self.bc_weight * float(self.bc_std_ref) / sigma

    def train(self) -> None:
        """SB3's PPO update (``PPO.train`` as of SB3 2.9, the same order of operations) with the behaviour-cloning
        term added to each minibatch's loss.

        Written out because the term joins PPO's loss before the one backward pass; an SB3 release that changes
        ``PPO.train`` does not reach this copy. ``pyproject.toml`` keeps SB3 below 3, and
        ``tests/test_ppo_bc.py`` checks that ``W = 0`` gives the installed SB3's parameters step for step."""
        self.policy.set_training_mode(True)
        self._update_learning_rate(self.policy.optimizer)
        clip_range = self.clip_range(self._current_progress_remaining)  # type: ignore[operator]
        clip_range_vf = (self.clip_range_vf(self._current_progress_remaining)  # type: ignore[operator]
                         if self.clip_range_vf is not None else None)
        low = th.as_tensor(self.action_space.low, device=self.device)
        high = th.as_tensor(self.action_space.high, device=self.device)
        bc_weight = self.current_bc_weight()
        entropy_losses, pg_losses, value_losses, clip_fractions, bc_losses = [], [], [], [], []
        approx_kl_divs: list[float] = []
        continue_training = True
        loss = th.zeros(())
        for epoch in range(self.n_epochs):
            approx_kl_divs = []
            for data in self.rollout_buffer.get(self.batch_size):
                values, log_prob, entropy = self.policy.evaluate_actions(data.observations, data.actions)
                values = values.flatten()
                advantages = data.advantages
                if self.normalize_advantage and len(advantages) > 1:
                    advantages = (advantages - advantages.mean()) / (advantages.std() + 1e-8)
                ratio = th.exp(log_prob - data.old_log_prob)
                policy_loss = -th.min(advantages * ratio,
                                      advantages * th.clamp(ratio, 1 - clip_range, 1 + clip_range)).mean()
                pg_losses.append(policy_loss.item())
                clip_fractions.append(th.mean((th.abs(ratio - 1) > clip_range).float()).item())
                values_pred = values if clip_range_vf is None else data.old_values + th.clamp(
                    values - data.old_values, -clip_range_vf, clip_range_vf)
                value_loss = F.mse_loss(data.returns, values_pred)
                value_losses.append(value_loss.item())
                entropy_loss = -th.mean(-log_prob) if entropy is None else -th.mean(entropy)
                entropy_losses.append(entropy_loss.item())
                loss = self.pg_coef * policy_loss + self.ent_coef * entropy_loss + self.vf_coef * value_loss
                if bc_weight > 0:
                    mean = self.policy.get_distribution(data.observations).distribution.mean
                    target = th.clamp(data.demo_actions, low, high)
                    bc_loss = th.mean(th.sum((mean - target) ** 2, dim=-1))
                    bc_losses.append(bc_loss.item())
                    loss = loss + bc_weight * bc_loss
                with th.no_grad():
                    log_ratio = log_prob - data.old_log_prob
                    approx_kl_div = th.mean((th.exp(log_ratio) - 1) - log_ratio).cpu().numpy()
                    approx_kl_divs.append(approx_kl_div)
                if self.target_kl is not None and approx_kl_div > 1.5 * self.target_kl:
                    continue_training = False
                    break
                self.policy.optimizer.zero_grad()
                loss.backward()
                th.nn.utils.clip_grad_norm_(self.policy.parameters(), self.max_grad_norm)
                self.policy.optimizer.step()
            self._n_updates += 1
            if not continue_training:
                break
        buf = self.rollout_buffer
        self.bc_stats = {
            "bc_loss": float(np.mean(bc_losses)) if bc_losses else float("nan"),
            "label_gap": float(np.mean(np.abs(np.clip(buf.actions, self.action_space.low, self.action_space.high)
                                              - buf.demo_actions))),
            "bc_weight": bc_weight,
        }
        self.logger.record("train/bc_weight", bc_weight)
        self.logger.record("train/entropy_loss", np.mean(entropy_losses))
        self.logger.record("train/policy_gradient_loss", np.mean(pg_losses))
        self.logger.record("train/value_loss", np.mean(value_losses))
        self.logger.record("train/approx_kl", np.mean(approx_kl_divs))
        self.logger.record("train/clip_fraction", np.mean(clip_fractions))
        self.logger.record("train/loss", loss.item())
        self.logger.record("train/explained_variance",
                           explained_variance(buf.values.flatten(), buf.returns.flatten()))
        if hasattr(self.policy, "log_std"):
            self.logger.record("train/std", th.exp(self.policy.log_std).mean().item())
        self.logger.record("train/n_updates", self._n_updates, exclude="tensorboard")
        self.logger.record("train/clip_range", clip_range)
        if clip_range_vf is not None:
            self.logger.record("train/clip_range_vf", clip_range_vf)
        self.logger.record("train/bc_loss", self.bc_stats["bc_loss"])
        self.logger.record("train/bc_label_gap", self.bc_stats["label_gap"])
