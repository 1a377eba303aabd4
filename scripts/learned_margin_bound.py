"""Could a learned margin drive faster than ``M_hat + k sigma`` at the same safety? A supervised upper bound.

The rule-based controller plans with a pessimistic mass ``M_hat + 2 sigma`` (plus a 15 s memory and an 8 s warm-up),
and the README's sensitivity study says that mass decides the speed limit (told 5 % light the controller already
drives over the limit; every +3 % of planning mass costs about +5 % of trip time). A learned controller (RL, a
residual, a margin schedule) can only be faster at equal safety if it plans with a mass that is *closer to the truth
as often* as the rule-based one: this script asks whether the information a policy sees allows that, with the best
supervision there is — the true mass as label, not RL's sparse cost.

It drives the default rule-based controller on training tracks (seeds 0…; the held-out tracks 100000… are not
touched), records at every policy step what a policy may observe (the estimates and their σ, the estimator's μ,
its σ and NIS, speed, position, the model-free grade's disagreement, the estimate's recent history) and the true
mass, fits gradient-boosted quantile regressions of ``log(M_true / M_hat)`` on the first tracks (scikit-learn,
fixed settings, not tuned) and scores them on the rest. Scored per step after the warm-up (t ≥ 8 s): how often the
planning mass is below the truth (*uncovered*), how often a whole track has a step more than 1 % light, and how
pessimistic the planning mass is (``planning / true − 1``: median, p10). Compared at equal uncovered fraction with
``M_hat + k sigma`` over a grid of ``k``.

    python scripts/learned_margin_bound.py --train 400 --validate 100 --workers 2 --out results/rl/learned_margin

Writes ``summary.md`` and ``tradeoff.png`` to ``--out``; the per-step rows are cached in ``--cache`` (not committed).
``--drive N`` then checks the proxy on the metric: the rule-based controller planning with one learned quantile (in
place of ``M_hat + 2 sigma`` and the memory) against the default on the first N held-out tracks, paired per track.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

COLUMNS = ("seed", "t_s", "mass_kg", "mass_std_kg", "true_mass_kg", "planning_mass_kg", "speed_mps", "slope_rad",
           "slope_std_rad", "position_m", "grade_gap_rad", "mu", "mu_std", "nis")
WARMUP_S = 8.0
LIGHT_TOLERANCE = 0.01
LAG_STEPS, RANGE_STEPS = 50, 150
"""The estimate's change over 5 s and its range over 15 s, in 10 Hz policy steps."""
K_GRID = np.round(np.arange(0.0, 4.01, 0.05), 2)
TABLE_KS = (1.0, 1.5, 2.0, 2.5, 3.0)


def observed_row(info: Any, x: Any, gap_from: float | None, seed: float = 0.0, true_mass_kg: float = np.nan,
                 planning_mass_kg: float = np.nan) -> tuple[float, ...]:
    """One step's row (``COLUMNS``) from the step's ``info``, the controller's input ``x`` and its model-free grade:
    the same row in training (with the truth) and online (without), so that the features match."""
    extras = info.get("est_extras") or {}
    return (seed, float(info["t_s"]), x.est_mass_kg, x.est_mass_std_kg, true_mass_kg, planning_mass_kg, x.speed_mps,
            x.est_slope_rad, x.est_slope_std_rad, x.position_m,
            0.0 if gap_from is None else gap_from - x.est_slope_rad, extras.get("mu", np.nan),
            extras.get("mu_std", np.nan), extras.get("nis", np.nan))


def episode(job: tuple[int, str]) -> np.ndarray:
    """One track with the default rule-based controller; one row per policy step (``COLUMNS``)."""
    import gymnasium as gym

    import uuom_gym  # noqa: F401 - registers the env
    from agents.control_input import control_input_from_obs
    from agents.controllers.rule_based import RuleBasedController

    seed, observer = job
    env = gym.make("UUOM-Track-v0", observer=observer)
    ctrl = RuleBasedController(env.unwrapped.vehicle)
    obs, info = env.reset(seed=seed)
    ctrl.reset(env, info)
    rows = []
    while True:
        x = control_input_from_obs(obs, ctrl.vehicle, ctrl.track_length_m, ctrl.dt_s)
        cmd = ctrl.command(x)
        planning_mass, _ = ctrl.pessimistic(x)
        rows.append(observed_row(info, x, ctrl.model_free_slope_rad, seed, info["true_mass_kg"], planning_mass))
        obs, _, term, trunc, info = env.step(np.array([cmd], dtype=np.float32))
        if term or trunc:
            break
    env.close()
    return np.asarray(rows, dtype=float)


def collect(seeds: range, observer: str, workers: int, cache: Path | None) -> tuple[dict[str, np.ndarray], bool]:
    """The per-step rows of ``seeds``, and whether they came from ``cache`` (used if it holds exactly these)."""
    if cache is not None and cache.exists():
        z = np.load(cache)
        if str(z["observer"]) == observer and np.array_equal(z["seeds"], np.asarray(seeds)):
            return {c: z[c] for c in COLUMNS}, True
    jobs = [(s, observer) for s in seeds]
    if workers > 1:
        with multiprocessing.get_context("spawn").Pool(workers) as pool:
            parts = pool.map(episode, jobs, chunksize=4)
    else:
        parts = [episode(j) for j in jobs]
    data = np.concatenate(parts)
    cols = {c: data[:, i] for i, c in enumerate(COLUMNS)}
    if cache is not None:
        cache.parent.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(cache, observer=observer, seeds=np.asarray(seeds), **cols)
    return cols, False


def _lagged(seed: np.ndarray, values: np.ndarray, steps: int, how: str) -> np.ndarray:
    """Per track: the value ``steps`` back (``how='lag'``) or the max / min over the last ``steps`` (causal)."""
    out = np.empty_like(values)
    for s in np.unique(seed):
        idx = np.flatnonzero(seed == s)
        v = values[idx]
        padded = np.concatenate([np.full(steps, v[0]), v])  # before the start: the first value
        if how == "lag":
            out[idx] = padded[: len(v)]
        else:
            win = np.lib.stride_tricks.sliding_window_view(padded, steps + 1)
            out[idx] = win.max(axis=1) if how == "max" else win.min(axis=1)
    return out


def features(d: dict[str, np.ndarray]) -> np.ndarray:
    """What a policy may observe at a step (10 Hz steps: 50 = 5 s, 150 = 15 s)."""
    m = d["mass_kg"]
    with np.errstate(divide="ignore", invalid="ignore"):
        x = _columns(d, m)
    return np.where(np.isfinite(x), x, np.nan)  # a zero σ (the oracle) or no μ: missing, which the trees handle


def _columns(d: dict[str, np.ndarray], m: np.ndarray) -> np.ndarray:
    return np.column_stack([
        np.minimum(d["t_s"], 300.0), np.log(d["mass_std_kg"] / m), m / 1000.0, d["slope_rad"], d["slope_std_rad"],
        d["speed_mps"], d["position_m"], d["grade_gap_rad"], d["mu"], np.log(d["mu_std"]), np.log(d["nis"] + 1e-9),
        np.log(m / _lagged(d["seed"], m, LAG_STEPS, "lag")), np.log(_lagged(d["seed"], m, RANGE_STEPS, "max") / m),
        np.log(m / _lagged(d["seed"], m, RANGE_STEPS, "min")),
    ])


def history_features(d: dict[str, np.ndarray]) -> np.ndarray:
    """What the whole track so far says (``--history``): the estimate against its running mean and spread, the
    excitation (summed speed changes, seconds and number of accelerations above 0.05 m/s²), the change since 10 s."""
    out = np.full((d["mass_kg"].size, 6), np.nan)
    for s in np.unique(d["seed"]):
        idx = np.flatnonzero(d["seed"] == s)
        m, v = d["mass_kg"][idx], d["speed_mps"][idx]
        n = np.arange(1, idx.size + 1)
        mean = np.cumsum(m) / n
        spread = np.sqrt(np.maximum(np.cumsum(m * m) / n - mean * mean, 0.0)) / mean
        dv = np.abs(np.diff(v, prepend=v[0]))
        accelerating = (dv > 0.005).astype(float)  # 0.05 m/s² over a 0.1 s step
        starts = np.cumsum(np.diff(accelerating, prepend=0.0) > 0)
        since_10s = np.where(n > 100, np.log(m / m[min(100, idx.size - 1)]), np.nan)
        out[idx] = np.column_stack([np.log(m / mean), spread, np.cumsum(dv), 0.1 * np.cumsum(accelerating), starts,
                                    since_10s])
    return out


def _learned_margin_controller(vehicle: Any, model: Any, history: bool) -> Any:
    """The rule-based controller planning with ``M_hat * exp(q(features))`` (the learned quantile) instead of
    ``M_hat + k sigma`` and its 15 s memory; warm-up, margins, cross-check and tracking unchanged. The features are
    computed by :func:`features` on the track's steps so far, exactly as in training."""
    from agents.controllers.rule_based import RuleBasedController
    from uuom_core.units import clamp

    class LearnedMarginController(RuleBasedController):
        name = "rule-based, learned mass margin"

        def reset(self, env: Any = None, info: Any = None) -> None:
            super().reset(env, info)
            self._steps: list[tuple[float, ...]] = []
            self._info: Any = info or {}
            self._planned: float | None = None

        def act(self, obs: Any, info: Any) -> np.ndarray:
            self._info, self._planned = info, None
            return super().act(obs, info)

        def _pessimistic_mass_now(self, x: Any) -> float:
            if self._planned is None:  # once per step: called again by pessimistic()
                self._steps.append(observed_row(self._info, x, self.model_free_slope_rad))
                steps = np.asarray(self._steps, dtype=float)
                # the 5 s lag and 15 s range need only the last 151 steps (a full history would make a track O(n²))
                recent = {c: v for c, v in zip(COLUMNS, steps[-(RANGE_STEPS + 1):].T)}
                feats = features(recent)[-1:]
                if history:
                    whole = {c: v for c, v in zip(COLUMNS, steps.T)}
                    feats = np.column_stack([feats, history_features(whole)[-1:]])
                q = float(model.predict(feats)[0])
                v = self.vehicle
                self._planned = clamp(x.est_mass_kg * math.exp(q), v.empty_mass_kg, v.max_mass_kg)
            return self._planned

    return LearnedMarginController(vehicle, memory_s=0.0)


def drive(job: tuple[int, str, Any, bool]) -> dict[str, Any]:
    """One held-out track: the default rule-based controller (``model`` None) or the learned-margin one."""
    import gymnasium as gym
    from threadpoolctl import threadpool_limits

    import uuom_gym  # noqa: F401 - registers the env
    from agents.controllers.rule_based import RuleBasedController
    from agents.metrics import drive_episode

    seed, observer, model, history = job
    threadpool_limits(1)  # one-row predictions: OpenMP threads only add overhead, and the workers share the cores
    env = gym.make("UUOM-Track-v0", observer=observer)
    vehicle = env.unwrapped.vehicle
    ctrl = RuleBasedController(vehicle) if model is None else _learned_margin_controller(vehicle, model, history)
    summary, _ = drive_episode(env, ctrl, seed)
    env.close()
    return summary.flat() | {"seed": seed, "learned": model is not None}


def paired_lines(rows: list[dict[str, Any]]) -> list[str]:
    """Markdown rows: each controller's trips, cost rate, speed-violating tracks; the paired trip-time ratio."""
    from agents.statistics import bootstrap_ci

    out = []
    by = {flag: {r["seed"]: r for r in rows if r["learned"] is flag} for flag in (False, True)}
    seeds = sorted(set(by[False]) & set(by[True]))
    both = [s for s in seeds if by[False][s]["success"] and by[True][s]["success"]]
    ratio = np.array([by[True][s]["trip_time_s"] / by[False][s]["trip_time_s"] for s in both])
    lo, hi = bootstrap_ci(ratio, np.mean) if ratio.size else (np.nan, np.nan)
    for flag, name in ((False, "rule-based default (2σ, 15 s memory)"), (True, "rule-based, learned mass margin")):
        rs = [by[flag][s] for s in seeds]
        rate = sum(r["cost"] for r in rs) / max(sum(r["steps"] for r in rs), 1)
        viol = sum(r["violations/speed_limit"] > 0 for r in rs)
        paired = "1" if not flag else (f"{ratio.mean():.3f} ({lo:.3f}–{hi:.3f}), faster on {int((ratio < 1).sum())}"
                                       if ratio.size else "–")
        out.append(f"| {name} | {sum(r['success'] for r in rs)}/{len(rs)} | {sum(r['overspeed_trip'] for r in rs)} | "
                   f"{rate:.2e} | {viol} | {paired} |")
    return out


def score(planning: np.ndarray, truth: np.ndarray, seed: np.ndarray) -> dict[str, float]:
    """Uncovered steps, tracks with a step > 1 % light, and the planning mass's pessimism (median, p10)."""
    r = planning / truth
    light = [np.any(r[seed == s] < 1.0 - LIGHT_TOLERANCE) for s in np.unique(seed)]
    return {"uncovered": float(np.mean(r < 1.0)), "tracks_light": float(np.mean(light)),
            "median": float(np.median(r) - 1.0), "p10": float(np.percentile(r, 10) - 1.0)}


def fit_quantile(x: np.ndarray, y: np.ndarray, q: float) -> Any:
    """Gradient-boosted quantile regression, fixed settings (every 3rd step: 10 Hz steps are strongly correlated)."""
    from sklearn.ensemble import HistGradientBoostingRegressor

    model = HistGradientBoostingRegressor(loss="quantile", quantile=q, max_iter=300, learning_rate=0.1,
                                          max_leaf_nodes=31, random_state=0)
    return model.fit(x[::3], y[::3])


def k_sigma_at(uncovered: float, curve: list[tuple[float, dict[str, float]]]) -> tuple[float, float]:
    """``(k, median pessimism)`` of ``M_hat + k sigma`` at the given uncovered fraction (linear in k)."""
    us = np.array([s["uncovered"] for _, s in curve])
    ks = np.array([k for k, _ in curve])
    meds = np.array([s["median"] for _, s in curve])
    order = np.argsort(us)
    k = float(np.interp(uncovered, us[order], ks[order]))
    return k, float(np.interp(k, ks, meds))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--train", type=int, default=400, help="training tracks: seeds 0..train-1")
    ap.add_argument("--validate", type=int, default=100, help="validation tracks: the next seeds")
    ap.add_argument("--observer", default="dffrls-aekf")
    ap.add_argument("--quantiles", type=float, nargs="+", default=[0.95, 0.98, 0.99, 0.995, 0.998])
    ap.add_argument("--sizes", type=int, nargs="*", default=[100, 200],
                    help="also fit on the first N training tracks only (does more data help?)")
    ap.add_argument("--history", action="store_true",
                    help="also give the learner six features of the whole track so far (history_features)")
    ap.add_argument("--drive", type=int, default=0, metavar="N",
                    help="also drive the first N held-out tracks (seeds 100000…) with the rule-based controller "
                         "planning with the learned quantile --drive-quantile (full training set), paired against "
                         "the default")
    ap.add_argument("--drive-quantile", type=float, default=0.998)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--cache", type=Path, default=Path("runs/learned_margin/steps.npz"))
    ap.add_argument("--out", type=Path, default=Path("results/rl/learned_margin"))
    args = ap.parse_args(argv)
    if args.train < 1 or args.validate < 1:
        ap.error("--train and --validate must be >= 1")
    if any(not 0.0 < q < 1.0 for q in args.quantiles):
        ap.error("--quantiles must lie in (0, 1)")
    if args.drive and args.drive_quantile not in args.quantiles:
        ap.error("--drive-quantile must be one of --quantiles")

    t0 = time.perf_counter()
    d, cached = collect(range(args.train + args.validate), args.observer, args.workers, args.cache)
    source = f"read from {args.cache}" if cached else "driven"
    print(f"{source} in {time.perf_counter() - t0:.0f} s", file=sys.stderr)
    x, y = features(d), np.log(d["true_mass_kg"] / d["mass_kg"])
    if args.history:
        x = np.column_stack([x, history_features(d)])
    seed, m, s, truth = d["seed"], d["mass_kg"], d["mass_std_kg"], d["true_mass_kg"]
    after = d["t_s"] >= WARMUP_S
    va = after & (seed >= args.train)
    n_train = int(np.unique(seed[after & (seed < args.train)]).size)

    def val(planning: np.ndarray) -> dict[str, float]:
        return score(planning[va], truth[va], seed[va])

    curve = [(float(k), val(m + k * s)) for k in K_GRID]
    rows: list[tuple[str, dict[str, float], str]] = [("rule-based default (2σ, 15 s memory, 8 s warm-up)",
                                                       val(d["planning_mass_kg"]), "")]
    rows += [(f"M̂ + {k:g} σ", val(m + k * s), "") for k in TABLE_KS]
    learned: list[tuple[int, float, dict[str, float]]] = []
    drive_model = None
    for n in sorted({*[n for n in args.sizes if n < args.train], args.train}):
        tr = after & (seed < n)
        for q in args.quantiles:
            model = fit_quantile(x[tr], y[tr], q)
            if n == args.train and q == args.drive_quantile:
                drive_model = model
            sc = val(np.exp(model.predict(x)) * m)
            learned.append((n, q, sc))
            k, med = k_sigma_at(sc["uncovered"], curve)
            rows.append((f"learned q{q:g}, {n} training tracks", sc, f"k = {k:.2f}: {100 * med:+.1f} %"))

    args.out.mkdir(parents=True, exist_ok=True)
    cmd = "python scripts/learned_margin_bound.py " + " ".join(argv if argv is not None else sys.argv[1:])
    lines = [f"Command: `{cmd.strip()}`", "",
             f"Observer `{args.observer}`; {n_train} training tracks (seeds 0–{args.train - 1}), {args.validate} "
             f"validation tracks (seeds {args.train}–{args.train + args.validate - 1}); {int(va.sum())} validation "
             f"steps after t ≥ {WARMUP_S:g} s; {x.shape[1]} features"
             f"{' (with the track history)' if args.history else ''}.", "",
             "| planning mass | uncovered steps (truth heavier) | tracks with a step > 1 % light | pessimism: median | "
             "p10 | M̂ + kσ at the same uncovered fraction: pessimism |",
             "| --- | --- | --- | --- | --- | --- |"]
    for name, sc, cmp_ in rows:
        lines.append(f"| {name} | {100 * sc['uncovered']:.2f} % | {100 * sc['tracks_light']:.0f} % | "
                     f"{100 * sc['median']:+.1f} % | {100 * sc['p10']:+.1f} % | {cmp_ or '–'} |")
    if args.drive:
        jobs = [(100_000 + i, args.observer, mdl, args.history) for i in range(args.drive)
                for mdl in (None, drive_model)]
        with multiprocessing.get_context("spawn").Pool(max(args.workers, 1)) as pool:
            driven = pool.map(drive, jobs, chunksize=1)
        lines += ["", f"Driven on held-out tracks 100000–{100_000 + args.drive - 1} (quantile "
                      f"{args.drive_quantile:g}, {args.train} training tracks; memory off, warm-up kept):", "",
                  "| controller | arrived | overspeed trips | cost rate | tracks with a speed-limit violation | "
                  "trip time / default, paired mean (95 % CI) |", "| --- | --- | --- | --- | --- | --- |"]
        lines += paired_lines(driven)
    (args.out / "summary.md").write_text("\n".join(lines) + "\n")
    _plot(curve, learned, rows[0][1], args.out / "tradeoff.png")
    print("\n".join(lines))
    return 0


def _plot(curve: list[tuple[float, dict[str, float]]], learned: list[tuple[int, float, dict[str, float]]],
          default: dict[str, float], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    ks = [(k, sc) for k, sc in curve if sc["uncovered"] > 0]
    ax.plot([100 * sc["uncovered"] for _, sc in ks], [100 * sc["median"] for _, sc in ks], "k-", label="M̂ + k σ")
    for k, sc in ks:
        if k in TABLE_KS:
            ax.annotate(f"k={k:g}", (100 * sc["uncovered"], 100 * sc["median"]), fontsize=8,
                        textcoords="offset points", xytext=(4, 2))
    for n in sorted({n for n, _, _ in learned}):
        pts = [(100 * sc["uncovered"], 100 * sc["median"]) for m_, _, sc in learned if m_ == n and sc["uncovered"] > 0]
        if pts:
            ax.plot(*zip(*pts), "o--", label=f"learned quantile, {n} training tracks")
    if default["uncovered"] > 0:
        ax.plot(100 * default["uncovered"], 100 * default["median"], "k*", ms=12, label="rule-based default")
    ax.set_xscale("log")
    ax.set_xlabel("steps with the planning mass below the truth (%, validation tracks)")
    ax.set_ylabel("planning mass / true mass − 1, median (%)")
    ax.set_title("Pessimism needed for a given coverage: σ-based vs learned")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


if __name__ == "__main__":
    sys.exit(main())
