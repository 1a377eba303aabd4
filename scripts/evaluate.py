#!/usr/bin/env python
"""Compare controllers x observers on the same held-out seeded ``UUOM-Track-v0`` tracks.

This table answers "how much does the estimator decide control safety?". Example::

    python scripts/evaluate.py --controllers oracle rule-based runs/ppo_dffrls-aekf_s0 \\
        --observers oracle dffrls-aekf rls-ekf ekf ffrls none --episodes 100 --out results/eval

Controllers: ``oracle`` (minimum-time controller with perfect knowledge; observer-independent, run once and the
reference for trip time), ``rule-based`` (tracks the pessimistic estimated limit), a trained run directory of
``scripts/train.py`` (model + VecNormalize stats; a run trained with ``--shield`` is evaluated behind the
shield), and ``<any>+shield`` to put the safety shield in front of any controller.

For every controller x observer, on episodes with seeds ``seed_base .. seed_base + episodes - 1`` (the same
tracks, loads and conditions for every row): success rate, overspeed trips, violations per km by rule (policy
steps with a breach per km driven), cost rate (mean ``info["cost"]`` per policy step), trip time relative to the
oracle controller on the same track (mean over tracks both completed), traction energy per t km, mean estimator
errors. Writes ``episodes.csv``, ``summary.csv``, ``summary.md`` and PNG figures into ``--out``.

Episodes run in parallel with multiprocessing (``--workers``, local by default); ``--ray`` sends them to a Ray
cluster instead (``pip install ray``; ``ray.init(address="auto")`` when ``RAY_ADDRESS`` is set).
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

ENV_ID = "UUOM-Track-v0"
DEFAULT_OBSERVERS = ("oracle", "dffrls-aekf", "rls-ekf", "ekf", "ffrls", "none")
DEFAULT_SEED_BASE = 100_000
"""Held-out tracks: training uses seeds near 0 and its EvalCallback near 1 000 000."""


@dataclass(frozen=True)
class Task:
    controller: str
    observer: str
    seed: int
    env_kwargs_json: str = "{}"
    record: bool = False


# --- controllers ---------------------------------------------------------------------------------------------
def _base_name(spec: str) -> tuple[str, bool]:
    if spec.endswith("+shield"):
        return spec[: -len("+shield")], True
    return spec, False


def controller_label(spec: str) -> str:
    """Short label for tables: run directories by their name."""
    base, shield = _base_name(spec)
    label = Path(base).name if ("/" in base or Path(base).is_dir()) else base
    return label + ("+shield" if shield else "")


class _ModelPolicy:
    """A trained SB3 model with its VecNormalize observation statistics, acting on raw observations."""

    def __init__(self, run_dir: Path) -> None:
        import pickle

        import torch

        from agents.algos import algo_class

        torch.set_num_threads(1)  # one episode per process: threads would only fight over the cores

        cfg = json.loads((run_dir / "config.json").read_text()) if (run_dir / "config.json").exists() else {}
        self.shield = bool(cfg.get("shield", False))
        self.residual = float(cfg.get("residual", 0.0))
        algo = cfg.get("algo", "ppo")
        path = run_dir / "model.zip"
        vn_path = run_dir / "vecnormalize.pkl"
        if not path.exists():
            raise FileNotFoundError(f"{run_dir}: no model.zip (train it with scripts/train.py first)")
        self.model = algo_class(algo).load(path, device="cpu")
        self.vecnorm = None
        if vn_path.exists():
            with open(vn_path, "rb") as fh:
                self.vecnorm = pickle.load(fh)
            self.vecnorm.training = False

    def act(self, obs: np.ndarray, info: dict[str, Any]) -> np.ndarray:
        o = self.vecnorm.normalize_obs(obs) if self.vecnorm is not None and self.vecnorm.norm_obs else obs
        action, _ = self.model.predict(o, deterministic=True)
        return np.asarray(action, dtype=np.float32).reshape(1)


_CACHE: dict[str, Any] = {}


def _make_controller(spec: str, vehicle):
    from agents.controllers import CONTROLLERS

    base, _ = _base_name(spec)
    if base in CONTROLLERS:
        return CONTROLLERS[base](vehicle)
    key = f"model:{base}"
    if key not in _CACHE:
        _CACHE[key] = _ModelPolicy(Path(base))
    return _CACHE[key]


def run_episode(task: Task) -> dict[str, Any]:
    """Run one episode; return its flat summary row (and, if ``task.record``, the per-step trace)."""
    import gymnasium as gym

    import uuom_gym  # noqa: F401
    from agents.metrics import EpisodeAccumulator
    from agents.shield import ShieldWrapper

    env_kwargs = json.loads(task.env_kwargs_json)
    env = gym.make(ENV_ID, observer=task.observer, **env_kwargs)
    vehicle = env.unwrapped.vehicle
    ctrl = _make_controller(task.controller, vehicle)
    shield = _base_name(task.controller)[1] or bool(getattr(ctrl, "shield", False))
    if shield:
        env = ShieldWrapper(env)
    if getattr(ctrl, "residual", 0.0) > 0:
        from agents.residual import ResidualWrapper

        env = ResidualWrapper(env, scale=ctrl.residual)
    obs, info = env.reset(seed=task.seed)
    if hasattr(ctrl, "reset"):
        ctrl.reset(env, info)
    acc = EpisodeAccumulator()
    acc.start(info)
    trace: dict[str, list[float]] = {k: [] for k in ("t_s", "position_m", "speed_mps", "true_limit_mps", "est_limit_mps", "command")}
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
    if task.record:
        row["trace"] = trace
    return row


# --- parallel execution --------------------------------------------------------------------------------------
def run_tasks(tasks: list[Task], workers: int, use_ray: bool = False, progress: bool = True) -> list[dict[str, Any]]:
    """Run the episodes locally (multiprocessing) or on Ray; results in task order."""
    if use_ray:
        try:
            import ray
        except ImportError:
            raise SystemExit("--ray needs Ray: pip install 'ray[default]'") from None
        ray.init(address=os.environ.get("RAY_ADDRESS"), ignore_reinit_error=True)
        remote = ray.remote(run_episode)
        return ray.get([remote.remote(t) for t in tasks])
    if workers <= 1:
        out = []
        for i, t in enumerate(tasks):
            out.append(run_episode(t))
            if progress:
                print(f"\r{i + 1}/{len(tasks)} episodes", end="", file=sys.stderr, flush=True)
        if progress:
            print(file=sys.stderr)
        return out
    import multiprocessing as mp

    ctx = mp.get_context("fork" if sys.platform.startswith("linux") else "spawn")
    out: list[dict[str, Any]] = []
    with ctx.Pool(workers) as pool:
        for i, row in enumerate(pool.imap(run_episode, tasks, chunksize=1)):
            out.append(row)
            if progress:
                print(f"\r{i + 1}/{len(tasks)} episodes", end="", file=sys.stderr, flush=True)
    if progress:
        print(file=sys.stderr)
    return out


# --- aggregation ---------------------------------------------------------------------------------------------
RULES = ("speed_limit", "adhesion", "rollback", "sway", "overspeed_trip", "stall")


def summarise(rows: list[dict[str, Any]], oracle_label: str = "oracle") -> list[dict[str, Any]]:
    """One summary row per (controller, observer)."""
    ref = {r["seed"]: r["trip_time_s"] for r in rows if r["controller"] == oracle_label and r["success"]}
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((r["controller"], r["observer"]), []).append(r)
    out = []
    for (ctrl, obs), rs in groups.items():
        n = len(rs)
        km = sum(r["distance_m"] for r in rs) / 1000.0
        steps = sum(r["steps"] for r in rs)
        ratios = [r["trip_time_s"] / ref[r["seed"]] for r in rs if r["success"] and r["seed"] in ref]
        energy = [r["energy_kj_per_tkm"] for r in rs if r["success"] and math.isfinite(r["energy_kj_per_tkm"])]
        mass_err = [r["mass_err_pct"] for r in rs if math.isfinite(r["mass_err_pct"])]
        slope_err = [r["slope_err_deg"] for r in rs if math.isfinite(r["slope_err_deg"])]
        row = {
            "controller": ctrl,
            "observer": obs,
            "episodes": n,
            "success_rate": sum(bool(r["success"]) for r in rs) / n,
            "overspeed_trips": sum(bool(r["overspeed_trip"]) for r in rs),
            "cost_rate": sum(r["cost"] for r in rs) / max(steps, 1),
            "trip_time_vs_oracle": float(np.mean(ratios)) if ratios else float("nan"),
            "energy_kj_per_tkm": float(np.mean(energy)) if energy else float("nan"),
            "mass_err_pct": float(np.mean(mass_err)) if mass_err else float("nan"),
            "slope_err_deg": float(np.mean(slope_err)) if slope_err else float("nan"),
            "km": km,
        }
        for rule in RULES:
            row[f"viol_per_km/{rule}"] = sum(r[f"violations/{rule}"] for r in rs) / max(km, 1e-9)
        out.append(row)
    order = {o: i for i, o in enumerate(DEFAULT_OBSERVERS)}
    out.sort(key=lambda r: (r["controller"] != oracle_label, r["controller"], order.get(r["observer"], 99), r["observer"]))
    return out


def write_csv(path: Path, rows: list[dict[str, Any]]) -> None:
    keys: list[str] = []
    for r in rows:
        for k in r:
            if k not in keys and k != "trace":
                keys.append(k)
    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=keys, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)


def markdown_table(summary: list[dict[str, Any]]) -> str:
    """The Markdown table of the summary (the README shows it)."""
    head = (
        "| controller | observer | success | overspeed trips | cost rate | trip time / oracle | energy kJ/(t km) "
        "| viol/km speed | adhesion | rollback | sway | stall | mass err % | slope err deg |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n"
    )

    def f(x: float, nd: int = 3) -> str:
        return "n/a" if not math.isfinite(x) else f"{x:.{nd}f}"

    lines = []
    for r in summary:
        lines.append(
            f"| {r['controller']} | {r['observer']} | {100 * r['success_rate']:.0f} % | {r['overspeed_trips']}/{r['episodes']} "
            f"| {r['cost_rate']:.2e} | {f(r['trip_time_vs_oracle'], 3)} | {f(r['energy_kj_per_tkm'], 0)} "
            f"| {f(r['viol_per_km/speed_limit'], 1)} | {f(r['viol_per_km/adhesion'], 1)} | {f(r['viol_per_km/rollback'], 1)} "
            f"| {f(r['viol_per_km/sway'], 1)} | {f(r['viol_per_km/stall'], 1)} | {f(r['mass_err_pct'], 1)} | {f(r['slope_err_deg'], 2)} |"
        )
    return head + "\n".join(lines) + "\n"


# --- figures -------------------------------------------------------------------------------------------------
def plot_bars(summary: list[dict[str, Any]], path: Path) -> None:
    """Grouped bars per observer: success rate, cost rate, trip time relative to the oracle."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    observers = [o for o in DEFAULT_OBSERVERS if any(r["observer"] == o for r in summary)]
    observers += sorted({r["observer"] for r in summary} - set(observers))
    ctrls = [c for c in dict.fromkeys(r["controller"] for r in summary) if c != "oracle"]
    metrics = [
        ("success_rate", "success rate"),
        ("overspeed_trip_rate", "overspeed trips (fraction of runs)"),
        ("cost_rate", "cost rate (per step)"),
        ("trip_time_vs_oracle", "trip time / oracle"),
    ]
    fig, axes = plt.subplots(1, len(metrics), figsize=(4.2 * len(metrics), 4.2))
    width = 0.8 / max(len(ctrls), 1)
    x = np.arange(len(observers))
    for ax, (key, title) in zip(axes, metrics):
        for i, c in enumerate(ctrls):
            vals = []
            for o in observers:
                m = [r for r in summary if r["controller"] == c and r["observer"] == o]
                if not m:
                    vals.append(np.nan)
                elif key == "overspeed_trip_rate":
                    vals.append(m[0]["overspeed_trips"] / max(m[0]["episodes"], 1))
                else:
                    vals.append(m[0][key])
            ax.bar(x + (i - (len(ctrls) - 1) / 2) * width, vals, width, label=c)
        if key == "trip_time_vs_oracle":
            ax.axhline(1.0, color="k", lw=0.8, ls="--")
            ax.axhline(1.25, color="r", lw=0.8, ls=":", label="target 1.25")
        ax.set_xticks(x, observers, rotation=35, ha="right", fontsize=8)
        ax.set_title(title, fontsize=10)
        ax.grid(axis="y", alpha=0.3)
    handles, labels = axes[-1].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, loc="lower center", ncol=len(labels), frameon=False)
    fig.suptitle("UUOM-Track-v0: controllers x observers on the same held-out tracks", fontsize=11)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_episode(rows: list[dict[str, Any]], path: Path) -> None:
    """Speed vs the true and the estimated speed limit along one episode, one panel per recorded run."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rec = [r for r in rows if "trace" in r]
    if not rec:
        return
    fig, axes = plt.subplots(len(rec), 1, figsize=(9, 2.6 * len(rec)), sharex=True, squeeze=False)
    for ax, r in zip(axes[:, 0], rec):
        tr = r["trace"]
        s = np.asarray(tr["position_m"])
        ax.plot(s, tr["true_limit_mps"], color="k", lw=1.2, label="true limit v_lim(M, slope)")
        ax.plot(s, tr["est_limit_mps"], color="tab:orange", lw=1.0, ls="--", label="limit from the estimates")
        ax.plot(s, tr["speed_mps"], color="tab:blue", lw=1.2, label="speed")
        ax.set_ylabel("m/s")
        ax.set_ylim(0, max(2.1, float(np.max(tr["speed_mps"])) + 0.1))
        ax.set_title(
            f"{r['controller']} / observer {r['observer']} - seed {r['seed']}: {r['termination']}, "
            f"{r['trip_time_s']:.0f} s, cost {r['cost']:.3g}",
            fontsize=9,
        )
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("position along the track (m)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# --- main ----------------------------------------------------------------------------------------------------
def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--controllers", nargs="+", default=["oracle", "rule-based"],
                    help="oracle, rule-based, a scripts/train.py run directory, any of them + '+shield'")
    ap.add_argument("--observers", nargs="+", default=list(DEFAULT_OBSERVERS))
    ap.add_argument("--episodes", type=int, default=100)
    ap.add_argument("--seed-base", type=int, default=DEFAULT_SEED_BASE)
    ap.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--ray", action="store_true", help="run the episodes on Ray instead of local processes")
    ap.add_argument("--env-kwargs", type=json.loads, default={})
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "eval")
    ap.add_argument("--plot-seed", type=int, default=None, help="episode drawn speed-vs-limit (default: first seed)")
    ap.add_argument("--plot-observer", default="dffrls-aekf")
    ap.add_argument("--bars-png", type=Path, default=None, help="also copy the bar chart here (e.g. docs/img/...)")
    ap.add_argument("--episode-png", type=Path, default=None, help="also copy the episode plot here")
    ap.add_argument("--merge", nargs="+", type=Path, default=None, metavar="DIR",
                    help="build the table and the bar chart from the episodes.csv of earlier --out directories "
                    "(no new episodes, except the one recorded episode per controller for the speed plot)")
    ap.add_argument("--quiet", action="store_true")
    return ap.parse_args(argv)


def read_episodes(path: Path) -> list[dict[str, Any]]:
    """Rows of an ``episodes.csv`` with numbers and booleans parsed back."""
    rows = []
    with path.open() as fh:
        for r in csv.DictReader(fh):
            out: dict[str, Any] = {}
            for k, v in r.items():
                if v in ("True", "False"):
                    out[k] = v == "True"
                else:
                    try:
                        out[k] = int(v)
                    except ValueError:
                        try:
                            out[k] = float(v)
                        except ValueError:
                            out[k] = v
            out["controller"] = str(r["controller"])
            out["observer"] = str(r["observer"])
            rows.append(out)
    return rows


def evaluate(args: argparse.Namespace) -> list[dict[str, Any]]:
    """Run the evaluation described by ``args``; return the summary rows (files written to ``args.out``)."""
    if args.episodes < 1:
        raise SystemExit("--episodes must be >= 1")
    kw = json.dumps(args.env_kwargs, sort_keys=True)
    seeds = [args.seed_base + i for i in range(args.episodes)]
    plot_seed = seeds[0] if args.plot_seed is None else args.plot_seed
    if args.merge:
        return _merge(args, kw, plot_seed)
    tasks: list[Task] = []
    for ctrl in args.controllers:
        base, _ = _base_name(ctrl)
        # The oracle controller reads the truth, not the observation: one run per track serves every observer.
        observers = ["oracle"] if base == "oracle" else args.observers
        for obs in observers:
            for s in seeds:
                record = s == plot_seed and (obs == args.plot_observer or base == "oracle")
                tasks.append(Task(ctrl, obs, s, kw, record=record))
    t0 = time.time()
    rows = run_tasks(tasks, args.workers, args.ray, progress=not args.quiet)
    wall = time.time() - t0
    summary = summarise(rows)
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "episodes.csv", rows)
    write_csv(out / "summary.csv", summary)
    md = markdown_table(summary)
    cmd = "python scripts/evaluate.py " + " ".join(sys.argv[1:]) if argv_was_cli() else "(called from Python)"
    (out / "summary.md").write_text(
        f"Held-out seeds {seeds[0]}..{seeds[-1]} ({len(seeds)} tracks), {len(rows)} episodes in {wall:.0f} s.\n"
        f"Command: `{cmd}`\n\n" + md
    )
    plot_bars(summary, out / "bars.png")
    rec = [r for r in rows if "trace" in r and (r["observer"] == args.plot_observer or r["controller"] == "oracle")]
    plot_episode(rec, out / "episode.png")
    import shutil

    if args.bars_png:
        args.bars_png.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(out / "bars.png", args.bars_png)
    if args.episode_png and (out / "episode.png").exists():
        args.episode_png.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(out / "episode.png", args.episode_png)
    if not args.quiet:
        print(md)
        print(f"{len(rows)} episodes in {wall:.0f} s -> {out}")
    return summary


def _merge(args: argparse.Namespace, kw: str, plot_seed: int) -> list[dict[str, Any]]:
    rows: list[dict[str, Any]] = []
    seen: set[tuple[str, str, int]] = set()
    for d in args.merge:
        for r in read_episodes(Path(d) / "episodes.csv"):
            key = (r["controller"], r["observer"], int(r["seed"]))
            if key not in seen:  # the same episode in two directories (e.g. the oracle rows) counts once
                seen.add(key)
                rows.append(r)
    summary = summarise(rows)
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "episodes.csv", rows)
    write_csv(out / "summary.csv", summary)
    seeds = sorted({int(r["seed"]) for r in rows})
    cmd = "python scripts/evaluate.py " + " ".join(sys.argv[1:]) if argv_was_cli() else "(called from Python)"
    (out / "summary.md").write_text(
        f"Held-out seeds {seeds[0]}..{seeds[-1]} ({len(seeds)} tracks), {len(rows)} episodes merged from "
        f"{', '.join(str(d) for d in args.merge)}.\nCommand: `{cmd}`\n\n" + markdown_table(summary)
    )
    plot_bars(summary, out / "bars.png")
    tasks = [Task(c, "oracle" if _base_name(c)[0] == "oracle" else args.plot_observer, plot_seed, kw, True)
             for c in args.controllers]
    rec = run_tasks(tasks, min(args.workers, len(tasks)), args.ray, progress=False)
    plot_episode(rec, out / "episode.png")
    import shutil

    if args.bars_png:
        args.bars_png.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(out / "bars.png", args.bars_png)
    if args.episode_png:
        args.episode_png.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy(out / "episode.png", args.episode_png)
    if not args.quiet:
        print((out / "summary.md").read_text())
    return summary


_CLI = False


def argv_was_cli() -> bool:
    return _CLI


def main(argv: list[str] | None = None) -> int:
    evaluate(parse_args(argv))
    return 0


if __name__ == "__main__":
    _CLI = True
    raise SystemExit(main())
