#!/usr/bin/env python
"""Train a speed controller on ``UUOM-Track-v0`` (PPO, SAC or PPO-Lagrangian, optionally behind the shield).

Example::

    python scripts/train.py --algo ppo --observer dffrls-aekf --timesteps 300000 --seed 0 --n-envs 2

Writes ``<log-dir>/<algo>_<observer>[_shield]_s<seed>/``:

- ``model.zip`` + ``vecnormalize.pkl``: the final policy and its observation/reward normalisation, saved
  together (``scripts/evaluate.py --model <run dir>`` loads both);
- ``checkpoints/``: periodic model + VecNormalize checkpoints; rerunning the same command resumes from the
  newest one (after an interruption) and trains only the remaining steps;
- ``best/``: the best model by EvalCallback on held-out seeded tracks (+ its VecNormalize stats);
- ``tb/``: TensorBoard logs with the ``uuom/`` custom scalars (cost rate, violations per km by rule, trip time,
  energy, estimator error; see :mod:`agents.callbacks`);
- ``config.json``: the arguments and hyperparameters used.

Hyperparameters come from ``agents/hyperparams/<algo>.yml`` (rl-baselines3-zoo layout), overridable with
``--hyperparams key=value ...``.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from agents.algos import ALGOS, algo_class  # noqa: E402

ENV_ID = "UUOM-Track-v0"
EVAL_SEED_OFFSET = 1_000_000
"""Evaluation tracks during training are drawn from seeds far from the training seeds (held out)."""


def load_hyperparams(algo: str, conf_file: Path | None, overrides: list[str]) -> dict[str, Any]:
    """Read the rl-zoo-style YAML entry for ``UUOM-Track-v0`` and apply ``key=value`` overrides."""
    path = conf_file or ROOT / "agents" / "hyperparams" / f"{algo}.yml"
    if not path.exists():
        raise SystemExit(f"hyperparameter file not found: {path}")
    data = yaml.load(path.read_text(), Loader=yaml.UnsafeLoader)  # rl-zoo files use !!float tags
    if ENV_ID not in data:
        raise SystemExit(f"{path} has no '{ENV_ID}' entry (keys: {', '.join(data)})")
    hp = dict(data[ENV_ID])
    for item in overrides:
        if "=" not in item:
            raise SystemExit(f"--hyperparams expects key=value, got {item!r}")
        k, v = item.split("=", 1)
        hp[k] = yaml.safe_load(v)
    return hp


def _evaluate_str(value: Any) -> Any:
    # rl-zoo stores policy_kwargs / normalize as Python expressions in strings.
    if isinstance(value, str):
        return eval(value, {"dict": dict, "True": True, "False": False})  # noqa: S307 - our own config file
    return value


def make_env_fn(observer: str, seed: int, shield: bool, env_kwargs: dict[str, Any], residual: float = 0.0):
    """A picklable env factory for SubprocVecEnv: env -> shield -> residual -> Monitor (normalisation outside)."""

    def _init():
        import gymnasium as gym
        from stable_baselines3.common.monitor import Monitor

        import uuom_gym  # noqa: F401 - registers the env

        env = gym.make(ENV_ID, observer=observer, **env_kwargs)
        if shield:
            from agents.shield import ShieldWrapper

            env = ShieldWrapper(env)
        if residual > 0:
            from agents.residual import ResidualWrapper

            env = ResidualWrapper(env, scale=residual)
        env = Monitor(env, info_keywords=("is_success",))
        env.reset(seed=seed)
        return env

    return _init


def make_vec_env(
    observer: str, seed: int, n_envs: int, shield: bool, env_kwargs: dict[str, Any], subproc: bool,
    residual: float = 0.0,
):
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    fns = [make_env_fn(observer, seed + i, shield, env_kwargs, residual) for i in range(n_envs)]
    if subproc and n_envs > 1:
        return SubprocVecEnv(fns, start_method="fork" if sys.platform.startswith("linux") else "spawn")
    return DummyVecEnv(fns)


def latest_checkpoint(ckpt_dir: Path) -> tuple[Path, Path | None, int] | None:
    """Newest ``model_<n>_steps.zip`` in a checkpoint directory, its VecNormalize file and step count."""
    best: tuple[Path, Path | None, int] | None = None
    for p in ckpt_dir.glob("model_*_steps.zip"):
        m = re.fullmatch(r"model_(\d+)_steps\.zip", p.name)
        if not m:
            continue
        n = int(m.group(1))
        if best is None or n > best[2]:
            vn = ckpt_dir / f"model_vecnormalize_{n}_steps.pkl"
            best = (p, vn if vn.exists() else None, n)
    return best


def run_dir_name(algo: str, observer: str, seed: int, shield: bool, residual: float = 0.0) -> str:
    return f"{algo}_{observer}{'_res' if residual > 0 else ''}{'_shield' if shield else ''}_s{seed}"


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--algo", choices=ALGOS, default="ppo")
    ap.add_argument("--observer", default="dffrls-aekf", help="estimator name, 'oracle' or 'none'")
    ap.add_argument("--timesteps", type=int, default=None, help="total env steps (default: n_timesteps of the YAML)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n-envs", type=int, default=None, help="parallel envs (default: n_envs of the YAML)")
    ap.add_argument("--shield", action=argparse.BooleanOptionalAction, default=True,
                    help="filter every action through agents.shield (default on; --no-shield for the bare policy)")
    ap.add_argument("--residual", type=float, default=0.5, metavar="SCALE",
                    help="residual policy on top of the rule-based controller with this authority (default 0.5; "
                    "0: the policy commands the train alone)")
    ap.add_argument("--log-dir", type=Path, default=ROOT / "runs")
    ap.add_argument("--run-dir", type=Path, default=None, help="explicit run directory (overrides --log-dir naming)")
    ap.add_argument("--conf-file", type=Path, default=None, help="rl-zoo style YAML (default agents/hyperparams/<algo>.yml)")
    ap.add_argument("--hyperparams", nargs="*", default=[], metavar="KEY=VALUE")
    ap.add_argument("--env-kwargs", type=json.loads, default={}, help='JSON dict of env config, e.g. \'{"track_length_m": [100, 200]}\'')
    ap.add_argument("--eval-freq", type=int, default=50_000, help="env steps between evaluations (0: none)")
    ap.add_argument("--eval-episodes", type=int, default=3)
    ap.add_argument("--checkpoint-freq", type=int, default=25_000, help="env steps between checkpoints")
    ap.add_argument("--no-subproc", action="store_true", help="DummyVecEnv instead of SubprocVecEnv")
    ap.add_argument("--no-progress", action="store_true", help="no progress bar")
    ap.add_argument("--fresh", action="store_true", help="ignore existing checkpoints and start over")
    ap.add_argument("--device", default="cpu")
    return ap.parse_args(argv)


def train(args: argparse.Namespace) -> Path:
    """Run (or resume) one training; return the run directory."""
    import torch
    from stable_baselines3.common.callbacks import CallbackList, CheckpointCallback, EvalCallback
    from stable_baselines3.common.vec_env import VecNormalize

    from agents.callbacks import UUOMMetricsCallback

    torch.set_num_threads(1)  # the env processes need the cores; small MLPs gain nothing from threads
    hp = load_hyperparams(args.algo, args.conf_file, args.hyperparams)
    n_envs = int(args.n_envs or hp.pop("n_envs", 1))
    hp.pop("n_envs", None)
    total = int(args.timesteps or hp.pop("n_timesteps", 100_000))
    hp.pop("n_timesteps", None)
    normalize = _evaluate_str(hp.pop("normalize", False))
    norm_kwargs = normalize if isinstance(normalize, dict) else ({} if normalize else None)
    policy = hp.pop("policy", "MlpPolicy")
    if "policy_kwargs" in hp:
        hp["policy_kwargs"] = _evaluate_str(hp["policy_kwargs"])
    for key in ("env_wrapper", "frame_stack", "callback", "vec_env_wrapper"):
        hp.pop(key, None)

    run_dir = args.run_dir or args.log_dir / run_dir_name(args.algo, args.observer, args.seed, args.shield, args.residual)
    ckpt_dir = run_dir / "checkpoints"
    if args.fresh and run_dir.exists():
        shutil.rmtree(run_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    (run_dir / "config.json").write_text(
        json.dumps(
            {
                "algo": args.algo,
                "observer": args.observer,
                "seed": args.seed,
                "n_envs": n_envs,
                "timesteps": total,
                "shield": args.shield,
                "residual": args.residual,
                "env_kwargs": args.env_kwargs,
                "hyperparams": {k: repr(v) for k, v in hp.items()},
                "normalize": norm_kwargs,
            },
            indent=2,
        )
    )

    venv = make_vec_env(
        args.observer, args.seed, n_envs, args.shield, args.env_kwargs, not args.no_subproc, args.residual
    )
    eval_venv = make_vec_env(
        args.observer, args.seed + EVAL_SEED_OFFSET, 1, args.shield, args.env_kwargs, False, args.residual
    )
    cls = algo_class(args.algo)
    resume = None if args.fresh else latest_checkpoint(ckpt_dir)
    if resume is not None:
        model_path, vn_path, done_steps = resume
        if norm_kwargs is not None:
            if vn_path is None:
                raise SystemExit(f"checkpoint {model_path} has no VecNormalize stats next to it")
            venv = VecNormalize.load(str(vn_path), venv)
            venv.training = True
        model = cls.load(model_path, env=venv, device=args.device)
        print(f"resuming from {model_path} at {model.num_timesteps} steps", flush=True)
    else:
        if norm_kwargs is not None:
            venv = VecNormalize(venv, **norm_kwargs)
        model = cls(policy, venv, seed=args.seed, device=args.device, verbose=0, tensorboard_log=str(run_dir / "tb"), **hp)
    if norm_kwargs is not None:
        eval_venv = VecNormalize(eval_venv, training=False, norm_reward=False, **{k: v for k, v in norm_kwargs.items() if k not in ("norm_reward", "training")})
    model.tensorboard_log = str(run_dir / "tb")

    callbacks = [
        UUOMMetricsCallback(),
        CheckpointCallback(
            save_freq=max(args.checkpoint_freq // n_envs, 1),
            save_path=str(ckpt_dir),
            name_prefix="model",
            save_vecnormalize=norm_kwargs is not None,
        ),
    ]
    if args.eval_freq > 0:
        callbacks.append(
            _SyncEvalCallback(
                eval_venv,
                n_eval_episodes=args.eval_episodes,
                eval_freq=max(args.eval_freq // n_envs, 1),
                best_model_save_path=str(run_dir / "best"),
                log_path=str(run_dir / "eval"),
                deterministic=True,
            )
        )
    remaining = total - model.num_timesteps
    t0 = time.time()
    if remaining > 0:
        model.learn(
            total_timesteps=remaining,
            callback=CallbackList(callbacks),
            progress_bar=not args.no_progress,
            reset_num_timesteps=resume is None,
            tb_log_name="run",
        )
    model.save(run_dir / "model.zip")
    if isinstance(model.get_env(), VecNormalize):
        model.get_env().save(str(run_dir / "vecnormalize.pkl"))
    venv.close()
    eval_venv.close()
    print(f"trained {model.num_timesteps} steps in {time.time() - t0:.0f} s -> {run_dir}", flush=True)
    return run_dir


def _sync_eval_callback_cls():
    from stable_baselines3.common.callbacks import EvalCallback
    from stable_baselines3.common.vec_env import VecNormalize

    class SyncEvalCallback(EvalCallback):
        """EvalCallback that also saves the VecNormalize stats next to the best model."""

        def _on_step(self) -> bool:
            best_before = self.best_mean_reward
            ok = super()._on_step()
            if self.best_mean_reward > best_before and self.best_model_save_path is not None:
                env = self.model.get_env()
                if isinstance(env, VecNormalize):
                    env.save(str(Path(self.best_model_save_path) / "vecnormalize.pkl"))
            return ok

    return SyncEvalCallback


def _SyncEvalCallback(*a, **kw):  # noqa: N802 - factory keeps the SB3 import lazy
    return _sync_eval_callback_cls()(*a, **kw)


def main(argv: list[str] | None = None) -> int:
    train(parse_args(argv))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
