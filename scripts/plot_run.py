#!/usr/bin/env python
"""Draw a track profile and a recorded run of the plant (speed, torque, accelerometer, sway, true slope).

    python scripts/plot_run.py roadtest --seed 0 --out docs/img/plant_run.png
    python scripts/plot_run.py --tracks --out docs/img/plant_tracks.png     # scenario + random track profiles
"""

from __future__ import annotations

import argparse

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from uuom_gym.sim import SCENARIO_NAMES, random_track, scenario, simulate_run  # noqa: E402


def plot_run(name: str, seed: int, out: str) -> None:
    sc = scenario(name)
    trace = simulate_run(name, seed=seed)
    t = trace["t_s"]
    fig, ax = plt.subplots(6, 1, figsize=(9, 12), sharex=False)
    tr = sc.track
    s = tr.s_m
    ax[0].plot(s, tr.z_m, "k")
    ax[0].set_ylabel("rail height (m)")
    ax0b = ax[0].twinx()
    ax0b.plot(s, np.degrees(tr.slope_rad), "C1", lw=1)
    ax0b.set_ylabel("slope (deg)", color="C1")
    ax[0].set_xlabel("distance along the track s (m)")
    ax[0].set_title(f"{name}: {sc.description}; {sc.load_kg / 1000:g} t load, seed {seed}", fontsize=9)
    ax[1].plot(t, trace["speed_mps"], lw=0.5, color="0.6", label="encoder (measured)")
    ax[1].plot(t, trace["true_speed_mps"], "C0", label="true ground speed")
    ax[1].set_ylabel("speed (m/s)")
    ax[1].legend(loc="upper right", fontsize=8)
    ax[2].plot(t, trace["torque_nm"] / 1000, lw=0.5, color="C3")
    ax[2].set_ylabel("drive torque (kN m)")
    ax[3].plot(t, trace["accel_mps2"], lw=0.4, color="0.5", label="accelerometer (specific force)")
    f_true = np.gradient(trace["true_speed_mps"], t) + 9.81 * np.sin(np.radians(trace["slope_deg"]))
    k = 100
    smooth = np.convolve(f_true, np.ones(k) / k, mode="same")
    ax[3].plot(t, smooth, "C2", label="dv/dt + g sin(slope), 0.5 s mean")
    ax[3].set_ylabel("accel (m/s$^2$)")
    ax[3].legend(loc="upper left", fontsize=8)
    ax[4].plot(t, np.degrees(trace["sway_rad"]), "C4")
    ax[4].set_ylabel("load sway (deg)")
    ax[5].plot(t, trace["slope_deg"], "k")
    ax[5].set_ylabel("true slope (deg)")
    ax[5].set_xlabel("time (s)")
    for a in ax[1:]:
        a.grid(alpha=0.3)
        a.set_xlim(t[0], t[-1])
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


def plot_tracks(out: str, seeds: int = 4) -> None:
    fig, ax = plt.subplots(2, 1, figsize=(9, 6))
    for name in SCENARIO_NAMES:
        tr = scenario(name).track
        ax[0].plot(tr.s_m, np.degrees(tr.slope_rad), label=name)
    ax[0].set_ylabel("slope (deg)")
    ax[0].set_title("fixed scenarios (paper 000 §4.2, §4.3, §5.2)", fontsize=9)
    ax[0].legend(fontsize=8)
    for seed in range(seeds):
        tr = random_track(np.random.default_rng(seed), load_kg=10_000.0)
        ax[1].plot(tr.s_m, np.degrees(tr.slope_rad), lw=1, label=f"seed {seed}")
    ax[1].set_title("random_track(rng, load_kg=10000): feasible for 26 t", fontsize=9)
    ax[1].set_xlabel("s (m)")
    ax[1].set_ylabel("slope (deg)")
    ax[1].legend(fontsize=8)
    for a in ax:
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print(f"wrote {out}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("scenario", nargs="?", default="roadtest", choices=SCENARIO_NAMES)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--tracks", action="store_true", help="plot track profiles instead of a run")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    if args.tracks:
        plot_tracks(args.out or "docs/img/plant_tracks.png")
    else:
        plot_run(args.scenario, args.seed, args.out or "docs/img/plant_run.png")


if __name__ == "__main__":
    main()
