"""Command-line front ends ``uuom-train`` and ``uuom-evaluate`` (``scripts/train.py`` / ``scripts/evaluate.py``
call the same functions).

Bad input gives one line ``uuom-train: error: ...`` and exit status 2; Ctrl-C during training writes a checkpoint,
prints one line and exits with 130 (continue with ``--resume``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any, NoReturn

from agents.algos import ALGOS
from uuom_gym.registration import ENV_IDS, env_kwargs_of


class _Parser(argparse.ArgumentParser):
    """argparse, but an error is one line (``prog: error: ... (see --help)``) and exit status 2."""

    def error(self, message: str) -> NoReturn:  # type: ignore[override]
        self.exit(2, f"{self.prog}: error: {message} (see --help)\n")


def _json_object(text: str) -> dict[str, Any]:
    try:
        value = json.loads(text)
    except json.JSONDecodeError as exc:
        raise argparse.ArgumentTypeError(f"not JSON ({exc.msg} at column {exc.colno}): {text!r}") from None
    if not isinstance(value, dict):
        raise argparse.ArgumentTypeError(f"must be a JSON object like '{{\"track_length_m\": [100, 200]}}', got {text!r}")
    return value


def parse_pool(text: str) -> tuple[str, list[str]]:
    """``--pool LABEL=CTRL,CTRL,...`` as ``(label, controllers)`` (argparse type; shared by the scripts)."""
    label, sep, members = text.partition("=")
    names = [m for m in members.split(",") if m]
    if not sep or not label.strip() or len(names) < 2:
        raise argparse.ArgumentTypeError(f"must be LABEL=CTRL,CTRL[,...] (two or more controllers), got {text!r}")
    return label.strip(), names


# --- uuom-train ----------------------------------------------------------------------------------------------
def train_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uuom-train``."""
    from agents import training

    ap = _Parser(
        prog="uuom-train",
        description=training.__doc__.split("\n\n")[0].replace("``", ""),
        epilog="Example: uuom-train --algo ppo --observer dffrls-aekf --timesteps 300000 --seed 0 --n-envs 2",
    )
    ap.add_argument("--algo", choices=ALGOS, default="ppo")
    ap.add_argument("--observer", default="dffrls-aekf", help="estimator name, 'oracle' or 'none'")
    ap.add_argument("--env", default="UUOM-Track-v0", choices=ENV_IDS,
                    help="registered env id: its configuration under --env-kwargs, its entry of the YAML")
    ap.add_argument("--timesteps", type=int, default=None, help="total env steps (default: n_timesteps of the YAML)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--n-envs", type=int, default=None, help="parallel envs (default: n_envs of the YAML)")
    ap.add_argument("--shield", action=argparse.BooleanOptionalAction, default=None,
                    help="filter every action through agents.shield (default: the YAML's env_wrapper)")
    ap.add_argument("--residual", type=float, default=None, metavar="SCALE",
                    help="residual on the rule-based controller with this authority, 0: the policy alone "
                    "(default: the YAML's env_wrapper)")
    ap.add_argument("--margin-schedule", type=float, nargs=2, default=None, metavar=("LO", "HI"),
                    help="the action sets the rule-based controller's speed margin in [LO, HI] "
                    "(agents.margin_schedule; needs --residual 0)")
    ap.add_argument("--log-dir", type=Path, default=Path("runs"))
    ap.add_argument("--run-dir", type=Path, default=None, help="explicit run directory (overrides --log-dir naming)")
    ap.add_argument("--conf-file", type=Path, default=None, help="rl-zoo style YAML (default agents/hyperparams/<algo>.yml)")
    ap.add_argument("--hyperparams", nargs="*", default=[], metavar="KEY=VALUE")
    ap.add_argument("--env-kwargs", type=_json_object, default={},
                    help='JSON object of env config, e.g. \'{"track_length_m": [100, 200]}\'')
    ap.add_argument("--eval-freq", type=int, default=50_000, help="env steps between evaluations (0: none)")
    ap.add_argument("--eval-episodes", type=int, default=3)
    ap.add_argument("--checkpoint-freq", type=int, default=25_000, help="env steps between checkpoints (0: none)")
    ap.add_argument("--no-subproc", action="store_true", help="DummyVecEnv instead of SubprocVecEnv")
    ap.add_argument("--no-progress", action="store_true", help="no progress bar")
    group = ap.add_mutually_exclusive_group()
    group.add_argument("--resume", action="store_true", help="continue from the newest checkpoint of the run directory")
    group.add_argument("--fresh", action="store_true", help="delete the run directory and start over")
    ap.add_argument("--device", default="cpu")
    ap.add_argument("--init-from", type=Path, default=None, metavar="DIR",
                    help="start from this run directory's (or checkpoints/step_<n>'s) policy and VecNormalize, its "
                    "step count going on: the next leg of a curriculum (--timesteps is the total); --hyperparams given "
                    "with it replace the source's (a lin_<value> schedule falls over this leg)")
    ap.add_argument("--action-std-ceiling", type=float, nargs=3, default=None, metavar=("START", "END", "STEPS"),
                    help="PPO: cap the action std by a ceiling falling log-linearly from START to END over STEPS env "
                    "steps from the run's first step (docs/rl.md §27)")
    ap.add_argument("--demo-episodes", type=int, default=0, metavar="N",
                    help="off-policy algorithms, bare set-up: start the replay buffer with N episodes of the rule-based "
                    "controller in the env's action space (agents/demonstrations.py; not counted in --timesteps)")
    ap.add_argument("--demo-bc", type=float, default=0.0, metavar="W",
                    help="SAC with --demo-episodes: also hold the policy to the demonstrations where its critic rates "
                    "them above its own action, a Q-filtered behaviour-cloning term of weight W (agents/demo_bc.py; "
                    "0.4 matches TD3+BC's alpha 2.5); PPO, bare set-up: add W times the squared distance of the mean "
                    "action to the demonstrator's labels of the rollouts' states to PPO's loss (agents/ppo_bc.py); "
                    "0: off")
    ap.add_argument("--demonstrator-options", type=_json_object, default=None, metavar="JSON",
                    help="PPO with --demo-bc: keyword arguments of the labelling rule-based controller (default "
                    "'{\"speed_margin\": 0.2}', the DAgger start's demonstrator; '{}': the controller as it is)")
    return ap


def train_config(args: argparse.Namespace) -> Any:
    """A :class:`agents.training.TrainConfig` from parsed ``uuom-train`` arguments."""
    from agents.training import TrainConfig

    return TrainConfig(
        algo=args.algo, observer=args.observer, timesteps=args.timesteps, seed=args.seed, n_envs=args.n_envs,
        shield=args.shield, residual=args.residual, log_dir=args.log_dir, run_dir=args.run_dir,
        margin_schedule=tuple(args.margin_schedule) if args.margin_schedule is not None else None,
        conf_file=args.conf_file, hyperparams=list(args.hyperparams), env_kwargs=args.env_kwargs, env_id=args.env,
        eval_freq=args.eval_freq, eval_episodes=args.eval_episodes, checkpoint_freq=args.checkpoint_freq,
        subproc=not args.no_subproc, progress=not args.no_progress, fresh=args.fresh, resume=args.resume,
        device=args.device, init_from=args.init_from,
        action_std_ceiling=tuple(args.action_std_ceiling)
        if args.action_std_ceiling is not None else None,
        demo_episodes=args.demo_episodes, demo_bc_weight=args.demo_bc,
        demonstrator_options=args.demonstrator_options,
    )


def train_main(argv: list[str] | None = None) -> int:
    """``uuom-train``: 0 when trained, 2 on bad input, 130 when interrupted (a checkpoint was written)."""
    ap = train_parser()
    args = ap.parse_args(argv)
    from agents.training import TrainConfigError, TrainingInterrupted, train

    try:
        train(train_config(args))
    except TrainConfigError as exc:
        ap.error(str(exc))
    except TrainingInterrupted as exc:
        print(f"uuom-train: {exc}", file=sys.stderr, flush=True)
        return 130
    except KeyboardInterrupt:
        print("uuom-train: interrupted before training started (nothing written)", file=sys.stderr, flush=True)
        return 130
    return 0


# --- uuom-evaluate -------------------------------------------------------------------------------------------
def evaluate_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uuom-evaluate``."""
    from agents.evaluation import DEFAULT_OBSERVERS, DEFAULT_SEED_BASE

    ap = _Parser(
        prog="uuom-evaluate",
        description="Compare controllers x observers on the same held-out seeded UUOM-Track-v0 tracks.",
        epilog="Example: uuom-evaluate --controllers oracle rule-based runs/ppo_dffrls-aekf_res_shield_s0 "
        "--episodes 100 --out results/agents/eval",
    )
    ap.add_argument("--controllers", nargs="+", default=["oracle", "rule-based"],
                    help="oracle, rule-based, full-throttle, a uuom-train run directory; any of them + '+shield'")
    ap.add_argument("--observers", nargs="+", default=list(DEFAULT_OBSERVERS))
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument("--seed-base", type=int, default=DEFAULT_SEED_BASE)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--ray", action="store_true", help="run the episodes on Ray instead of local processes")
    ap.add_argument("--env", default="UUOM-Track-v0", choices=ENV_IDS,
                    help="registered env id: its configuration under --env-kwargs (use the id a policy was trained on)")
    ap.add_argument("--env-kwargs", type=_json_object, default={},
                    help="JSON env config for every controller; a run directory trained on another one is an error "
                    "(the message gives its training config) unless --allow-env-shift")
    ap.add_argument("--allow-env-shift", action="store_true",
                    help="evaluate run directories on an env other than their training one on purpose (a robustness "
                    "test); summary.md lists each difference")
    ap.add_argument("--out", type=Path, default=Path("results") / "eval")
    ap.add_argument("--plot-seed", type=int, default=None, help="episode drawn speed-vs-limit (default: first seed)")
    ap.add_argument("--plot-observer", default="dffrls-aekf")
    ap.add_argument("--bars-png", type=Path, default=None, help="also copy the bar chart here (e.g. docs/img/...)")
    ap.add_argument("--episode-png", type=Path, default=None, help="also copy the episode plot here")
    ap.add_argument("--merge", nargs="+", type=Path, default=None, metavar="DIR",
                    help="build the table and the bar chart from the episodes.csv of earlier --out directories "
                    "(no new episodes, except the one recorded episode per controller for the speed plot)")
    ap.add_argument("--pool", action="append", type=parse_pool, default=None, metavar="LABEL=CTRL,CTRL,...",
                    help="with --merge: show these controllers (e.g. the run directories of several training seeds) "
                    "as one row LABEL; its trip-time interval resamples the seeds and the tracks (repeatable)")
    ap.add_argument("--quiet", action="store_true")
    return ap


def evaluate_main(argv: list[str] | None = None, prog: str = "uuom-evaluate") -> int:
    """``uuom-evaluate``: 0 when the table is written, 2 on bad input, 130 on Ctrl-C."""
    ap = evaluate_parser()
    args = ap.parse_args(argv)
    from agents.evaluation import EvalConfig, EvalConfigError, evaluate
    from agents.ray_support import RayUnavailableError

    config = EvalConfig(
        controllers=list(args.controllers), observers=list(args.observers), episodes=args.episodes,
        seed_base=args.seed_base, workers=args.workers, use_ray=args.ray,
        env_kwargs={**env_kwargs_of(args.env), **args.env_kwargs}, allow_env_shift=args.allow_env_shift,
        out=args.out, plot_seed=args.plot_seed,
        plot_observer=args.plot_observer, bars_png=args.bars_png, episode_png=args.episode_png, merge=args.merge, quiet=args.quiet, pool=dict(args.pool or []),
        command=" ".join([prog, *(sys.argv[1:] if argv is None else argv)]),
    )
    try:
        evaluate(config)
    except (EvalConfigError, RayUnavailableError) as exc:
        ap.error(str(exc))
    except KeyboardInterrupt:
        print(f"{prog}: interrupted (no table written)", file=sys.stderr, flush=True)
        return 130
    return 0


# --- uuom-tune -----------------------------------------------------------------------------------------------
def tune_parser() -> argparse.ArgumentParser:
    """The argument parser of ``uuom-tune``: ``uuom-train``'s options (the base training) plus the sweep's."""
    from agents.tune import BACKENDS, SEARCHES, VALIDATION_SEED_BASE

    ap = train_parser()
    ap.prog = "uuom-tune"
    ap.description = ("Hyperparameter sweep: the training of uuom-train with the --space values applied, each trial "
                      "scored on validation tracks; one trial after another, or Ray Tune trials with --backend ray.")
    ap.epilog = ("Example: uuom-tune --residual 0 --no-shield --timesteps 100000 --space learning_rate=1e-4,3e-4 "
                 "seed=0,1 --backend ray --out runs/tune/lr")
    ap.add_argument("--space", nargs="+", required=True, metavar="KEY=VALUES",
                    help="KEY=V1,V2,... (a grid) or KEY=uniform:LO:HI / loguniform:LO:HI (--search optuna); KEY is a "
                    "hyperparameter or seed / observer / residual / timesteps")
    ap.add_argument("--search", choices=SEARCHES, default="grid")
    ap.add_argument("--samples", type=int, default=1, help="grid: repeats of every combination; optuna: trials")
    ap.add_argument("--backend", choices=BACKENDS, default="local",
                    help="local: one trial after another; ray: Ray Tune (RAY_ADDRESS for a cluster)")
    ap.add_argument("--val-episodes", type=int, default=10, help="validation tracks per trial")
    ap.add_argument("--val-seed-base", type=int, default=VALIDATION_SEED_BASE)
    ap.add_argument("--failure-ratio", type=float, default=3.0,
                    help="objective of a failed or tripped track (trip time / oracle of an arrived one)")
    ap.add_argument("--cpus-per-trial", type=int, default=1)
    ap.add_argument("--out", type=Path, default=Path("runs/tune"))
    return ap


def tune_main(argv: list[str] | None = None) -> int:
    """``uuom-tune``: 0 when every trial ran, 2 on bad input, 130 when interrupted."""
    ap = tune_parser()
    args = ap.parse_args(argv)
    from agents.ray_support import RayUnavailableError
    from agents.tune import SweepConfig, TuneConfigError, parse_space, sweep

    if args.run_dir is not None or args.resume or args.fresh:
        ap.error("--run-dir / --resume / --fresh: a sweep writes every trial fresh under --out")
    try:
        config = SweepConfig(
            base=train_config(args), space=parse_space(args.space), search=args.search, samples=args.samples,
            backend=args.backend, val_episodes=args.val_episodes, val_seed_base=args.val_seed_base,
            failure_ratio=args.failure_ratio, cpus_per_trial=args.cpus_per_trial, out=args.out, seed=args.seed,
            command=" ".join(["uuom-tune", *(sys.argv[1:] if argv is None else argv)]),
        )
        rows = sweep(config)
    except (TuneConfigError, RayUnavailableError) as exc:
        ap.error(str(exc))
    except KeyboardInterrupt:
        print("uuom-tune: interrupted (trials finished so far are under --out)", file=sys.stderr, flush=True)
        return 130
    best = rows[0]
    print(f"best: {({k[6:]: v for k, v in best.items() if k.startswith('param.')})} objective "
          f"{best['objective']:.3f} -> {Path(args.out) / 'summary.md'}")
    return 0


__all__ = ["evaluate_main", "evaluate_parser", "parse_pool", "train_config", "train_main", "train_parser", "tune_main",
           "tune_parser"]
