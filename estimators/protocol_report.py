"""Tables (Markdown) and figures of the generalisation protocol, from the rows of :func:`estimators.protocol.run_protocol`.

Nothing here computes an estimate: it groups the per-run rows and summarises each metric across runs with
:func:`estimators.metrics.distribution`. matplotlib is imported only when a figure is drawn.
"""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path
from typing import Any, Iterable

import numpy as np

from .metrics import distribution

__all__ = ["PAPER_MASS_RMSE", "PAPER_SLOPE_RMSE_DEG", "TARGET_MASS_MAX_PCT", "TARGET_SLOPE_RMSE_DEG", "write_report"]

TARGET_MASS_MAX_PCT = 2.0
TARGET_SLOPE_RMSE_DEG = 0.15
"""Issue 10's floors: 95th percentile of the per-run mass max error and slope RMSE (train-averaged slope)."""

PAPER_SCENARIOS = ("section1", "section2", "roadtest")
PAPER_MASS_RMSE: dict[str, tuple[float, float, float]] = {
    "ffrls": (5.197, 5.197, 151.8), "ekf": (3.657, 4.602, 188.0), "dffrls": (3.065, 4.295, 123.2),
    "dffrls-aekf": (3.065, 4.295, 123.2), "dffrls-aekf-paper": (3.065, 4.295, 123.2),
}
"""Paper 000, Tables 1, 2, 4: mass RMSE (unit "kg" as printed; spec model.md §5.5)."""
PAPER_SLOPE_RMSE_DEG: dict[str, tuple[float, float, float]] = {
    "ffrls": (0.131, 0.149, 0.468), "rls-ekf": (0.096, 0.057, 0.388), "ekf": (0.281, 0.058, 0.427),
    "dffrls-aekf": (0.053, 0.031, 0.328), "dffrls-aekf-paper": (0.053, 0.031, 0.328),
}
"""Paper 000, Tables 1, 2, 4: slope RMSE (degrees as far as can be told)."""


def _f(x: float, nd: int = 2) -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "–"
    if math.isinf(x):
        return "∞"
    return f"{x:.{nd}f}"


def _col(rows: Iterable[dict], key: str) -> list[float]:
    out = []
    for r in rows:
        v = r.get(key)
        out.append(math.nan if v is None else float(v))
    return out


def _frac(rows: Iterable[dict], key: str) -> float:
    v = [r.get(key) for r in rows if r.get(key) is not None]
    return 100.0 * float(np.mean(v)) if v else math.nan


def _group(rows: list[dict]) -> dict[tuple[str, str], list[dict]]:
    g: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for r in rows:
        g[(r["group"], r["estimator"])].append(r)
    return g


def _names(rows: list[dict]) -> list[str]:
    return list(dict.fromkeys(r["estimator"] for r in rows))


def _per_world(rows: list[dict], names: list[str], worlds: tuple[tuple[str, str], ...]):
    """``(name, world label, its rows)`` for every estimator and ``(group, label)`` in ``worlds`` that has runs."""
    g = _group(rows)
    for name in names:
        for grp, world in worlds:
            rs = g.get((grp, name), [])
            if rs:
                yield name, world, rs


def _generalisation_table(rows: list[dict], names: list[str]) -> list[str]:
    out = [
        "| estimator | world | runs | mass max error %: median / p95 / max | slope RMSE ° (train-averaged): "
        "median / p95 / max | slope RMSE ° (under the sensors): p95 | meets p95 targets |",
        "| --- | --- | ---: | --- | --- | --- | --- |",
    ]
    for name, world, rs in _per_world(rows, names, (("plant", "(a) plant"), ("point", "(b) point mass"))):
        m = distribution(_col(rs, "mass_max_pct"))
        s = distribution(_col(rs, "slope_train_rmse_deg"))
        sl = distribution(_col(rs, "slope_rmse_deg"))
        ok_m = m["n"] > 0 and m["p95"] <= TARGET_MASS_MAX_PCT
        ok_s = s["n"] > 0 and s["p95"] <= TARGET_SLOPE_RMSE_DEG
        verdict = ("mass " + ("yes" if ok_m else "no") if m["n"] else "mass –") + ", slope " + (
            ("yes" if ok_s else "no") if s["n"] else "–")
        out.append(
            f"| `{name}` | {world} | {len(rs)} | {_f(m['median'])} / {_f(m['p95'])} / {_f(m['max'])} | "
            f"{_f(s['median'], 3)} / {_f(s['p95'], 3)} / {_f(s['max'], 3)} | {_f(sl['p95'], 3)} | {verdict} |")
    return out


def _consistency_table(rows: list[dict], names: list[str]) -> list[str]:
    out = [
        "| estimator | world | mass settled to 2 % by the end (% runs) / median settling s | mass NEES in χ² band "
        "/ σ too wide / too narrow (% runs) | truth within ±2σ, mass (mean %) | slope NEES in band / too wide / "
        "too narrow (% runs) | within ±2σ, slope (mean %) | speed NIS in band (% runs) / median |",
        "| --- | --- | --- | --- | ---: | --- | ---: | --- |",
    ]
    for name, world, rs in _per_world(rows, names, (("plant", "plant"), ("point", "point mass"))):
        st = np.array(_col(rs, "mass_settle_s"))
        st = st[~np.isnan(st)]
        settled = 100.0 * float(np.mean(np.isfinite(st))) if st.size else math.nan
        med = float(np.median(st[np.isfinite(st)])) if np.any(np.isfinite(st)) else math.nan
        w_m = np.nanmean(_col(rs, "mass_within_2sigma")) * 100 if rs[0].get("provides_mass") else math.nan
        w_s = np.nanmean(_col(rs, "slope_within_2sigma")) * 100 if rs[0].get("provides_slope") else math.nan
        nis = [(r.get("speed_nis_in_band"), r.get("speed_nis")) for r in rs if r.get("speed_nis_in_band") is not None]
        nis_txt = (f"{_f(100 * sum(1 for b, _ in nis if b) / len(nis), 0)} / {_f(float(np.median([x for _, x in nis])), 2)}"
                   if nis else "–")
        out.append(f"| `{name}` | {world} | {_f(settled, 0)} / {_f(med, 1)} | {_nees_split(rs, 'mass')} | "
                   f"{_f(w_m, 0)} | {_nees_split(rs, 'slope')} | {_f(w_s, 0)} | {nis_txt} |")
    return out


def _nees_split(rs: list[dict], q: str) -> str:
    """In band / outside with NEES < 1 (σ too wide) / outside with NEES > 1 (σ too narrow), % of runs."""
    v = [(r.get(f"{q}_nees_in_band"), r.get(f"{q}_nees")) for r in rs if r.get(f"{q}_nees_in_band") is not None]
    if not v:
        return "–"
    n = len(v)
    inside = sum(1 for b, _ in v if b)
    wide = sum(1 for b, x in v if not b and x < 1.0)
    return f"{_f(100 * inside / n, 0)} / {_f(100 * wide / n, 0)} / {_f(100 * (n - inside - wide) / n, 0)}"


def _mu_table(rows: list[dict], names: list[str], mu_by_run: dict[str, float | None], mu_file: float) -> list[str]:
    out = ["| estimator | world | corr(|μ/μ_file − 1|, mass max %) | mass max %, median: runs with |μ/μ_file − 1| < 5 % "
           "(n) / the others |", "| --- | --- | ---: | --- |"]
    g = _group(rows)
    for name in names:
        for grp in ("plant", "point"):
            rs = [r for r in g.get((grp, name), []) if mu_by_run.get(r["run"]) is not None
                  and np.isfinite(r.get("mass_max_pct", math.nan))]
            if len(rs) < 3:
                continue
            dm = np.array([abs(mu_by_run[r["run"]] / mu_file - 1.0) for r in rs])
            e = np.array([r["mass_max_pct"] for r in rs])
            near = dm < 0.05
            corr = float(np.corrcoef(dm, e)[0, 1]) if np.std(e) > 0 else math.nan
            med_near = float(np.median(e[near])) if near.any() else math.nan
            med_far = float(np.median(e[~near])) if (~near).any() else math.nan
            out.append(f"| `{name}` | {grp} | {_f(corr, 2)} | {_f(med_near, 1)} ({int(near.sum())}) / {_f(med_far, 1)} |")
    return out


def _by_scenario(rows: list[dict]) -> dict[tuple[str, str], list[dict]]:
    g: dict[tuple[str, str], list[dict]] = defaultdict(list)
    for r in rows:
        if r["group"] == "paper":
            sc = r["run"].removeprefix("paper-").rsplit("-s", 1)[0]
            g[(sc, r["estimator"])].append(r)
    return g


def _paper_table(rows: list[dict], names: list[str]) -> list[str]:
    g = _by_scenario(rows)
    hdr = " | ".join(f"{sc}: mass RMSE kg [paper] / slope RMSE ° [paper] / vs train-avg °" for sc in PAPER_SCENARIOS)
    out = [f"| estimator | {hdr} |", "| --- |" + " --- |" * len(PAPER_SCENARIOS)]
    for name in names:
        cells = []
        for i, sc in enumerate(PAPER_SCENARIOS):
            rs = g.get((sc, name), [])
            if not rs:
                cells.append("–")
                continue
            pm = PAPER_MASS_RMSE.get(name)
            ps = PAPER_SLOPE_RMSE_DEG.get(name)
            m = np.mean(_col(rs, "mass_rmse_kg"))
            mtxt = f"{_f(m, 0)} [{pm[i]:g}]" if pm else _f(m, 0)
            s = np.mean(_col(rs, "slope_rmse_deg"))
            stxt = f"{_f(s, 3)} [{ps[i]:g}]" if ps else _f(s, 3)
            cells.append(f"{mtxt} / {stxt} / {_f(np.mean(_col(rs, 'slope_train_rmse_deg')), 3)}")
        out.append(f"| `{name}` | " + " | ".join(cells) + " |")
    return out


def _fixed_table(rows: list[dict], names: list[str]) -> list[str]:
    g = _by_scenario(rows)
    scen = [sc for sc in dict.fromkeys(s for s, _ in g) if sc not in PAPER_SCENARIOS]
    out = ["| estimator | " + " | ".join(f"`{s}`" for s in scen) + " |", "| --- |" + " --- |" * len(scen)]
    for name in names:
        cells = []
        for sc in scen:
            rs = g.get((sc, name), [])
            cells.append(f"{_f(np.max(_col(rs, 'mass_max_pct')), 1)} % / {_f(np.max(_col(rs, 'slope_train_rmse_deg')), 2)}°"
                         if rs else "–")
        out.append(f"| `{name}` | " + " | ".join(cells) + " |")
    return out


def _fault_table(rows: list[dict], names: list[str]) -> list[str]:
    g: dict[tuple[str, str, str], list[dict]] = defaultdict(list)
    for r in rows:
        if r["group"] == "fault":
            g[(r["fault"], r["world"], r["estimator"])].append(r)
    keys = list(dict.fromkeys((f, w) for f, w, _ in g))
    out = ["| estimator | " + " | ".join(f"{f}, {'plant' if w == 'plant' else 'point mass'}" for f, w in keys) + " |",
           "| --- |" + " --- |" * len(keys)]
    for name in names:
        cells = []
        for f, w in keys:
            rs = g.get((f, w, name), [])
            if not rs:
                cells.append("–")
                continue
            txt = (f"{_f(np.max(_col(rs, 'mass_rmse_pct')), 1)} % / "
                   f"{_f(np.max(_col(rs, 'slope_train_rmse_deg')), 2)}°")
            if f == "stuck":
                txt += (f" (10 s after: {_f(np.max(_col(rs, 'recovered_mass_max_pct')), 1)} % max / "
                        f"{_f(np.max(_col(rs, 'recovered_slope_train_rmse_deg')), 2)}°)")
            cells.append(txt)
        out.append(f"| `{name}` | " + " | ".join(cells) + " |")
    return out


def _figures(rows: list[dict], names: list[str], out: Path) -> list[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    g = _group(rows)
    paths = []

    def save(fig, name: str) -> None:
        fig.tight_layout()
        p = out / name
        fig.savefig(p, dpi=90)
        plt.close(fig)
        paths.append(p)

    fig, axes = plt.subplots(1, 2, figsize=(14, 5.5))
    for ax, key, target, label in (
        (axes[0], "mass_max_pct", TARGET_MASS_MAX_PCT, "mass: max |error| after settling (%)"),
        (axes[1], "slope_train_rmse_deg", TARGET_SLOPE_RMSE_DEG, "slope RMSE vs train-averaged slope (deg)"),
    ):
        pos, data, colors = [], [], []
        for i, name in enumerate(names):
            for j, (grp, c) in enumerate((("plant", "tab:blue"), ("point", "tab:orange"))):
                v = np.array(_col(g.get((grp, name), []), key))
                v = v[np.isfinite(v)]
                if v.size:
                    pos.append(3 * i + j)
                    data.append(np.maximum(v, 1e-3))
                    colors.append(c)
        if data:
            bp = ax.boxplot(data, positions=pos, widths=0.8, whis=(5, 95), showfliers=True, patch_artist=True,
                            flierprops={"markersize": 2})
            for patch, c in zip(bp["boxes"], colors):
                patch.set_facecolor(c)
                patch.set_alpha(0.6)
        ax.axhline(target, color="k", ls="--", lw=1, label=f"target (p95) {target:g}")
        ax.set_yscale("log")
        ax.set_xticks([3 * i + 0.5 for i in range(len(names))], names, rotation=45, ha="right")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3, which="both", axis="y")
    axes[0].plot([], [], "s", color="tab:blue", alpha=0.6, label="(a) pymunk plant, random runs")
    axes[0].plot([], [], "s", color="tab:orange", alpha=0.6, label="(b) point-mass world, random runs")
    axes[0].legend(fontsize=8, loc="upper left")
    fig.suptitle("Estimators untuned on two worlds: per-run errors (box 25-75 %, whiskers 5-95 %)")
    save(fig, "generalisation.png")

    fig, ax = plt.subplots(figsize=(11, 4.5))
    width = 0.2
    for k, (key, lab) in enumerate((("mass_within_2sigma", "mass: truth within ±2σ"),
                                    ("slope_within_2sigma", "slope: truth within ±2σ"),
                                    ("mass_nees_in_band", "mass: NEES in χ² 95 % band"),
                                    ("slope_nees_in_band", "slope: NEES in χ² 95 % band"))):
        vals = []
        for name in names:
            rs = g.get(("plant", name), []) + g.get(("point", name), [])
            v = [r.get(key) for r in rs if r.get(key) is not None and not
                 (isinstance(r.get(key), float) and math.isnan(r.get(key)))]
            vals.append(100.0 * float(np.mean(v)) if v else math.nan)
        x = np.arange(len(names)) + (k - 1.5) * width
        ax.bar(x, vals, width, label=lab, color=f"C{k}")
        for xi, v in zip(x, vals):  # a method that does not estimate the quantity: say so, not a zero bar
            if math.isnan(v):
                ax.text(xi, 1.0, "n/a", rotation=90, ha="center", va="bottom", fontsize=6, color=f"C{k}")
    ax.axhline(95.4, color="k", ls=":", lw=1, label="95.4 % (consistent Gaussian)")
    ax.axhline(90.0, color="k", ls="--", lw=1, label="90 % of runs (issue 10 target for NEES)")
    ax.set_xticks(np.arange(len(names)), names, rotation=45, ha="right")
    ax.set_ylabel("% (time for ±2σ, runs for NEES)")
    ax.set_ylim(0, 105)
    ax.legend(fontsize=7, ncol=3, loc="upper center", bbox_to_anchor=(0.5, -0.35))
    ax.set_title("Do the reported uncertainties mean something? (random runs of both worlds)")
    save(fig, "consistency.png")
    return paths


def write_report(rows: list[dict[str, Any]], out_dir: str | Path, *, command: str, skipped: dict[str, str],
                 settle_s: float = 10.0, figures: bool = True, mu_by_run: dict[str, float | None] | None = None,
                 mu_file: float = 0.02) -> list[Path]:
    """Write ``summary.md`` (and the figures) for the protocol rows into ``out_dir``; return the paths.

    ``mu_by_run`` (run name -> the true running resistance of a random run) adds a table of the mass error
    against the mismatch with the vehicle file's ``mu_file``.
    """
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    ok = [r for r in rows if "error" not in r]
    names = _names(rows)
    counts = defaultdict(set)
    for r in rows:
        counts[r["group"]].add(r["run"])
    lines = [
        "# Estimator generalisation protocol: results",
        "",
        f"Produced by `{command}` (protocol: `docs/estimation.md`). Every estimator with its default settings, "
        f"errors after {settle_s:g} s; runs: " + ", ".join(f"{k} {len(v)}" for k, v in counts.items()) + ".",
        "",
    ]
    versions = dict.fromkeys(f"`{r['estimator']}` {r['key'].split('|')[2]}" for r in rows if "key" in r)
    if versions:
        lines += ["Estimator code versions (source fingerprints, `estimators.protocol.fingerprint`): "
                  + ", ".join(versions) + ".", ""]
    if skipped:
        lines += ["Not scored: " + "; ".join(f"`{k}` ({v})" for k, v in skipped.items()) + ".", ""]
    bad = sorted({(r["estimator"], r.get("error", "non-finite output")) for r in rows
                  if "error" in r or not r.get("finite", True)})
    if bad:
        lines += ["Failures (an exception or a NaN/inf in the output): " +
                  "; ".join(f"`{n}`: {why}" for n, why in bad[:20]) + ".", ""]
    lines += ["## (a) + (b): random runs of the plant and of the point-mass world", "",
              f"Per run: the maximum |mass error| in % and the slope RMSE after {settle_s:g} s; across runs: "
              "median, 95th percentile, maximum. Targets (issue 10): p95 mass max ≤ "
              f"{TARGET_MASS_MAX_PCT:g} %, p95 slope RMSE ≤ {TARGET_SLOPE_RMSE_DEG:g}° against the "
              "train-averaged slope.", ""]
    lines += _generalisation_table(ok, names)
    lines += ["", "## Settling and consistency (random runs)", "",
              "Settling: time after which the mass error stays within 2 % to the end of the run. NEES: mean of "
              "(error/σ)² over one sample a second after settling, in its χ² 95 % band (slope against the "
              "train-averaged slope). ±2σ: share of samples whose truth lies within ±2σ of the estimate. Speed NIS (where "
              "an estimator reports its innovations): mean of ε²/(HP⁻Hᵀ + R) of the speed corrections, one a "
              "second after settling, in its χ²(1) 95 % band — the test that needs no truth.", ""]
    lines += _consistency_table(ok, names)
    if mu_by_run:
        lines += ["", "## Mass error against the running-resistance mismatch (random runs)", "",
                  f"The vehicle file says μ = {mu_file:g}; each random run draws its true μ in 0.015–0.03.", ""]
        lines += _mu_table(ok, names, mu_by_run, mu_file)
    lines += ["", "## (c) The paper's scenarios (plant, 10 t, mean over seeds) beside paper 000's Tables 1, 2, 4",
              "", "Mass RMSE in kg, slope RMSE in degrees against the slope under the sensors; paper in brackets.", ""]
    lines += _paper_table(ok, names)
    lines += ["", "## Fixed scenarios: station stops (plant) and the point-mass set",
              "", "Per cell: max |mass error| % / slope RMSE (train-averaged), after the settle time.", ""]
    lines += _fixed_table(ok, names)
    lines += ["", "## Robustness: sensor faults on the road test", "",
              "Per cell (worst over seeds): mass RMSE % / slope RMSE (train-averaged) over the whole run after "
              "settling; for the stuck speed sensor (5 s from 30 s) also the errors from 10 s after it ends.", ""]
    lines += _fault_table(ok, names)
    paths = [out / "summary.md"]
    if figures and ok:
        fig_paths = _figures(ok, names, out)
        paths += fig_paths
        lines += ["", "## Figures", ""] + [f"![{p.stem}]({p.name})" for p in fig_paths]
    (out / "summary.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return paths
