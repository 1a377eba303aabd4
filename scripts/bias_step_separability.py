"""Can a step of accelerometer bias be told from a grade change by the signals alone? (docs/robustness.md, negative)

Usage::

    python scripts/bias_step_separability.py [--plant 60] [--point 100] [--swing-model | --swing-truth]

``fused`` and ``sf-kf`` do not recover from the fault test's 3 s accelerometer bias (+0.5 m/s², torque +10 %): to the
slope layer a bias step is a grade step. Two signals could tell them apart without a second slope sensor:

- **rate**: the specific force minus the encoder's acceleration, ``g_k = mean(f) - dv/dt`` over 0.5 s blocks (the
  slope under the sensors, times g), changes faster across a bias step than a grade can change along the track
  (the plant's vertical curves have radius >= 60 m);
- **force balance**: ``r_k = F / (M + m_rot) - mean(f)`` with the *true* mass (the best an estimator could do) moves
  by ``-b`` across a bias step and, for a point mass, not at all across a grade change.

A step of ``b`` gives ``d = g_k - g_{k-2} = +b`` and ``e = r_k - r_{k-2} = -b``; the joint statistic is
``min(|d|, |e|)`` where their signs are opposite (else 0). The script prints its value across the fault test's bias
(:func:`estimators.fault_injection.seven_channel_rows`, seeds 0-7) and its maximum over clean protocol runs
(:func:`uuom_gym.sim.protocol_runs.protocol_runs`, the first ``--plant`` plant and ``--point`` point-mass runs,
blocks from 10 s on). A detector needs a threshold between the two. ``--swing-model`` takes the load's swing out with the estimators'
pendulum (the vehicle file's chain, driven by the encoder); ``--swing-truth`` takes the load's swing out of
the point-mass force balance with the truth (the load's acceleration relative to its pivot along the track): a perfect swing model.
"""

from __future__ import annotations

import argparse

import numpy as np

from estimators import dffrls_aekf_kernel as kern
from estimators.dffrls_aekf import DFFRLSAEKFConfig
from estimators.fault_injection import inject, seven_channel_rows
from uuom_core.vehicle import DEFAULT_VEHICLE as VEH
from uuom_gym.sim.protocol_runs import make_run, protocol_runs

BLOCK_S = 0.5


def block_steps(t: np.ndarray, f: np.ndarray, v: np.ndarray, force_n: np.ndarray, mass_kg: float
                ) -> tuple[np.ndarray, np.ndarray]:
    """``d`` and ``e`` (module docstring) of every block against the block two before it."""
    nb = int(round(BLOCK_S / float(np.median(np.diff(t)))))
    g, r = [], []
    for k in range(len(t) // nb):
        sl = slice(k * nb, (k + 1) * nb)
        ok = np.isfinite(f[sl]) & np.isfinite(v[sl]) & np.isfinite(force_n[sl])
        if ok.sum() < 0.8 * nb:  # a dropout: no statistic for this block
            g.append(np.nan)
            r.append(np.nan)
            continue
        tt = t[sl][ok]
        # least-squares slope of the speed: centred on the block like the mean of f (a difference of the end
        # speeds is too noisy, a difference of block means lags by half a block)
        dvdt = np.polyfit(tt - tt.mean(), v[sl][ok], 1)[0]
        fm = float(f[sl][ok].mean())
        g.append(fm - dvdt)
        r.append(float(force_n[sl][ok].mean()) / (mass_kg + VEH.rotating_mass_kg) - fm)
    ga, ra = np.array(g), np.array(r)
    return ga[2:] - ga[:-2], ra[2:] - ra[:-2]


def _hanging_mass_kg(mass_kg: float) -> float:
    """The hook block and load, which hang on the chains: the train's mass less the rigid body's."""
    return max(mass_kg - (VEH.empty_mass_kg - VEH.hook_mass_kg), 0.0)


def _modelled_load_force(t: np.ndarray, v: np.ndarray, mass_kg: float) -> np.ndarray:
    """The load's inertial pull beyond a rigid load's, ``m_load (a_load - a)``, from the single pendulum of the
    ``dffrls-aekf`` kernel (the vehicle file's chain, the default damping): its own low-pass and integrator
    (:func:`estimators.dffrls_aekf_kernel._lp`, ``_swing``), forced by the encoder as in its force balance."""
    C = DFFRLSAEKFConfig().settings(VEH)
    S = np.zeros(kern.N_S)
    S[kern.PREV_VQ] = np.nan
    m_load = _hanging_mass_kg(mass_kg)
    out = np.zeros(len(t))
    for i in range(1, len(t)):
        dt = float(t[i] - t[i - 1])
        if not dt > 0.0:
            continue
        vq = kern._lp(S, kern.LQ1, float(v[i]), 1.0 - np.exp(-2.0 * np.pi * C[kern.FAST_HZ] * dt))
        pq = S[kern.PREV_VQ]
        S[kern.PREV_VQ] = vq
        a_fast = (vq - pq) / dt if pq == pq else 0.0
        a_load = kern._swing(S, kern.SWAY, C[kern.CHAIN_L], C[kern.SWAY_DAMP], C[kern.SWAY_H], a_fast, dt)
        out[i] = m_load * (a_load - a_fast)
    return out


def joint(d: np.ndarray, e: np.ndarray) -> np.ndarray:
    """``min(|d|, |e|)`` where ``d`` and ``e`` have opposite signs (a bias step's signature), else 0."""
    with np.errstate(invalid="ignore"):
        return np.where(np.sign(d) == -np.sign(e), np.minimum(np.abs(d), np.abs(e)), 0.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--plant", type=int, default=60, help="clean plant runs (protocol order)")
    ap.add_argument("--point", type=int, default=100, help="clean point-mass runs (protocol order)")
    swing = ap.add_mutually_exclusive_group()
    swing.add_argument("--swing-truth", action="store_true", help="point mass: remove the load's swing with the truth")
    swing.add_argument("--swing-model", action="store_true",
                       help="remove the load's swing with the estimators' pendulum (vehicle file's chain, forced by the encoder)")
    a = ap.parse_args()
    radius = VEH.drive_wheel_radius_m
    fault = []
    for seed in range(8):
        rows = seven_channel_rows(seed=seed)
        t = np.cumsum(rows[:, 3])
        bad = inject(rows, "bias", 2000, 2600)  # 10-13 s, as the test
        fault.append(np.nanmax(joint(*block_steps(t, bad[:, 2], bad[:, 1], bad[:, 0] / radius, 26_000.0))))
    print(f"fault test's bias, seeds 0-7: joint statistic across the step {min(fault):.3f}-{max(fault):.3f} m/s^2")
    runs = protocol_runs(n_plant=a.plant, n_point=a.point)
    for group in ("plant", "point"):
        worst = []
        for spec in (s for s in runs if s.group == group):
            tr = make_run(spec)
            t = np.asarray(tr["t_s"])
            mass = float(np.asarray(tr["mass_kg"])[0])
            force = np.asarray(tr["torque_nm"]) / radius
            if a.swing_model:
                force = force - _modelled_load_force(t, np.asarray(tr["speed_mps"]), mass)
            elif group == "point" and a.swing_truth:
                m_load = _hanging_mass_kg(mass)
                chain = float(tr.meta.get("chain_m", VEH.chain_length_m))
                th = np.radians(np.asarray(tr["slope_deg"]))
                phi = np.asarray(tr["sway_rad"]) + th  # the chain's angle from the vertical
                # the load's acceleration relative to the pivot, projected on the track's (rotating) direction
                ax = chain * np.gradient(np.gradient(np.sin(phi), t), t)
                az = -chain * np.gradient(np.gradient(np.cos(phi), t), t)
                force = force - m_load * (ax * np.cos(th) + az * np.sin(th))
            d, e = block_steps(t, np.asarray(tr["accel_mps2"]), np.asarray(tr["speed_mps"]), force, mass)
            skip = int(round(10.0 / BLOCK_S)) - 2  # from 10 s on, as the protocol scores
            worst.append(float(np.nanmax(joint(d[skip:], e[skip:]))))
        if not worst:
            continue
        q = np.percentile(worst, [50, 90, 99, 100])
        above = sum(w >= min(fault) for w in worst)
        print(f"clean {group} runs ({len(worst)}): max joint statistic per run, median {q[0]:.3f}, p90 {q[1]:.3f}, "
              f"p99 {q[2]:.3f}, max {q[3]:.3f} m/s^2; {above} runs at or above the fault's smallest")


if __name__ == "__main__":
    main()
