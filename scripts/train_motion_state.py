#!/usr/bin/env python
"""Train and evaluate the motion-state recogniser (paper 001 §2.3) on simulated runs; per-state accuracy table.

Trains a random forest on the training runs for each feature set, evaluates on held-out runs with and without
the temporal order constraint, prints a Markdown table (per-state recall, i.e. the paper's per-state accuracy)
and optionally saves the model, a JSON summary and a figure.

    python scripts/train_motion_state.py                      # default: 8 training + 4 test runs of 120 s
    python scripts/train_motion_state.py --plot docs/img/imu_motion_state.png --save model.pkl

Fixed seeds throughout; training takes a few seconds.
"""

from __future__ import annotations

import argparse
import json
import pickle
import sys
import time
from pathlib import Path

import numpy as np

import estimators
from estimators.imu.motion_state import (STATE_NAMES, MotionStateRecognizer, label_motion_states,
                                         per_state_accuracy)
from uuom_gym.sim.imu_runs import make_runs


def _pitch(tr) -> np.ndarray:
    return estimators.make("imu-ukf").run(tr).slope_rad


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--source", choices=("sim", "synthetic"), default="sim")
    ap.add_argument("--n-train", type=int, default=8)
    ap.add_argument("--n-test", type=int, default=4)
    ap.add_argument("--duration-s", type=float, default=120.0)
    ap.add_argument("--seed", type=int, default=0, help="first run seed (test runs follow the training runs)")
    ap.add_argument("--trees", type=int, default=40)
    ap.add_argument("--window", type=int, default=100, help="feature window (samples)")
    ap.add_argument("--hop", type=int, default=20, help="samples between classifications")
    ap.add_argument("--stay-prob", type=float, default=0.9, help="self-transition probability of the order")
    ap.add_argument("--save", type=Path, help="pickle the recogniser (paper+speed, monorail constraint) here")
    ap.add_argument("--json", type=Path, help="write the accuracy table as JSON here")
    ap.add_argument("--plot", type=Path, help="PNG: states and slope of the first test run")
    args = ap.parse_args(argv)
    if args.n_train < 1 or args.n_test < 1:
        ap.error("--n-train and --n-test must be >= 1")

    t0 = time.perf_counter()
    runs, used = make_runs(args.n_train + args.n_test, args.seed, args.duration_s, args.source)
    pitches = [_pitch(tr) for tr in runs]
    t_data = time.perf_counter() - t0
    train, test = runs[:args.n_train], runs[args.n_train:]
    p_train, p_test = pitches[:args.n_train], pitches[args.n_train:]
    truth = [label_motion_states(tr["true_speed_mps"], float(np.median(np.diff(tr["t_s"])))) for tr in test]
    y_true = np.concatenate(truth)
    mean_len_s = float(np.mean([tr["t_s"][-1] - tr["t_s"][0] for tr in runs]))
    print(f"source: {used}; {args.n_train} training + {args.n_test} test runs of {mean_len_s:.0f} s on average "
          f"(seeds {args.seed}..{args.seed + len(runs) - 1}); data + imu-ukf pitch in {t_data:.1f} s")
    share = np.bincount(y_true, minlength=4) / y_true.size
    print("test samples per state: " + ", ".join(f"{n} {s:.1%}" for n, s in zip(STATE_NAMES, share)))

    rows = []
    models = {}
    for fs in ("paper", "paper+speed"):
        for tc in ("none", "paper", "monorail"):
            t1 = time.perf_counter()
            rec = MotionStateRecognizer(feature_set=fs, transitions=tc, n_estimators=args.trees, seed=args.seed,
                                        window=args.window, hop=args.hop, stay_prob=args.stay_prob)
            rec.fit(train, p_train)
            t_fit = time.perf_counter() - t1
            pred = [rec.predict_trace(tr["accel_mps2"], tr["speed_mps"], p) for tr, p in zip(test, p_test)]
            acc = per_state_accuracy(y_true, np.concatenate(pred))
            rows.append({"features": fs, "constraint": tc, "fit_s": t_fit, **acc})
            models[(fs, tc)] = (rec, pred)

    print()
    print("| features | constraint | " + " | ".join(STATE_NAMES) + " | overall | fit (s) |")
    print("|---|---|" + "---|" * (len(STATE_NAMES) + 2))
    for r in rows:
        print(f"| {r['features']} | {r['constraint']} | "
              + " | ".join(f"{100 * r[n]:.1f} %" for n in STATE_NAMES)
              + f" | {100 * r['overall']:.1f} % | {r['fit_s']:.1f} |")

    rec, pred = models[("paper+speed", "monorail")]
    # online path == offline path (same windows); time it
    tr, p = test[0], p_test[0]
    rec.reset()
    t2 = time.perf_counter()
    online = np.array([rec.update(a, v, q) for a, v, q in zip(tr["accel_mps2"], tr["speed_mps"], p)])
    t_on = (time.perf_counter() - t2) / len(tr)
    print(f"\nonline update(): {1e6 * t_on:.1f} us/sample (paper+speed, monorail); "
          f"agrees with the offline pass on {100 * np.mean(online == pred[0]):.1f} % of samples")

    if args.save:
        with open(args.save, "wb") as fh:
            pickle.dump(rec, fh)
        print(f"saved {args.save}")
    if args.json:
        args.json.write_text(json.dumps({"source": used, "rows": rows, "online_us_per_sample": 1e6 * t_on},
                                        indent=2))
    if args.plot:
        _plot(args.plot, test[0], p_test[0], truth[0], models)
        print(f"wrote {args.plot}")
    return 0


def _plot(path: Path, tr, pitch, truth, models) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = tr["t_s"]
    fig, ax = plt.subplots(3, 1, figsize=(9, 7), sharex=True)
    ax[0].plot(t, tr["true_speed_mps"], "k", lw=1, label="true speed")
    ax[0].set_ylabel("speed (m/s)")
    ax[0].legend(loc="upper right")
    ax[1].plot(t, truth, "k", lw=2, label="truth")
    ax[1].plot(t, models[("paper", "paper")][1][0] + 0.08, lw=1, label="paper features, paper order")
    ax[1].plot(t, models[("paper+speed", "monorail")][1][0] - 0.08, lw=1, label="+speed features, monorail order")
    ax[1].set_yticks(range(4), STATE_NAMES)
    ax[1].legend(loc="upper right", fontsize=8)
    ax[2].plot(t, tr["slope_deg"], "k", lw=1.5, label="true slope")
    ax[2].plot(t, np.degrees(pitch), lw=1, label="imu-ukf")
    ax[2].set_ylabel("slope (deg)")
    ax[2].set_xlabel("time (s)")
    ax[2].legend(loc="upper right")
    fig.suptitle(f"IMU pipeline on a held-out run ({tr.source})", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    sys.exit(main())
