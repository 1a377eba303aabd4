"""Figures of :func:`agents.evaluation.evaluate`: grouped bars per observer, trip time vs trip rate with 95 %
intervals, speed vs limit along an episode."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from agents.evaluation_table import DEFAULT_OBSERVERS


def plot_bars(summary: list[dict[str, Any]], path: Path) -> None:
    """Grouped bars per observer: success rate, cost rate, trip time relative to the oracle."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    observers = [o for o in DEFAULT_OBSERVERS if any(r["observer"] == o for r in summary)]
    observers += sorted({r["observer"] for r in summary} - set(observers))
    ctrls = [c for c in dict.fromkeys(r["controller"] for r in summary) if c != "oracle"]
    metrics = [
        ("success_rate", "success rate"),
        ("overspeed_trip_rate", "overspeed trips (fraction of runs)"),
        ("cost_rate", "cost rate (per step)"),
        ("trip_time_vs_oracle", "trip time / oracle"),
    ]
    fig, axes = plt.subplots(1, len(metrics), figsize=(4.2 * len(metrics), 4.2))
    width = 0.8 / max(len(ctrls), 1)
    x = np.arange(len(observers))
    for ax, (key, title) in zip(axes, metrics):
        for i, c in enumerate(ctrls):
            vals = []
            for o in observers:
                m = [r for r in summary if r["controller"] == c and r["observer"] == o]
                if not m:
                    vals.append(np.nan)
                elif key == "overspeed_trip_rate":
                    vals.append(m[0]["overspeed_trips"] / max(m[0]["episodes"], 1))
                else:
                    vals.append(m[0][key])
            ax.bar(x + (i - (len(ctrls) - 1) / 2) * width, vals, width, label=c)
        if key == "trip_time_vs_oracle":
            ax.axhline(1.0, color="k", lw=0.8, ls="--")
            ax.axhline(1.25, color="r", lw=0.8, ls=":", label="target 1.25")
        ax.set_xticks(x, observers, rotation=35, ha="right", fontsize=8)
        ax.set_title(title, fontsize=10)
        ax.grid(axis="y", alpha=0.3)
    handles, labels = axes[-1].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=8, loc="lower center", ncol=len(labels), frameon=False)
    fig.suptitle("UUOM-Track-v0: controllers x observers on the same held-out tracks", fontsize=11)
    fig.tight_layout(rect=(0, 0.07, 1, 1))
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_tradeoff(summary: list[dict[str, Any]], path: Path) -> None:
    """One point per controller x observer: overspeed-trip rate (x) against trip time / oracle (IQM, y), with
    their 95 % intervals. Down and left is better: the figure to read in ten seconds."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [r for r in summary if r["controller"] != "oracle" and np.isfinite(r.get("trip_time_iqm", np.nan))]
    if not rows:
        return
    ctrls = list(dict.fromkeys(r["controller"] for r in rows))
    fig, ax = plt.subplots(figsize=(8, 5))
    for i, ctrl in enumerate(ctrls):
        rs = [r for r in rows if r["controller"] == ctrl]
        x = np.array([100 * r["overspeed_trips"] / r["episodes"] for r in rs])
        y = np.array([r["trip_time_iqm"] for r in rs])
        xerr = np.array([[x[k] - 100 * r["trip_rate_lo"], 100 * r["trip_rate_hi"] - x[k]] for k, r in enumerate(rs)]).T
        yerr = np.array([[y[k] - r["trip_time_iqm_lo"], r["trip_time_iqm_hi"] - y[k]] for k, r in enumerate(rs)]).T
        ax.errorbar(x, y, xerr=xerr, yerr=yerr, fmt="o", color=f"C{i}", capsize=3, label=ctrl)
        for xk, yk, r in zip(x, y, rs):
            ax.annotate(r["observer"], (xk, yk), textcoords="offset points", xytext=(5, 4), fontsize=8)
    ax.set_xlabel("overspeed trips (% of episodes, 95 % interval)")
    ax.set_ylabel("trip time / oracle (IQM, 95 % bootstrap interval)")
    ax.set_title("Estimator and safety: lower left is better")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_episode(rows: list[dict[str, Any]], path: Path) -> None:
    """Speed vs the true and the estimated speed limit along one episode, one panel per recorded run."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rec = [r for r in rows if "trace" in r]
    if not rec:
        return
    fig, axes = plt.subplots(len(rec), 1, figsize=(9, 2.6 * len(rec)), sharex=True, squeeze=False)
    for ax, r in zip(axes[:, 0], rec):
        tr = r["trace"]
        s = np.asarray(tr["position_m"])
        ax.plot(s, tr["true_limit_mps"], color="k", lw=1.2, label="true limit v_lim(M, slope)")
        ax.plot(s, tr["est_limit_mps"], color="tab:orange", lw=1.0, ls="--", label="limit from the estimates")
        ax.plot(s, tr["speed_mps"], color="tab:blue", lw=1.2, label="speed")
        ax.set_ylabel("m/s")
        ax.set_ylim(0, max(2.1, float(np.max(tr["speed_mps"])) + 0.1))
        ax.set_title(
            f"{r['controller']} / observer {r['observer']} - seed {r['seed']}: {r['termination']}, "
            f"{r['trip_time_s']:.0f} s, cost {r['cost']:.3g}",
            fontsize=9,
        )
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7, loc="upper right")
    axes[-1, 0].set_xlabel("position along the track (m)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


__all__ = ["plot_bars", "plot_episode"]
