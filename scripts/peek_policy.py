#!/usr/bin/env python
"""Run a trained policy (or one of its checkpoints) deterministically on a few seeds and print how each ends.

Example::

    python scripts/peek_policy.py results/rl/policies/ppo_bare_rev2_200k_s0 --seeds 100000 100001 100002
    python scripts/peek_policy.py runs/x/checkpoints/model_100000_steps.zip --max-steps 1500

A run directory means its ``model.zip`` + ``vecnormalize.pkl``; a checkpoint ``model_<n>_steps.zip`` is paired
with ``model_vecnormalize_<n>_steps.pkl`` next to it. Prints per seed: the ending (or ``running`` after
``--max-steps``), time, distance covered, load, mean/max speed, mean true limit, mean deterministic command. Used
in docs/rl.md to see what a policy's *mean* action does (the training curves show the noisy policy).
"""

from __future__ import annotations

import argparse
import json
import pickle
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))  # this checkout's packages, not another installed copy


def _paths(target: Path) -> tuple[Path, Path]:
    if target.is_dir():
        return target / "model.zip", target / "vecnormalize.pkl"
    if target.name == "model.zip":  # a run's or a checkpoint folder's model: its statistics lie beside it
        return target, target.with_name("vecnormalize.pkl")
    return target, target.with_name(target.name.replace("model_", "model_vecnormalize_")).with_suffix(".pkl")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("target", type=Path, help="run directory or checkpoint .zip")
    ap.add_argument("--seeds", type=int, nargs="+", default=[100_000, 100_001, 100_002])
    ap.add_argument("--observer", default="dffrls-aekf")
    ap.add_argument("--max-steps", type=int, default=3000)
    ap.add_argument("--no-normalize", action="store_true",
                    help="run a policy trained without VecNormalize (otherwise its statistics must be found)")
    ap.add_argument("--env-kwargs", type=json.loads, default={},
                    help='JSON env config the policy was trained with, e.g. \'{"action_mode": "speed_target"}\'')
    args = ap.parse_args(argv)
    import gymnasium as gym
    import torch
    from stable_baselines3 import PPO

    import uuom_gym  # noqa: F401

    torch.set_num_threads(1)
    model_path, vn_path = _paths(args.target)
    if not model_path.exists():
        raise SystemExit(f"no model at {model_path}")
    model = PPO.load(model_path, device="cpu")
    vn = None
    if not vn_path.exists() and not args.no_normalize:
        # Without its observation statistics a policy sees garbage and "fails" for no reason of its own.
        raise SystemExit(f"no VecNormalize statistics at {vn_path}; pass --no-normalize if the policy had none")
    if vn_path.exists() and not args.no_normalize:
        with open(vn_path, "rb") as fh:
            vn = pickle.load(fh)
        vn.training = False
    for seed in args.seeds:
        env = gym.make("UUOM-Track-v0", observer=args.observer, **args.env_kwargs)
        obs, info = env.reset(seed=seed)
        speed, cmd, lim = [], [], []
        for _ in range(args.max_steps):
            a, _ = model.predict(vn.normalize_obs(obs) if vn is not None else obs, deterministic=True)
            obs, _, term, trunc, info = env.step(a)
            speed.append(info["speed_mps"])
            cmd.append(float(np.clip(a[0], -1.0, 1.0)))
            lim.append(info["true_speed_limit_mps"])
            if term or trunc:
                break
        env.close()
        print(
            f"seed {seed}: {info['termination'] or 'running'} at {info['t_s']:.0f} s, "
            f"{info['position_m']:.1f} / {info['track_length_m']:.0f} m, load {info['load_kg']:.0f} kg, "
            f"speed mean {np.mean(speed):.2f} max {np.max(speed):.2f} m/s, true limit mean {np.mean(lim):.2f}, "
            f"command mean {np.mean(cmd):.2f}"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
