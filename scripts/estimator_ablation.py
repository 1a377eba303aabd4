#!/usr/bin/env python
"""Ablation of ``dffrls-aekf``: each deviation from paper 000 switched off alone, beside the paper as printed and
``fused``, on random runs of both simulators (issue 10 item 2).

Runs: the first ``--plant`` random plant runs and the first ``--point`` random point-mass runs of
:func:`uuom_gym.sim.protocol_runs.protocol_runs` (the protocol's own draws, none of them used for tuning; the
estimators were tuned on plant runs 1000-1015). Errors after 10 s: mass max |error| in %, slope RMSE in degrees
against the slope gravity acts on (``effective_slope_deg``: the train-averaged slope on the plant, the local slope
on the point-mass world). Printed as a Markdown table of medians and 95th percentiles.

Usage::

    python scripts/estimator_ablation.py [--plant 40] [--point 40] [--duration 60] [--cache DIR] [--only fused]
"""

from __future__ import annotations

import argparse
import os
import pickle
import sys

import numpy as np

import estimators
from uuom_gym.sim.protocol_runs import RunSpec, make_run

# (label, estimator, options): one deviation switched off per row
VARIANTS: list[tuple[str, str, dict]] = [
    ("dffrls-aekf (all deviations; geometry bank: point mass or 12 m window)", "dffrls-aekf", {}),
    ("- geometry bank: the 12 m window fixed (the env's plant setting)", "dffrls-aekf", {"train_length_m": 12.0}),
    ("- geometry bank: the point slope fixed", "dffrls-aekf", {"train_length_m": 0.0}),
    ("- geometry bank: mass learnt while the geometry is ambiguous", "dffrls-aekf",
     {"max_geometry_ambiguity_rad": float("inf")}),
    ("- session 23's ambiguity gate (0.004 rad, as before)", "dffrls-aekf", {"max_geometry_ambiguity_rad": 0.004}),
    ("- geometry bank: evidence from the first window length travelled (not counted)", "dffrls-aekf",
     {"max_early_evidence": 0.0}),
    ("- accelerometer drives the slope EKF (paper's torque/mass model)", "dffrls-aekf", {"use_accel": False}),
    ("- load pendulum in the regression (rigid load)", "dffrls-aekf", {"chain_length_m": 0.0}),
    ("- chain-length bank (one pendulum on the vehicle file's chains)", "dffrls-aekf", {"chain_length_factors": ()}),
    ("- vector forgetting (paper's single lambda)", "dffrls-aekf", {"mass_forgetting_ratio": 1.0}),
    ("- offset parameter (mu cos(theta) regressor)", "dffrls-aekf", {"offset_forgetting_ratio": 0.0}),
    ("- resistance estimated (vehicle file's mu)", "dffrls-aekf",
     {"estimate_mu": False, "offset_forgetting_ratio": 0.0}),
    ("- mass only from accelerations", "dffrls-aekf", {"min_accel_mps2": 0.0}),
    ("- session 22's mass gate (0.05 m/s² in both members, as before)", "dffrls-aekf",
     {"min_accel_mps2": 0.05, "point_min_accel_mps2": None}),
    ("- the point member's constant-speed samples counted as correlated (at full weight)", "dffrls-aekf",
     {"weak_accel_noise_factor": 1.0}),
    ("- the offset forgotten as a random walk on those samples (its covariance scaled, as before session 58)",
     "dffrls-aekf", {"weak_offset_random_walk": False}),
    ("- a window member's constant-speed samples on a uniform grade used (held, as before session 63)", "dffrls-aekf",
     {"window_weak_spread_rad": 0.0}),
    ("- measured electric braking used (traction samples only, as before session 23)", "dffrls-aekf",
     {"braking_samples": False}),
    ("- jump gates on the torque and the accelerometer (none, as before session 24)", "dffrls-aekf",
     {"torque_jump_fraction": 0.0, "accel_jump_mps2": 0.0}),
    ("- missing speed filled with the predicted speed (filters paused, as before session 24)", "dffrls-aekf",
     {"fill_missing_speed": False}),
    ("- session 24's early-evidence cap (1 nat, as before)", "dffrls-aekf", {"max_early_evidence": 1.0}),
    ("- evidence only where the geometries disagree (every sample counted, as before session 27)", "dffrls-aekf",
     {"evidence_min_disagreement_rad": 0.0}),
    ("- clamped mass moves the offset with it (projection)", "dffrls-aekf", {"clamp_projection": False}),
    ("- grade curvature state (the paper's two-state slope EKF)", "dffrls-aekf", {"grade_curvature_std": 0.0}),
    ("- spike / innovation gates", "dffrls-aekf", {"gates": False}),
    ("- Sage-Husa R adaptation", "dffrls-aekf", {"adapt_r": False}),
    ("- the gyro witness of grade changes (none, as before session 55)", "dffrls-aekf", {"gyro_witness_deg": 0.0}),
    ("dffrls-aekf-paper (as printed)", "dffrls-aekf-paper", {}),
    ("dffrls-aekf-paper without noise means", "dffrls-aekf-paper", {"adapt_means": False}),
    ("fused", "fused", {}),
    ("fused without the spread gate on its mass (as before session 24)", "fused", {"fused_spread_gate": False}),
    ("fused, its blend learnt only once the window holds measured slopes (as before session 25)", "fused",
     {"blend_from_start": False}),
    ("fused, its blend learnt on every steady-speed sample (as before session 27)", "fused",
     {"evidence_min_disagreement_rad": 0.0}),
    ("fused without the gyro witness (as before session 55)", "fused", {"gyro_witness_deg": 0.0}),
    ("fused without the grade curvature state (as before session 62)", "fused", {"grade_curvature_std": 0.0}),
    ("fused without the grade's variance in its mass regression's noise (as before session 63)", "fused",
     {"slope_var_weight": 0.0}),
    ("fused with the mass gate at 0.05 m/s² (as before session 63)", "fused", {"min_accel_mps2": 0.05}),
    ("fused as before session 63 (both)", "fused", {"slope_var_weight": 0.0, "min_accel_mps2": 0.05}),
]


def runs(n_plant: int, n_point: int, duration_s: float, cache: str | None) -> dict[str, list]:
    out: dict[str, list] = {"plant": [], "point": []}
    for world, n in (("plant", n_plant), ("point", n_point)):
        for i in range(n):
            path = os.path.join(cache, f"{world}-{i:03d}-{duration_s:g}.pkl") if cache else None
            if path and os.path.exists(path):
                with open(path, "rb") as f:
                    out[world].append(pickle.load(f))
                continue
            tr = make_run(RunSpec(world, f"{world}-{i:03d}", i, i, world, duration_s=duration_s))
            if path:
                with open(path, "wb") as f:
                    pickle.dump(tr, f)
            out[world].append(tr)
    return out


def errors(tr, name: str, opts: dict) -> tuple[float, float]:
    s = estimators.make(name, **opts).run(tr)
    k = tr["t_s"] >= tr["t_s"][0] + 10.0
    m = tr["mass_kg"][k]
    ref = tr.columns.get("effective_slope_deg", tr["slope_deg"])[k]
    mass = float(np.max(np.abs(s.mass_kg[k] - m) / m)) * 100.0
    slope = float(np.sqrt(np.mean((s.slope_deg[k] - ref) ** 2)))
    return mass, slope


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plant", type=int, default=40)
    ap.add_argument("--point", type=int, default=40)
    ap.add_argument("--duration", type=float, default=60.0)
    ap.add_argument("--cache", default=None, help="folder to keep the generated traces in")
    ap.add_argument("--only", default=None, help="comma-separated estimator names: only their rows")
    args = ap.parse_args(argv)
    if args.cache:
        os.makedirs(args.cache, exist_ok=True)
    data = runs(args.plant, args.point, args.duration, args.cache)
    print(f"{args.plant} random plant runs, {args.point} random point-mass runs (protocol draws 0..), "
          f"{args.duration:g} s each; errors after 10 s; p50 / p95 over runs\n")
    print("| variant | plant mass max % | plant slope RMSE ° | point mass max % | point slope RMSE ° |")
    print("| --- | --- | --- | --- | --- |")
    only = set(args.only.split(",")) if args.only else None
    for label, name, opts in VARIANTS:
        if only is not None and name not in only:
            continue
        cells = []
        for world in ("plant", "point"):
            e = np.array([errors(tr, name, opts) for tr in data[world]]) if data[world] else np.full((1, 2), np.nan)
            for j in (0, 1):
                cells.append(f"{np.percentile(e[:, j], 50):.2f} / {np.percentile(e[:, j], 95):.2f}")
        print(f"| {label} | {cells[0]} | {cells[1]} | {cells[2]} | {cells[3]} |", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
