"""Evaluate controllers x observers on the same held-out seeded ``UUOM-Track-v0`` tracks.

This table answers "how much does the estimator decide control safety?". Controllers (``spec`` strings):
``oracle`` (minimum-time controller with perfect knowledge; observer-independent, run once and the reference
for trip time), ``rule-based``, ``full-throttle``, a run directory of :func:`agents.training.train` (model +
VecNormalize stats; a run trained with the shield and/or the residual is evaluated the same way), and
``<any>+shield`` to put the safety shield in front of any controller. A reference controller takes keyword
options after ``@``: ``rule-based@speed_margin=0.04,k_sigma=1`` (its constructor's names, numbers or
``true``/``false``; the whole spec is the row's label), e.g. to trace its trip-time/cost trade-off.

For every controller x observer, on episodes with seeds ``seed_base .. seed_base + episodes - 1`` (the same
tracks, loads and conditions for every row): success rate, overspeed trips, violations per km by rule, cost
rate (mean ``info["cost"]`` per policy step), trip time relative to the oracle controller on the same track (mean
over tracks both completed), traction energy per t km, mean estimator errors. :func:`evaluate` writes
``episodes.csv``, ``summary.csv`` and ``summary.md`` into ``config.out``, and the figures
(:mod:`agents.evaluation_plots`) there too or, once, where ``bars_png`` / ``episode_png`` say (``summary.md``
names them). In ``results/<study>/`` only ``summary.md``, ``summary.csv`` and the figures are committed; the
per-episode ``episodes.csv`` is git-ignored (rerun the command in ``summary.md`` to regenerate it). A trained
policy runs on the env it was trained on (its ``config.json``): another ``env_kwargs`` is an :class:`EvalConfigError`
naming the differences, unless ``allow_env_shift`` (then ``summary.md`` lists them; :data:`EVALUATION_SIDE_KEYS` are
exempt). Episodes run
in parallel with multiprocessing or on Ray (:mod:`agents.ray_support`).
"""

from __future__ import annotations

import itertools
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from agents.evaluation_table import (DEFAULT_OBSERVERS, RULES, markdown_ci_table, markdown_table, pool_rows, read_episodes,
                                     summarise, write_csv)
from agents.hyperparameters import ENV_ID

DEFAULT_SEED_BASE = 100_000
"""Held-out tracks: training uses seeds near 0 and its EvalCallback near 1 000 000."""

EVALUATION_SIDE_KEYS = frozenset({"observer", "observer_options", "reward_weights", "shaping_gamma", "render_fps",
                                  "render_size", "render_window_m", "vehicle_spread"})
"""Env settings an evaluation may set differently from a policy's training without shifting its task: the reward
and rendering do not change an episode, the observer (with its options) is what the cross table and the
sensitivity curves vary on purpose, and a policy trained on vehicles drawn around the configured one
(``vehicle_spread``) is judged on fixed vehicles: the configured one, or a study's sister vehicles."""


class EvalConfigError(ValueError):
    """An evaluation input that cannot work (unknown controller or observer, no episodes, missing directory)."""


@dataclass(frozen=True)
class Task:
    """One episode to run: a controller spec on one observer and one track seed."""

    controller: str
    observer: str
    seed: int
    env_kwargs_json: str = "{}"
    record: bool = False


# --- controllers ---------------------------------------------------------------------------------------------
def split_shield(spec: str) -> tuple[str, bool]:
    """``("rule-based", True)`` for ``"rule-based+shield"``."""
    if spec.endswith("+shield"):
        return spec[: -len("+shield")], True
    return spec, False


def split_options(base: str) -> tuple[str, dict[str, float | bool]]:
    """``("rule-based", {"speed_margin": 0.04})`` for ``"rule-based@speed_margin=0.04"``.

    Raises
    ------
    EvalConfigError
        An option that is not ``name=value`` or whose value is neither a number nor ``true``/``false``.
    """
    if "@" not in base:
        return base, {}
    name, _, text = base.partition("@")
    opts: dict[str, float | bool] = {}
    for item in filter(None, text.split(",")):
        key, sep, value = item.partition("=")
        if not sep or not key.isidentifier():
            raise EvalConfigError(f"controller {base!r}: option {item!r} is not name=value")
        if value.lower() in ("true", "false"):
            opts[key] = value.lower() == "true"
            continue
        try:
            opts[key] = float(value)
        except ValueError:
            raise EvalConfigError(f"controller {base!r}: option {key}={value!r} is not a number or true/false") from None
    return name, opts


def controller_label(spec: str) -> str:
    """Short label for tables: run directories by their name, a checkpoint folder as ``<run>_step_<n>``."""
    base, shield = split_shield(spec)
    if "/" in base or Path(base).is_dir():
        path = Path(base)
        label = f"{path.parent.parent.name}_{path.name}" if path.parent.name == "checkpoints" else path.name
    else:
        label = base
    return label + ("+shield" if shield else "")


def run_config_path(model_dir: Path) -> Path:
    """The ``config.json`` that describes a model folder: its own, or for a checkpoint folder
    (``<run>/checkpoints/step_<n>``, which has none) its run's."""
    model_dir = Path(model_dir)
    own = model_dir / "config.json"
    if not own.is_file() and model_dir.parent.name == "checkpoints":
        return model_dir.parent.parent / "config.json"
    return own


class ModelPolicy:
    """A trained SB3 model with its VecNormalize observation statistics, acting on raw observations.

    Parameters
    ----------
    run_dir : Path
        A training run directory (``model.zip``, optional ``vecnormalize.pkl`` and ``config.json``), or one of its
        checkpoint folders (``checkpoints/step_<n>``: the run's ``config.json`` describes it).
    """

    def __init__(self, run_dir: Path) -> None:
        import pickle

        import torch

        from agents.algos import algo_class

        torch.set_num_threads(1)  # one episode per process: threads would only fight over the cores

        cfg_path = run_config_path(run_dir)
        cfg = json.loads(cfg_path.read_text()) if cfg_path.is_file() else {}
        self.shield = bool(cfg.get("shield", False))
        self.residual = float(cfg.get("residual", 0.0))
        span = cfg.get("margin_schedule")
        self.margin_schedule = tuple(float(x) for x in span) if span is not None else None
        algo = cfg.get("algo", "ppo")
        path = run_dir / "model.zip"
        vn_path = run_dir / "vecnormalize.pkl"
        if not path.exists():
            raise FileNotFoundError(f"{run_dir}: no model.zip (train it with uuom-train first)")
        self.model = algo_class(algo).load(path, device="cpu")
        self.run_dir = run_dir
        self.obs_shape = tuple(self.model.observation_space.shape)
        self.vecnorm = None
        if not vn_path.exists() and (cfg.get("normalize") or {}).get("norm_obs"):
            # Run without the statistics it was trained with, a policy sees garbage and "fails" for no fault of its own.
            raise FileNotFoundError(f"{run_dir}: no vecnormalize.pkl, but {cfg_path} says it was trained with "
                                    f"normalized observations")
        if vn_path.exists():
            with open(vn_path, "rb") as fh:
                self.vecnorm = pickle.load(fh)
            self.vecnorm.training = False

    def normalized(self, obs: np.ndarray) -> np.ndarray:
        """One raw observation as the model sees it (its VecNormalize statistics applied, if it had them)."""
        if np.shape(obs) != self.obs_shape:
            # e.g. a policy trained with idle_clock_observation run without it: say so, not a broadcast error
            raise ValueError(f"{self.run_dir}: the policy takes observations of shape {self.obs_shape}, the env gives "
                             f"{np.shape(obs)}; build the env with the policy's training configuration "
                             f"(its config.json env_kwargs, e.g. idle_clock_observation)")
        return self.vecnorm.normalize_obs(obs) if self.vecnorm is not None and self.vecnorm.norm_obs else obs

    def act(self, obs: np.ndarray, info: dict[str, Any], deterministic: bool = True) -> np.ndarray:
        """The action for one raw observation: the policy's mean, or with ``deterministic=False`` a sample from its
        distribution (torch's global generator)."""
        action, _ = self.model.predict(self.normalized(obs), deterministic=deterministic)
        return np.asarray(action, dtype=np.float32).reshape(1)


_MODEL_CACHE: dict[str, ModelPolicy] = {}


def env_shift(trained: dict[str, Any], evaluated: dict[str, Any]) -> list[str]:
    """Where the evaluation env differs from a policy's training env, as ``"key: trained -> evaluated"`` lines.

    Both are completed with :func:`uuom_gym.envs.config.default_config` first, so an explicit default equals an
    omitted one; :data:`EVALUATION_SIDE_KEYS` are not compared.
    """
    from uuom_gym.envs.config import default_config

    def full(kwargs: dict[str, Any]) -> dict[str, Any]:
        return json.loads(json.dumps({**default_config(), **kwargs}, default=str))

    a, b = full(trained), full(evaluated)
    return [f"{k}: {a.get(k)!r} -> {b.get(k)!r}" for k in sorted(set(a) | set(b))
            if k not in EVALUATION_SIDE_KEYS and a.get(k) != b.get(k)]


def trained_env_kwargs(run_dir: Path) -> dict[str, Any]:
    """The env configuration a run directory's (or checkpoint folder's) policy was trained with (``config.json``;
    {} when it has none)."""
    path = run_config_path(run_dir)
    return dict(json.loads(path.read_text()).get("env_kwargs") or {}) if path.is_file() else {}


def make_controller(spec: str, vehicle: Any) -> Any:
    """A reference controller by name, or the (cached per process) trained model of a run directory."""
    from agents.controllers import CONTROLLERS

    base, _ = split_shield(spec)
    name, opts = split_options(base)
    if name in CONTROLLERS:
        return CONTROLLERS[name](vehicle, **opts)
    if base not in _MODEL_CACHE:
        _MODEL_CACHE[base] = ModelPolicy(Path(base))
    return _MODEL_CACHE[base]


def start_episode(task: Task) -> tuple[Any, Any, np.ndarray, dict[str, Any]]:
    """The env (wrapped as the controller was trained: shield, residual, margin schedule) and the controller of one
    episode, reset on its track: ``(env, controller, obs, info)``. The caller steps it and closes the env."""
    import gymnasium as gym

    import uuom_gym  # noqa: F401 - registers the env
    from agents.training import wrap_env

    env = gym.make(ENV_ID, observer=task.observer, **json.loads(task.env_kwargs_json))
    ctrl = make_controller(task.controller, env.unwrapped.vehicle)
    shield = split_shield(task.controller)[1] or bool(getattr(ctrl, "shield", False))
    env = wrap_env(env, shield, getattr(ctrl, "residual", 0.0), getattr(ctrl, "margin_schedule", None))
    obs, info = env.reset(seed=task.seed)
    if hasattr(ctrl, "reset"):
        ctrl.reset(env, info)
    return env, ctrl, obs, info


def run_episode(task: Task) -> dict[str, Any]:
    """Run one episode; return its flat summary row (and, if ``task.record``, the per-step trace)."""
    from agents.metrics import EpisodeAccumulator

    env, ctrl, obs, info = start_episode(task)
    acc = EpisodeAccumulator()
    acc.start(info)
    keys = ("t_s", "position_m", "speed_mps", "true_limit_mps", "est_limit_mps", "command")
    trace: dict[str, list[float]] = {k: [] for k in keys}
    t0 = time.perf_counter()
    while True:
        action = ctrl.act(obs, info)
        obs, _, term, trunc, info = env.step(action)
        acc.add(info)
        if task.record:
            trace["t_s"].append(info["t_s"])
            trace["position_m"].append(info["position_m"])
            trace["speed_mps"].append(info["speed_mps"])
            trace["true_limit_mps"].append(info["true_speed_limit_mps"])
            trace["est_limit_mps"].append(info["est_speed_limit_mps"])
            trace["command"].append(float(info.get("shield_command", info["command"])))
        if term or trunc:
            break
    env.close()
    row = acc.finish(info).flat()
    row.update(
        controller=controller_label(task.controller),
        observer=task.observer,
        seed=task.seed,
        wall_s=time.perf_counter() - t0,
        shield_interventions=int(info.get("shield_interventions", 0)),
    )
    if isinstance(ctrl, ModelPolicy):  # where a trained policy's episode can be reproduced bit for bit
        from agents.float_path import float_path_fingerprint

        row["float_path"] = float_path_fingerprint()
    if task.record:
        row["trace"] = trace
    return row


# --- parallel execution --------------------------------------------------------------------------------------
def _progress(i: int, n: int, show: bool) -> None:
    if show:
        print(f"\r{i}/{n} episodes", end="", file=sys.stderr, flush=True)


def run_tasks(tasks: list[Task], workers: int, use_ray: bool = False, progress: bool = True) -> list[dict[str, Any]]:
    """Run the episodes locally (multiprocessing) or on Ray; results in task order."""
    if use_ray:
        from agents.ray_support import init_ray

        ray = init_ray()
        remote = ray.remote(run_episode)
        return ray.get([remote.remote(t) for t in tasks])
    out: list[dict[str, Any]] = []
    if workers <= 1:
        for i, t in enumerate(tasks):
            out.append(run_episode(t))
            _progress(i + 1, len(tasks), progress)
    else:
        import multiprocessing as mp

        ctx = mp.get_context("fork" if sys.platform.startswith("linux") else "spawn")
        with ctx.Pool(workers) as pool:
            for i, row in enumerate(pool.imap(run_episode, tasks, chunksize=1)):
                out.append(row)
                _progress(i + 1, len(tasks), progress)
    if progress:
        print(file=sys.stderr)
    return out


# --- the whole evaluation ------------------------------------------------------------------------------------
@dataclass
class EvalConfig:
    """What :func:`evaluate` runs and where it writes (the fields of ``uuom-evaluate``'s options).

    ``merge``: build the table from the ``episodes.csv`` of earlier ``out`` directories instead of running
    episodes (only the one recorded episode per controller for the speed plot is run). ``pool`` (with ``merge``):
    label -> controllers, several training seeds shown as one row (:func:`agents.evaluation_table.pool_rows`). ``command``: the command
    line written into ``summary.md`` (``None``: "called from Python").
    """

    controllers: list[str] = field(default_factory=lambda: ["oracle", "rule-based"])
    observers: list[str] = field(default_factory=lambda: list(DEFAULT_OBSERVERS))
    episodes: int = 100
    seed_base: int = DEFAULT_SEED_BASE
    workers: int = 1
    use_ray: bool = False
    env_kwargs: dict[str, Any] = field(default_factory=dict)
    allow_env_shift: bool = False
    out: Path = Path("results/eval")
    plot_seed: int | None = None
    plot_observer: str = "dffrls-aekf"
    bars_png: Path | None = None
    episode_png: Path | None = None
    merge: list[Path] | None = None
    pool: dict[str, list[str]] | None = None
    quiet: bool = False
    command: str | None = None


def evaluate(config: EvalConfig) -> list[dict[str, Any]]:
    """Run the evaluation; return the summary rows (files written to ``config.out``).

    Raises
    ------
    EvalConfigError
        Bad input (checked before any episode runs).
    agents.ray_support.RayUnavailableError
        ``use_ray`` without Ray installed.
    """
    from agents.evaluation_plots import plot_bars, plot_episode, plot_tradeoff

    check_config(config)
    kw = json.dumps(config.env_kwargs, sort_keys=True)
    seeds = [config.seed_base + i for i in range(config.episodes)]
    plot_seed = seeds[0] if config.plot_seed is None else config.plot_seed
    cmd = config.command or "(called from Python)"
    out = Path(config.out)
    if config.merge:
        rows = _merged_rows(config.merge)
        if config.pool:
            try:
                rows = pool_rows(rows, config.pool)
            except ValueError as exc:
                raise EvalConfigError(f"--pool: {exc}") from None
        seeds = sorted({int(r["seed"]) for r in rows})
        head = (f"Held-out seeds {seeds[0]}..{seeds[-1]} ({len(seeds)} tracks), {len(rows)} episodes merged from "
                f"{', '.join(str(d) for d in config.merge)}.\nCommand: `{cmd}`\n\n{_parts(config.merge)}")
        rec_tasks = [Task(c, "oracle" if split_shield(c)[0] == "oracle" else config.plot_observer, plot_seed, kw, True)
                     for c in config.controllers]
        rec = run_tasks(rec_tasks, min(config.workers, len(rec_tasks)), config.use_ray, progress=False)
    else:
        tasks: list[Task] = []
        for ctrl in config.controllers:
            base, _ = split_shield(ctrl)
            # The oracle controller reads the truth, not the observation: one run per track serves every observer.
            observers = ["oracle"] if base == "oracle" else config.observers
            for obs in observers:
                for s in seeds:
                    record = s == plot_seed and (obs == config.plot_observer or base == "oracle")
                    tasks.append(Task(ctrl, obs, s, kw, record=record))
        t0 = time.time()
        rows = run_tasks(tasks, config.workers, config.use_ray, progress=not config.quiet)
        wall = time.time() - t0
        head = (f"Held-out seeds {seeds[0]}..{seeds[-1]} ({len(seeds)} tracks), {len(rows)} episodes in {wall:.0f} s.\n"
                f"Command: `{cmd}`\n\n{_shift_note(config)}")
        rec = [r for r in rows if "trace" in r and (r["observer"] == config.plot_observer or r["controller"] == "oracle")]
    summary = summarise(rows)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "episodes.csv", rows)
    write_csv(out / "summary.csv", summary)
    md = markdown_table(summary)
    # One copy of each figure: where asked (e.g. docs/img for the README), else beside the table.
    bars_png = Path(config.bars_png) if config.bars_png is not None else out / "bars.png"
    episode_png = Path(config.episode_png) if config.episode_png is not None else out / "episode.png"
    for path in (bars_png, episode_png):
        path.parent.mkdir(parents=True, exist_ok=True)
    tradeoff_png = bars_png.with_name(bars_png.stem.replace("bars", "tradeoff") if "bars" in bars_png.stem
                                      else bars_png.stem + "_tradeoff").with_suffix(".png")
    plot_bars(summary, bars_png)
    plot_tradeoff(summary, tradeoff_png)
    plot_episode(rec, episode_png)
    figures = [str(p) for p in (bars_png, tradeoff_png, episode_png) if p.exists()]
    md_ci = markdown_ci_table(summary)
    (out / "summary.md").write_text(head + md + "\nWith 95 % intervals (rates: Wilson, or where training seeds "
                                    "are pooled a bootstrap over seeds and tracks that contains the Wilson interval over "
                                    "the tracks; the interquartile mean of trip time / oracle: bootstrap over tracks, and "
                                    "over training seeds where pooled):\n\n" + md_ci
                                    + f"\nFigures: {', '.join(figures)}.\n")
    if not config.quiet:
        print(md)
        print(md_ci)
        print(f"{len(rows)} episodes -> {out}")
    return summary


def check_config(config: EvalConfig) -> None:
    """Check every input in this process, before any worker starts.

    Raises
    ------
    EvalConfigError
        The first input that cannot work, named.
    """
    import gymnasium as gym

    import uuom_gym  # noqa: F401 - registers the env
    from agents.controllers import CONTROLLERS
    from uuom_core.vehicle import VehicleParams

    if config.episodes < 1:
        raise EvalConfigError(f"episodes must be >= 1, got {config.episodes}")
    if config.workers < 1:
        raise EvalConfigError(f"workers must be >= 1, got {config.workers}")
    if config.seed_base < 0:  # the env's reset() refuses a negative seed, after the workers had started
        raise EvalConfigError(f"seed must be >= 0, got {config.seed_base}")
    if not config.controllers:
        raise EvalConfigError("no controllers given")
    for spec in config.controllers:
        base, _ = split_shield(spec)
        name, opts = split_options(base)
        if name in CONTROLLERS:
            try:
                CONTROLLERS[name](VehicleParams(), **opts)
            except (TypeError, ValueError) as exc:
                raise EvalConfigError(f"controller {spec!r}: {exc}") from None
        elif opts or not (Path(base) / "model.zip").is_file():
            raise EvalConfigError(
                f"controller {spec!r} is neither one of {', '.join(CONTROLLERS)} nor a run directory with a model.zip"
            )
    shifts = {} if config.allow_env_shift else _env_shifts(config)
    if shifts:
        spec, shift = next(iter(shifts.items()))
        trained = trained_env_kwargs(Path(split_shield(spec)[0]))
        raise EvalConfigError(
            f"controller {spec!r} was trained on another env than this evaluation's ({'; '.join(shift)}): "
            f"pass its training configuration, --env-kwargs '{json.dumps(trained)}', or --allow-env-shift "
            "to evaluate it off its training env on purpose"
        )
    if config.pool and not config.merge:
        raise EvalConfigError("--pool needs --merge (it pools the rows of earlier evaluations)")
    for d in config.merge or []:
        if not (Path(d) / "episodes.csv").is_file():
            raise EvalConfigError(f"--merge {d}: no episodes.csv there")
    for obs in dict.fromkeys([*config.observers, config.plot_observer]):
        try:
            env = gym.make(ENV_ID, observer=obs, **config.env_kwargs)
        except (ValueError, TypeError) as exc:
            raise EvalConfigError(str(exc).splitlines()[0]) from None
        mode = env.unwrapped.config["action_mode"]
        env.close()
    for spec in config.controllers:
        name, _ = split_options(split_shield(spec)[0])
        modes = getattr(CONTROLLERS.get(name), "action_modes", None)
        if modes is not None and mode not in modes:
            raise EvalConfigError(f"controller {spec!r} acts on action_mode {' or '.join(map(repr, modes))}; this "
                                  f"evaluation's env has action_mode {mode!r} (set it with --env-kwargs)")


def _env_shifts(config: EvalConfig) -> dict[str, list[str]]:
    """The trained policies among the controllers whose training env differs from the evaluation's, and how."""
    out = {}
    for spec in config.controllers:
        base, _ = split_shield(spec)
        if (Path(base) / "model.zip").is_file():
            shift = env_shift(trained_env_kwargs(Path(base)), config.env_kwargs)
            if shift:
                out[spec] = shift
    return out


def _shift_note(config: EvalConfig) -> str:
    """With ``allow_env_shift``: which trained policies ran off their training env, and how (empty otherwise)."""
    lines = [f"- `{controller_label(spec)}` (trained -> evaluated): {'; '.join(shift)}"
             for spec, shift in _env_shifts(config).items()]
    return "Evaluated off the training env (`--allow-env-shift`):\n\n" + "\n".join(lines) + "\n\n" if lines else ""


def _parts(dirs: list[Path]) -> str:
    """The head lines (seeds, command) of the merged directories' ``summary.md``: where each row came from."""
    lines = []
    for d in dirs:
        md = Path(d) / "summary.md"
        if md.exists():
            text = md.read_text().splitlines()
            head = [ln for ln in text[:2] if ln.strip()]
            lines.append(f"- `{d}`: " + " ".join(head))
            # a merge of merges keeps its parts' provenance, one level down
            body = list(itertools.takewhile(lambda ln: not ln.startswith("|"), text[2:]))
            lines += ["  " + ln for ln in body if ln.startswith("- ")]
    return ("Parts:\n" + "\n".join(lines) + "\n\n") if lines else ""


def _merged_rows(dirs: list[Path]) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    seen: set[tuple[str, str, int, str]] = set()
    for d in dirs:
        for r in read_episodes(Path(d) / "episodes.csv"):
            # a pooled row keeps its training run: the seeds of one pooled label are different episodes
            key = (r["controller"], r["observer"], int(r["seed"]), str(r.get("training_run") or ""))
            if key not in seen:  # the same episode in two directories (e.g. the oracle rows) counts once
                seen.add(key)
                rows.append(r)
    return rows


__all__ = [
    "DEFAULT_OBSERVERS",
    "DEFAULT_SEED_BASE",
    "EvalConfig",
    "EvalConfigError",
    "ModelPolicy",
    "RULES",
    "Task",
    "check_config",
    "controller_label",
    "evaluate",
    "make_controller",
    "markdown_table",
    "read_episodes",
    "run_episode",
    "run_config_path",
    "run_tasks",
    "split_options",
    "split_shield",
    "start_episode",
    "summarise",
    "write_csv",
]
