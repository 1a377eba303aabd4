#!/usr/bin/env python
"""How much of an estimator's mass comes from the start from rest: the protocol's runs scored as they are, and
the same runs as logs that begin in motion (the first ``--starts`` seconds cut off, as a logger switched on
mid-run records them).

Every run of the generalisation protocol starts at a standstill, and the pull-away is the strongest excitation a
run has. This script asks what is left without it, and whether the estimators *say* so (their σ), per estimator,
world and start time:

- the mass max error after 10 s (of the log as given), and the error at its last sample;
- the share of samples whose true mass lies within ±2σ, and the runs whose error ever exceeds 3σ;
- for the logs from rest, the **measured-force share** after 10 s: the share of samples with a drive force above
  2 % of the traction limit and the train moving. Below it the plant's brake cars hold the train on a
  down-grade with the motors at ~0 N·m, a force no sensor in the trace measures, so those samples say nothing about
  the mass. Runs with less than 10 % of it get their mass from the first 10 s or not at all.

Nothing here is tuned; the runs are the protocol's evaluation runs (``uuom_gym.sim.protocol_runs``).

    python scripts/start_dependence.py --runs 200 --scenario-seeds 10 --workers 2 \\
        --out results/estimation/start_dependence.md       # 70-90 s on 2 cores
"""

from __future__ import annotations

import argparse
import multiprocessing
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

import estimators
from estimators.dffrls_aekf import DFFRLSAEKFConfig
from estimators.metrics import distribution, train_slope_deg
from uuom_core.trace import Trace
from uuom_core.vehicle import DEFAULT_VEHICLE
from uuom_gym.sim.protocol_runs import RunSpec, make_run, protocol_runs

SETTLE_S = 10.0
FORCE_FRACTION = DFFRLSAEKFConfig.min_traction_fraction
"""Drive force above this share of the traction limit counts as measured force (the estimators' own gate)."""
LOW_FORCE_SHARE = 0.10


def run_specs(n_runs: int, scenario_seeds: int) -> list[tuple[str, RunSpec]]:
    """(group, run): the protocol's random runs of both worlds and its point-mass scenarios over sensor seeds."""
    out = [(s.group, s) for s in protocol_runs(n_runs, n_runs, paper_seeds=0, fault_seeds=0)]
    scenarios = [s for s in protocol_runs(0, 0, paper_seeds=1, fault_seeds=0) if s.world == "point"]
    out += [("pm-scenarios", s.with_sensor_seed(k)) for k in range(scenario_seeds) for s in scenarios]
    return out


def measured_force_share(tr: Trace, settle_s: float = SETTLE_S) -> float:
    """Share of the samples after ``settle_s`` with a measured drive force (module docstring)."""
    t = tr["t_s"]
    force = tr["torque_nm"] / DEFAULT_VEHICLE.drive_wheel_radius_m
    moving = np.nan_to_num(tr["speed_mps"]) > 0.05
    after = t >= t[0] + settle_s
    return float(np.mean(((force > FORCE_FRACTION * DEFAULT_VEHICLE.max_traction_n) & moving)[after]))


def log_begun_at(tr: Trace, start_s: float) -> Trace:
    """The log a logger switched on ``start_s`` after the run's first sample records (0: the whole run)."""
    return tr if start_s == 0 else tr.from_time(tr["t_s"][0] + start_s)


def score(tr: Trace, name: str) -> dict[str, float]:
    """One estimator on one log: the module docstring's measures."""
    s = estimators.make(name).run(tr)
    t, truth = s.t_s, tr["mass_kg"]
    k = (t >= t[0] + SETTLE_S) & np.isfinite(truth)
    err = (s.mass_kg[k] - truth[k]) / truth[k] * 100.0
    z = np.abs(s.mass_kg[k] - truth[k]) / s.mass_std_kg[k]
    slope = train_slope_deg(tr)[k]
    return {"mass_max": float(np.max(np.abs(err))), "mass_at_10s": float(abs(err[0])),
            "mass_end": float(abs(err[-1])), "within_2sd": float(np.mean(z <= 2.0)), "max_z": float(np.max(z)),
            "slope_rmse": float(np.sqrt(np.mean((s.slope_deg[k] - slope) ** 2)))}


def _work(job: tuple[str, RunSpec, tuple[float, ...], tuple[str, ...]]) -> list[dict[str, Any]]:
    group, spec, starts, names = job
    full = make_run(spec)
    rows = []
    for start in starts:
        tr = log_begun_at(full, start)
        share = measured_force_share(tr)
        for name in names:
            rows.append({"group": group, "run": spec.name, "start_s": start, "estimator": name,
                         "force_share": share, **score(tr, name)})
    return rows


def report(rows: list[dict[str, Any]], command: str) -> str:
    groups = list(dict.fromkeys(r["group"] for r in rows))
    names = list(dict.fromkeys(r["estimator"] for r in rows))
    starts = sorted({r["start_s"] for r in rows})
    lines = ["# Where the mass comes from: the start from rest, and logs that begin in motion", "",
             f"Produced by `{command}`. Errors after the first 10 s of each log; mass errors in % of the true mass.",
             "", "## Logs from rest, and the same logs begun later", "",
             "| estimator | world | log begins at | runs | mass max error: median / p90 / p95 | mass error at the end: "
             "median / p95 | truth within ±2σ (mean) | runs ever beyond 3σ | slope RMSE °: median / p95 |",
             "| --- | --- | ---: | ---: | --- | --- | ---: | ---: | --- |"]
    for name in names:
        for g in groups:
            for st in starts:
                sel = [r for r in rows if r["estimator"] == name and r["group"] == g and r["start_s"] == st]
                if not sel:
                    continue
                mass, end, slope = (distribution(r[k] for r in sel) for k in ("mass_max", "mass_end", "slope_rmse"))
                begins = "rest (t = 0)" if st == 0 else f"{st:g} s"
                lines.append(
                    f"| `{name}` | {g} | {begins} | {len(sel)} | {mass['median']:.2f} / {mass['p90']:.2f} / "
                    f"{mass['p95']:.2f} | {end['median']:.2f} / {end['p95']:.2f} | "
                    f"{100 * np.mean([r['within_2sd'] for r in sel]):.1f} % | "
                    f"{100 * np.mean([r['max_z'] > 3.0 for r in sel]):.1f} % | {slope['median']:.3f} / "
                    f"{slope['p95']:.3f} |")
    lines += ["", "## Measured drive force after the first 10 s (logs from rest)", "",
              f"Share of samples with a drive force above {100 * FORCE_FRACTION:g} % of the traction limit and the "
              f"train moving; runs below {100 * LOW_FORCE_SHARE:g} % of it against the others. \"at 10 s\": the "
              "error of the first scored sample, which only the first 10 s can have set.", "",
              "| estimator | world | measured-force share: median | runs below 10 % | their mass max error: median "
              "/ p95 | their error at 10 s: median / p95 | the others' mass max error: median / p95 |",
              "| --- | --- | ---: | ---: | --- | --- | --- |"]
    for name in names:
        for g in groups:
            sel = [r for r in rows if r["estimator"] == name and r["group"] == g and r["start_s"] == 0]
            if not sel:
                continue
            share = distribution(r["force_share"] for r in sel)["median"]
            low = [r for r in sel if r["force_share"] < LOW_FORCE_SHARE]
            high = [r for r in sel if r["force_share"] >= LOW_FORCE_SHARE]

            def stats(rs: list[dict[str, Any]], key: str) -> str:
                d = distribution(r[key] for r in rs)
                return "–" if d["n"] == 0 else f"{d['median']:.2f} / {d['p95']:.2f}"

            lines.append(f"| `{name}` | {g} | {100 * share:.0f} % | {len(low)} of {len(sel)} | "
                         f"{stats(low, 'mass_max')} | {stats(low, 'mass_at_10s')} | {stats(high, 'mass_max')} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=200, help="random runs of each world (the protocol's first N)")
    ap.add_argument("--scenario-seeds", type=int, default=10, help="sensor seeds of each point-mass scenario")
    ap.add_argument("--starts", type=float, nargs="+", default=[0.0, 15.0, 30.0],
                    help="where each log begins, s after the run's start (0: from rest)")
    ap.add_argument("--estimators", nargs="+", default=["dffrls-aekf", "fused"])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--out", default=None, help="write the report (markdown) here too")
    args = ap.parse_args(argv)
    if args.runs < 0 or args.scenario_seeds < 0 or args.workers < 1:
        ap.error("--runs and --scenario-seeds must be >= 0, --workers >= 1")
    if any(not (0.0 <= s < 50.0) for s in args.starts):
        ap.error("--starts must lie in [0, 50) s: every random run lasts 60 s and 10 s are the settle time")
    try:
        names = estimators.parse_names(args.estimators)
    except (ValueError, estimators.UnknownEstimatorError) as exc:
        ap.error(str(exc))
    jobs = [(g, s, tuple(args.starts), tuple(names)) for g, s in run_specs(args.runs, args.scenario_seeds)]
    t0 = time.time()
    if args.workers == 1:  # in-process: no pickling of this script's functions
        rows = [r for part in map(_work, jobs) for r in part]
    else:
        with multiprocessing.Pool(args.workers) as pool:
            rows = [r for part in pool.imap(_work, jobs, chunksize=4) for r in part]
    command = "python scripts/start_dependence.py " + " ".join(sys.argv[1:] if argv is None else argv)
    text = report(rows, command.strip())
    print(text)
    print(f"{len(jobs)} runs in {time.time() - t0:.0f} s", file=sys.stderr)
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        Path(args.out).write_text(text, encoding="utf-8")
    return 0


if __name__ == "__main__":
    sys.exit(main())
