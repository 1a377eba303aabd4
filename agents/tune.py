"""Hyperparameter sweeps around the same trainer and evaluation as ``uuom-train`` / ``uuom-evaluate``, run one
trial after another on this machine or as Ray Tune trials (``uuom-tune``).

A trial is :func:`agents.training.train` with the trial's values applied to a base :class:`TrainConfig`, then the
trained policy driven by :func:`agents.evaluation.run_episode` on *validation* tracks (seeds from
:data:`VALIDATION_SEED_BASE`, disjoint from the training seeds, the training evaluation callback's and the held-out
tracks of ``uuom-evaluate``, so choosing hyperparameters never looks at the tracks a table is reported on). The
same function runs a trial on both back ends; with the same values and seed the two give the same numbers (tested).

The score a trial reports, lower is better (``objective``)::

    mean over the validation tracks of  trip time / oracle trip time   if the train arrived without an overspeed trip
                                        failure_ratio (default 3)       otherwise

so one failed track costs as much as running twice as slowly as the rule-based controller with no estimator on
that track. ``success``, ``trip_rate``, ``cost_rate`` and ``trip_time_vs_oracle`` are reported beside it.

What a sweep varies (:func:`parse_space`): any hyperparameter of the algorithm's YAML or constructor, plus
``seed``, ``observer``, ``residual`` and ``timesteps``. Values are YAML scalars; ``KEY=a,b,c`` is a grid (every
combination is one trial, ``samples`` times), ``KEY=uniform:lo:hi`` / ``loguniform:lo:hi`` a range for
``search="optuna"`` (Ray Tune's ``OptunaSearch``, ``samples`` trials, TPE with the sweep's seed).
"""

from __future__ import annotations

import csv
import dataclasses
import itertools
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.training import TrainConfig

VALIDATION_SEED_BASE = 200_000
"""Tracks a sweep scores trials on: training uses seeds near 0 (its callback near 1 000 000), tables 100 000+."""

TRAIN_FIELDS = ("seed", "observer", "residual", "timesteps")
"""Sweep keys that set a :class:`TrainConfig` field; every other key is a hyperparameter override."""

SEARCHES = ("grid", "optuna")
BACKENDS = ("local", "ray")


class TuneConfigError(ValueError):
    """A sweep that cannot run (malformed space, unknown hyperparameter, optuna without Ray, ...)."""


@dataclass(frozen=True)
class Range:
    """A continuous search range for ``search="optuna"``."""

    kind: str  # "uniform" or "loguniform"
    low: float
    high: float


@dataclass
class SweepConfig:
    """A sweep: the base training, what varies, how trials are scored and where the results go."""

    base: TrainConfig
    space: dict[str, list[Any] | Range]
    search: str = "grid"
    samples: int = 1
    backend: str = "local"
    val_episodes: int = 10
    val_seed_base: int = VALIDATION_SEED_BASE
    failure_ratio: float = 3.0
    cpus_per_trial: int = 1
    out: Path = Path("runs/tune")
    seed: int = 0
    command: str | None = None


# --- the search space ----------------------------------------------------------------------------------------
def parse_space(items: list[str]) -> dict[str, list[Any] | Range]:
    """``["learning_rate=1e-4,3e-4", "ent_coef=uniform:0:0.02"]`` -> ``{"learning_rate": [0.0001, 0.0003],
    "ent_coef": Range("uniform", 0.0, 0.02)}``.

    Raises
    ------
    TuneConfigError
        An item without ``=``, an empty value, a repeated key or a malformed range.
    """
    import yaml

    from agents.hyperparameters import parse_value

    space: dict[str, list[Any] | Range] = {}
    for item in items:
        key, sep, text = item.partition("=")
        key = key.strip()
        if not sep or not key or not text.strip():
            raise TuneConfigError(f"--space expects KEY=V1,V2,... or KEY=uniform:LO:HI, got {item!r}")
        if key in space:
            raise TuneConfigError(f"--space names {key!r} twice")
        kind = text.split(":", 1)[0]
        if kind in ("uniform", "loguniform"):
            parts = text.split(":")
            try:
                low, high = float(parts[1]), float(parts[2])
            except (IndexError, ValueError):
                raise TuneConfigError(f"--space {item!r}: a range is {kind}:LOW:HIGH with two numbers") from None
            if len(parts) != 3 or not (math.isfinite(low) and math.isfinite(high) and low < high) or (
                    kind == "loguniform" and low <= 0):
                raise TuneConfigError(f"--space {item!r}: need finite LOW < HIGH (and LOW > 0 for loguniform)")
            space[key] = Range(kind, low, high)
            continue
        try:
            values = [parse_value(v) for v in text.split(",")]
        except yaml.YAMLError:
            raise TuneConfigError(f"--space {item!r}: a value is not a YAML scalar") from None
        if any(v is None for v in values):
            raise TuneConfigError(f"--space {item!r}: empty value")
        space[key] = values
    return space


def trial_config(base: TrainConfig, params: dict[str, Any], run_dir: Path) -> TrainConfig:
    """The :class:`TrainConfig` of one trial: ``params`` applied to ``base``, writing to ``run_dir``."""
    fields = {k: params[k] for k in TRAIN_FIELDS if k in params}
    overrides = [f"{k}={json.dumps(v) if isinstance(v, str) else v!r}" for k, v in sorted(params.items())
                 if k not in TRAIN_FIELDS]
    return dataclasses.replace(base, **fields, hyperparams=list(base.hyperparams) + overrides, run_dir=run_dir,
                               log_dir=run_dir.parent, progress=False, resume=False, fresh=True)


def grid(space: dict[str, list[Any] | Range]) -> list[dict[str, Any]]:
    """Every combination of the listed values (ranges are not a grid)."""
    keys = sorted(space)
    lists = [space[k] for k in keys]
    return [dict(zip(keys, combo)) for combo in itertools.product(*lists)]  # type: ignore[arg-type]


def check_sweep(config: SweepConfig) -> None:
    """Check a sweep before anything trains: known keys, kinds, back end, counts.

    Raises
    ------
    TuneConfigError
    """
    from agents.hyperparameters import TrainConfigError
    from agents.training import plan

    if config.search not in SEARCHES:
        raise TuneConfigError(f"unknown search {config.search!r} (choose from {', '.join(SEARCHES)})")
    if config.backend not in BACKENDS:
        raise TuneConfigError(f"unknown backend {config.backend!r} (choose from {', '.join(BACKENDS)})")
    ranges = [k for k, v in config.space.items() if isinstance(v, Range)]
    if ranges and config.search != "optuna":
        raise TuneConfigError(f"{', '.join(ranges)}: a range needs --search optuna (a grid needs listed values)")
    if config.search == "optuna" and config.backend != "ray":
        raise TuneConfigError("--search optuna runs on Ray Tune's OptunaSearch: add --backend ray")
    for name, value in (("samples", config.samples), ("val_episodes", config.val_episodes),
                        ("cpus_per_trial", config.cpus_per_trial)):
        if isinstance(value, bool) or not isinstance(value, int) or value < 1:
            raise TuneConfigError(f"{name} must be a whole number >= 1, got {value!r}")
    if not (math.isfinite(config.failure_ratio) and config.failure_ratio >= 1.0):
        raise TuneConfigError(f"failure_ratio must be a finite number >= 1, got {config.failure_ratio!r}")
    # every value of every key through the trainer's own checks (one trial per value, the others at their first)
    first = {k: (v[0] if isinstance(v, list) else v.low) for k, v in config.space.items()}
    for key, values in config.space.items():
        for v in (values if isinstance(values, list) else [values.low, values.high]):
            try:
                plan(trial_config(config.base, {**first, key: v}, Path(config.out) / "check"))
            except TrainConfigError as exc:
                raise TuneConfigError(f"--space {key}={v!r}: {exc}") from None


# --- one trial -----------------------------------------------------------------------------------------------
def score(rows: list[dict[str, Any]], oracle_s: dict[int, float], failure_ratio: float) -> dict[str, float]:
    """A trial's numbers from its validation episodes and the oracle's trip time per track (module docstring)."""
    ratios, arrived = [], []
    for r in rows:
        ok = bool(r["success"]) and int(r["seed"]) in oracle_s and not r["overspeed_trip"]
        ratio = r["trip_time_s"] / oracle_s[int(r["seed"])] if ok else failure_ratio
        ratios.append(min(ratio, failure_ratio))
        if ok:
            arrived.append(ratio)
    steps = sum(float(r["steps"]) for r in rows)
    cost = sum(float(r["cost"]) for r in rows)
    return {
        "objective": float(np.mean(ratios)),
        "success": float(np.mean([bool(r["success"]) for r in rows])),
        "trip_rate": float(np.mean([bool(r["overspeed_trip"]) for r in rows])),
        "cost_rate": cost / steps if steps else math.nan,
        "trip_time_vs_oracle": float(np.mean(arrived)) if arrived else math.nan,
    }


def oracle_trip_times(base: TrainConfig, val_seeds: list[int]) -> dict[int, float]:
    """The oracle controller's trip time on each validation track it completes, in the base training's env (no
    sweep key changes the env, so every trial is scored against the same reference)."""
    from agents.evaluation import Task, run_episode
    from agents.training import plan

    kw = json.dumps(plan(base).env_kwargs, sort_keys=True)
    refs = {s: run_episode(Task("oracle", "oracle", s, kw)) for s in val_seeds}
    return {s: float(r["trip_time_s"]) for s, r in refs.items() if r["success"]}


def run_trial(base: TrainConfig, params: dict[str, Any], run_dir: Path, val_seeds: list[int],
              oracle_s: dict[int, float], failure_ratio: float) -> dict[str, Any]:
    """Train one trial into ``run_dir`` and score it on ``val_seeds`` against the oracle's trip times ``oracle_s``
    (the same function on both back ends)."""
    from agents.evaluation import Task, run_episode
    from agents.training import train

    t0 = time.time()
    config = trial_config(base, params, Path(run_dir))
    train(config)
    # the run's whole configuration (the env id's with the sweep's on top), as uuom-train recorded it
    kw = json.dumps(json.loads((Path(run_dir) / "config.json").read_text())["env_kwargs"], sort_keys=True)
    rows = [run_episode(Task(str(run_dir), config.observer, s, kw)) for s in val_seeds]
    return {**score(rows, oracle_s, failure_ratio), "wall_s": time.time() - t0, "run_dir": str(run_dir)}


def _slug(params: dict[str, Any]) -> str:
    """A trial's values as a directory-name fragment (``learning_rate-0.0003_seed-1``)."""
    text = "_".join(f"{k}-{v}" for k, v in sorted(params.items()))
    return "".join(ch if ch.isalnum() or ch in "-_." else "" for ch in text)[:80]


# --- the sweep -----------------------------------------------------------------------------------------------
def sweep(config: SweepConfig) -> list[dict[str, Any]]:
    """Run every trial, write ``results.csv`` and ``summary.md`` to ``config.out``; return the rows, best first.

    Raises
    ------
    TuneConfigError
        Bad input (before any trial).
    agents.ray_support.RayUnavailableError
        ``backend="ray"`` without Ray installed (or ``search="optuna"`` without optuna).
    """
    check_sweep(config)
    out = Path(config.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    val_seeds = [config.val_seed_base + i for i in range(config.val_episodes)]
    # a trial on one CPU steps its envs in-process; with more, in worker processes (the same on both back ends)
    conf = config.base.conf_file
    base = dataclasses.replace(config.base, env_kwargs=dict(config.base.env_kwargs),
                               subproc=config.base.subproc and config.cpus_per_trial > 1, eval_freq=0,
                               conf_file=Path(conf).resolve() if conf is not None else None)
    oracle_s = oracle_trip_times(dataclasses.replace(base, run_dir=out / "trials"), val_seeds)
    if config.backend == "local":
        trials = [p for p in grid(config.space) for _ in range(config.samples)]
        rows = []
        for i, params in enumerate(trials):
            res = run_trial(base, params, out / "trials" / f"trial{i:03d}_{_slug(params)}", val_seeds, oracle_s,
                            config.failure_ratio)
            rows.append({**{f"param.{k}": v for k, v in params.items()}, **res})
            print(f"trial {i + 1}/{len(trials)} {params}: objective {res['objective']:.3f}", flush=True)
    else:
        rows = _sweep_ray(config, base, out, val_seeds, oracle_s)
    rows.sort(key=lambda r: (r["objective"], r["run_dir"]))
    _write(config, out, rows)
    return rows


def _sweep_ray(config: SweepConfig, base: TrainConfig, out: Path, val_seeds: list[int],
               oracle_s: dict[int, float]) -> list[dict[str, Any]]:
    from agents.ray_support import RayUnavailableError, init_ray

    init_ray()
    from ray import tune

    if config.search == "optuna":
        try:
            from ray.tune.search.optuna import OptunaSearch
            import optuna
        except ImportError:
            raise RayUnavailableError("--search optuna needs optuna: pip install optuna") from None
        param_space = {k: (tune.choice(v) if isinstance(v, list) else
                           (tune.uniform if v.kind == "uniform" else tune.loguniform)(v.low, v.high))
                       for k, v in config.space.items()}
        search_alg = OptunaSearch(sampler=optuna.samplers.TPESampler(seed=config.seed), metric="objective", mode="min")
        num_samples = config.samples
    else:
        param_space = {k: tune.grid_search(v) for k, v in config.space.items()}
        search_alg, num_samples = None, config.samples
    trials_dir = out / "trials"
    failure_ratio = config.failure_ratio

    def trainable(params: dict[str, Any]) -> dict[str, Any]:
        ctx = tune.get_context()
        name = f"{ctx.get_trial_name()}_{_slug(params)}"
        return run_trial(base, params, trials_dir / name, val_seeds, oracle_s, failure_ratio)

    tuner = tune.Tuner(
        tune.with_resources(trainable, {"cpu": config.cpus_per_trial}),
        param_space=param_space,
        tune_config=tune.TuneConfig(metric="objective", mode="min", num_samples=num_samples, search_alg=search_alg),
        run_config=tune.RunConfig(storage_path=str(out / "ray"), name="sweep", verbose=0),
    )
    results = tuner.fit()
    rows = []
    for res in results:
        if res.error is not None:
            raise RuntimeError(f"a Ray Tune trial failed: {res.error}")
        keep = ("objective", "success", "trip_rate", "cost_rate", "trip_time_vs_oracle", "wall_s", "run_dir")
        rows.append({**{f"param.{k}": v for k, v in res.config.items()}, **{k: res.metrics[k] for k in keep}})
    return rows


def _write(config: SweepConfig, out: Path, rows: list[dict[str, Any]]) -> None:
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(out / "results.csv", "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys)
        w.writeheader()
        w.writerows(rows)
    params = [k for k in keys if k.startswith("param.")]
    head = "| " + " | ".join(k[6:] for k in params) + " | objective | success | trips | cost rate | trip time / oracle |"
    lines = [
        f"# Sweep: {len(rows)} trials, {config.backend} back end, search {config.search}",
        "",
        f"Command: `{config.command or '(called from Python)'}`",
        "",
        f"Scored on {config.val_episodes} validation tracks (seeds {config.val_seed_base}.."
        f"{config.val_seed_base + config.val_episodes - 1}); objective = mean trip time / oracle with "
        f"{config.failure_ratio:g} for a failed or tripped track (lower is better). Best first.",
        "",
        head,
        "|" + "---|" * (len(params) + 5),
    ]
    for r in rows:
        vals = " | ".join(str(r[k]) for k in params)
        lines.append(f"| {vals} | {r['objective']:.3f} | {r['success']:.0%} | {r['trip_rate']:.0%} | "
                     f"{r['cost_rate']:.2e} | {r['trip_time_vs_oracle']:.3f} |")
    (out / "summary.md").write_text("\n".join(lines) + "\n")


__all__ = ["BACKENDS", "Range", "SEARCHES", "SweepConfig", "TuneConfigError", "VALIDATION_SEED_BASE", "check_sweep",
           "grid", "oracle_trip_times", "parse_space", "run_trial", "score", "sweep", "trial_config"]
