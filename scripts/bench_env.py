#!/usr/bin/env python
"""Benchmark UUOM-Track-v0: env steps per second with random actions, and where the time goes.

Default configuration (full pymunk plant, sensors and the DFFRLS-AEKF observer at 200 Hz, 10 Hz policy). The
run is pinned to one CPU core (``--core``) with single-threaded BLAS; it reports wall-clock steps/s and steps per
CPU-second (the latter is what one uncontended core gives when the machine is shared). The profile times the plant's
``advance`` (physics), the sensor model (sensors), the observer (estimator, 20 updates per step) and the rest
(the env's own bookkeeping: safety rules, reward, observation, info, resets) by wrapping those calls.

Usage::

    python scripts/bench_env.py                 # 5000 steps, default config
    python scripts/bench_env.py --steps 20000 --observer oracle --json
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402


class _Timed:
    """Wraps a bound method and accumulates its wall time."""

    def __init__(self, fn):
        self.fn = fn
        self.total_s = 0.0

    def __call__(self, *args, **kwargs):
        t0 = time.perf_counter()
        try:
            return self.fn(*args, **kwargs)
        finally:
            self.total_s += time.perf_counter() - t0


def main(argv: list[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=5000, help="env steps to time (default 5000)")
    ap.add_argument("--warmup", type=int, default=200, help="untimed steps first (default 200)")
    ap.add_argument("--observer", default=None, help="observer (default: the env default, dffrls-aekf)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--core", type=int, default=0, help="CPU core to pin to (-1: no pinning)")
    ap.add_argument("--no-profile", action="store_true", help="time without the per-part wrappers")
    ap.add_argument("--json", action="store_true", help="print the result as JSON")
    ap.add_argument(
        "--baseline", type=int, default=0, metavar="N",
        help="instead of timing: run the plain speed controller (agents.controllers.proportional) on N random tracks "
        "(seeds 0..N-1) for each of the observers oracle, dffrls-aekf, none, and print the outcomes",
    )
    args = ap.parse_args(argv)
    if args.baseline:
        return baseline(args.baseline, args.json)
    if args.core >= 0 and hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {args.core})

    import uuom_gym  # noqa: F401
    from uuom_gym.envs.track_env import UUOMTrackEnv

    cfg = {} if args.observer is None else {"observer": args.observer}
    env = UUOMTrackEnv(**cfg)
    env.action_space.seed(args.seed)
    timers = {"physics": [], "sensors": [], "estimator": []}

    def instrument() -> None:
        if args.no_profile:
            return
        p = _Timed(env.plant.advance)
        s = _Timed(env.sensors.measure)
        env.plant.advance = p  # type: ignore[method-assign]
        env.sensors.measure = s  # type: ignore[method-assign]
        timers["physics"].append(p)
        timers["sensors"].append(s)

    if not args.no_profile:
        o = _Timed(env.observer.observe)
        env.observer.observe = o  # type: ignore[method-assign]
        timers["estimator"].append(o)

    env.reset(seed=args.seed)
    instrument()
    episodes = 0
    for _ in range(args.warmup):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if term or trunc:
            env.reset()
            instrument()
    for lst in timers.values():
        for t in lst:
            t.total_s = 0.0
    reset_s = 0.0
    c0 = time.process_time()
    t0 = time.perf_counter()
    for _ in range(args.steps):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if term or trunc:
            r0 = time.perf_counter()
            env.reset()
            instrument()
            reset_s += time.perf_counter() - r0
            episodes += 1
    wall = time.perf_counter() - t0
    cpu = time.process_time() - c0
    parts = {k: sum(t.total_s for t in v) for k, v in timers.items()}
    result = {
        "steps": args.steps,
        "observer": env.observer.name,
        "wall_s": wall,
        "steps_per_s": args.steps / wall,
        "cpu_s": cpu,
        "steps_per_cpu_s": args.steps / cpu,
        "load_avg_1min": os.getloadavg()[0] if hasattr(os, "getloadavg") else None,
        "us_per_step": wall / args.steps * 1e6,
        "physics_ticks_per_step": env.ticks_per_step,
        "episodes_finished": episodes,
        "profile": None,
    }
    if not args.no_profile:
        parts["reset"] = reset_s
        parts["rest"] = wall - sum(parts.values())
        result["profile"] = {k: {"s": v, "share": v / wall} for k, v in parts.items()}
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        print(
            f"UUOM-Track-v0 observer={result['observer']}: {result['steps_per_s']:.0f} env steps/s "
            f"({result['us_per_step']:.0f} us/step, {env.ticks_per_step} physics ticks + estimator updates each), "
            f"{args.steps} random-action steps, {episodes} episodes ended"
        )
        print(
            f"  CPU time: {result['steps_per_cpu_s']:.0f} env steps per CPU-second (wall/CPU = {wall / cpu:.2f}; "
            f"1-min load average {result['load_avg_1min']:.2f} - on a shared machine wall time includes waiting)"
        )
        if result["profile"]:
            for k, v in result["profile"].items():
                print(f"  {k:10s} {100 * v['share']:5.1f} %  ({1e6 * v['s'] / args.steps:6.1f} us/step)")
    env.close()
    return result


def baseline(n_episodes: int, as_json: bool) -> dict:
    """Outcomes of a plain controller (70 % of the estimated limit) per observer: what the estimate is worth."""
    from agents.controllers.proportional import proportional_command
    from uuom_gym.envs.track_env import UUOMTrackEnv

    out: dict = {}
    for observer in ("oracle", "dffrls-aekf", "none"):
        env = UUOMTrackEnv(observer=observer)
        rows = []
        for seed in range(n_episodes):
            obs, info = env.reset(seed=seed)
            ret = 0.0
            while True:
                a = proportional_command(obs, info["distance_to_go_m"])
                obs, r, term, trunc, info = env.step(np.array([a], np.float32))
                ret += r
                if term or trunc:
                    break
            rows.append((info["is_success"], info["termination"], info["episode_cost"], info["t_s"], ret,
                         info["track_length_m"] / info["t_s"]))
        env.close()
        out[observer] = {
            "episodes": n_episodes,
            "success_rate": float(np.mean([r[0] for r in rows])),
            "trips": int(sum(r[1] == "overspeed_trip" for r in rows)),
            "mean_episode_cost": float(np.mean([r[2] for r in rows])),
            "episodes_with_cost": int(sum(r[2] > 0 for r in rows)),
            "mean_time_s": float(np.mean([r[3] for r in rows])),
            "mean_return": float(np.mean([r[4] for r in rows])),
            "mean_speed_arrived_mps": float(np.mean([r[5] for r in rows if r[0]])) if any(r[0] for r in rows)
            else float("nan"),
            "terminations": {t: int(sum(r[1] == t for r in rows)) for t in sorted({r[1] for r in rows})},
        }
    if as_json:
        print(json.dumps(out, indent=2))
    else:
        print(f"plain controller (70 % of the estimated limit), random tracks, seeds 0..{n_episodes - 1}")
        print("observer      success  trips  eps.with.cost  mean cost  mean time s  speed(arrived) m/s  mean return"
              "  endings")
        for k, v in out.items():
            print(f"{k:12s} {v['success_rate']:7.2f} {v['trips']:6d} {v['episodes_with_cost']:14d} "
                  f"{v['mean_episode_cost']:10.3f} {v['mean_time_s']:12.1f} {v['mean_speed_arrived_mps']:19.3f} "
                  f"{v['mean_return']:12.2f}  {v['terminations']}")
    return out


if __name__ == "__main__":
    main()
