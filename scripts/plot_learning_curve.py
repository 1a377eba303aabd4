#!/usr/bin/env python
"""Learning curves of ``scripts/train.py`` runs from their TensorBoard logs (one PNG, one CSV, optional table).

Example::

    python scripts/plot_learning_curve.py /tmp/runs/ppo_defaults_s0 /tmp/runs/ppo_v0_s0 \\
        --labels "old defaults" "new defaults" --out results/rl/learning_curve.png

Reads ``<run>/tb/**/events.out.tfevents.*`` and plots, against environment steps: the training-episode success
rate and overspeed-trip rate (``uuom/``, running mean over the last 50 training episodes, see
:mod:`agents.callbacks`), the mean episode return (``rollout/ep_rew_mean``) and the simulated duration of the training episodes (``uuom/trip_time_s``: every ending, not only arrivals).
``--tags`` plots other TensorBoard scalars instead, one panel each (e.g. ``train/approx_kl train/std
train/clip_fraction`` for the size of PPO's updates; a KL panel is drawn on a log scale).
``--csv`` writes the same series as rows ``run,tag,step,value``; ``--print`` prints the last value of each tag;
``--median-from STEP`` prints, per run and tag, the median, 5-95 % range and largest value from that step on.
"""

from __future__ import annotations

import argparse
import csv
import sys
from pathlib import Path

TAGS: tuple[tuple[str, str], ...] = (
    ("uuom/success_rate", "success rate (last 50 training episodes)"),
    ("uuom/overspeed_trip_rate", "overspeed-trip rate (last 50 training episodes)"),
    ("rollout/ep_rew_mean", "episode return (raw, last 100)"),
    ("uuom/trip_time_s", "simulated episode duration (s)"),
)


def read_scalars(run_dir: Path) -> dict[str, tuple[list[int], list[float]]]:
    """All scalar series of a run's TensorBoard logs, ``tag -> (steps, values)`` sorted by step."""
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    files = sorted((run_dir / "tb").rglob("events.out.tfevents.*")) if (run_dir / "tb").exists() else []
    if not files:
        raise SystemExit(f"{run_dir}: no TensorBoard event files under {run_dir / 'tb'}")
    merged: dict[str, dict[int, float]] = {}
    segments = []
    for f in files:
        acc = EventAccumulator(str(f), size_guidance={"scalars": 0})
        acc.Reload()
        series = {tag: [(int(ev.step), float(ev.value)) for ev in acc.Scalars(tag)] for tag in acc.Tags().get("scalars", [])}
        first = min((pts[0][0] for pts in series.values() if pts), default=0)
        segments.append((first, series))
    # A resumed run (scripts/train.py restarts from the newest checkpoint) writes a new event file starting at the
    # checkpoint's step: the interrupted run's points from that step on are superseded.
    segments.sort(key=lambda seg: seg[0])
    for i, (first, series) in enumerate(segments):
        cut = segments[i + 1][0] if i + 1 < len(segments) else None
        for tag, pts in series.items():
            for step, val in pts:
                if cut is None or step < cut:
                    merged.setdefault(tag, {})[step] = val
    return {t: (sorted(d), [d[s] for s in sorted(d)]) for t, d in merged.items()}


def plot(runs: list[tuple[str, dict[str, tuple[list[int], list[float]]]]], path: Path, title: str,
         tags: tuple[tuple[str, str], ...] = TAGS) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(tags), figsize=(4.3 * len(tags), 3.8), squeeze=False)
    axes = axes[0]
    for ax, (tag, name) in zip(axes, tags):
        for label, series in runs:
            if tag in series:
                steps, vals = series[tag]
                ax.plot([s / 1e3 for s in steps], vals, lw=1.3, label=label)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel("env steps (thousands)")
        ax.grid(alpha=0.3)
        if "rate" in tag:
            ax.set_ylim(-0.03, 1.03)
        if "approx_kl" in tag:  # spans decades: 0.01 is a PPO update inside its trust region, 10 is far outside
            ax.set_yscale("log")
    handles, labels = axes[0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, loc="lower center", ncol=max(len(labels), 1), frameon=False)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", type=Path, help="run directories of scripts/train.py")
    ap.add_argument("--labels", nargs="+", default=None)
    ap.add_argument("--out", type=Path, default=None, help="PNG to write")
    ap.add_argument("--csv", type=Path, default=None, help="also write the series as CSV")
    ap.add_argument("--title", default="UUOM-Track-v0: bare PPO (no residual, no shield), observer dffrls-aekf")
    ap.add_argument("--print", action="store_true", dest="print_last", help="print the last value of each tag")
    ap.add_argument("--tags", nargs="+", default=None, metavar="TAG",
                    help="TensorBoard scalar tags to plot instead of the default four (e.g. train/approx_kl train/std)")
    ap.add_argument("--median-from", type=int, default=None, metavar="STEP",
                    help="print each tag's median, 5-95 %% range and largest value over the points at or after STEP")
    args = ap.parse_args(argv)
    names = dict(TAGS)
    tags = tuple((t, names.get(t, t)) for t in args.tags) if args.tags else TAGS
    labels = args.labels or [r.name for r in args.runs]
    if len(labels) != len(args.runs):
        raise SystemExit(f"--labels needs {len(args.runs)} labels, got {len(labels)}")
    runs = [(lab, read_scalars(r)) for lab, r in zip(labels, args.runs)]
    for tag in args.tags or ():  # the default panels skip what a run does not log; a named tag must exist
        if not any(tag in series for _, series in runs):
            known = sorted({t for _, series in runs for t in series})
            raise SystemExit(f"--tags: no run logs {tag!r}; the runs log {', '.join(known)}")
    if args.print_last:
        for lab, series in runs:
            last = {t: series[t][1][-1] for t, _ in tags if t in series}
            steps = max((s[0][-1] for s in series.values() if s[0]), default=0)
            print(f"{lab} @ {steps} steps: " + ", ".join(f"{t}={v:.3g}" for t, v in last.items()))
    if args.median_from is not None:
        import numpy as np

        for lab, series in runs:
            for tag, _ in tags:
                vals = [v for st, v in zip(*series[tag]) if st >= args.median_from] if tag in series else []
                if vals:
                    p5, med, p95 = np.percentile(vals, [5, 50, 95])
                    print(f"{lab} {tag} from {args.median_from}: median {med:.3g} (5-95 % {p5:.3g}-{p95:.3g}), "
                          f"max {max(vals):.3g}, {len(vals)} points")
    if args.csv:
        args.csv.parent.mkdir(parents=True, exist_ok=True)
        with args.csv.open("w", newline="") as fh:
            w = csv.writer(fh)
            w.writerow(["run", "tag", "step", "value"])
            for lab, series in runs:
                for tag, _ in tags:
                    if tag in series:
                        for s, v in zip(*series[tag]):
                            w.writerow([lab, tag, s, f"{v:.6g}"])
    if args.out:
        plot(runs, args.out, args.title, tags)
        print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
