#!/usr/bin/env python
"""Where a sensor's noise enters ``dffrls-aekf``'s mass regression: each point-mass scenario run twice with the same
random draws, once with the named sensor fields scaled and once with them set to zero, and the regression's signals
compared sample by sample.

For every sample that reaches the mass layer the script reads, from the filter's state after the step, the regressand
``y = (F − m_rot a − M_rigid (a − a_L)) / M_ref`` and the regressor ``h = a_L + g sin θ̄`` (``a`` the 1 Hz low-passed
dv/dt of the encoder, ``a_L`` the modelled acceleration of the load on its chains, θ̄ the slope layer's grade) and
prints, per run and on average over the runs, the mean square of the noise each carries (the difference between the
two runs): ``dh2`` of the regressor, ``daL2`` of the load's acceleration, ``da2`` of dv/dt, ``dhdy`` the regressor's
noise times the regressand's (errors in the variables: a fit's slope is pulled by ``dhdy − c dh2``), and the mass error
at 30 s of both runs. One filter of the bank (``--train-length-m``, default 0: the point member, the geometry that is
right on the point-mass world).

Usage::

    python scripts/regressor_noise.py --scale-fields '{"speed_noise_std_mps": 3, "speed_resolution_mps": 3}'
    python scripts/regressor_noise.py --seeds 3 --options '{"sway_damping_ratio": 0.15}'
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

import numpy as np

import estimators
from estimators import dffrls_aekf_kernel as kern
from uuom_core.vehicle import G_MPS2
from uuom_gym.sim.point_mass import POINT_MASS_SCENARIOS, PointMassSensors, simulate_point_mass, with_options
from uuom_gym.sim.sensor_factors import scale_sensor_fields

COLUMNS = ("dh2", "daL2", "da2", "dhdy", "mass30_noisy_pct", "mass30_quiet_pct")


def regression_signals(trace, train_length_m: float, options: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    """Step one filter over ``trace``; per sample ``[y, h, a_L, a]`` where the mass layer ran (NaN elsewhere), and the
    mass estimate (kg) after every sample."""
    f = estimators.make("dffrls-aekf", **options, train_length_m=train_length_m).members[0]
    S, C = f.S, f.C
    t = trace["t_s"]
    dts = np.diff(t, prepend=t[0] - (t[1] - t[0]))
    out = np.full((len(t), 4), np.nan)
    mass = np.empty(len(t))
    n_mass = S[kern.N_MASS]
    for i in range(len(t)):
        f.update(trace["torque_nm"][i], trace["speed_mps"][i], trace["accel_mps2"][i], dts[i])
        mass[i] = S[kern.MC] * C[kern.M_REF]
        if S[kern.N_MASS] > n_mass:  # the mass layer ran on this sample: its inputs are the low-pass outputs
            n_mass = S[kern.N_MASS]
            a, a_load = S[kern.ACC_F], S[kern.A_LOAD]
            y = (S[kern.LF1 + 1] - C[kern.M_ROT] * a - C[kern.M_RIGID] * (a - a_load)) / C[kern.M_REF]
            out[i] = (y, a_load + G_MPS2 * S[kern.LS1 + 1], a_load, a)
    return out, mass


def compare(job: tuple[str, int, dict[str, float], float, dict[str, Any]]) -> list[float]:
    """One scenario and seed, noisy and quiet: the row of :data:`COLUMNS`."""
    scenario, seed, per_field, length, options = job
    sc = POINT_MASS_SCENARIOS[scenario]
    runs = []
    for factors in (per_field, dict.fromkeys(per_field, 0.0)):
        s = with_options(sc, sensors=scale_sensor_fields(sc.sensors, factors))
        tr = simulate_point_mass(s, seed=seed)
        i30 = min(int(np.searchsorted(tr["t_s"], 30.0)), len(tr["t_s"]) - 1)
        sig, mass = regression_signals(tr, length, options)
        runs.append((sig, (mass[i30] / tr["mass_kg"][i30] - 1.0) * 100.0))
    (a, err_a), (b, err_b) = runs
    ok = np.isfinite(a[:, 0]) & np.isfinite(b[:, 0])
    d = a[ok] - b[ok]
    if not ok.any():
        return [np.nan] * 4 + [err_a, err_b]
    return [float(np.mean(d[:, 1] ** 2)), float(np.mean(d[:, 2] ** 2)), float(np.mean(d[:, 3] ** 2)),
            float(np.mean(d[:, 1] * d[:, 0])), err_a, err_b]


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scale-fields", default='{"speed_noise_std_mps": 3, "speed_resolution_mps": 3}',
                    help="JSON object: PointMassSensors field -> factor in the noisy run (0 in the quiet one)")
    ap.add_argument("--options", default="{}", help="JSON object of dffrls-aekf options")
    ap.add_argument("--train-length-m", type=float, default=0.0, help="the bank member (slope window) to step")
    ap.add_argument("--seeds", type=int, default=3, help="sensor seeds 0..N-1 per scenario")
    ap.add_argument("--scenarios", nargs="*", default=None, help="default: all eight")
    args = ap.parse_args(argv)
    try:
        per_field, options = json.loads(args.scale_fields), json.loads(args.options)
    except json.JSONDecodeError as exc:
        ap.error(f"--scale-fields / --options must be JSON objects: {exc}")
    if not isinstance(per_field, dict) or not isinstance(options, dict) or not per_field:
        ap.error("--scale-fields must be a non-empty JSON object, --options a JSON object")
    try:
        scale_sensor_fields(PointMassSensors(), per_field)
    except ValueError as exc:
        ap.error(f"--scale-fields: {exc}")
    scenarios = args.scenarios or list(POINT_MASS_SCENARIOS)
    bad = sorted(set(scenarios) - set(POINT_MASS_SCENARIOS))
    if bad:
        ap.error(f"unknown scenario(s) {bad}")
    if args.seeds < 1:
        ap.error("--seeds must be >= 1")
    member = estimators.make("dffrls-aekf", **options, train_length_m=args.train_length_m)  # bad options: refused
    if member.config.accel_regressor or not member.config.estimate_mu:
        # regression_signals rebuilds y and h with the default regression's formula; these two change its form
        ap.error("--options: accel_regressor and estimate_mu=false change the regression's form, which this "
                 "diagnostic does not rebuild")
    rows = []
    print(f"# fields {json.dumps(per_field)} (0 in the quiet run), options {json.dumps(options)}, member "
          f"train_length_m={args.train_length_m:g}")
    print(f"{'scenario':24s} seed " + " ".join(f"{c:>16s}" for c in COLUMNS))
    for sc in scenarios:
        for seed in range(args.seeds):
            rows.append(compare((sc, seed, per_field, args.train_length_m, options)))
            print(f"{sc:24s} {seed:4d} " + " ".join(f"{x:16.4g}" for x in rows[-1]), flush=True)
    r = np.array(rows)
    print(f"{'mean':29s} " + " ".join(f"{x:16.4g}" for x in np.nanmean(r, 0)))
    print(f"load acceleration's share of the regressor's noise (mean daL2 / mean dh2): "
          f"{np.nanmean(r[:, 1]) / np.nanmean(r[:, 0]):.2f}; mean |mass error| at 30 s noisy / quiet: "
          f"{np.mean(np.abs(r[:, 4])):.2f} / {np.mean(np.abs(r[:, 5])):.2f} %")
    return 0


if __name__ == "__main__":
    sys.exit(main())
