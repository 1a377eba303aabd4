"""SAC with a Q-filtered behaviour-cloning term on its demonstrations (``uuom-train --demo-bc W``).

Why: with the replay buffer seeded by rule-based episodes (:mod:`agents.demonstrations`, docs/rl.md §40) bare SAC
learns faster, but its checkpoints swing between safe and tripping from one 100 000 steps to the next, and its
fastest seed drives at 85 times the demonstrator's cost rate. Nothing in plain SAC keeps what the demonstrations
showed once the critic's estimate drifts. The remedy of Nair et al. (2018, "Overcoming exploration in
reinforcement learning with demonstrations") is a behaviour-cloning loss on the demonstrated states, applied only
where the critic itself rates the demonstrated action above the policy's own (the *Q-filter*): the policy is held
to the demonstrator where it has not found better, and free to leave it where it has.

How, after every SAC gradient step (stable-baselines3's own, unchanged), one more actor step on a batch of
demonstration transitions ``(s, a_d)`` held in their own buffer (:attr:`SACWithDemoBC.demo_buffer`, never
overwritten by the agent's transitions):

``L_bc = W * mean|Q(s, mu(s))| * mean_s[ 1{Q(s, a_d) > Q(s, mu(s))} * ||mu(s) - a_d||^2 ]``

with ``mu(s)`` the actor's deterministic (mean) action and ``Q`` the minimum over SAC's critics. The factor
``mean|Q|`` (detached) puts the term on the scale of SAC's actor loss, whatever the reward scale, as TD3+BC does
(Fujimoto & Gu 2021, whose ``alpha = 2.5`` corresponds to ``W = 0.4``). With ``W = 0`` or an empty demonstration
buffer the algorithm is SAC, step for step. The saved model loads as plain SAC: the term only shapes training.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch as th
from stable_baselines3 import SAC
from stable_baselines3.common.buffers import ReplayBuffer


class SACWithDemoBC(SAC):
    """Soft actor-critic plus a Q-filtered behaviour-cloning actor step on demonstrations.

    Parameters
    ----------
    policy, env : as for :class:`stable_baselines3.SAC`
    bc_weight : float
        ``W`` of the module's loss, >= 0 (0: plain SAC).
    demo_buffer_size : int
        Capacity of :attr:`demo_buffer` in transitions per env slot (as SB3's ``buffer_size``).
    **kwargs
        Everything else of :class:`stable_baselines3.SAC`.

    Attributes
    ----------
    demo_buffer : ReplayBuffer
        The demonstrations (filled by :func:`agents.demonstrations.seed_replay_buffer`); not saved with the model.
    bc_stats : dict
        The last BC step's loss and the fraction of demonstrated states where the Q-filter kept the term.
    """

    def __init__(self, policy: Any, env: Any, bc_weight: float = 0.4, demo_buffer_size: int = 300_000,
                 **kwargs: Any) -> None:
        bc_weight = float(bc_weight)
        if not np.isfinite(bc_weight) or bc_weight < 0:
            raise ValueError(f"bc_weight must be a finite number >= 0, got {bc_weight!r}")
        if int(demo_buffer_size) < 1:
            raise ValueError(f"demo_buffer_size must be >= 1, got {demo_buffer_size!r}")
        self.bc_weight = bc_weight
        self.demo_buffer_size = int(demo_buffer_size)
        self.demo_buffer: ReplayBuffer | None = None
        self.bc_stats: dict[str, float] = {}
        super().__init__(policy, env, **kwargs)
        if self.target_update_interval != 1:
            # train() runs SAC's update one gradient step at a time, so SAC's own interval count restarts every step
            raise ValueError(f"SACWithDemoBC: target_update_interval must be 1, got {self.target_update_interval}")

    def _setup_model(self) -> None:
        super()._setup_model()
        self.demo_buffer = ReplayBuffer(self.demo_buffer_size, self.observation_space, self.action_space,
                                        device=self.device, n_envs=self.n_envs, handle_timeout_termination=True)

    def _excluded_save_params(self) -> list[str]:
        return [*super()._excluded_save_params(), "demo_buffer"]

    def train(self, gradient_steps: int, batch_size: int = 64) -> None:
        for _ in range(gradient_steps):
            super().train(1, batch_size)
            if self.bc_weight > 0 and self.demo_buffer is not None and self.demo_buffer.size() > 0:
                self._bc_step(batch_size)
        if self.bc_stats:
            self.logger.record("train/bc_loss", self.bc_stats["loss"])
            self.logger.record("train/bc_kept_fraction", self.bc_stats["kept_fraction"])

    def _bc_step(self, batch_size: int) -> None:
        demo = self.demo_buffer.sample(batch_size, env=self._vec_normalize_env)
        self.policy.set_training_mode(True)
        mu = self.actor(demo.observations, deterministic=True)
        with th.no_grad():
            q_demo = th.min(th.cat(self.critic(demo.observations, demo.actions), dim=1), dim=1).values
            q_pi = th.min(th.cat(self.critic(demo.observations, mu), dim=1), dim=1).values
            keep = (q_demo > q_pi).float()
            scale = q_pi.abs().mean().clamp_min(1e-6)
        sq = ((mu - demo.actions) ** 2).sum(dim=1)
        loss = self.bc_weight * scale * (keep * sq).mean()
        self.actor.optimizer.zero_grad()
        loss.backward()
        self.actor.optimizer.step()
        self.bc_stats = {"loss": float(loss.item()), "kept_fraction": float(keep.mean().item())}


__all__ = ["SACWithDemoBC"]
