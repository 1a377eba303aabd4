#!/usr/bin/env python
"""Sum ``info["rewards"]`` per term and ``info["violations"]`` per rule for fixed-action drivers (docs/rl.md §7).

Drives held-out tracks with a fixed action (``const:A``) or with ``envelope`` (the target speed capped by a
braking curve to the station, the action that a perfect policy on top of the speed-target tracker would give), and
prints per episode and in total how the return splits into terms. Answers "is stopping at the start a better
return than driving to the station?" by measurement.

Example::

    python -m scripts.reward_accounting --env-kwargs '{"action_mode": "speed_target"}' --drivers const:-1 const:0 \
        const:1 envelope --seeds 100001 100002 100008 100010
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))


def envelope_action(info: dict, cautious_mps: float) -> float:
    """Action (under ``speed_target_cap="cautious"``) whose target is ``min(cautious limit, station envelope)``.

    Uses the true distance to go (a measuring driver, not a controller); ``speed_target_cap="station"`` gives the
    same target from the odometry inside the env.
    """
    from uuom_gym.envs.speed_target import station_envelope_mps

    v = min(cautious_mps, station_envelope_mps(info["distance_to_go_m"]))
    return -1.0 if cautious_mps <= 0 else 2.0 * v / cautious_mps - 1.0


def run(driver: str, seed: int, env_kwargs: dict, max_steps: int) -> dict:
    import gymnasium as gym

    import uuom_gym  # noqa: F401

    env = gym.make("UUOM-Track-v0", **env_kwargs)
    obs, info = env.reset(seed=seed)
    sums: dict[str, float] = defaultdict(float)
    viol: dict[str, int] = defaultdict(int)
    ret, n = 0.0, 0
    for n in range(1, max_steps + 1):
        if driver == "envelope":
            a = envelope_action(info, float(obs[13]) * 2.0)
        else:
            a = float(driver.split(":")[1])
        obs, r, term, trunc, info = env.step(np.array([a], np.float32))
        ret += r
        for k, v in info["rewards"].items():
            sums[k] += v
        for k, v in info["violations"].items():
            viol[k] += int(v)
        if term or trunc:
            break
    env.close()
    return {
        "driver": driver, "seed": seed, "mass_t": info["true_mass_kg"] / 1000, "length_m": info["track_length_m"],
        "end": info["termination"] or "running", "t_s": info["t_s"], "pos_m": info["position_m"], "return": ret,
        "rewards": dict(sums), "violations": dict(viol), "steps": n,
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--drivers", nargs="+", default=["const:-1", "const:0", "const:1", "envelope"])
    ap.add_argument("--seeds", type=int, nargs="+", default=[100001, 100002, 100008, 100010])
    ap.add_argument("--env-kwargs", type=json.loads, default={"action_mode": "speed_target"})
    ap.add_argument("--max-steps", type=int, default=30000)
    ap.add_argument("--json", type=Path, default=None, help="also write the rows here")
    args = ap.parse_args(argv)
    rows = []
    for d in args.drivers:
        for s in args.seeds:
            row = run(d, s, args.env_kwargs, args.max_steps)
            rows.append(row)
            rw = " ".join(f"{k}={v:+.2f}" for k, v in row["rewards"].items() if abs(v) > 1e-9)
            vi = " ".join(f"{k}={v}" for k, v in row["violations"].items() if v)
            print(f"{d:9s} seed {s} {row['mass_t']:.1f} t {row['length_m']:.0f} m: {row['end']} at {row['t_s']:.0f} s, "
                  f"{row['pos_m']:.1f} m, return {row['return']:+.2f} | {rw} | viol {vi or '-'}", flush=True)
    print("\nmean per driver:")
    for d in args.drivers:
        rs = [r for r in rows if r["driver"] == d]
        terms = sorted({k for r in rs for k in r["rewards"]})
        mean = {k: float(np.mean([r["rewards"].get(k, 0.0) for r in rs])) for k in terms}
        print(f"{d:9s} return {np.mean([r['return'] for r in rs]):+.2f} | "
              + " ".join(f"{k}={v:+.2f}" for k, v in mean.items() if abs(v) > 1e-9)
              + f" | ends {[r['end'] for r in rs]}")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
