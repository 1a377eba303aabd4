"""Train a speed controller on ``UUOM-Track-v0``: PPO, SAC or PPO-Lagrangian, optionally as a residual on the
rule-based controller and behind the safety shield (``uuom-train`` / ``scripts/train.py`` are front ends).

A run writes ``<log_dir>/<algo>_<observer>[_res][_shield]_s<seed>/`` (or ``run_dir``):

- ``model.zip`` + ``vecnormalize.pkl``: the final policy and its normalisation (written atomically);
- ``checkpoints/step_<n>/``: complete checkpoints (:mod:`agents.checkpoints`: model, VecNormalize, SAC's replay
  buffer, the evaluation history); ``resume=True`` continues from the newest, Ctrl-C writes one and stops;
- ``best/``: the best model by evaluation on held-out seeded tracks (+ VecNormalize, ``best.json``);
- ``eval/evaluations.npz``, ``tb/`` (TensorBoard with the ``uuom/`` scalars of :mod:`agents.callbacks`),
  ``config.json`` (what was trained).

Hyperparameters come from ``agents/hyperparams/<algo>.yml`` (rl-baselines3-zoo layout). Its ``env_wrapper``
entry (shield, residual) is the default set-up, so ``python -m rl_zoo3.train`` and ``uuom-train`` train the same
thing; ``shield`` / ``residual`` override it. Every input is checked in the parent process before any worker
starts (:class:`TrainConfigError`, one line).
"""

from __future__ import annotations

import json
import math
import shutil
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from agents.algos import ALGOS, algo_class
from agents.checkpoints import Checkpoint, atomic_write, atomic_write_text, clean_partial, latest_checkpoint
from agents.hyperparameters import (ENV_ID, NOISE_KEYS, TrainConfigError, action_noise, evaluate_str,
                                    load_hyperparams, resolve_schedules, wrappers_from_env_wrapper)
from uuom_gym.registration import env_kwargs_of

EVAL_SEED_OFFSET = 1_000_000
"""Evaluation tracks during training are drawn from seeds far from the training seeds (held out)."""
_ZOO_ONLY_KEYS = ("frame_stack", "callback", "vec_env_wrapper")


class TrainingInterrupted(Exception):
    """Training stopped by SIGINT after writing a checkpoint (``checkpoint`` holds its directory)."""

    def __init__(self, checkpoint: Path, steps: int) -> None:
        super().__init__(f"interrupted at {steps} steps; checkpoint {checkpoint} (continue with --resume)")
        self.checkpoint = checkpoint
        self.steps = steps


@dataclass
class TrainConfig:
    """One training run (the options of ``uuom-train``).

    ``timesteps`` / ``n_envs`` ``None``: the YAML's ``n_timesteps`` / ``n_envs``. ``shield`` / ``residual``
    ``None``: the YAML's ``env_wrapper``. ``resume``: continue from the newest checkpoint of the run directory
    (required when it has one, unless ``fresh`` starts over). ``env_id``: a registered id; its configuration is
    the base of ``env_kwargs`` (recorded in full in the run's ``config.json``) and its entry of the YAML is read.

    ``init_from``: a run directory or one of its ``checkpoints/step_<n>`` whose policy and VecNormalize this run
    starts from, its step count going on (``timesteps`` is the total): the next leg of a curriculum on another env
    configuration; hyperparameters named in ``hyperparams`` replace the source's (all but the network's), the rest
    stay as it was trained. ``action_std_ceiling`` ``(start, end, steps)``: PPO's action standard deviation may not
    exceed a ceiling falling log-linearly from ``start`` to ``end`` over ``steps`` env steps from this run's first
    step, and ``end`` after (:class:`agents.training_callbacks.ActionStdCeiling`): the mean action must take over what
    the exploration noise did (docs/rl.md §27). ``demo_episodes``: an off-policy learner's replay buffer starts with
    that many episodes of the rule-based controller in the env's action space (:mod:`agents.demonstrations`; bare
    set-up only, a new run only); the demonstrator's steps are not counted in ``timesteps``. ``demo_bc_weight`` > 0
    (SAC with ``demo_episodes`` only): the learner is :class:`agents.demo_bc.SACWithDemoBC`, which also holds the
    policy to the demonstrations where its critic rates them above its own action (a Q-filtered behaviour-cloning
    term of that weight); the saved policy is a plain SAC policy. With PPO (bare set-up), ``demo_bc_weight`` > 0
    makes the learner :class:`agents.ppo_bc.PPOWithDemoBC`: its rollouts are labelled online by the demonstrator
    (:class:`agents.demonstrations.DemonstratorLabels` with ``demonstrator_options``, default
    :data:`agents.dagger.DEFAULT_DEMONSTRATOR_OPTIONS`: the DAgger start's demonstrator) and the policy's mean is held
    to the labels by a term of that weight in PPO's loss; the saved policy is a plain PPO policy.
    """

    algo: str = "ppo"
    observer: str = "dffrls-aekf"
    timesteps: int | None = None
    seed: int = 0
    n_envs: int | None = None
    shield: bool | None = None
    residual: float | None = None
    margin_schedule: tuple[float, float] | None = None
    log_dir: Path = Path("runs")
    run_dir: Path | None = None
    conf_file: Path | None = None
    hyperparams: list[str] = field(default_factory=list)
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    env_id: str = ENV_ID
    eval_freq: int = 50_000
    eval_episodes: int = 3
    checkpoint_freq: int = 25_000
    subproc: bool = True
    progress: bool = True
    fresh: bool = False
    resume: bool = False
    device: str = "cpu"
    init_from: Path | None = None
    action_std_ceiling: tuple[float, float, int] | None = None
    demo_episodes: int = 0
    demo_bc_weight: float = 0.0
    demonstrator_options: dict[str, Any] | None = None


# --- environments --------------------------------------------------------------------------------------------
def wrap_env(env: Any, shield: bool, residual: float = 0.0, margin_schedule: tuple[float, float] | None = None) -> Any:
    """The set-up a policy acts in, around a bare env: shield, then the residual or the margin schedule outside it.

    One place for training (:func:`make_env_fn`) and evaluation (:func:`agents.evaluation.run_episode`), so a policy
    is always evaluated behind the wrappers it was trained behind.
    """
    if shield:
        from agents.shield import ShieldWrapper

        env = ShieldWrapper(env)
    if residual > 0:
        from agents.residual import ResidualWrapper

        env = ResidualWrapper(env, scale=residual)
    if margin_schedule is not None:
        from agents.margin_schedule import MarginScheduleWrapper

        env = MarginScheduleWrapper(env, span=margin_schedule)
    return env


def make_env_fn(observer: str, seed: int, shield: bool, env_kwargs: dict[str, Any], residual: float = 0.0,
                margin_schedule: tuple[float, float] | None = None, demo_labels: dict[str, Any] | None = None):
    """A picklable env factory for SubprocVecEnv: env -> shield -> residual or margin schedule -> Monitor
    (normalisation outside). ``demo_labels`` (demonstrator options): the bare env's steps also carry the
    demonstrator's label (:class:`agents.demonstrations.DemonstratorLabels`)."""

    def _init():
        import multiprocessing

        import gymnasium as gym
        from stable_baselines3.common.monitor import Monitor

        import uuom_gym  # noqa: F401 - registers the env

        if multiprocessing.current_process().name != "MainProcess":
            # Ctrl-C is the parent's to handle (it saves a checkpoint); workers must not die with a traceback.
            signal.signal(signal.SIGINT, signal.SIG_IGN)
        env = wrap_env(gym.make(ENV_ID, observer=observer, **env_kwargs), shield, residual, margin_schedule)
        if demo_labels is not None:
            from agents.demonstrations import DemonstratorLabels

            env = DemonstratorLabels(env, **demo_labels)
        env = Monitor(env, info_keywords=("is_success",))
        env.reset(seed=seed)
        return env

    return _init


def make_vec_env(
    observer: str, seed: int, n_envs: int, shield: bool, env_kwargs: dict[str, Any], subproc: bool,
    residual: float = 0.0, margin_schedule: tuple[float, float] | None = None,
    demo_labels: dict[str, Any] | None = None,
):
    """``n_envs`` envs with seeds ``seed, seed + 1, ...`` (SubprocVecEnv if ``subproc`` and ``n_envs > 1``)."""
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    fns = [make_env_fn(observer, seed + i, shield, env_kwargs, residual, margin_schedule, demo_labels)
           for i in range(n_envs)]
    if subproc and n_envs > 1:
        return SubprocVecEnv(fns, start_method="fork" if sys.platform.startswith("linux") else "spawn")
    return DummyVecEnv(fns)


def run_dir_name(algo: str, observer: str, seed: int, shield: bool, residual: float = 0.0, margin: bool = False) -> str:
    """``<algo>_<observer>[_res][_margin][_shield]_s<seed>``."""
    return (f"{algo}_{observer}{'_res' if residual > 0 else ''}{'_margin' if margin else ''}"
            f"{'_shield' if shield else ''}_s{seed}")


# --- validation ----------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _Plan:
    """A validated :class:`TrainConfig` with the YAML's defaults filled in."""

    total: int
    n_envs: int
    shield: bool
    residual: float
    policy: str
    normalize: dict[str, Any] | None
    hp: dict[str, Any]
    run_dir: Path
    env_kwargs: dict[str, Any]  # the env id's registered configuration with the config's on top
    margin_schedule: tuple[float, float] | None = None


def plan(config: TrainConfig) -> _Plan:
    """Check every input and fill in the YAML defaults; nothing is created.

    Raises
    ------
    TrainConfigError
        The first input that cannot work, named.
    """
    c = config
    if c.algo not in ALGOS:
        raise TrainConfigError(f"unknown algo {c.algo!r}; choose one of {', '.join(ALGOS)}")
    for name in ("timesteps", "n_envs"):
        v = getattr(c, name)
        if v is not None and (isinstance(v, bool) or not isinstance(v, int) or v < 1):
            raise TrainConfigError(f"{name} must be a whole number >= 1, got {v!r}")
    if isinstance(c.seed, bool) or not isinstance(c.seed, int) or c.seed < 0:
        # the env's reset() refuses a negative seed, inside the workers (a ConnectionResetError, not a message)
        raise TrainConfigError(f"seed must be a whole number >= 0, got {c.seed!r}")
    for name in ("eval_freq", "checkpoint_freq"):
        if getattr(c, name) < 0:
            raise TrainConfigError(f"{name} must be >= 0 (0: never), got {getattr(c, name)!r}")
    if c.eval_episodes < 1:
        raise TrainConfigError(f"eval_episodes must be >= 1, got {c.eval_episodes!r}")
    if c.residual is not None and not (c.residual == 0.0 or 0.0 < c.residual <= 2.0):
        raise TrainConfigError(f"residual must be 0 (off) or in (0, 2], got {c.residual!r}")
    margin_schedule = None
    if c.margin_schedule is not None:
        from agents.margin_schedule import check_span

        try:
            margin_schedule = check_span(c.margin_schedule)
        except ValueError as exc:
            raise TrainConfigError(str(exc)) from None
    if c.fresh and c.resume:
        raise TrainConfigError("fresh and resume exclude each other")
    if c.init_from is not None and not (Path(c.init_from) / "model.zip").is_file():
        raise TrainConfigError(f"init_from {str(c.init_from)!r}: no model.zip there (a run directory or a "
                               "checkpoints/step_<n> directory)")
    if c.action_std_ceiling is not None:
        start, end, steps = c.action_std_ceiling
        from stable_baselines3 import PPO

        if not issubclass(algo_class(c.algo), PPO):  # the ceiling caps PPO's state-independent log_std
            raise TrainConfigError(f"action_std_ceiling: {c.algo.upper()} has no state-independent action std "
                                   "(PPO only)")
        from agents.training_callbacks import ActionStdCeiling

        try:
            ActionStdCeiling.check(start, end, steps)
        except ValueError as exc:
            raise TrainConfigError(f"action_std_ceiling {exc}") from None
    if not isinstance(c.env_kwargs, dict):
        raise TrainConfigError(f"env_kwargs must be a JSON object, got {c.env_kwargs!r}")
    if isinstance(c.demo_episodes, bool) or not isinstance(c.demo_episodes, int) or c.demo_episodes < 0:
        raise TrainConfigError(f"demo_episodes must be a whole number >= 0, got {c.demo_episodes!r}")
    if (isinstance(c.demo_bc_weight, bool) or not isinstance(c.demo_bc_weight, (int, float))
            or not math.isfinite(c.demo_bc_weight) or c.demo_bc_weight < 0):
        raise TrainConfigError(f"demo_bc_weight must be a finite number >= 0, got {c.demo_bc_weight!r}")
    if c.demo_bc_weight > 0 and c.algo not in ("sac", "ppo"):
        raise TrainConfigError(f"demo_bc_weight: a behaviour-cloning term is SAC's (on --demo-episodes) or PPO's (on "
                               f"online labels); got --algo {c.algo}")
    if c.demo_bc_weight > 0 and c.algo == "sac" and not c.demo_episodes:
        raise TrainConfigError("demo_bc_weight: SAC's behaviour-cloning term is on its demonstrations "
                               f"(--demo-episodes N > 0); got --algo sac, --demo-episodes {c.demo_episodes}")
    if c.demonstrator_options is not None and not (c.algo == "ppo" and c.demo_bc_weight > 0):
        raise TrainConfigError("demonstrator_options: the online labeller of PPO's behaviour-cloning term "
                               "(--algo ppo --demo-bc W > 0) is the only demonstrator it sets")
    if c.demonstrator_options is not None and not isinstance(c.demonstrator_options, dict):
        raise TrainConfigError(f"demonstrator_options must be a JSON object, got {c.demonstrator_options!r}")
    try:
        env_kwargs = {**env_kwargs_of(c.env_id), **c.env_kwargs}
    except ValueError as exc:
        raise TrainConfigError(str(exc)) from None
    # the learner's own arguments (PPOWithDemoBC's pg_coef) may be named in --hyperparams
    hp = load_hyperparams(c.algo, c.conf_file, c.hyperparams, c.env_id, learner_class(c))
    n_envs = c.n_envs if c.n_envs is not None else hp.pop("n_envs", 1)
    total = c.timesteps if c.timesteps is not None else hp.pop("n_timesteps", 100_000)
    hp.pop("n_envs", None)
    hp.pop("n_timesteps", None)
    n_envs, total = _whole(n_envs, "n_envs"), _whole(total, "n_timesteps")
    yaml_shield, yaml_residual = wrappers_from_env_wrapper(hp.pop("env_wrapper", None))
    shield = yaml_shield if c.shield is None else bool(c.shield)
    residual = yaml_residual if c.residual is None else float(c.residual)
    if margin_schedule is not None and residual > 0:
        raise TrainConfigError("a margin schedule and a residual both set the command from the rule-based controller: "
                               "pass --residual 0 with --margin-schedule")
    normalize = evaluate_str(hp.pop("normalize", False), "normalize")
    if not isinstance(normalize, (bool, dict)):
        raise TrainConfigError(f"hyperparameter normalize must be a bool or a dict, got {normalize!r}")
    norm_kwargs = normalize if isinstance(normalize, dict) else ({} if normalize else None)
    policy = hp.pop("policy", "MlpPolicy")
    if "policy_kwargs" in hp:
        hp["policy_kwargs"] = evaluate_str(hp["policy_kwargs"], "policy_kwargs")
    for key in _ZOO_ONLY_KEYS:
        hp.pop(key, None)
    resolve_schedules(hp, 0, 1)  # a malformed lin_<value> fails here, before any env starts
    if action_noise(dict(hp), 1) is not None and c.algo not in _off_policy_algos():
        raise TrainConfigError(f"hyperparameters noise_type / noise_std: {c.algo} takes no action noise "
                               f"({', '.join(_off_policy_algos())})")
    labels = demo_label_options(c)
    if labels is not None and (shield or residual > 0 or margin_schedule is not None):
        raise TrainConfigError("demo_bc_weight: the demonstrator labels the bare env's action; pass --residual 0 "
                               "--no-shield (and no margin schedule)")
    # with labels the one env built here also builds the labeller: a bad option or action mode fails here
    action_mode = _check_env(c.observer, env_kwargs, shield, residual, margin_schedule, labels)
    if c.demo_episodes:
        _check_demonstrations(c, action_mode, shield, residual, margin_schedule)
    run_dir = Path(c.run_dir) if c.run_dir is not None else Path(c.log_dir) / run_dir_name(
        c.algo, c.observer, c.seed, shield, residual, margin_schedule is not None)
    return _Plan(total, n_envs, shield, residual, policy, norm_kwargs, hp, run_dir, env_kwargs, margin_schedule)


def _whole(v: Any, name: str) -> int:
    if isinstance(v, float) and v.is_integer():
        v = int(v)
    if isinstance(v, bool) or not isinstance(v, int) or v < 1:
        raise TrainConfigError(f"{name} must be a whole number >= 1, got {v!r}")
    return v


def _check_env(observer: str, env_kwargs: dict[str, Any], shield: bool, residual: float,
               margin_schedule: tuple[float, float] | None = None, demo_labels: dict[str, Any] | None = None) -> str:
    """Build the env once in this process: a bad observer, env or labeller option fails here, not in every worker.
    Returns its ``action_mode``."""
    try:
        env = make_env_fn(observer, 0, shield, env_kwargs, residual, margin_schedule, demo_labels)()
    except (ValueError, TypeError, KeyError) as exc:
        raise TrainConfigError(str(exc).splitlines()[0] if str(exc) else type(exc).__name__) from None
    mode = env.unwrapped.config["action_mode"]
    env.close()
    return mode


def _off_policy_algos() -> list[str]:
    from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm

    return [a for a in ALGOS if issubclass(algo_class(a), OffPolicyAlgorithm)]


def _check_demonstrations(c: TrainConfig, action_mode: str, shield: bool, residual: float,
                          margin_schedule: tuple[float, float] | None) -> None:
    if c.algo not in _off_policy_algos():
        raise TrainConfigError(f"demo_episodes: {c.algo} has no replay buffer (an off-policy algorithm: "
                               f"{', '.join(_off_policy_algos())})")
    if shield or residual > 0 or margin_schedule is not None:
        raise TrainConfigError("demo_episodes: the demonstrator acts in the bare env's action space; pass --residual 0 "
                               "--no-shield (and no margin schedule)")
    if c.init_from is not None:
        raise TrainConfigError("demo_episodes: a run started from init_from keeps its source's learner; seed the "
                               "buffer of a new run only")
    from agents.demonstrations import demonstrator_class

    try:
        demonstrator_class(action_mode)
    except ValueError as exc:
        raise TrainConfigError(str(exc)) from None


def learner_class(config: TrainConfig) -> type:
    """The class that trains: the algorithm's (:func:`agents.algos.algo_class`), or its behaviour-cloning subclass
    when ``demo_bc_weight`` > 0 (SAC: :class:`agents.demo_bc.SACWithDemoBC`, PPO:
    :class:`agents.ppo_bc.PPOWithDemoBC`)."""
    if config.demo_bc_weight and config.algo == "sac":
        from agents.demo_bc import SACWithDemoBC

        return SACWithDemoBC
    if config.demo_bc_weight and config.algo == "ppo":
        from agents.ppo_bc import PPOWithDemoBC

        return PPOWithDemoBC
    return algo_class(config.algo)


def demo_label_options(config: TrainConfig) -> dict[str, Any] | None:
    """The demonstrator options of the online labeller (PPO with ``demo_bc_weight`` > 0), else ``None``."""
    if config.algo != "ppo" or not config.demo_bc_weight:
        return None
    from agents.dagger import DEFAULT_DEMONSTRATOR_OPTIONS

    opts = config.demonstrator_options
    return dict(DEFAULT_DEMONSTRATOR_OPTIONS if opts is None else opts)


# --- training ------------------------------------------------------------------------------------------------
def train(config: TrainConfig) -> Path:
    """Run (or, with ``config.resume``, continue) one training; return the run directory.

    Raises
    ------
    TrainConfigError
        Bad input (checked before anything is created or any worker starts).
    TrainingInterrupted
        SIGINT: a checkpoint was written and training stopped.
    """
    p = plan(config)
    run_dir = p.run_dir
    ckpt_dir = run_dir / "checkpoints"
    if config.fresh and run_dir.exists():
        shutil.rmtree(run_dir)
    clean_partial(run_dir)
    resume = latest_checkpoint(ckpt_dir)
    if config.resume and resume is None:
        raise TrainConfigError(f"nothing to resume: {ckpt_dir} holds no complete checkpoint")
    if resume is not None and not config.resume:
        raise TrainConfigError(
            f"{run_dir} already has a checkpoint at {resume.steps} steps: pass --resume to continue it or --fresh "
            "to start over"
        )
    record = {
        "algo": config.algo, "observer": config.observer, "seed": config.seed, "n_envs": p.n_envs,
        "timesteps": p.total, "shield": p.shield, "residual": p.residual, "env_kwargs": p.env_kwargs,
        **({"margin_schedule": list(p.margin_schedule)} if p.margin_schedule is not None else {}),
        "hyperparams": {k: repr(v) for k, v in p.hp.items()}, "normalize": p.normalize,
        **({"demo_episodes": config.demo_episodes} if config.demo_episodes else {}),
        **({"demo_bc_weight": float(config.demo_bc_weight)} if config.demo_bc_weight else {}),
        **({"demonstrator_options": labels} if (labels := demo_label_options(config)) is not None else {}),
    }
    init = None
    if config.init_from is not None:
        saved = _saved_data(Path(config.init_from) / "model.zip")
        init = Checkpoint(Path(config.init_from), int(saved.get("num_timesteps", 0)))
        if p.total <= init.steps:
            raise TrainConfigError(f"timesteps ({p.total}) is the total: it must exceed init_from's step count "
                                   f"({init.steps})")
        record.update(init_from=str(config.init_from), init_steps=init.steps)
        fixed = [k for k in _named_hyperparams(config) if k in _FIXED_BY_INIT]
        if fixed and resume is None:  # before any env starts
            raise TrainConfigError(f"--hyperparams {fixed[0]}: cannot change the network of init_from "
                                   f"{config.init_from}")
        noise = _leg_noise(config, p, saved.get("action_noise"))
        p.hp.update(noise)  # recorded as run: the noise key not named is the source's, not the YAML's
        record["hyperparams"].update({k: repr(v) for k, v in noise.items()})
    if config.action_std_ceiling is not None:
        start, end, steps = config.action_std_ceiling
        record["action_std_ceiling"] = [float(start), float(end), int(steps)]
    if resume is not None:
        _check_same_run(run_dir, record)
    return _learn(config, p, record, resume, init)


_FIXED_BY_INIT = ("policy", "policy_kwargs")
"""Hyperparameters that shape the network: a run started from another run's policy cannot change them."""


def _named_hyperparams(config: TrainConfig) -> list[str]:
    """The keys given on the command line (``--hyperparams key=value ...``)."""
    return [item.split("=", 1)[0] for item in config.hyperparams]


def _init_overrides(config: TrainConfig, p: _Plan, first_step: int) -> dict[str, Any]:
    """The hyperparameters named on the command line (``--hyperparams``) of a run started with ``init_from``:
    they replace the source model's (its learning rate, rollout length, ...); the rest stay as it was trained
    (:func:`train` refused the network's, :data:`_FIXED_BY_INIT`). A ``lin_<value>`` schedule falls over this
    run's steps, from the source's step count ``first_step`` to ``p.total``."""
    # n_envs, n_timesteps, normalize and env_wrapper are not model attributes: plan() took them out of p.hp
    named = {k for k in _named_hyperparams(config) if k in p.hp}
    if named & set(NOISE_KEYS):
        named |= set(NOISE_KEYS)  # train() completed the one not named from the source (_leg_noise)
    return _model_kwargs({k: p.hp[k] for k in named}, first_step, p.total)


def _leg_noise(config: TrainConfig, p: _Plan, source: Any) -> dict[str, Any]:
    """The action noise of a run started from ``init_from`` when ``--hyperparams`` name ``noise_type`` and/or
    ``noise_std`` (else ``{}``): the keys named, the other one the source's where it has noise (a leg that lowers
    the std keeps the source's kind of noise), else the YAML's. plan() saw both keys in ``p.hp``."""
    named = [k for k in _named_hyperparams(config) if k in NOISE_KEYS]
    if not named:
        return {}
    from stable_baselines3.common.noise import OrnsteinUhlenbeckActionNoise

    source = getattr(source, "base_noise", source)  # SB3 vectorises the noise over the envs
    kept = {} if source is None else {
        "noise_type": "ornstein-uhlenbeck" if isinstance(source, OrnsteinUhlenbeckActionNoise) else "normal",
        "noise_std": float(source._sigma[0]),
    }
    return {k: p.hp[k] if k in named or k not in kept else kept[k] for k in NOISE_KEYS}


def _model_kwargs(hp: dict[str, Any], first_step: int, total: int) -> dict[str, Any]:
    """The SB3 constructor / ``load`` arguments of ``hp``: schedules resolved, rl-zoo's action noise built."""
    kwargs = resolve_schedules(hp, first_step, total)
    noise = action_noise(kwargs, 1)  # the env's action is one number (UUOM-Track-v0's Action Space)
    if noise is not None:
        kwargs["action_noise"] = noise
    return kwargs


def _saved_data(model_zip: Path) -> dict[str, Any]:
    """The ``data`` entry of a saved SB3 model (step count, action noise, ...; the parameters are not loaded)."""
    from stable_baselines3.common.save_util import load_from_zip_file

    try:
        data, _, _ = load_from_zip_file(model_zip, load_data=True, device="cpu", print_system_info=False)
    except Exception as exc:  # a zip SB3 cannot read: name the file, not SB3's internals
        raise TrainConfigError(f"init_from: {model_zip} is not a saved SB3 model ({type(exc).__name__})") from None
    return data or {}


def _check_same_run(run_dir: Path, record: dict[str, Any]) -> None:
    path = run_dir / "config.json"
    if not path.exists():
        return
    old = json.loads(path.read_text())
    # absent from a record when off: off is a change too
    for k in ("demo_episodes", "demo_bc_weight", "demonstrator_options"):
        if k in old and k not in record:
            raise TrainConfigError(f"--resume with a different {k} ({old[k]!r} in {path}, now off)")
    # The step budget may grow on resume; everything that defines the task and the learner must not change.
    diff = [k for k in record if k not in ("timesteps",) and k in old and old[k] != json.loads(json.dumps(record[k]))]
    if diff:
        k = diff[0]
        raise TrainConfigError(f"--resume with a different {k} ({old[k]!r} in {path}, now {record[k]!r})")


def _learn(config: TrainConfig, p: _Plan, record: dict[str, Any], resume: Any, init: Any = None) -> Path:
    import torch
    from stable_baselines3.common.callbacks import CallbackList
    from stable_baselines3.common.vec_env import VecNormalize

    from agents.callbacks import UUOMMetricsCallback
    from agents.training_callbacks import ActionStdCeiling, CheckpointEvery, HistoryEvalCallback, StopFlag

    torch.set_num_threads(1)  # the env processes need the cores; small MLPs gain nothing from threads
    run_dir, ckpt_dir = p.run_dir, p.run_dir / "checkpoints"
    cls = learner_class(config)
    bc = {"bc_weight": float(config.demo_bc_weight)} if config.demo_bc_weight else {}
    venv = make_vec_env(config.observer, config.seed, p.n_envs, p.shield, p.env_kwargs, config.subproc, p.residual,
                        p.margin_schedule, demo_label_options(config))
    eval_venv = None
    start = resume if resume is not None else init
    try:
        if start is not None:
            if p.normalize is not None:
                if start.vecnormalize is None:
                    raise TrainConfigError(f"checkpoint {start.path} has no vecnormalize.pkl")
                venv = VecNormalize.load(str(start.vecnormalize), venv)
                venv.training = True
            model = cls.load(start.model, env=venv, device=config.device, **bc,
                             **(_init_overrides(config, p, record["init_steps"]) if resume is None else {}))
            if start.replay_buffer is not None and hasattr(model, "load_replay_buffer"):
                model.load_replay_buffer(start.replay_buffer)
            if resume is None and model.seed != config.seed:
                # SB3's load seeds every generator and the envs with the source's seed; --seed must count for a new
                # run (with the source's seed nothing changes, so a chain run before this line reproduces)
                model.seed = config.seed
                model.set_random_seed(config.seed)
            print(f"{'resuming' if resume is not None else 'starting'} from {start.path} at {model.num_timesteps} "
                  "steps", flush=True)
        else:
            if p.normalize is not None:
                venv = VecNormalize(venv, **p.normalize)
            try:
                model = cls(p.policy, venv, seed=config.seed, device=config.device, verbose=0,
                            **_model_kwargs(p.hp, 0, p.total), **bc)
            except (TypeError, ValueError, AssertionError) as exc:
                raise TrainConfigError(f"{config.algo} rejects the hyperparameters: {exc}") from None
        run_dir.mkdir(parents=True, exist_ok=True)
        atomic_write_text(run_dir / "config.json", json.dumps(record, indent=2))
        if config.demo_episodes and (start is None or config.demo_bc_weight):
            from agents.demonstrations import seed_replay_buffer

            t_demo = time.time()
            # a resumed BC run rebuilds the demonstration buffer it does not save; its replay buffer has them
            demo = seed_replay_buffer(model, config.observer, p.env_kwargs, config.demo_episodes, config.seed,
                                      into_replay=start is None)
            demo["seconds"] = round(time.time() - t_demo, 1)
            atomic_write_text(run_dir / "demonstrations.json", json.dumps(demo, indent=2))
            print(f"replay buffer seeded: {demo['episodes']} demonstrator episodes ({demo['arrived']} arrived), "
                  f"{demo['transitions']} transitions in {demo['seconds']} s", flush=True)
        model.tensorboard_log = str(run_dir / "tb")
        eval_cb = None
        if config.eval_freq > 0:
            eval_venv = make_vec_env(config.observer, config.seed + EVAL_SEED_OFFSET, 1, p.shield, p.env_kwargs,
                                     False, p.residual, p.margin_schedule)
            if p.normalize is not None:
                kw = {k: v for k, v in p.normalize.items() if k not in ("norm_reward", "training")}
                eval_venv = VecNormalize(eval_venv, training=False, norm_reward=False, **kw)
            eval_cb = HistoryEvalCallback(
                eval_venv, n_eval_episodes=config.eval_episodes, eval_freq=max(config.eval_freq // p.n_envs, 1),
                best_model_save_path=str(run_dir / "best"), log_path=str(run_dir / "eval"),
                deterministic=True,
            )
            if resume is not None:
                eval_cb.restore(resume.state())
        is_off_policy = hasattr(model, "replay_buffer")
        ckpt = CheckpointEvery(max(config.checkpoint_freq // p.n_envs, 1) if config.checkpoint_freq else 0,
                               ckpt_dir, eval_cb, replay_buffer=is_off_policy)
        stop = StopFlag()
        callbacks = [UUOMMetricsCallback(), stop] + ([eval_cb] if eval_cb is not None else [])
        if config.action_std_ceiling is not None:
            callbacks.append(ActionStdCeiling(*config.action_std_ceiling, first_step=record.get("init_steps", 0)))
        if config.checkpoint_freq:
            callbacks.append(ckpt)
        remaining = p.total - model.num_timesteps
        t0 = time.time()
        previous = signal.getsignal(signal.SIGINT)

        def _on_sigint(signum: int, frame: Any) -> None:
            stop.stop = True
            signal.signal(signal.SIGINT, previous)  # a second Ctrl-C aborts at once

        # a Ray Tune trial runs in a worker thread, where handlers cannot be installed (Tune stops it instead)
        in_main = threading.current_thread() is threading.main_thread()
        if in_main:
            signal.signal(signal.SIGINT, _on_sigint)
        try:
            if remaining > 0:
                model.learn(total_timesteps=remaining, callback=CallbackList(callbacks),
                            progress_bar=config.progress and _has_progress_deps(),
                            reset_num_timesteps=start is None, tb_log_name="run")
        finally:
            if in_main:
                signal.signal(signal.SIGINT, previous)
        if stop.stop:
            ckpt.model = model
            path = ckpt.save()
            raise TrainingInterrupted(path, int(model.num_timesteps))
        atomic_write(run_dir / "model.zip", lambda f: model.save(f))
        if isinstance(model.get_env(), VecNormalize):
            atomic_write(run_dir / "vecnormalize.pkl", lambda f: model.get_env().save(str(f)))
        print(f"trained {model.num_timesteps} steps in {time.time() - t0:.0f} s -> {run_dir}", flush=True)
        return run_dir
    finally:
        venv.close()
        if eval_venv is not None:
            eval_venv.close()


def _has_progress_deps() -> bool:
    try:
        import rich  # noqa: F401
        import tqdm  # noqa: F401
    except ImportError:
        return False
    return True


__all__ = [
    "ENV_ID",
    "EVAL_SEED_OFFSET",
    "TrainConfig",
    "TrainConfigError",
    "TrainingInterrupted",
    "load_hyperparams",
    "make_env_fn",
    "make_vec_env",
    "plan",
    "run_dir_name",
    "train",
    "wrappers_from_env_wrapper",
]
