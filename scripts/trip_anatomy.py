#!/usr/bin/env python
"""When, and on what estimate, a controller's overspeed trips happen: its episodes replayed step by step.

For every episode that ends in an overspeed trip, the state at the trip: time and distance from the start, the true
mass and limit, the speed, what the observer believed (mass ± std, its limit ``v_lim(M̂, θ̂)`` and the cautious one
``v_lim(M̂ + 2σ, ·)``, observation entries 7 and 13), and when the speed first passed that cautious limit. Written for
docs/rl.md §28: a policy that trips in the first seconds, before the estimator has moved off its prior, trips for
want of the mass, not for a wrong one.

Usage::

    python scripts/trip_anatomy.py --controller results/rl/policies/ppo_bare_traction_ceiling_1150k_s0 \\
        --observer dffrls-aekf --episodes 100 --workers 2 --csv trips.csv

``--episodes-csv`` replays only the trips of an earlier ``uuom-evaluate`` table (its ``episodes.csv``, rows of
``--controller``'s label and ``--observer``) instead of every track. Prints one row per trip and a summary; the run is
deterministic (the evaluation's seeds and code path), so its rows match ``uuom-evaluate``'s.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import statistics
import sys
from multiprocessing import get_context
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))  # this checkout's packages, not another installed copy

PRIOR_STD_KEPT = 0.9
"""A trip "on the prior": the mass std at the trip still at least this share of its value at the start."""


def replay(task: Any) -> dict[str, Any]:
    """One episode (an :class:`agents.evaluation.Task`); the trip's anatomy (``tripped`` False otherwise)."""
    from agents.evaluation import controller_label, start_episode

    env, ctrl, obs, info = start_episode(task)
    std0 = float(info["est_mass_std_kg"]) if "est_mass_std_kg" in info else float("nan")
    first_over_cautious = float("nan")
    prev = info
    while True:
        obs, _, term, trunc, info = env.step(ctrl.act(obs, info))
        if math.isnan(first_over_cautious) and info["speed_mps"] > info["est_speed_limit_2sigma_mps"]:
            first_over_cautious = float(info["t_s"])
        if term or trunc:
            break
        prev = info
    env.close()
    return {
        "controller": controller_label(task.controller), "observer": task.observer, "seed": task.seed,
        "ending": info.get("termination") or ("time_limit" if trunc else ""),
        "tripped": info.get("termination") == "overspeed_trip",
        "true_mass_t": info["true_mass_kg"] / 1000.0, "t_s": float(info["t_s"]),
        "distance_m": float(info["position_m"]), "speed_mps": float(info["speed_mps"]),
        "true_limit_mps": float(info["true_speed_limit_mps"]),
        # the estimate the last command was chosen on (the step before the trip)
        "est_mass_t": prev["est_mass_kg"] / 1000.0, "est_mass_std_t": prev["est_mass_std_kg"] / 1000.0,
        "std_share_of_prior": prev["est_mass_std_kg"] / std0 if std0 > 0 else float("nan"),
        "est_limit_mps": float(prev["est_speed_limit_mps"]),
        "cautious_limit_mps": float(prev["est_speed_limit_2sigma_mps"]),
        "first_over_cautious_s": first_over_cautious,
        "last_command": float(prev.get("command", float("nan"))),
    }


def trip_seeds(path: Path, label: str, observer: str) -> list[int]:
    with open(path, newline="") as fh:
        rows = [r for r in csv.DictReader(fh) if r["controller"] == label and r["observer"] == observer]
    if not rows:
        raise SystemExit(f"--episodes-csv {path}: no rows of controller {label!r} with observer {observer!r}")
    return sorted(int(r["seed"]) for r in rows if r["termination"] == "overspeed_trip")


def summary_lines(rows: list[dict[str, Any]], n_episodes: int) -> list[str]:
    trips = [r for r in rows if r["tripped"]]
    if not trips:
        return [f"{n_episodes} episodes, no overspeed trip"]
    t = [r["t_s"] for r in trips]
    on_prior = [r for r in trips if r["std_share_of_prior"] >= PRIOR_STD_KEPT]
    over = [r for r in trips if r["first_over_cautious_s"] <= r["t_s"]]
    past = [r for r in trips if r["speed_mps"] > r["est_limit_mps"]]
    if all(math.isnan(r["std_share_of_prior"]) for r in trips):  # no std at the start
        prior = "on the prior: - (the observer reports no mass uncertainty at the start)"
    else:
        prior = (f"on the prior (mass std still >= {PRIOR_STD_KEPT:.0%} of its start value): {len(on_prior)}; true mass "
                 "of those " + (f"{min(r['true_mass_t'] for r in on_prior):.1f}-"
                                f"{max(r['true_mass_t'] for r in on_prior):.1f} t" if on_prior else "-"))
    return [
        f"{len(trips)} overspeed trips in {n_episodes} episodes; trip time median {statistics.median(t):.1f} s "
        f"(min {min(t):.1f}, max {max(t):.1f}); {sum(x <= 5.0 for x in t)} within the first 5 s",
        prior,
        f"speed above the cautious limit v_lim(M + 2 sigma) before the trip: {len(over)} of {len(trips)}",
        f"at the trip, speed above the estimated limit v_lim(M, slope) (the controller drove past what it was told): "
        f"{len(past)}; at or below it (the estimate's limit was too high): {len(trips) - len(past)}",
    ]


def main(argv: list[str] | None = None) -> int:
    from agents.evaluation import (DEFAULT_SEED_BASE, EvalConfig, EvalConfigError, Task, check_config,
                                   controller_label)

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--controller", required=True, help="a run directory or a reference controller's name")
    ap.add_argument("--observer", default="dffrls-aekf")
    ap.add_argument("--episodes", type=int, default=100, help="held-out tracks from --seed-base")
    ap.add_argument("--seed-base", type=int, default=DEFAULT_SEED_BASE)
    ap.add_argument("--episodes-csv", type=Path, default=None,
                    help="replay only the overspeed trips of this uuom-evaluate episodes.csv")
    ap.add_argument("--env-kwargs", default="{}", help="JSON env config (the policy's training env; not enforced)")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--csv", type=Path, default=None, help="write the trip rows here")
    args = ap.parse_args(argv)
    try:
        env_kwargs = json.loads(args.env_kwargs)
    except json.JSONDecodeError as exc:
        ap.error(f"--env-kwargs: not JSON ({exc})")
    if not isinstance(env_kwargs, dict):
        ap.error("--env-kwargs: a JSON object expected")
    try:  # uuom-evaluate's own checks: controller, observer, env config, counts (a replay may run off the training env)
        check_config(EvalConfig(controllers=[args.controller], observers=[args.observer], episodes=args.episodes,
                                workers=args.workers, env_kwargs=env_kwargs, allow_env_shift=True,
                                plot_observer=args.observer))
    except EvalConfigError as exc:
        ap.error(str(exc))
    label = controller_label(args.controller)
    if args.episodes_csv is not None:
        seeds = trip_seeds(args.episodes_csv, label, args.observer)
    else:
        seeds = list(range(args.seed_base, args.seed_base + args.episodes))
    n_episodes = len(seeds)
    tasks = [Task(args.controller, args.observer, s, json.dumps(env_kwargs, sort_keys=True)) for s in seeds]
    if args.workers > 1 and len(tasks) > 1:
        with get_context("spawn").Pool(args.workers) as pool:
            rows = pool.map(replay, tasks, chunksize=1)
    else:
        rows = [replay(t) for t in tasks]
    trips = sorted((r for r in rows if r["tripped"]), key=lambda r: r["true_mass_t"])
    print(f"`{label}` with `{args.observer}` on {n_episodes} tracks "
          + (f"(the trips of {args.episodes_csv})" if args.episodes_csv else f"(seeds {seeds[0]}..{seeds[-1]})"))
    print("\n| seed | true mass t | trip at s | m | speed | true limit | est. mass t (std) | est. limit | cautious "
          "limit | over cautious from s |\n|---|---|---|---|---|---|---|---|---|---|")
    for r in trips:
        print(f"| {r['seed']} | {r['true_mass_t']:.1f} | {r['t_s']:.1f} | {r['distance_m']:.1f} | {r['speed_mps']:.2f} "
              f"| {r['true_limit_mps']:.2f} | {r['est_mass_t']:.1f} ({r['est_mass_std_t']:.1f}) | "
              f"{r['est_limit_mps']:.2f} | {r['cautious_limit_mps']:.2f} | {r['first_over_cautious_s']:.1f} |")
    print()
    for line in summary_lines(rows, n_episodes):
        print(line)
    if args.csv is not None and trips:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        with open(args.csv, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(trips[0]))
            w.writeheader()
            w.writerows(trips)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
