#!/usr/bin/env python
"""Render README frames of UUOM-Track-v0: ``docs/img/env_frame.png`` (one frame mid-run) and
``docs/img/env_episode.png`` (one episode: true vs estimated speed limit, speed, mass and slope).

The run drives the roadtest scenario with the default DFFRLS-AEKF observer and a plain ramped proportional speed
controller that aims at 70 % of the *estimated* limit, so the pictures show what the estimate does to the limit.

Usage::

    python scripts/render_frame.py [--out-dir docs/img] [--seed 0] [--frame-s 60]
"""

from __future__ import annotations

import argparse
import os
from pathlib import Path

import numpy as np

from agents.controllers.proportional import proportional_command


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out-dir", default="docs/img")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--scenario", default="roadtest")
    ap.add_argument(
        "--frame-s", type=float, default=None,
        help="simulated time of the README frame (default: when the train first reaches the steepest grade)",
    )
    args = ap.parse_args(argv)
    os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from uuom_gym.envs.track_env import UUOMTrackEnv

    out = Path(args.out_dir)
    out.mkdir(parents=True, exist_ok=True)
    env = UUOMTrackEnv(render_mode="rgb_array", scenario=args.scenario)
    obs, info = env.reset(seed=args.seed)
    rows = []
    frame_saved = False
    steepest = float(np.max(np.abs(env.track.slope_rad)))
    while True:
        a = proportional_command(obs, info["distance_to_go_m"])
        obs, r, term, trunc, info = env.step(np.array([a], np.float32))
        rows.append(
            (info["t_s"], info["speed_mps"], info["true_speed_limit_mps"], info["est_speed_limit_mps"],
             info["true_mass_kg"], info["est_mass_kg"], info["true_slope_rad"], info["est_slope_rad"], info["cost"])
        )
        at_frame = (
            info["t_s"] >= args.frame_s if args.frame_s is not None else abs(info["true_slope_rad"]) >= 0.95 * steepest
        )
        if not frame_saved and at_frame:
            plt.imsave(out / "env_frame.png", env.render())
            frame_saved = True
            frame_t = info["t_s"]
        if term or trunc:
            break
    if not frame_saved:
        plt.imsave(out / "env_frame.png", env.render())
        frame_t = info["t_s"]
    env.close()
    d = np.array(rows)
    fig, ax = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    ax[0].plot(d[:, 0], d[:, 1], "k", label="true speed")
    ax[0].plot(d[:, 0], d[:, 2], "r", label="true limit v_lim(M, slope)")
    ax[0].plot(d[:, 0], d[:, 3], "b--", label="limit from the estimates")
    ax[0].set_ylabel("m/s")
    ax[0].legend(fontsize=8)
    ax[1].plot(d[:, 0], d[:, 4] / 1000, "r", label="true mass")
    ax[1].plot(d[:, 0], d[:, 5] / 1000, "b--", label="DFFRLS-AEKF")
    ax[1].set_ylabel("t")
    ax[1].legend(fontsize=8)
    ax[2].plot(d[:, 0], np.degrees(d[:, 6]), "r", label="true slope")
    ax[2].plot(d[:, 0], np.degrees(d[:, 7]), "b--", label="DFFRLS-AEKF")
    ax[2].set_ylabel("deg")
    ax[2].set_xlabel("time (s)")
    ax[2].legend(fontsize=8)
    fig.suptitle(
        f"UUOM-Track-v0 scenario={args.scenario} seed={args.seed}: {info['termination'] or 'running'}, "
        f"episode cost {info['episode_cost']:.3f}",
        fontsize=10,
    )
    fig.tight_layout()
    fig.savefig(out / "env_episode.png", dpi=110)
    print(f"frame at t = {frame_t:.1f} s; wrote {out / 'env_frame.png'} and {out / 'env_episode.png'}; "
          f"episode ended: {info['termination']}, "
          f"t = {info['t_s']:.1f} s, cost {info['episode_cost']:.4f}")


if __name__ == "__main__":
    main()
