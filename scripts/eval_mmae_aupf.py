"""Accuracy of the MMAE payload bank and the AUPF slip/radius filter on the pymunk plant, and their figures.

Usage::

    python scripts/eval_mmae_aupf.py [--quick] [--no-figures]

Prints Markdown tables (the numbers in docs/mmae_aupf.md) and writes ``docs/img/mmae_station.png`` and
``docs/img/aupf_wet_rail.png``. Every run is seeded; the same command gives the same numbers.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from estimators.aupf import AUPFEstimator
from estimators.base import first_step_dts
from estimators.mmae import MMAEEstimator
from uuom_gym.sim.station import station_trace
from uuom_gym.sim.plant import PlantConfig
from uuom_gym.sim.recording import simulate_run
from uuom_gym.sim.track import SCENARIO_NAMES

IMG = Path(__file__).resolve().parent.parent / "docs" / "img"


def time_to_within(t: np.ndarray, est: np.ndarray, truth: np.ndarray, frac: float, start_s: float = 0.0) -> float:
    """First time after ``start_s`` from which the estimate stays within ``frac`` of the truth (nan if never)."""
    ok = np.abs(est - truth) <= frac * truth
    sel = t >= start_s
    idx = np.nonzero(sel)[0]
    bad = idx[~ok[idx]]
    if len(bad) == 0:
        return float(t[idx[0]] - start_s)
    if bad[-1] == idx[-1]:
        return float("nan")
    return float(t[bad[-1] + 1] - start_s)


def eval_mmae(quick: bool) -> None:
    loads = (2000.0, 10000.0, 18000.0)
    names = SCENARIO_NAMES
    seeds = (1,) if quick else (1, 2)
    print("\n### MMAE (default bank: 30 payloads, each as the two-section train and as a point mass) on the plant\n")
    print("| scenario | load (t) | seed | mass error, last 20 % (%) | mass MAE, 2nd half (kg) | within 5 % from (s) |"
          " slope RMSE, 2nd half (deg) |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    errs = []
    for name in names:
        for load in loads:
            for seed in seeds:
                tr = simulate_run(name, seed=seed, load_kg=load)
                es = MMAEEstimator().run(tr)
                n = len(tr)
                truth = tr["mass_kg"]
                last = slice(int(0.8 * n), None)
                half = slice(n // 2, None)
                e_last = 100.0 * (np.mean(es.mass_kg[last]) - truth[-1]) / truth[-1]
                mae = np.mean(np.abs(es.mass_kg[half] - truth[half]))
                t5 = time_to_within(tr["t_s"], es.mass_kg, truth, 0.05)
                srmse = np.sqrt(np.mean((es.slope_deg[half] - tr["slope_deg"][half]) ** 2))
                errs.append(abs(e_last))
                print(f"| {name} | {load / 1000:.0f} | {seed} | {e_last:+.1f} | {mae:.0f} | {t5:.1f} | {srmse:.2f} |")
    print(f"\nmean |mass error, last 20 %| over {len(errs)} runs: {np.mean(errs):.1f} %, worst {np.max(errs):.1f} %")
    tr = station_trace(2000.0, 16000.0, seed=5)
    es = MMAEEstimator().run(tr)
    t = tr["t_s"]
    restart = 70.0
    t5 = time_to_within(t, es.mass_kg, tr["mass_kg"], 0.05, start_s=restart)
    t10 = time_to_within(t, es.mass_kg, tr["mass_kg"], 0.10, start_s=restart)
    print(f"\nstation loading 2 t -> 16 t (section1, seed 5): after the restart at {restart:.0f} s the estimate stays"
          f" within 10 % from {t10:.1f} s and within 5 % from {t5:.1f} s on")


def eval_aupf(quick: bool) -> None:
    cases = [
        ("section1", 10000.0, 0.004, None),
        ("section1", 10000.0, 0.004, 0.12),
        ("section2", 18000.0, 0.002, 0.13),
        ("roadtest", 10000.0, 0.008, 0.15),
        ("roadtest", 18000.0, 0.010, 0.10),
    ]
    seeds = (2,) if quick else (2, 3)
    print("\n### AUPF (64 particles) on the plant\n")
    print("| scenario | load (t) | wear (mm) | adhesion | seed | true slip max | slip max abs err | slip p99 abs err |"
          " radius max abs err after 20 s (mm) | radius err at end (mm) |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, load, wear, adh in cases:
        for seed in seeds:
            cfg = PlantConfig(load_kg=load, wheel_wear_m=wear, adhesion=adh)
            tr = simulate_run(name, seed=seed, load_kg=load, plant_config=cfg)
            es = AUPFEstimator().run(tr)
            x = es.extras
            # moving, or stalled with the drive wheel spinning (slip ~1)
            rim = tr["motor_speed_radps"] * tr["drive_radius_m"]
            mov = (tr["true_speed_mps"] > 0.2) | (np.nan_to_num(rim) > 0.2)
            settled = (tr["true_speed_mps"] > 0.2) & (tr["t_s"] > 20.0)
            ie = (x["slip_ratio"] - tr["slip_ratio"])[mov]
            re = (x["drive_radius_m"] - tr["drive_radius_m"])[settled]
            adh_s = "dry 0.35" if adh is None else f"{adh:.2f}"
            print(f"| {name} | {load / 1000:.0f} | {wear * 1e3:.0f} | {adh_s} | {seed} |"
                  f" {tr['slip_ratio'][mov].max():.2f} | {np.abs(ie).max():.3f} | {np.quantile(np.abs(ie), 0.99):.3f} | {1e3 * np.abs(re).max():.2f} |"
                  f" {1e3 * re[-1]:+.2f} |")


def figures() -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    IMG.mkdir(parents=True, exist_ok=True)
    # MMAE: loading at a station
    tr = station_trace(2000.0, 16000.0, seed=5)
    est = MMAEEstimator()
    n = len(tr)
    t = tr["t_s"]
    mass = np.empty(n)
    std = np.empty(n)
    grid = est.config.n_models  # payload hypotheses; the bank holds each once per geometry
    probs = np.empty((n, grid))
    point_share = np.empty(n)
    nan = float("nan")
    dts = first_step_dts(t)  # as Estimator.run steps a trace
    for k in range(n):
        e = est.update(tr["torque_nm"][k], tr["speed_mps"][k], tr["accel_mps2"][k], dts[k], nan)
        mass[k], std[k] = e.mass_kg, e.mass_std_kg
        p = est.probabilities.reshape(-1, grid)  # (geometries, payloads)
        probs[k] = p.sum(axis=0)  # the payload's probability over both geometries
        point_share[k] = p[1:].sum()
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    ax1.plot(t, tr["mass_kg"] / 1000, "k", lw=1.5, label="true total mass")
    ax1.plot(t, mass / 1000, "C0", lw=1.0, label="MMAE estimate")
    ax1.fill_between(t, (mass - 2 * std) / 1000, (mass + 2 * std) / 1000, color="C0", alpha=0.25, label="±2σ")
    ax1.set_ylabel("mass (t)")
    ax1b = ax1.twinx()
    ax1b.plot(t, tr["slope_deg"], "C2", lw=0.8, alpha=0.7)
    ax1b.set_ylabel("slope (deg)", color="C2")
    ax1.legend(loc="upper left")
    ax1.set_title("MMAE on the plant: 2 t payload, station stop at 70 s, loaded to 16 t, on up the 8° grade")
    ax2.imshow(probs.T, aspect="auto", origin="lower", cmap="viridis",
               extent=(t[0], t[-1], est.payloads_kg[0] / 1000, est.payloads_kg[grid - 1] / 1000), vmin=0, vmax=1)
    ax2.set_ylabel("hypothesised payload (t)")
    ax2.set_xlabel("time (s)")
    if est.n_models > grid:
        ax2b = ax2.twinx()
        ax2b.plot(t, point_share, "w", lw=1.0)
        ax2b.set_ylim(0.0, 1.0)
        ax2b.set_ylabel("point-mass geometry's share (white)")
    ax2.set_title(f"payload probabilities, both geometries summed ({grid} payloads x {est.n_models // grid}, "
                  f"floor 1e-6)")
    fig.tight_layout()
    fig.savefig(IMG / "mmae_station.png", dpi=110)
    plt.close(fig)
    # AUPF: wet rail
    cfg = PlantConfig(load_kg=10000.0, wheel_wear_m=0.004, adhesion=0.12)
    tr = simulate_run("section1", seed=2, load_kg=10000.0, plant_config=cfg)
    es = AUPFEstimator().run(tr)
    x = es.extras
    t = tr["t_s"]
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 6), sharex=True)
    a1.plot(t, tr["slip_ratio"], "k", lw=1.5, label="true slip ratio")
    a1.plot(t, x["slip_ratio"], "C3", lw=0.8, label="AUPF")
    a1.plot(t, x["macro_slip_prob"], "C1", lw=0.8, alpha=0.7, label="P(macro-slip)")
    a1.set_ylabel("slip ratio / probability")
    a1.legend(loc="upper left")
    a1.set_title("AUPF on the plant: section1, 10 t, wet rail (adhesion 0.12), 4 mm wheel wear")
    a2.plot(t, 1e3 * tr["drive_radius_m"], "k", lw=1.5, label="true effective radius")
    a2.plot(t, 1e3 * x["drive_radius_m"], "C0", lw=1.0, label="AUPF")
    r, s = 1e3 * x["drive_radius_m"], 1e3 * x["drive_radius_m_std"]
    a2.fill_between(t, r - 2 * s, r + 2 * s, color="C0", alpha=0.25, label="±2σ")
    a2.set_ylim(1e3 * tr["drive_radius_m"][0] - 6, 1e3 * tr["drive_radius_m"][0] + 8)
    a2.set_ylabel("drive radius (mm)")
    a2.set_xlabel("time (s)")
    a2.legend(loc="upper right")
    fig.tight_layout()
    fig.savefig(IMG / "aupf_wet_rail.png", dpi=110)
    plt.close(fig)
    print(f"\nwrote {IMG / 'mmae_station.png'} and {IMG / 'aupf_wet_rail.png'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one seed per case")
    parser.add_argument("--no-figures", action="store_true")
    args = parser.parse_args()
    eval_mmae(args.quick)
    eval_aupf(args.quick)
    if not args.no_figures:
        figures()


if __name__ == "__main__":
    main()
