#!/usr/bin/env python
"""Run a trained policy (or one of its checkpoints) deterministically on a few seeds and print how each ends.

Example::

    python scripts/peek_policy.py results/rl/policies/ppo_bare_rev2_200k_s0 --seeds 100000 100001 100002
    python scripts/peek_policy.py runs/x/checkpoints/step_0000100000 --max-steps 1500
    python scripts/peek_policy.py results/rl/policies/ppo_bare_accel_mix_s0_selected --seeds 100000 --trace 40

The target is a run directory, one of its checkpoint folders (``checkpoints/step_<n>``) or the ``model.zip`` in
either; it is loaded as ``uuom-evaluate`` loads it (:class:`agents.evaluation.ModelPolicy`: the algorithm and the
observation statistics from the run). The env is built with the configuration and the observer the policy was trained
with (the run's ``config.json``), updated by ``--env-kwargs`` / ``--observer``; a policy that acts through the shield,
a residual or a margin schedule is refused (``uuom-evaluate`` runs those). Prints per seed: the ending (or ``running`` after
``--max-steps``), time, distance covered, load, mean/max speed, mean true limit, mean deterministic command;
``--trace N`` also prints the episode's last N steps, with ``--trace-obs NAME ...`` named observation entries
beside them and with ``--critic`` an off-policy learner's critic, ``min(Q1, Q2)`` of the policy's action and of
-1, 0, +1 (SAC/TD3: is the freeze the critic's or the actor's?); ``--sample SEED`` runs the policy on sampled actions
instead of its mean (what its training episodes did); ``--compare OTHER`` also computes another policy's (e.g. the next
checkpoint's) mean action on the same observations and prints the mean and largest |difference| of the clipped
commands per episode: how far one stretch of training moved the policy where it drives. Used in docs/rl.md to see what a policy's *mean* action does
(the training curves show the noisy policy).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))  # this checkout's packages, not another installed copy

TRACE_COLUMNS = ("t_s", "position_m", "to_go_m", "speed_mps", "true_limit_mps", "action", "ending")
CRITIC_COLUMNS = ("Q(action)", "Q(-1)", "Q(0)", "Q(+1)")
"""The observation entries of ``--trace-obs`` are printed as they were when the step's action was chosen; so is the
critic."""


def critic_values(policy, obs: np.ndarray, action: float) -> list[float]:
    """``min(Q1, Q2)`` of the policy's critic at ``obs`` (normalised as the policy sees it) for ``action`` and for
    -1, 0, +1, in that order."""
    import torch

    o = policy.normalized(obs)
    acts = torch.tensor([[action], [-1.0], [0.0], [1.0]], dtype=torch.float32)
    with torch.no_grad():
        q = policy.model.critic(torch.as_tensor(np.repeat(np.asarray(o, dtype=np.float32)[None], 4, 0)), acts)
    return torch.min(*q).squeeze(-1).tolist()


def load_bare_policy(run_dir: Path, no_normalize: bool):
    """A policy that acts alone in the bare env (:class:`agents.evaluation.ModelPolicy`), or ``SystemExit`` naming
    what is missing or why it cannot run here."""
    from agents.evaluation import ModelPolicy

    if not (run_dir / "model.zip").is_file():
        raise SystemExit(f"no model at {run_dir / 'model.zip'}")
    if not (run_dir / "vecnormalize.pkl").is_file() and not no_normalize:
        # Without its observation statistics a policy sees garbage and "fails" for no reason of its own.
        raise SystemExit(f"no VecNormalize statistics at {run_dir / 'vecnormalize.pkl'}; "
                         f"pass --no-normalize if the policy had none")
    try:
        policy = ModelPolicy(run_dir)
    except FileNotFoundError as exc:
        raise SystemExit(str(exc)) from None
    if policy.shield or policy.residual or policy.margin_schedule:
        # the env here is the bare one: the policy's action alone would be judged, not the controller it is part of
        raise SystemExit(f"{run_dir} acts through the shield, a residual or a margin schedule; run it with "
                         f"uuom-evaluate, which wraps it as it was trained")
    if no_normalize:
        policy.vecnorm = None
    return policy


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("target", type=Path, help="run directory, checkpoint folder, or the model.zip in one")
    ap.add_argument("--seeds", type=int, nargs="+", default=[100_000, 100_001, 100_002])
    ap.add_argument("--observer", default=None, help="default: the one the policy was trained with")
    ap.add_argument("--max-steps", type=int, default=3000)
    ap.add_argument("--no-normalize", action="store_true",
                    help="run a policy trained without VecNormalize (otherwise its statistics must be found)")
    ap.add_argument("--env-kwargs", type=json.loads, default={},
                    help="JSON env config on top of the one the policy was trained with")
    ap.add_argument("--trace", type=int, default=0, metavar="N", help="print each episode's last N steps")
    ap.add_argument("--trace-obs", nargs="+", default=[], metavar="NAME",
                    help="observation entries (names of the env's observation table) printed in the trace")
    ap.add_argument("--critic", action="store_true",
                    help="print the critic's min(Q1, Q2) in the trace (SAC/TD3): of the action taken and of -1, 0, +1")
    ap.add_argument("--sample", type=int, default=None, metavar="SEED",
                    help="sample the actions from the policy's distribution (torch seeded once with SEED) instead of "
                         "taking its mean")
    ap.add_argument("--compare", type=Path, default=None, metavar="OTHER",
                    help="another run directory or checkpoint folder: print how far its mean action is from the "
                         "policy's on the states the policy drives")
    args = ap.parse_args(argv)
    import gymnasium as gym
    import torch

    import uuom_gym  # noqa: F401
    from agents.evaluation import run_config_path

    run_dir = args.target.parent if args.target.name == "model.zip" else args.target
    policy = load_bare_policy(run_dir, args.no_normalize)
    other = None
    if args.compare is not None:
        other = load_bare_policy(args.compare.parent if args.compare.name == "model.zip" else args.compare,
                                 args.no_normalize)
        other_name = other.run_dir.name
        if other.obs_shape != policy.obs_shape:
            raise SystemExit(f"--compare: {args.compare} takes observations of shape {other.obs_shape}, "
                             f"{run_dir} of {policy.obs_shape}")
    cfg_path = run_config_path(run_dir)
    trained = json.loads(cfg_path.read_text()) if cfg_path.is_file() else {}
    observer = args.observer or trained.get("observer", "dffrls-aekf")
    env_kwargs = {**(trained.get("env_kwargs") or {}), **args.env_kwargs}
    if args.sample is not None:
        torch.manual_seed(args.sample)
    if (args.critic or args.trace_obs) and not args.trace:
        raise SystemExit("--critic and --trace-obs print columns of the trace: give --trace N too")
    critic = getattr(policy.model, "critic", None) if args.critic else None
    if args.critic and critic is None:
        raise SystemExit(f"{run_dir}: --critic needs an off-policy learner with a Q critic (SAC/TD3), "
                         f"this is {type(policy.model).__name__}")
    columns = TRACE_COLUMNS + tuple(args.trace_obs) + (CRITIC_COLUMNS if critic is not None else ())
    endings: Counter[str] = Counter()
    for seed in args.seeds:
        env = gym.make("UUOM-Track-v0", observer=observer, **env_kwargs)
        names = env.unwrapped.observation_names
        unknown = [n for n in args.trace_obs if n not in names]
        if unknown:
            raise SystemExit(f"--trace-obs: unknown observation name(s) {', '.join(unknown)}; "
                             f"the env's are {', '.join(names)}")
        shown = [names.index(n) for n in args.trace_obs]
        obs, info = env.reset(seed=seed)
        speed, cmd, lim, rows, gaps = [], [], [], [], []
        for _ in range(args.max_steps):
            a = policy.act(obs, info, deterministic=args.sample is None)
            if other is not None:  # the other policy's mean draws nothing: a sampled run's actions stay the same
                gaps.append(abs(float(np.clip(a[0], -1.0, 1.0)) - float(np.clip(other.act(obs, info)[0], -1.0, 1.0))))
            seen = [float(obs[i]) for i in shown]
            if critic is not None:
                seen += critic_values(policy, obs, float(a[0]))
            obs, _, term, trunc, info = env.step(a)
            speed.append(info["speed_mps"])
            cmd.append(float(np.clip(a[0], -1.0, 1.0)))
            lim.append(info["true_speed_limit_mps"])
            if args.trace:
                rows.append((info["t_s"], info["position_m"], info["distance_to_go_m"],
                             info["speed_mps"], info["true_speed_limit_mps"], cmd[-1], info["termination"] or "",
                             *seen))
                del rows[:-args.trace]
            if term or trunc:
                break
        env.close()
        ending = info["termination"] or "running"
        endings[ending] += 1
        print(
            f"seed {seed}: {ending} at {info['t_s']:.0f} s, "
            f"{info['position_m']:.1f} / {info['track_length_m']:.0f} m, load {info['load_kg']:.0f} kg, "
            f"speed mean {np.mean(speed):.2f} max {np.max(speed):.2f} m/s, true limit mean {np.mean(lim):.2f}, "
            f"command mean {np.mean(cmd):.2f}"
            + (f", |command - {other_name}'s| mean {np.mean(gaps):.3f} max {np.max(gaps):.3f}" if gaps else "")
        )
        if rows:
            print("  " + " ".join(f"{c:>14}" for c in columns))
            for row in rows:
                print("  " + " ".join(f"{x:14.3f}" if isinstance(x, float) else f"{x:>14}" for x in row))
    if len(args.seeds) > 1:
        print("endings: " + ", ".join(f"{k} {v}" for k, v in sorted(endings.items())))
    return 0


if __name__ == "__main__":
    sys.exit(main())
