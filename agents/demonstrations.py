"""Seed an off-policy learner's replay buffer with a reference controller's episodes (``uuom-train --demo-episodes``).

Why: bare SAC on the acceleration action (docs/rl.md §33–§39) fails seed by seed in ways that look like
exploration, not capacity: a seed is trapped at the start or metres before the station for half its training,
heavy trains are learnt late or not at all, and the recipes' seeds first arrive on half their training episodes
after 100 000–440 000 steps. Episodes of a controller that already arrives with every load put arrivals of every
load in the buffer from the first gradient step. The learner stays plain SAC: the transitions are ordinary
``(obs, action, reward, next_obs, done)`` tuples of the same env configuration, sampled like its own; the trained
policy acts alone (no residual, no shield, no demonstrator at test time).

The demonstrator is the rule-based controller in the env's action space (:func:`demonstrator_for`). Its tracks
are drawn from seeds ``DEMO_SEED_OFFSET + 1000 * seed + i``, apart from the training, evaluation, validation
(200 000+) and held-out (100 000+) seeds.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

DEMO_SEED_OFFSET = 5_000_000
"""Demonstration tracks of training seed ``s`` are seeds ``DEMO_SEED_OFFSET + 1000 s + i``."""


def demonstrator_class(action_mode: str) -> type:
    """The reference controller that acts in this action space: the rule-based controller (traction command) or its
    acceleration-demand adapter. The speed-target action has none (its tracker already is the reference's force
    law; a target speed is not what the rule-based controller computes)."""
    from agents.controllers import AccelerationRuleBased, RuleBasedController

    if action_mode == "command":
        return RuleBasedController
    if action_mode == "acceleration":
        return AccelerationRuleBased
    raise ValueError(f"demonstrations: no demonstrator for action_mode={action_mode!r} (command or acceleration)")


def demonstrator_for(env: Any, **options: Any) -> Any:
    """A new :func:`demonstrator_class` controller for ``env``'s action space and vehicle (``options``: its keyword
    arguments)."""
    base = env.unwrapped
    return demonstrator_class(base.config["action_mode"])(base.vehicle, **options)


def seed_replay_buffer(model: Any, observer: str, env_kwargs: dict[str, Any], n_episodes: int,
                       seed: int, into_replay: bool = True) -> dict[str, int]:
    """Add ``n_episodes`` demonstrator episodes to ``model.replay_buffer``; return what was added.

    A model with a ``demo_buffer`` (:class:`agents.demo_bc.SACWithDemoBC`) gets them there too. ``into_replay=False``
    fills only that buffer and leaves the normaliser alone: a resumed run rebuilds the demonstrations it does not
    save (the same tracks, so the same transitions), its replay buffer and statistics already holding them.

    One env per buffer slot (``replay_buffer.n_envs``), stepped together as a vector env would be: an episode that
    ends is followed by the next track in that slot, its last ``next_obs`` the terminal observation, a time-limit
    end stored as a timeout (SB3's ``TimeLimit.truncated``). Observations and rewards are stored raw, as SB3 stores
    them behind ``VecNormalize``; the normaliser's observation statistics are updated with them. Collection stops
    when ``n_episodes`` have ended (the other slots' unfinished episodes stay in the buffer: valid transitions).
    """
    import gymnasium as gym
    from stable_baselines3.common.vec_env import VecNormalize

    from agents.hyperparameters import ENV_ID

    buf = model.replay_buffer
    demo_buf = getattr(model, "demo_buffer", None)
    if not into_replay and demo_buf is None:
        raise ValueError("seed_replay_buffer: into_replay=False needs a model with a demo_buffer")
    n_slots = int(buf.n_envs)
    envs = [gym.make(ENV_ID, observer=observer, **env_kwargs) for _ in range(n_slots)]
    ctrls = [demonstrator_for(e) for e in envs]
    venv = model.get_env()
    norm = venv if isinstance(venv, VecNormalize) else None
    next_seed = DEMO_SEED_OFFSET + 1000 * int(seed)
    obs, infos = [], []
    for env, ctrl in zip(envs, ctrls):
        o, info = env.reset(seed=next_seed)
        next_seed += 1
        ctrl.reset(env, info)
        obs.append(o)
        infos.append(info)
    ended = arrived = transitions = 0
    try:
        while ended < n_episodes:
            actions = np.stack([c.act(o, i) for c, o, i in zip(ctrls, obs, infos)]).astype(np.float32)
            next_obs, rewards, dones, step_infos, new_obs, new_infos = [], [], [], [], [], []
            for k, env in enumerate(envs):
                o2, r, term, trunc, info = env.step(actions[k])
                next_obs.append(o2)
                rewards.append(r)
                dones.append(term or trunc)
                step_infos.append({"TimeLimit.truncated": bool(trunc and not term)})
                if term or trunc:
                    ended += 1
                    arrived += int(bool(info.get("is_success")))
                    o2, info = env.reset(seed=next_seed)
                    next_seed += 1
                    ctrls[k].reset(env, info)
                new_obs.append(o2)
                new_infos.append(info)
            obs_arr = np.stack(obs)
            step = (obs_arr, np.stack(next_obs), actions, np.asarray(rewards, dtype=np.float32), np.asarray(dones),
                    step_infos)
            if into_replay:
                buf.add(*step)
                if norm is not None and norm.norm_obs:
                    norm.obs_rms.update(obs_arr)
            if demo_buf is not None:
                demo_buf.add(*step)
            transitions += n_slots
            obs, infos = new_obs, new_infos
    finally:
        for env in envs:
            env.close()
    return {"episodes": ended, "arrived": arrived, "transitions": transitions}


class DemonstratorLabels(gym.Wrapper):
    """``env`` with every step's ``info["demo_action"]``: what the demonstrator (:func:`demonstrator_for`,
    ``options`` its keyword arguments) would have commanded at the observation the step's action was taken at -- the
    online labels of :class:`agents.ppo_bc.PPOWithDemoBC` (DAgger's labelling, during training).

    The demonstrator follows every episode (reset with the env, fed every observation), so its state is the
    episode's whoever drives; the action applied is the caller's.
    """

    def __init__(self, env: Any, **options: Any) -> None:
        super().__init__(env)
        try:
            self.demonstrator = demonstrator_for(env, **options)
        except TypeError as exc:  # an option the controller does not take: say which input it was
            raise TypeError(f"demonstrator_options: {exc}") from None
        self._obs: Any = None
        self._info: Any = None

    def reset(self, **kwargs: Any) -> Any:
        obs, info = self.env.reset(**kwargs)
        self.demonstrator.reset(self.env, info)
        self._obs, self._info = obs, info
        return obs, info

    def step(self, action: Any) -> Any:
        if self._obs is None:
            raise RuntimeError("DemonstratorLabels: step() before reset()")
        label = np.clip(np.asarray(self.demonstrator.act(self._obs, self._info), dtype=np.float32), -1.0, 1.0)
        obs, reward, terminated, truncated, info = self.env.step(action)
        self._obs, self._info = obs, info
        info = {**info, "demo_action": label}
        return obs, reward, terminated, truncated, info


__all__ = ["DEMO_SEED_OFFSET", "demonstrator_class", "demonstrator_for", "DemonstratorLabels", "seed_replay_buffer"]
