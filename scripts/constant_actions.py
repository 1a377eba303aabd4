#!/usr/bin/env python
"""How held-out episodes end when the action is held constant: what an action parameterisation gives for free.

Usage::

    python scripts/constant_actions.py --env-kwargs '{"action_mode": "acceleration"}' --actions -0.05 0 0.05 0.2 1 \\
        --episodes 10
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter

import numpy as np


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--actions", type=float, nargs="+", required=True)
    ap.add_argument("--episodes", type=int, default=10)
    ap.add_argument("--seed-base", type=int, default=100_000)
    ap.add_argument("--observer", default="dffrls-aekf")
    ap.add_argument("--env-kwargs", type=json.loads, default={})
    args = ap.parse_args(argv)
    import gymnasium as gym

    import uuom_gym  # noqa: F401 - registers the env

    print("| action | endings |\n|---|---|")
    for a in args.actions:
        ends: Counter[str] = Counter()
        for seed in range(args.seed_base, args.seed_base + args.episodes):
            env = gym.make("UUOM-Track-v0", observer=args.observer, **args.env_kwargs)
            env.reset(seed=seed)
            done = False
            while not done:
                *_, terminated, truncated, info = env.step(np.array([a], dtype=np.float32))
                done = terminated or truncated
            ends[info["termination"] or "time_limit"] += 1
            env.close()
        print(f"| {a:+g} | " + ", ".join(f"{k} {v}" for k, v in sorted(ends.items())) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
