"""How far apart the slope-layer grade of ``fused`` or ``dffrls-aekf`` and its gyro witness's pitch come on
fault-free data: the margin under the witness's threshold (``gyro_witness_deg``, docs/robustness.md).

For each run: the largest |grade - gyro pitch| once the witness is armed (after the regression starts and the
settle time), and how many samples the witness held the regression for (0 on fault-free data, unless the threshold
is too tight). Runs: the generalisation protocol's random plant runs and the paper's plant scenarios
(``uuom_gym.sim.protocol_runs``, sensor faults none) and env episodes on held-out tracks driven by the rule-based
controller (``--env-episodes``). The point-mass world has no gyro: the witness is off there.

    python scripts/gyro_witness_margin.py --plant-runs 20 --env-episodes 10 [--estimator dffrls-aekf]
"""

from __future__ import annotations

import argparse
import math

import numpy as np

import estimators
import estimators.dffrls_aekf_kernel as kern


def _state(est) -> tuple[np.ndarray, np.ndarray]:
    """The kernel state and settings of ``fused``, or of the first member of ``dffrls-aekf``'s geometry bank (the
    members share the slope layer and the gyro, so their witnesses agree)."""
    if hasattr(est, "S"):
        return est.S, est.C
    return est._SS[0], est._CC[0]


def _armed_gap(est) -> float:
    S, C = _state(est)
    return abs(S[kern.TH] - S[kern.TH_G]) if S[kern.G_OK] >= C[kern.WIT_SETTLE] else 0.0


def trace_margin(tr, name: str) -> tuple[float, int]:
    """Largest armed gap (rad) and held samples of estimator ``name`` over one trace, sample by sample."""
    est = estimators.make(name)
    t = tr["t_s"]
    dts = np.diff(t, prepend=t[0] - (t[1] - t[0]))
    cols = [tr[k] for k in ("torque_nm", "speed_mps", "accel_mps2", "gyro_radps")]
    gap, held = 0.0, 0
    for i in range(len(t)):
        est.update(cols[0][i], cols[1][i], cols[2][i], dts[i], gyro_radps=cols[3][i])
        gap = max(gap, _armed_gap(est))
        held += _state(est)[0][kern.WIT_LEFT] > 0.0
    return gap, held


def env_margin(seed: int, name: str) -> tuple[float, int]:
    """The same over one env episode (the observer's block path), read after every policy step."""
    from agents.evaluation import Task, start_episode

    env, ctrl, obs, info = start_episode(Task("rule-based", name, seed))
    est = env.unwrapped.observer.estimator
    gap, held = 0.0, 0
    while True:
        obs, _, term, trunc, info = env.step(ctrl.act(obs, info))
        gap = max(gap, _armed_gap(est))
        held += _state(est)[0][kern.WIT_LEFT] > 0.0
        if term or trunc:
            break
    env.close()
    return gap, held


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--plant-runs", type=int, default=20, help="first N random plant runs of the protocol")
    ap.add_argument("--no-paper", action="store_true", help="leave out the paper's plant scenarios")
    ap.add_argument("--env-episodes", type=int, default=0, help="held-out env episodes (seeds 100000 on)")
    ap.add_argument("--estimator", default="fused", choices=("fused", "dffrls-aekf"))
    args = ap.parse_args(argv)
    from uuom_gym.sim.protocol_runs import make_run, protocol_runs

    specs = [r for r in protocol_runs() if r.world == "plant" and not r.fault and (
        (r.group == "plant" and r.index < args.plant_runs) or (r.group == "paper" and not args.no_paper))]
    rows = [(s.name, *trace_margin(make_run(s), args.estimator)) for s in specs]
    rows += [(f"env-{seed}", *env_margin(seed, args.estimator)) for seed in range(100000, 100000 + args.env_episodes)]
    thr = estimators.make(args.estimator).config.gyro_witness_deg
    print(f"`{args.estimator}`\n\n| run | largest armed gap (deg) | samples held |\n| --- | --- | --- |")
    for name, gap, held in rows:
        print(f"| {name} | {math.degrees(gap):.2f} | {held} |")
    gaps = np.degrees([g for _, g, _ in rows])
    print(f"\n{len(rows)} runs: largest gap {gaps.max():.2f} deg (median {np.median(gaps):.2f}), threshold {thr:g} deg; "
          f"runs with a hold: {sum(h > 0 for *_, h in rows)}")


if __name__ == "__main__":
    main()
