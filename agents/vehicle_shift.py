"""Do the controllers hold on a vehicle they were not built on? Every controller, hand-written or trained, driven
unchanged on seeded *sister vehicles* (every field of the vehicle file drawn within ×/÷ a factor of the project's,
:func:`uuom_core.vehicle_variants.sister_vehicles`) and, as the control, on the project's own vehicle.

Why: the rule-based controller reads the vehicle file, the estimator too; a trained policy saw one vehicle in
training and reads observations scaled by that vehicle's numbers. A table judged on the training vehicle says
nothing about the next monorail of the same class.

The env is given the vehicle (its ``vehicle`` config entry); a trained policy runs on its own training env otherwise
(its ``config.json``), so the vehicle is the only shift. Each track is identified by ``(vehicle, seed)``: on another
vehicle the same seed can draw another track (random tracks are capped by what that train can climb and brake), so
the oracle runs on every vehicle and each trip time is divided by the oracle's on the same vehicle and seed.
:func:`run_vehicle_shift` writes ``episodes.csv`` (column ``vehicle``: 0 is the project's vehicle), ``vehicles.json``
(the draws, as env ``vehicle`` overrides), ``run.json`` (the configuration and command), ``summary.md`` (the project's vehicle, the sister vehicles pooled, and
one line per vehicle) and ``vehicle_shift.png``; :func:`report_vehicle_shift` rebuilds the last two from the first three.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from agents.evaluation import DEFAULT_SEED_BASE, Task, run_tasks, split_options, split_shield, trained_env_kwargs
from agents.evaluation_table import markdown_ci_table, markdown_table, pool_rows, read_episodes, summarise, write_csv
from uuom_core.vehicle import DEFAULT_VEHICLE, VehicleParams
from uuom_core.vehicle_variants import sister_vehicles, vehicle_overrides

__all__ = ["ShiftConfig", "load_config", "plot_vehicle_shift", "report_vehicle_shift", "run_vehicle_shift", "shift_tasks", "track_id"]

TRACK_STRIDE = 1_000_000
"""``track_id = vehicle * TRACK_STRIDE + seed``: one key per (vehicle, seed) for the tables' oracle reference."""


@dataclass(frozen=True)
class ShiftConfig:
    """One vehicle-shift study.

    Attributes
    ----------
    controllers : tuple of str
        Controller specs as for ``uuom-evaluate`` (``oracle`` is added when missing: it is the reference).
    observer : str
        The observer every non-oracle controller drives with.
    vehicles, spread, vehicle_seed : int, float, int
        How many sister vehicles, within ×/÷ ``spread`` of the project's, drawn with ``vehicle_seed``.
    episodes, seed_base : int
        Tracks per vehicle: seeds ``seed_base ..`` (the held-out seeds by default).
    vehicle_files : tuple of str
        TOML vehicle files to drive on instead of drawn sister vehicles (``vehicles``, ``spread`` and
        ``vehicle_seed`` are then not used): does a controller hold on *this* vehicle?
    pools : dict
        Label -> controller labels shown as one row (training seeds; see :func:`agents.evaluation_table.pool_rows`).
    workers : int
    out : Path
    command : str
        The command line, for ``summary.md``.
    """

    controllers: tuple[str, ...]
    observer: str = "dffrls-aekf"
    vehicles: int = 10
    spread: float = 1.25
    vehicle_seed: int = 0
    episodes: int = 20
    seed_base: int = DEFAULT_SEED_BASE
    vehicle_files: tuple[str, ...] = ()
    pools: dict[str, list[str]] = field(default_factory=dict)
    workers: int = 2
    out: Path = Path("results/agents/vehicle_shift")
    command: str = "(called from Python)"


def track_id(vehicle: int, seed: int) -> int:
    return vehicle * TRACK_STRIDE + seed


def _vehicle_list(config: ShiftConfig) -> list[VehicleParams]:
    """The project's vehicle first (index 0), then the sister vehicles."""
    if config.episodes < 1 or config.episodes >= TRACK_STRIDE // 2:
        raise ValueError(f"vehicle shift: episodes must be in [1, {TRACK_STRIDE // 2}), got {config.episodes!r}")
    if config.vehicle_files:
        return [DEFAULT_VEHICLE] + [VehicleParams.from_toml(f) for f in config.vehicle_files]
    return [DEFAULT_VEHICLE] + sister_vehicles(config.vehicle_seed, config.vehicles, config.spread)


def shift_tasks(config: ShiftConfig, vehicles: list[VehicleParams] | None = None) -> list[tuple[int, Task]]:
    """``(vehicle index, Task)`` for every controller x vehicle x track (the oracle on every vehicle); ``vehicles``:
    the study's list when already drawn (:func:`_vehicle_list`)."""
    vehicles = _vehicle_list(config) if vehicles is None else vehicles
    controllers = list(dict.fromkeys(["oracle", *config.controllers]))
    own_env: dict[str, dict[str, Any]] = {}
    for c in controllers:
        name = split_options(split_shield(c)[0])[0]
        own_env[c] = trained_env_kwargs(Path(name)) if ("/" in name or Path(name).is_dir()) else {}
        own_env[c].pop("vehicle_spread", None)  # trained on drawn vehicles: judged here on the study's fixed ones
    tasks = []
    for k, v in enumerate(vehicles):
        over = vehicle_overrides(v)
        for c in controllers:
            kw = {**own_env[c], **({"vehicle": over} if over else {})}
            observer = "oracle" if split_shield(c)[0] == "oracle" else config.observer
            for i in range(config.episodes):
                tasks.append((k, Task(c, observer, config.seed_base + i, json.dumps(kw, sort_keys=True))))
    return tasks


def _fmt_vehicle(v: VehicleParams) -> str:
    return (f"{v.empty_mass_kg / 1e3:.1f} t + {v.rated_load_kg / 1e3:.1f} t, {v.length_m:.1f} m, "
            f"{v.max_traction_n / 1e3:.0f} kN, v_rated {v.max_speed_rated_mps:.2f} m/s, chains {v.chain_length_m:.1f} m")


def _per_vehicle_lines(per_vehicle: list[dict[str, dict[str, Any]]], vehicles: list[VehicleParams],
                       labels: list[str]) -> str:
    head = "| vehicle | " + " | ".join(labels) + " |\n| --- |" + " --- |" * len(labels) + "\n"
    lines = []
    for k, (v, by_label) in enumerate(zip(vehicles, per_vehicle)):
        cells = []
        for lab in labels:
            s = by_label.get(lab)
            if s is None:
                cells.append("–")
                continue
            arrived = round(s["success_rate"] * s["episodes"])
            iqm = s["trip_time_iqm"]
            cells.append(f"{arrived}/{s['episodes']}, {s['overspeed_trips']} trips"
                         + (f", {iqm:.3f}" if math.isfinite(iqm) and lab != "oracle" else ""))
        name = "0: the project's" if k == 0 else f"{k}: {_fmt_vehicle(v)}"
        lines.append(f"| {name} | " + " | ".join(cells) + " |")
    return head + "\n".join(lines) + "\n"


def plot_vehicle_shift(per_vehicle: list[dict[str, dict[str, Any]]], labels: list[str], path: Path) -> None:
    """Per vehicle (x; 0 the project's): each controller's trip time / oracle (IQM, top) and its cost rate and
    overspeed trips (bottom; a trip marked by its count). ``per_vehicle[k]``: vehicle k's summary rows by label."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = [c for c in labels if c != "oracle"]
    n_vehicles = len(per_vehicle)
    fig, (ax_t, ax_c) = plt.subplots(2, 1, figsize=(9, 6.4), sharex=True)
    x = np.arange(n_vehicles)
    for j, lab in enumerate(labels):
        rows = [by_label.get(lab) for by_label in per_vehicle]
        iqm = [r["trip_time_iqm"] if r else np.nan for r in rows]
        cost = [r["cost_rate"] if r else np.nan for r in rows]
        trips = [r["overspeed_trips"] if r else 0 for r in rows]
        off = (j - (len(labels) - 1) / 2) * 0.08
        line = ax_t.plot(x + off, iqm, "o-", ms=4, lw=1, label=lab)[0]
        ax_c.semilogy(x + off, np.maximum(cost, 1e-9), "o-", ms=4, lw=1, color=line.get_color())
        for k, n in enumerate(trips):
            if n:
                ax_c.annotate(f"{n} trip{'s' if n > 1 else ''}", (k + off, max(cost[k], 1e-9)), fontsize=7,
                              color=line.get_color(), xytext=(3, 4), textcoords="offset points")
    ax_t.axvspan(-0.5, 0.5, color="0.9", zorder=0)
    ax_c.axvspan(-0.5, 0.5, color="0.9", zorder=0)
    ax_t.set_ylabel("trip time / oracle (IQM)")
    ax_c.set_ylabel("cost rate per step (0 drawn at 1e-9)")
    ax_c.set_xticks(x, ["project's"] + [str(k) for k in range(1, n_vehicles)])
    ax_c.set_xlabel("vehicle (shaded: the one every controller was built and trained on)")
    for ax in (ax_t, ax_c):
        ax.grid(alpha=0.3)
    ax_t.legend(fontsize=7, ncol=2)
    fig.suptitle("The same controllers on sister vehicles", fontsize=11)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def run_vehicle_shift(config: ShiftConfig, progress: bool = True) -> dict[str, list[dict[str, Any]]]:
    """Run the study; write its files to ``config.out`` (:func:`report_vehicle_shift`); return its summaries."""
    vehicles = _vehicle_list(config)
    pairs = shift_tasks(config, vehicles)
    t0 = time.time()
    raw = run_tasks([t for _, t in pairs], config.workers, progress=progress)
    wall = time.time() - t0
    rows = []
    for (k, task), r in zip(pairs, raw):
        r = {key: val for key, val in r.items() if key != "trace"}
        r["vehicle"] = k
        r["track_seed"] = task.seed
        r["seed"] = track_id(k, task.seed)
        rows.append(r)
    out = Path(config.out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(out / "episodes.csv", rows)
    (out / "vehicles.json").write_text(json.dumps(
        [{"index": k, "vehicle": vehicle_overrides(v)} for k, v in enumerate(vehicles)], indent=1) + "\n")
    (out / "run.json").write_text(json.dumps({"wall_s": round(wall), "episodes": len(rows), "command": config.command,
                                              "config": _config_json(config)}, indent=1) + "\n")
    return report_vehicle_shift(out, progress)


def _config_json(config: ShiftConfig) -> dict[str, Any]:
    return {"controllers": list(config.controllers), "observer": config.observer, "vehicles": config.vehicles,
            "spread": config.spread, "vehicle_seed": config.vehicle_seed, "episodes": config.episodes,
            "seed_base": config.seed_base, "vehicle_files": list(config.vehicle_files), "pools": config.pools}


def load_config(out: Path) -> ShiftConfig:
    """The configuration of the finished run in ``out`` (its ``run.json``).

    Raises
    ------
    FileNotFoundError
        ``out`` holds no ``run.json``.
    """
    return _config_from(json.loads((Path(out) / "run.json").read_text()), Path(out))


def _config_from(run: dict[str, Any], out: Path) -> ShiftConfig:
    c = run["config"]
    return ShiftConfig(controllers=tuple(c["controllers"]), observer=c["observer"], vehicles=c["vehicles"],
                       spread=c["spread"], vehicle_seed=c["vehicle_seed"], episodes=c["episodes"],
                       seed_base=c["seed_base"], vehicle_files=tuple(c.get("vehicle_files", ())),
                       pools={k: list(v) for k, v in c["pools"].items()}, out=Path(out),
                       command=run.get("command", "(called from Python)"))


def report_vehicle_shift(out: Path, progress: bool = True) -> dict[str, list[dict[str, Any]]]:
    """``summary.md``, ``summary_vehicles.csv`` and ``vehicle_shift.png`` from the ``episodes.csv``, ``vehicles.json``
    and ``run.json`` of the finished run in ``out`` (no episode is run); return ``{"project": ..., "sisters": ...}``.

    Raises
    ------
    FileNotFoundError
        ``out`` holds no finished run.
    """
    out = Path(out)
    run = json.loads((out / "run.json").read_text())
    config = _config_from(run, out)
    rows = read_episodes(out / "episodes.csv")
    vehicles = [VehicleParams(**{**dataclasses.asdict(DEFAULT_VEHICLE), **v["vehicle"]})
                for v in json.loads((out / "vehicles.json").read_text())]
    pooled = pool_rows(rows, config.pools) if config.pools else rows
    per_vehicle = [{r["controller"]: r for r in summarise([x for x in pooled if x["vehicle"] == k])}
                   for k in range(len(vehicles))]
    project = list(per_vehicle[0].values())
    sisters = summarise([r for r in pooled if r["vehicle"] > 0])
    labels = list(dict.fromkeys(r["controller"] for r in pooled))
    episodes = len({r["track_seed"] for r in rows})
    seeds = sorted({r["track_seed"] for r in rows})
    wall = f" in {run['wall_s']} s" if "wall_s" in run else ""
    drawn = (f"the vehicle files {', '.join(f'`{f}`' for f in config.vehicle_files)}" if config.vehicle_files else
             f"{len(vehicles) - 1} sister vehicles (every field log-uniform within ×/÷ {config.spread:g} of the "
             f"project's, vehicle seed {config.vehicle_seed})")
    md = (f"{drawn} and the project's vehicle, {episodes} tracks each (seeds "
          f"{seeds[0]}..{seeds[-1]}), observer `{config.observer}`; {len(rows)} episodes{wall}.\n"
          f"Command: `{config.command}`\n\n"
          "Trip time / oracle: against the oracle controller on the same vehicle and track. Intervals as in "
          "`uuom-evaluate` (rates: Wilson, or for pooled training seeds a bootstrap over seeds and tracks; IQM: "
          "bootstrap).\n\n## The project's vehicle\n\n" + markdown_table(project) + "\n" + markdown_ci_table(project)
          + "\n## The sister vehicles, pooled\n\n" + markdown_table(sisters) + "\n" + markdown_ci_table(sisters)
          + "\n## Per vehicle (arrived, overspeed trips, trip time / oracle IQM)\n\n"
          + _per_vehicle_lines(per_vehicle, vehicles, labels)
          + "\nThe vehicles' fields: `vehicles.json` (env `vehicle` overrides; index 0 is the project's). "
          "Figure: `vehicle_shift.png`.\n")
    (out / "summary.md").write_text(md)
    write_csv(out / "summary_vehicles.csv", [{**r, "vehicles": "project"} for r in project]
              + [{**r, "vehicles": "sisters"} for r in sisters])
    plot_vehicle_shift(per_vehicle, labels, out / "vehicle_shift.png")
    if progress:
        print(md)
    return {"project": project, "sisters": sisters}
