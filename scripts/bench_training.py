#!/usr/bin/env python
"""Benchmark training throughput: env steps per second inside ``uuom-train`` and where the time goes.

Runs a real training (:func:`agents.training.train`, the code path of ``uuom-train``: SubprocVecEnv, VecNormalize,
the metrics callback) for ``--timesteps`` steps and times, by wrapping the SB3 methods at class level:

- **env**: ``VecEnv.step_wait`` in the main process (the workers' physics, sensors, estimator and env bookkeeping,
  plus the pipe round trip; with SubprocVecEnv the workers run in parallel);
- **policy inference + rollout bookkeeping**: the rest of ``collect_rollouts`` (policy forward pass, buffer,
  callbacks);
- **policy update**: ``PPO.train`` / ``SAC.train`` (the gradient epochs).

It also reports the CPU seconds of the main process and of the env workers per env step, and the time 10^6 steps
would take at the measured rate. The split inside an env step (physics, sensors, estimator) is
``scripts/bench_env.py``'s.

Usage::

    python scripts/bench_training.py                                   # UUOM-Track-v0 defaults, 40 960 steps
    python scripts/bench_training.py --env UUOM-Track-SpeedTarget-v0 --timesteps 100000
    python scripts/bench_training.py --bare                            # --residual 0 --no-shield
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import tempfile
import time
from pathlib import Path


class _Timer:
    """Accumulates the wall time of a method, wrapped on its class."""

    def __init__(self, cls: type, name: str) -> None:
        self.cls, self.name, self.total_s = cls, name, 0.0
        self.original = cls.__dict__[name]
        timer = self

        def wrapped(obj, *args, **kwargs):
            t0 = time.perf_counter()
            try:
                return timer.original(obj, *args, **kwargs)
            finally:
                timer.total_s += time.perf_counter() - t0

        setattr(cls, name, wrapped)

    def restore(self) -> None:
        setattr(self.cls, self.name, self.original)


def main(argv: list[str] | None = None) -> int:
    from uuom_gym.registration import ENV_IDS

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--env", default="UUOM-Track-v0", choices=ENV_IDS)
    ap.add_argument("--algo", default="ppo", choices=("ppo", "sac"))
    ap.add_argument("--observer", default="dffrls-aekf")
    ap.add_argument("--timesteps", type=int, default=40_960)
    ap.add_argument("--n-envs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--bare", action="store_true", help="no residual, no shield (--residual 0 --no-shield)")
    ap.add_argument("--json", action="store_true", help="print the figures as one JSON object")
    args = ap.parse_args(argv)

    from stable_baselines3 import PPO, SAC
    from stable_baselines3.common.off_policy_algorithm import OffPolicyAlgorithm
    from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    from agents.training import TrainConfig, train

    timers = {
        "collect": _Timer(OnPolicyAlgorithm if args.algo == "ppo" else OffPolicyAlgorithm, "collect_rollouts"),
        "update": _Timer(PPO if args.algo == "ppo" else SAC, "train"),
        "env_subproc": _Timer(SubprocVecEnv, "step_wait"),
        "env_dummy": _Timer(DummyVecEnv, "step_wait"),
    }
    extra = {"shield": False, "residual": 0.0} if args.bare else {}
    cpu0 = time.process_time()
    children0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    with tempfile.TemporaryDirectory() as tmp:
        cfg = TrainConfig(algo=args.algo, observer=args.observer, seed=args.seed, timesteps=args.timesteps,
                          n_envs=args.n_envs, eval_freq=0, checkpoint_freq=0, progress=False, env_id=args.env,
                          run_dir=Path(tmp) / "run", **extra)
        t0 = time.perf_counter()
        train(cfg)
        wall = time.perf_counter() - t0
    for t in timers.values():
        t.restore()
    cpu_main = time.process_time() - cpu0
    ch = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_workers = (ch.ru_utime + ch.ru_stime) - (children0.ru_utime + children0.ru_stime)
    n = args.timesteps
    env_s = timers["env_subproc"].total_s + timers["env_dummy"].total_s
    collect_s, update_s = timers["collect"].total_s, timers["update"].total_s
    learn_s = collect_s + update_s
    out = {
        "env": args.env, "algo": args.algo, "observer": args.observer, "bare": args.bare, "n_envs": args.n_envs,
        "timesteps": n, "wall_s": wall, "steps_per_s": n / learn_s, "minutes_per_1e6_steps": 1e6 / (n / learn_s) / 60,
        "share_env": env_s / learn_s, "share_inference": (collect_s - env_s) / learn_s,
        "share_update": update_s / learn_s, "setup_s": wall - learn_s,
        "cpu_main_us_per_step": 1e6 * cpu_main / n, "cpu_workers_us_per_step": 1e6 * cpu_workers / n,
    }
    if args.json:
        print(json.dumps(out))
        return 0
    print(f"{args.env} {args.algo}{' bare' if args.bare else ''} observer={args.observer}, {args.n_envs} envs "
          f"({'SubprocVecEnv' if args.n_envs > 1 else 'DummyVecEnv'}), {n} steps")
    print(f"  {out['steps_per_s']:.0f} env steps/s in training -> 10^6 steps in {out['minutes_per_1e6_steps']:.1f} min "
          f"(+ {out['setup_s']:.1f} s set-up)")
    print(f"  env step (workers + pipes) {100 * out['share_env']:5.1f} %   policy inference + rollout bookkeeping "
          f"{100 * out['share_inference']:5.1f} %   policy update {100 * out['share_update']:5.1f} %")
    print(f"  CPU per env step: main process {out['cpu_main_us_per_step']:.0f} us, env workers "
          f"{out['cpu_workers_us_per_step']:.0f} us")
    return 0


if __name__ == "__main__":
    sys.exit(main())
