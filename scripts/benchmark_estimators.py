#!/usr/bin/env python
"""Benchmark every registered estimator on the plant's named scenarios, like paper 000's Tables 1, 2 and 4.

For each scenario (``section1``, ``section2``, ``roadtest``) and seed, :func:`uuom_gym.sim.recording.simulate_run`
records a run of the pymunk plant with the default sensor noise; every estimator that imports
(:func:`estimators.available`) runs over it sample by sample. Reported per estimator and scenario, averaged over
the seeds: mass RMSE (kg and %) and slope RMSE (deg) over the samples after ``--settle-s`` (eq. 31 of the paper),
final mass error, and the time for the whole run (the paper's "identification time") — next to the paper's values
where it has them. Figures like the paper's Figs. 6-9 (estimate vs truth and error over time, first seed) go to
``docs/img/estimators_<scenario>.png``.

Usage::

    python scripts/benchmark_estimators.py                  # 3 seeds, 10 t load (the paper's road-test load)
    python scripts/benchmark_estimators.py --quick          # CI size: 1 seed, 60 s runs, no figures
    python scripts/benchmark_estimators.py --loads 0,20000  # other loads (the estimators' prior is 26 t)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import estimators
from estimators.cli import names_argument
from estimators.metrics import error_after_settling
from estimators.protocol_report import PAPER_MASS_RMSE, PAPER_SLOPE_RMSE_DEG
from uuom_core.trace import Trace
from uuom_gym.sim.track import SCENARIO_NAMES as SCENARIOS

# paper 000, Tables 1, 2, 4 (RMSE; mass in kg, slope in degrees as far as can be told; spec model.md §5.5)
PAPER_MASS = PAPER_MASS_RMSE
PAPER_SLOPE = PAPER_SLOPE_RMSE_DEG
PAPER_TIME = {"dffrls-aekf": ("1.10-1.50", "1.31-1.61", "1.32-1.66")}
FIG_METHODS = ("ffrls", "ekf", "rls-ekf", "dffrls-aekf", "sf-kf")


NOT_ESTIMATED = f"{'(not estimated: prior)':<30}"


def paper_text(table: dict, name: str, scenario: str, fmt: str) -> str:
    """The paper's value for an estimator and scenario as ``[value]`` (``""`` where the paper has none)."""
    paper = table.get(name)
    pi = SCENARIOS.index(scenario) if scenario in SCENARIOS else None
    return f"[{paper[pi]:{fmt}}]" if paper and pi is not None else ""


def print_rows(usable: list[str], scenarios, res: dict, cell) -> None:
    """One table row per estimator: ``cell(name, scenario, results of the seeds)`` per scenario column."""
    for name in usable:
        print(f"{name:<12} | " + " | ".join(cell(name, sc, res[name][sc]) for sc in scenarios))


def record(scenario: str, seed: int, load_kg: float | None, duration_s: float | None):
    """The trace and the plant's truth log of one run."""
    from uuom_gym.sim.recording import simulate_run

    return simulate_run(scenario, seed=seed, load_kg=load_kg, duration_s=duration_s, return_log=True)


def train_slope_deg(log) -> np.ndarray | None:
    """The slope gravity acts on, ``asin(sum m_i sin(slope_i) / M)`` over the plant's bodies (the 18 m train).

    What a point-mass dynamic model can see, as opposed to the slope at the reference point (the truth column).
    From the plant's truth log; a reference for the analysis only, not an estimator input.
    """
    eff = getattr(log, "effective_slope_rad", None)
    return None if eff is None else np.degrees(np.asarray(eff))


def evaluate(name: str, trace: Trace, settle_s: float, train_slope: np.ndarray | None = None):
    est = estimators.make(name)
    t0 = time.perf_counter()
    s = est.run(trace)
    elapsed = time.perf_counter() - t0
    t = trace["t_s"]
    mass_pct = error_after_settling(t, s.mass_kg, trace["mass_kg"], settle_s, relative=True)
    mass_kg = error_after_settling(t, s.mass_kg, trace["mass_kg"], settle_s)
    slope = error_after_settling(t, s.slope_deg, trace["slope_deg"], settle_s)
    vs_train = (error_after_settling(t, s.slope_deg, train_slope, settle_s) if train_slope is not None else None)
    return s, {
        "provides_mass": "mass" in est.provides,
        "provides_slope": "slope" in est.provides,
        "slope_vs_train_rmse_deg": vs_train.rmse if vs_train is not None else float("nan"),
        "mass_rmse_kg": mass_kg.rmse,
        "mass_rmse_pct": mass_pct.rmse,
        "mass_final_pct": float(100 * (s.mass_kg[-1] / trace["mass_kg"][-1] - 1)),
        "slope_rmse_deg": slope.rmse,
        "time_s": elapsed,
        "finite": bool(np.all(np.isfinite(s.mass_kg)) and np.all(np.isfinite(s.slope_rad))),
    }


def figure(scenario: str, trace: Trace, series: dict, path: Path, load_kg: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = trace["t_s"]
    fig, ax = plt.subplots(2, 2, figsize=(12, 7), sharex=True)
    ax[0, 0].plot(t, trace["mass_kg"] / 1000, "k", lw=2, label="truth")
    ax[1, 0].axhline(0, color="k", lw=1)
    ax[0, 1].plot(t, trace["slope_deg"], "k", lw=2, label="truth")
    ax[1, 1].axhline(0, color="k", lw=1)
    for name, s in series.items():
        ax[0, 0].plot(t, s.mass_kg / 1000, lw=1, label=name)
        ax[1, 0].plot(t, 100 * (s.mass_kg / trace["mass_kg"] - 1), lw=1, label=name)
        ax[0, 1].plot(t, s.slope_deg, lw=1, label=name)
        ax[1, 1].plot(t, s.slope_deg - trace["slope_deg"], lw=1, label=name)
    ax[0, 0].set_ylabel("mass (t)")
    ax[1, 0].set_ylabel("mass error (%)")
    ax[1, 0].set_ylim(-40, 40)
    ax[0, 1].set_ylabel("slope (deg)")
    ax[1, 1].set_ylabel("slope error (deg)")
    ax[1, 1].set_ylim(-5, 5)
    for a in ax[1]:
        a.set_xlabel("t (s)")
    for a in ax.flat:
        a.grid(alpha=0.3)
    ax[0, 0].legend(fontsize=8, ncol=2)
    fig.suptitle(f"{scenario}: plant run (seed 0, load {load_kg / 1000:g} t), estimates vs truth")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--loads", default="10000", help="comma-separated payloads in kg (paper: 10000)")
    ap.add_argument("--scenarios", default=",".join(SCENARIOS))
    ap.add_argument("--estimators", default=None, help="names, comma- or space-separated in one argument (default: all that import)")
    ap.add_argument("--settle-s", type=float, default=10.0)
    ap.add_argument("--duration-s", type=float, default=None, help="run length (default: the scenario's 120 s)")
    ap.add_argument("--quick", action="store_true", help="1 seed, 60 s runs, no figures")
    ap.add_argument("--no-figures", action="store_true")
    ap.add_argument("--fig-dir", default="docs/img")
    ap.add_argument("--json-out", default=None, help="write all results as JSON here")
    args = ap.parse_args(argv)
    if args.quick:
        args.seeds, args.duration_s, args.no_figures = 1, 60.0, True
    scenarios = args.scenarios.split(",")
    loads = [float(x) for x in args.loads.split(",")]
    names = names_argument(ap, args.estimators, default=estimators.available())
    usable = []
    for name in names:
        try:
            estimators.get_class(name)
            usable.append(name)
        except Exception as exc:
            print(f"# skipping {name}: {type(exc).__name__}: {exc}".splitlines()[0], file=sys.stderr)
    results: dict = {}
    for load in loads:
        for sc in scenarios:
            for seed in range(args.seeds):
                tr, log = record(sc, seed, load, args.duration_s)
                ts = train_slope_deg(log)
                fig_series = {}
                for name in usable:
                    s, r = evaluate(name, tr, args.settle_s, ts)
                    results.setdefault(load, {}).setdefault(name, {}).setdefault(sc, []).append(r)
                    if seed == 0 and name in FIG_METHODS:
                        fig_series[name] = s
                if seed == 0 and not args.no_figures and load == loads[0]:
                    figure(sc, tr, fig_series, Path(args.fig_dir) / f"estimators_{sc}.png", load)
    for load in loads:
        res = results[load]
        print(f"\n## load {load / 1000:g} t, {args.seeds} seed(s), errors after {args.settle_s:g} s "
              f"(mean over seeds; paper value in brackets)")
        hdr = " | ".join(f"{sc:^30}" for sc in scenarios)
        print(f"\n### mass RMSE: kg (%), final error %\n{'estimator':<12} | {hdr}")

        def mass_cell(name: str, sc: str, rs: list[dict]) -> str:
            if not rs[0]["provides_mass"]:
                return NOT_ESTIMATED
            kg = np.mean([r["mass_rmse_kg"] for r in rs])
            pct = np.mean([r["mass_rmse_pct"] for r in rs])
            fin = np.mean([r["mass_final_pct"] for r in rs])
            ptxt = paper_text(PAPER_MASS, name, sc, "g")
            return f"{kg:6.0f} ({pct:4.1f}%) {fin:+5.1f}% {ptxt:>7}"

        print_rows(usable, scenarios, res, mass_cell)
        print(f"\n### slope RMSE, deg\n{'estimator':<12} | {hdr}")

        def slope_cell(name: str, sc: str, rs: list[dict]) -> str:
            if not rs[0]["provides_slope"]:
                return NOT_ESTIMATED
            v = np.mean([r["slope_rmse_deg"] for r in rs])
            return f"{v:8.3f} {paper_text(PAPER_SLOPE, name, sc, 'g'):>8}{'':>13}"

        print_rows(usable, scenarios, res, slope_cell)
        print(f"\n### slope RMSE, deg, against the plant's effective slope (mass-weighted over the train; analysis only)"
              f"\n{'estimator':<12} | {hdr}")

        def train_slope_cell(name: str, sc: str, rs: list[dict]) -> str:
            v = np.mean([r["slope_vs_train_rmse_deg"] for r in rs])
            return f"{v:8.3f}{'':>22}" if rs[0]["provides_slope"] else NOT_ESTIMATED

        print_rows(usable, scenarios, res, train_slope_cell)
        print(f"\n### time for the whole run, s (paper: MATLAB)\n{'estimator':<12} | {hdr}")

        def time_cell(name: str, sc: str, rs: list[dict]) -> str:
            v = np.mean([r["time_s"] for r in rs])
            return f"{v:8.3f} {paper_text(PAPER_TIME, name, sc, ''):>11}{'':>10}"

        print_rows(usable, scenarios, res, time_cell)
        bad = [n for n in usable for sc in scenarios for r in res[n][sc] if not r["finite"]]
        if bad:
            print(f"\nNON-FINITE OUTPUT: {sorted(set(bad))}")
    if args.json_out:
        Path(args.json_out).write_text(json.dumps({str(k): v for k, v in results.items()}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
