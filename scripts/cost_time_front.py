#!/usr/bin/env python
"""Trip time against cost rate: learned controllers against the rule-based controller's whole trade-off curve.

A controller that is faster than the rule-based controller *at its default margins* may only have bought the speed
with a higher cost rate — which the rule-based controller could do too, by driving closer to its limit. This script
puts every controller of some ``uuom-evaluate`` output folders on one plane: x = cost rate (mean ``info["cost"]`` per
policy step, log scale), y = trip time / oracle (interquartile mean), each with a 95 % bootstrap interval over the
tracks (and over training seeds for a ``--pool`` row). Rows whose controller is ``rule-based`` or
``rule-based@<options>`` form the hand-written family (their lower envelope is drawn as a line); every other
controller except the oracle is a point. For each point it names the fastest rule-based setting whose cost rate is
no higher — "faster at equal safety" is then a statement with a number, not a choice of margin.

Usage::

    python scripts/cost_time_front.py runs/obs/reference runs/rb_front runs/span13_now \\
        --pool "PPO, span 0.8-1.3=ppo_bare_span_08_13_300k_s0,ppo_bare_span_08_13_300k_s1,ppo_bare_span_08_13_300k_s2" \\
        --out results/rl/cost_time_front        # writes front.md and front.png there
"""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path
from typing import Any

import numpy as np

from agents.episode_endings import run_name
from agents.evaluation_table import pool_rows, read_episodes
from agents.statistics import bootstrap_ci, iqm

RULE_BASED = "rule-based"


def _is_rule_based(label: str) -> bool:
    return label == RULE_BASED or label.startswith(RULE_BASED + "@")


def controller_point(rows: list[dict[str, Any]], oracle_time: dict[int, float]) -> dict[str, Any]:
    """Success, trips, cost rate and trip time / oracle (IQM) of one controller's episodes, with 95 % intervals."""
    runs = sorted({run_name(r) for r in rows})
    tracks = sorted({int(r["seed"]) for r in rows})
    col = {s: j for j, s in enumerate(tracks)}
    cost = np.full((len(runs), len(tracks)), np.nan)
    steps = np.full_like(cost, np.nan)
    ratio = np.full_like(cost, np.nan)
    for r in rows:
        i, j = runs.index(run_name(r)), col[int(r["seed"])]
        cost[i, j], steps[i, j] = float(r["cost"]), float(r["steps"])
        if r["success"] and int(r["seed"]) in oracle_time:
            ratio[i, j] = float(r["trip_time_s"]) / oracle_time[int(r["seed"])]
    flat_cost, flat_steps = cost.reshape(-1), steps.reshape(-1)

    def rate(idx: np.ndarray) -> float:  # ratio of sums over the resampled (run, track) cells
        k = idx.astype(int)
        return float(np.nansum(flat_cost[k]) / max(np.nansum(flat_steps[k]), 1.0))

    cells = np.arange(cost.size, dtype=float).reshape(cost.shape)
    cells[np.isnan(cost)] = np.nan
    return {
        "runs": len(runs),
        "episodes": len(rows),
        "success": sum(bool(r["success"]) for r in rows) / len(rows),
        "trips": sum(bool(r["overspeed_trip"]) for r in rows),
        "cost_rate": rate(cells[np.isfinite(cells)]),
        "cost_rate_ci": bootstrap_ci(cells, rate),
        "time_iqm": iqm(ratio[np.isfinite(ratio)]),
        "time_ci": bootstrap_ci(ratio),
        "time_mean": float(np.nanmean(ratio)),
    }


def fastest_no_costlier(point: dict[str, Any], family: dict[str, dict[str, Any]]) -> str | None:
    """The rule-based setting with the lowest trip time among those with a cost rate no higher than ``point``'s."""
    ok = {k: p for k, p in family.items() if p["cost_rate"] <= point["cost_rate"] and p["trips"] == 0}
    return min(ok, key=lambda k: ok[k]["time_iqm"]) if ok else None


def short_names(family: dict[str, dict[str, Any]]) -> dict[str, str]:
    """``R0`` for the default setting, ``R1``, ``R2``, ... for the others in order of cost rate (figure labels)."""
    order = sorted((k for k in family if k != RULE_BASED), key=lambda k: family[k]["cost_rate"])
    return {RULE_BASED: "R0", **{k: f"R{i}" for i, k in enumerate(order, start=1)}}


def _envelope(family: dict[str, dict[str, Any]]) -> list[tuple[float, float]]:
    """Lower envelope (cost rate, IQM) of the settings without trips: none is both costlier and slower than another."""
    pts = sorted((p["cost_rate"], p["time_iqm"]) for p in family.values() if p["trips"] == 0)
    env: list[tuple[float, float]] = []
    for c, t in pts:
        if not env or t < env[-1][1]:
            env.append((c, t))
    return env


def plot(family: dict[str, dict[str, Any]], learned: dict[str, dict[str, Any]], path: Path, floor: float) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(11.0, 5.0))

    def xy(p: dict[str, Any]) -> tuple[float, float, list[list[float]], list[list[float]]]:
        x = max(p["cost_rate"], floor)
        lo, hi = (max(v, floor) for v in p["cost_rate_ci"])
        return x, p["time_iqm"], [[x - lo], [hi - x]], [[p["time_iqm"] - p["time_ci"][0]], [p["time_ci"][1] - p["time_iqm"]]]

    env = _envelope(family)
    ax.plot([max(c, floor) for c, _ in env], [t for _, t in env], "-", color="0.6", zorder=1,
            label="rule-based settings (R0 = default;\nids in front.md), envelope of\nthose without trips")
    short = short_names(family)
    for name, p in family.items():
        x, y, xe, ye = xy(p)
        ax.errorbar(x, y, xerr=xe, yerr=ye, fmt="s", color="0.35", ms=5, capsize=2, zorder=2,
                    mfc="0.35" if p["trips"] == 0 else "white")
        ax.annotate(short[name] + (f" ({p['trips']} trips)" if p["trips"] else ""), (x, y), fontsize=7,
                    xytext=(4, 3), textcoords="offset points")
    colours = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for k, (name, p) in enumerate(learned.items()):
        x, y, xe, ye = xy(p)
        fixed = "full-throttle" in name  # a fixed action, not a policy: drawn as a diamond
        colour = colours[k % len(colours)]
        ax.errorbar(x, y, xerr=xe, yerr=ye, fmt="D" if fixed else "o", color=colour, ms=6 if fixed else 7, capsize=3,
                    zorder=3, mfc=colour if p["trips"] == 0 else "white",
                    label=name + (f" ({p['runs']} seeds)" if p["runs"] > 1 else "")
                    + (f", {p['trips']} trips" if p["trips"] else ""))
    ax.set_xscale("log")
    ax.set_xlabel("cost rate (mean safety cost per policy step, log)")
    ax.set_ylabel("trip time / oracle (IQM, 95 % CI)")
    ax.set_title("Faster at equal safety? Learned controllers vs the rule-based trade-off", fontsize=10)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("dirs", nargs="+", type=Path, help="uuom-evaluate output folders (their episodes.csv)")
    ap.add_argument("--pool", action="append", default=[], metavar="LABEL=CTRL,CTRL,...",
                    help="show these controllers (training seeds) as one point")
    ap.add_argument("--prefix", action="append", default=[], metavar="DIR=TEXT",
                    help="put TEXT before the controller labels of that folder (e.g. one fixed action in several env set-ups)")
    ap.add_argument("--out", type=Path, required=True, help="folder for front.md and front.png")
    args = ap.parse_args(argv)
    prefixes: dict[Path, str] = {}
    for spec in args.prefix:
        folder, sep, text = spec.partition("=")
        if not sep or Path(folder) not in args.dirs:
            raise SystemExit(f"--prefix {spec!r}: expected DIR=TEXT with DIR one of the folders given")
        prefixes[Path(folder)] = text
    rows: list[dict[str, Any]] = []
    for d in args.dirs:
        if not (d / "episodes.csv").is_file():
            raise SystemExit(f"{d}: no episodes.csv (run uuom-evaluate --out {d} first)")
        for r in read_episodes(d / "episodes.csv"):
            if d in prefixes:
                r["controller"] = prefixes[d] + str(r["controller"])
            rows.append(r)
    pools: dict[str, list[str]] = {}
    for spec in args.pool:
        label, sep, members = spec.partition("=")
        if not sep or not members:
            raise SystemExit(f"--pool {spec!r}: expected LABEL=CTRL,CTRL,...")
        pools[label] = members.split(",")
    for r in rows:
        r["controller"] = Path(str(r["controller"])).name if "/" in str(r["controller"]) else str(r["controller"])
    rows = pool_rows(rows, pools) if pools else rows
    oracle_time = {int(r["seed"]): float(r["trip_time_s"]) for r in rows if r["controller"] == "oracle" and r["success"]}
    if not oracle_time:
        raise SystemExit("no oracle episodes in these folders: include the reference run (trip time / oracle)")
    by_ctrl: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        if r["controller"] != "oracle":
            by_ctrl.setdefault(str(r["controller"]), []).append(r)
    points = {k: controller_point(v, oracle_time) for k, v in by_ctrl.items()}
    family = {k: p for k, p in points.items() if _is_rule_based(k)}
    learned = {k: p for k, p in points.items() if not _is_rule_based(k)}
    floor = 0.3 * min([p["cost_rate"] for p in points.values() if p["cost_rate"] > 0] or [1e-9])

    lines = [
        f"Command: `python scripts/cost_time_front.py {' '.join(shlex.quote(str(a)) for a in (argv or sys.argv[1:]))}`",
        "",
        "| id | controller | seeds | episodes | success | trips | cost rate (95 % CI) | trip time / oracle, IQM (95 % CI) | mean |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    short = short_names(family)
    for name, p in sorted(points.items(), key=lambda kv: (not _is_rule_based(kv[0]), kv[1]["cost_rate"])):
        lo, hi = p["cost_rate_ci"]
        tlo, thi = p["time_ci"]
        lines.append(f"| {short.get(name, '')} | {name} | {p['runs']} | {p['episodes']} | {p['success']:.0%} | {p['trips']} | "
                     f"{p['cost_rate']:.2e} ({lo:.1e}–{hi:.1e}) | {p['time_iqm']:.3f} ({tlo:.3f}–{thi:.3f}) | "
                     f"{p['time_mean']:.3f} |")
    lines += ["", "Where the episodes come from (each folder's `uuom-evaluate` command, from its summary.md):", ""]
    for d in args.dirs:
        summary = d / "summary.md"
        cmd = next((ln for ln in summary.read_text().splitlines() if ln.startswith("Command:")), None) if summary.is_file() else None
        lines.append(f"- `{d}`" + (f" ({prefixes[d].strip()})" if d in prefixes else "") + f": {cmd or 'no summary.md'}")
    lines += ["", "Each other controller (learned, or a fixed action) against the fastest rule-based setting (0 trips) with no higher cost rate:", ""]
    for name, p in learned.items():
        if p["trips"]:
            lines.append(f"- {name}: {p['trips']} overspeed trips in {p['episodes']} episodes: not a candidate at equal safety.")
            continue
        best = fastest_no_costlier(p, family)
        if best is None:
            lines.append(f"- {name}: no rule-based setting here is as safe (cost rate {p['cost_rate']:.2e}).")
            continue
        b = family[best]
        verdict = "faster" if p["time_ci"][1] < b["time_ci"][0] else (
            "slower" if p["time_ci"][0] > b["time_ci"][1] else "not separable (intervals overlap)")
        lines.append(f"- {name}: IQM {p['time_iqm']:.3f} at {p['cost_rate']:.2e} vs `{best}` {b['time_iqm']:.3f} at "
                     f"{b['cost_rate']:.2e}: **{verdict}**.")
    args.out.mkdir(parents=True, exist_ok=True)
    plot(family, learned, args.out / "front.png", floor)
    lines += ["", f"Figure: {args.out / 'front.png'} (cost rate 0 drawn at {floor:.1e})."]
    text = "\n".join(lines) + "\n"
    (args.out / "front.md").write_text(text)
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
