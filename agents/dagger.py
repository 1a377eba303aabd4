"""DAgger: a warm start for bare PPO on the traction command, imitating the rule-based controller.

Why: bare PPO on ``UUOM-Track-v0``'s default action never needs a mean action that drives -- the exploration noise
starts the train, so the deterministic policy holds the brake at the start (the *start trap*, docs/rl.md §3, §27), and
twenty recipes of noise, curricula and algorithms left it at 47-62 % arrivals pooled over seeds. The rule-based
controller already drives every track. DAgger (Ross, Gordon & Bagnell, 2011, "A reduction of imitation learning and
structured prediction to no-regret online learning") fits the policy's mean action to the demonstrator's action *on
the states the policy itself visits*: behaviour cloning on the demonstrator's own episodes alone leaves the policy
lost as soon as it drifts off them (measured: 3 of 20 validation tracks).

What :func:`dagger` does, in a PPO model built exactly as ``uuom-train --residual 0 --no-shield`` builds it
(``agents/hyperparams/ppo.yml``, VecNormalize):

1. ``demo_episodes`` episodes of the demonstrator (:func:`agents.demonstrations.demonstrator_for`); the observation
   normaliser's statistics are set from them and kept;
2. the actor (``mlp_extractor.policy_net`` + ``action_net``) regressed on the demonstrator's actions (mean squared
   error on the Gaussian policy's mean);
3. ``iterations`` times: ``episodes_per_iteration`` episodes driven by the policy (its mean plus
   ``rollout_noise_std`` of Gaussian noise), every state labelled with what the demonstrator, following the same
   episode, would do; aggregated, refitted; after each fit the policy is driven on ``validation_episodes`` validation
   tracks (:data:`agents.tune.VALIDATION_SEED_BASE` on) and the best fit is kept (``keep``: the most arrivals, or
   the checkpoint rule's score of :mod:`agents.checkpoint_selection`, arrivals minus ten per trip; then the faster
   arrivals; on a full tie the earlier fit, where that rule takes the later checkpoint);
4. the critic regressed on the discounted normalised returns of ``value_episodes`` episodes of the kept policy
   sampled as PPO will sample it, and the reward normaliser's statistics set from them, so that PPO's first updates
   see sensible advantages; the policy's ``log_std`` set to ``log_std``.

The result is a run directory (``model.zip``, ``vecnormalize.pkl``, ``config.json`` with a ``dagger`` entry,
``dagger.json`` with every iteration's validation, ``iterations/<k>/`` each fit as a policy folder) that
``uuom-evaluate`` drives like any policy and ``uuom-train --init-from DIR --residual 0 --no-shield`` continues with
PPO. The policy acts alone: no demonstrator, residual or shield at test time. Tracks: demonstrations and DAgger
episodes from :data:`agents.demonstrations.DEMO_SEED_OFFSET` ``+ 1000 seed``, apart from training, validation and
held-out seeds.
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Callable

import numpy as np

__all__ = ["DEFAULT_DEMONSTRATOR_OPTIONS", "KEEP_RULES", "DaggerConfig", "DaggerError", "dagger"]


DEFAULT_DEMONSTRATOR_OPTIONS: dict[str, Any] = {"speed_margin": 0.2}
"""The demonstrator: the rule-based controller 20 % under its pessimistic limit (8 % by default). Measured (docs/rl.md
§46): with the controller's own margin the fitted network under-brakes heavy trains over the limit and trips them
(61 / 87 of 100 held-out tracks, 37 / 12 trips); with 20 % the same error stays under the trip (97 / 97 / 89, 0 / 1 / 1).
``{}`` gives the controller as it is."""


class DaggerError(ValueError):
    """A DAgger input that cannot work (named in the message)."""


@dataclass(frozen=True)
class DaggerConfig:
    """One DAgger warm start (``scripts/dagger.py``'s options; the module docstring says what each step does).
    ``hyperparams``: ``key=value`` overrides of ``agents/hyperparams/ppo.yml``'s ``UUOM-Track-v0`` entry, as
    ``uuom-train --hyperparams`` takes them (e.g. the network: ``policy_kwargs=...``). ``demonstrator_options``:
    keyword arguments of :class:`agents.controllers.RuleBasedController` (default
    :data:`DEFAULT_DEMONSTRATOR_OPTIONS`). ``keep``: :data:`KEEP_RULES`."""

    run_dir: str
    observer: str = "dffrls-aekf"
    seed: int = 0
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    demo_episodes: int = 40
    iterations: int = 6
    episodes_per_iteration: int = 20
    epochs: int = 30
    batch_size: int = 512
    learning_rate: float = 1e-3
    rollout_noise_std: float = 0.1
    validation_episodes: int = 20
    value_episodes: int = 20
    log_std: float = math.log(0.1)
    hyperparams: tuple[str, ...] = ()
    keep: str = "safety"
    demonstrator_options: dict[str, Any] = field(default_factory=lambda: dict(DEFAULT_DEMONSTRATOR_OPTIONS))

    def check(self) -> None:
        """Raise :class:`DaggerError` naming the first bad field."""
        from estimators.filters import check_int_option

        counts = {"demo_episodes": 1, "iterations": 0, "episodes_per_iteration": 1, "epochs": 1, "batch_size": 1,
                  "validation_episodes": 1, "value_episodes": 1, "seed": 0}
        for name, low in counts.items():
            check_int_option(name, getattr(self, name), DaggerError, low)
        if self.demo_episodes + self.iterations * self.episodes_per_iteration + self.value_episodes > 1000:
            raise DaggerError("demo_episodes + iterations x episodes_per_iteration + value_episodes must be <= 1000 "
                              "(the tracks of one seed)")
        for name in ("learning_rate", "rollout_noise_std", "log_std"):
            v = getattr(self, name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise DaggerError(f"{name} must be a finite number, got {v!r}")
        if self.learning_rate <= 0 or self.rollout_noise_std < 0:
            raise DaggerError("learning_rate must be > 0 and rollout_noise_std >= 0")
        if self.keep not in KEEP_RULES:
            raise DaggerError(f"keep must be one of {', '.join(KEEP_RULES)}, got {self.keep!r}")
        if not isinstance(self.demonstrator_options, dict):
            raise DaggerError(f"demonstrator_options must be a dict, got {type(self.demonstrator_options).__name__}")
        if not isinstance(self.env_kwargs, dict):
            raise DaggerError(f"env_kwargs must be a dict, got {type(self.env_kwargs).__name__}")


def _rollout(env: Any, ctrl: Any, seed: int, act: Callable[[np.ndarray], np.ndarray] | None = None,
             noise_std: float = 0.0, rng: np.random.Generator | None = None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """One episode on track ``seed``: raw observations, the demonstrator's action at each, the rewards, the last
    info. Driven by the demonstrator, or by ``act`` (raw observation -> action) plus ``noise_std`` noise."""
    obs, info = env.reset(seed=seed)
    ctrl.reset(env, info)
    xs, ys, rs = [], [], []
    while True:
        label = ctrl.act(obs, info)  # the demonstrator follows every episode, so its state is the episode's
        xs.append(obs)
        ys.append(label)
        if act is None:
            a = label
        else:
            a = act(obs)
            if noise_std > 0:
                a = a + noise_std * rng.standard_normal(a.shape)
        obs, r, term, trunc, info = env.step(np.clip(a, -1.0, 1.0).astype(np.float32))
        rs.append(r)
        if term or trunc:
            return np.asarray(xs), np.asarray(ys), np.asarray(rs, dtype=np.float64), info


def _regress(params: list, predict: Callable, x: np.ndarray, y: np.ndarray, epochs: int, batch_size: int,
             lr: float, gen: Any) -> float:
    """Mean-squared-error fit of ``predict(x) ~ y`` over ``params`` (Adam, shuffled minibatches from ``gen``);
    returns the last epoch's mean loss."""
    import torch

    xt = torch.as_tensor(x, dtype=torch.float32)
    yt = torch.as_tensor(y, dtype=torch.float32).reshape(len(y), -1)
    opt = torch.optim.Adam(params, lr=lr)
    loss_sum = 0.0
    for _ in range(epochs):
        perm = torch.randperm(len(xt), generator=gen)
        loss_sum = 0.0
        for k in range(0, len(xt), batch_size):
            idx = perm[k:k + batch_size]
            loss = torch.mean((predict(xt[idx]) - yt[idx]) ** 2)
            opt.zero_grad()
            loss.backward()
            opt.step()
            loss_sum += loss.item() * len(idx)
    return loss_sum / len(xt)


def _validate(env: Any, ctrl: Any, act: Callable, n: int) -> dict[str, Any]:
    """The policy's mean on ``n`` validation tracks: arrivals, trips, mean trip time of the arrivals, endings."""
    from agents.tune import VALIDATION_SEED_BASE

    arrived = trips = 0
    times: list[float] = []
    endings: dict[str, int] = {}
    for i in range(n):
        _, _, _, info = _rollout(env, ctrl, VALIDATION_SEED_BASE + i, act)
        end = str(info.get("termination"))
        endings[end] = endings.get(end, 0) + 1
        if info.get("is_success"):
            arrived += 1
            times.append(float(info["t_s"]))
        trips += end == "overspeed_trip"
    return {"episodes": n, "arrived": arrived, "trips": trips,
            "mean_trip_time_s": float(np.mean(times)) if times else None, "endings": endings}


KEEP_RULES = ("arrivals", "safety")
"""Which fit :func:`dagger` keeps: the most validation arrivals (then fewer trips; a warm start's job is to drive,
PPO's reward punishes a trip), or the checkpoint rule (:data:`agents.checkpoint_selection.TRIP_WEIGHT`)."""


def _score(v: dict[str, Any], keep: str = "arrivals") -> tuple[float, ...]:
    from agents.checkpoint_selection import TRIP_WEIGHT

    t = v["mean_trip_time_s"]
    faster = -(t if t is not None else math.inf)
    if keep == "arrivals":
        return (v["arrived"], -v["trips"], faster)
    return (v["arrived"] - TRIP_WEIGHT * v["trips"], faster)


def dagger(config: DaggerConfig, log: Callable[[str], None] = print) -> Path:
    """Run the DAgger warm start of :class:`DaggerConfig`; return its run directory (module docstring)."""
    import gymnasium as gym
    import torch

    from scipy.signal import lfilter

    from agents.checkpoints import atomic_write, atomic_write_text
    from agents.demonstrations import DEMO_SEED_OFFSET, demonstrator_for
    from agents.hyperparameters import ENV_ID
    from agents.training import TrainConfig, _model_kwargs, make_vec_env, plan

    config.check()
    torch.set_num_threads(1)
    try:
        p = plan(TrainConfig(algo="ppo", observer=config.observer, seed=config.seed, residual=0.0, shield=False,
                             env_kwargs=dict(config.env_kwargs), run_dir=config.run_dir,
                             hyperparams=list(config.hyperparams)))
    except ValueError as exc:
        raise DaggerError(str(exc)) from None
    from stable_baselines3 import PPO
    from stable_baselines3.common.policies import BaseModel
    from stable_baselines3.common.vec_env import VecNormalize

    if p.normalize is None or not p.normalize.get("norm_obs", False):
        raise DaggerError("dagger: the PPO entry of the hyperparameter file must normalise observations")
    env = gym.make(ENV_ID, observer=config.observer, **p.env_kwargs)
    mode = env.unwrapped.config["action_mode"]
    try:
        if mode != "command":
            raise DaggerError(f"dagger: the demonstrator drives the traction command (action_mode 'command'), got "
                              f"{mode!r}")
        ctrl = demonstrator_for(env, **config.demonstrator_options)
    except TypeError as exc:
        env.close()
        raise DaggerError(f"demonstrator_options: {exc}") from None
    except DaggerError:
        env.close()
        raise
    venv = VecNormalize(make_vec_env(config.observer, config.seed, p.n_envs, False, p.env_kwargs, False), **p.normalize)
    model = PPO(p.policy, venv, seed=config.seed, device="cpu", verbose=0, **_model_kwargs(p.hp, 0, p.total))
    policy = model.policy
    gen = torch.Generator().manual_seed(config.seed)
    rng = np.random.default_rng(config.seed)
    t0 = time.time()
    next_track = DEMO_SEED_OFFSET + 1000 * config.seed
    run_dir = Path(config.run_dir)
    record = {
        "algo": "ppo", "observer": config.observer, "seed": config.seed, "n_envs": p.n_envs, "timesteps": 0,
        "shield": False, "residual": 0.0, "env_kwargs": p.env_kwargs,
        "hyperparams": {k: repr(v) for k, v in p.hp.items()}, "normalize": p.normalize,
        "dagger": {k: v for k, v in asdict(config).items() if k not in ("run_dir", "observer", "seed", "env_kwargs")},
    }

    def save(folder: Path) -> None:
        """The model as it is now, as a policy folder ``uuom-evaluate`` drives."""
        folder.mkdir(parents=True, exist_ok=True)
        atomic_write_text(folder / "config.json", json.dumps(record, indent=2))
        atomic_write(folder / "model.zip", lambda f: model.save(f))
        atomic_write(folder / "vecnormalize.pkl", lambda f: venv.save(str(f)))

    try:
        xs, ys = [], []
        arrived = 0
        for _ in range(config.demo_episodes):
            x, y, _, info = _rollout(env, ctrl, next_track)
            next_track += 1
            xs.append(x)
            ys.append(y)
            arrived += bool(info.get("is_success"))
        demo = np.concatenate(xs)
        venv.obs_rms.mean = demo.mean(axis=0).astype(np.float64)
        venv.obs_rms.var = demo.var(axis=0).astype(np.float64)
        venv.obs_rms.count = float(len(demo))
        log(f"demonstrations: {config.demo_episodes} episodes ({arrived} arrived), {len(demo)} states, "
            f"{time.time() - t0:.0f} s")

        def norm(o: np.ndarray) -> np.ndarray:
            return venv.normalize_obs(o).astype(np.float32)

        def mean_action(z: Any) -> Any:
            return policy.action_net(policy.mlp_extractor.forward_actor(
                BaseModel.extract_features(policy, z, policy.pi_features_extractor)))

        def act(o: np.ndarray) -> np.ndarray:
            with torch.no_grad():
                return mean_action(torch.as_tensor(norm(o)[None])).numpy()[0]

        actor = list(policy.mlp_extractor.policy_net.parameters()) + list(policy.action_net.parameters())
        history: list[dict[str, Any]] = []
        best: tuple[tuple[float, ...], dict[str, Any], int] | None = None
        for it in range(config.iterations + 1):
            if it > 0:
                for _ in range(config.episodes_per_iteration):
                    x, y, _, _ = _rollout(env, ctrl, next_track, act, config.rollout_noise_std, rng)
                    next_track += 1
                    xs.append(x)
                    ys.append(y)
            x_all = norm(np.concatenate(xs))
            y_all = np.clip(np.concatenate(ys), -1.0, 1.0)
            loss = _regress(actor, mean_action, x_all, y_all, config.epochs, config.batch_size,
                            config.learning_rate, gen)
            val = _validate(env, ctrl, act, config.validation_episodes)
            val.update(iteration=it, states=int(len(x_all)), loss=loss, seconds=round(time.time() - t0, 1))
            history.append(val)
            log(f"iteration {it}: {len(x_all)} states, loss {loss:.2e}; validation {val['arrived']}/{val['episodes']} "
                f"arrived, {val['trips']} trips, endings {val['endings']}")
            save(run_dir / "iterations" / str(it))  # each fit, for its own evaluation (its critic untrained)
            if best is None or _score(val, config.keep) > best[0]:
                best = (_score(val, config.keep), {k: v.clone() for k, v in policy.state_dict().items()}, it)
        policy.load_state_dict(best[1])
        kept = best[2]
        with torch.no_grad():
            policy.log_std.fill_(float(config.log_std))
        # the critic: discounted returns of the kept policy sampled as PPO samples it, in the normaliser's units
        gamma = float(p.hp.get("gamma", 0.99))
        std = math.exp(config.log_std)
        vx, vr = [], []
        for _ in range(config.value_episodes):
            x, _, r, _ = _rollout(env, ctrl, next_track, act, std, rng)
            next_track += 1
            vx.append(x)
            vr.append(r)
        # VecNormalize's running return (reset at each episode's start) sets the reward scale; the critic's targets
        # are the discounted returns to go of the scaled rewards
        running = np.concatenate([lfilter([1.0], [1.0, -gamma], r) for r in vr])
        venv.ret_rms.mean, venv.ret_rms.var = float(running.mean()), float(running.var())
        venv.ret_rms.count = float(len(running))
        targets = [lfilter([1.0], [1.0, -gamma], venv.normalize_reward(r)[::-1])[::-1] for r in vr]
        critic = list(policy.mlp_extractor.value_net.parameters()) + list(policy.value_net.parameters())

        def value(z: Any) -> Any:
            return policy.value_net(policy.mlp_extractor.forward_critic(
                BaseModel.extract_features(policy, z, policy.vf_features_extractor)))

        v_loss = _regress(critic, value, norm(np.concatenate(vx)), np.concatenate(targets), config.epochs,
                          config.batch_size, config.learning_rate, gen)
        log(f"kept iteration {kept}; critic fitted on {config.value_episodes} episodes (loss {v_loss:.3g}); "
            f"{time.time() - t0:.0f} s")
        save(run_dir)
        atomic_write_text(run_dir / "dagger.json", json.dumps(
            {"kept_iteration": kept, "iterations": history, "critic_loss": v_loss,
             "seconds": round(time.time() - t0, 1)}, indent=2))
        return run_dir
    finally:
        env.close()
        venv.close()
