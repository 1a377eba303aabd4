"""Score every registered estimator on a set of runs, untuned, with the metrics of :mod:`estimators.metrics`.

The runs come from outside (a list of specs and a picklable ``make_trace(spec) -> Trace``; the project's are in
:mod:`uuom_gym.sim.protocol_runs`), so this module depends on the core only. For each run and estimator one row
(a flat dict, JSON-ready) holds:

- ``mass_rmse_pct``, ``mass_max_pct``, ``mass_rmse_kg`` -- mass errors after the settle time (estimators that
  estimate mass);
- ``slope_rmse_deg``, ``slope_max_deg`` -- against the slope under the sensors (``slope_deg``);
  ``slope_train_rmse_deg``, ``slope_train_max_deg`` -- against the train-averaged slope (``effective_slope_deg``),
  what a point-mass longitudinal model can see;
- ``mass_settle_s`` -- settling time to within 2 % (``inf``: outside at the end);
- ``mass_nees``, ``mass_nees_in_band``, ``mass_within_2sigma`` and the same for the slope against the
  train-averaged slope (``slope_*``) and against the slope under the sensors (``slope_local_*``) -- consistency
  of the reported standard deviations;
- ``speed_nis``, ``speed_nis_in_band`` -- NIS of the speed corrections (estimators that report ``extras["nis"]``),
  the consistency test that needs no truth;
- ``recovered_*`` -- errors from 10 s after a finite fault ends (``meta["fault_end_s"]``);
- ``finite`` (no NaN/inf ever output), ``seconds`` (run time, for information only).

Rows are cached in a JSON-lines file keyed by run, estimator and a fingerprint of the estimator's source, so a
re-run recomputes only what changed (an estimator edited or added) -- results stay exactly reproducible because
every run is deterministic from its seed.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Any, Callable, Iterable, Sequence

import numpy as np

from uuom_core.trace import Trace
from uuom_core.vehicle import VehicleParams

from .metrics import consistency, error_after_settling, nis_consistency, settling_time_s, train_slope_deg
from .registry import available, get_class, make

__all__ = ["MASS_SETTLE_TOL_PCT", "cached_rows", "fingerprint", "run_protocol", "score_trace", "usable_estimators"]

MASS_SETTLE_TOL_PCT = 2.0
"""Tolerance of the mass settling time (the issue's 2 % target)."""

RECOVERY_S = 10.0
"""After a finite fault ends, errors are also scored from this long after its end (issue 10: recovery in 10 s)."""


def usable_estimators(names: Iterable[str] | None = None) -> tuple[list[str], dict[str, str]]:
    """The estimators to score and, for the others, why not (does not import, or estimates neither mass nor slope)."""
    ok: list[str] = []
    skipped: dict[str, str] = {}
    for name in (available() if names is None else names):
        try:
            cls = get_class(name)
        except Exception as exc:  # one broken method must not stop the protocol
            skipped[name] = f"does not load ({type(exc).__name__}: {exc})".splitlines()[0]
            continue
        outputs = set(getattr(cls, "outputs", ("mass", "slope")))
        if not ({"mass", "slope"} & outputs & set(cls.provides)):
            skipped[name] = f"estimates {', '.join(sorted(cls.provides)) or 'nothing'}, not mass or slope"
            continue
        ok.append(name)
    return ok, skipped


def _module_closure(module_name: str) -> list[str]:
    """The ``estimators.*`` modules a module refers to, transitively (itself included), by name."""
    seen: set[str] = set()
    todo = [module_name]
    while todo:
        name = todo.pop()
        if name in seen or name not in sys.modules:
            continue
        seen.add(name)
        for value in vars(sys.modules[name]).values():
            mod = value if inspect.ismodule(value) else getattr(value, "__module__", None)
            mod_name = mod.__name__ if inspect.ismodule(mod) else mod
            if isinstance(mod_name, str) and mod_name.startswith("estimators") and mod_name not in seen:
                todo.append(mod_name)
    return sorted(seen)


_FINGERPRINTS: dict[str, str] = {}


def fingerprint(name: str) -> str:
    """Short hash of the source of the estimator's module and the ``estimators`` modules it uses.

    Taken once per process (on the first call, right after the import), so it describes the code this process
    runs even if the files change on disk while it runs.
    """
    if name not in _FINGERPRINTS:
        _FINGERPRINTS[name] = _fingerprint(name)
    return _FINGERPRINTS[name]


def _fingerprint(name: str) -> str:
    cls = get_class(name)
    h = hashlib.sha1(name.encode())
    for mod in _module_closure(cls.__module__):
        path = getattr(sys.modules[mod], "__file__", None)
        if path and os.path.exists(path):
            h.update(mod.encode())
            h.update(Path(path).read_bytes())
    return h.hexdigest()[:12]


def _scoring_fingerprint() -> str:
    """Hash of the metric module and of the scoring functions here (not the whole file: docs may change)."""
    h = hashlib.sha1(Path(sys.modules["estimators.metrics"].__file__).read_bytes())
    for fn in (_stats, _consistency, score_trace, _meta_row, _work):
        h.update(inspect.getsource(fn).encode())
    return h.hexdigest()[:12]


def _stats(prefix: str, t: np.ndarray, est: np.ndarray, truth: np.ndarray | None, settle_s: float,
           relative: bool = False) -> dict[str, float]:
    nan = {f"{prefix}_rmse": math.nan, f"{prefix}_max": math.nan}
    if truth is None:
        return nan
    e = error_after_settling(t, est, truth, settle_s, relative=relative)
    return nan if e is None else {f"{prefix}_rmse": e.rmse, f"{prefix}_max": e.max_abs}


def _consistency(prefix: str, t, est, std, truth, settle_s) -> dict[str, Any]:
    c = None if truth is None else consistency(t, est, std, truth, settle_s)
    if c is None:
        return {f"{prefix}_nees": math.nan, f"{prefix}_nees_in_band": None, f"{prefix}_within_2sigma": math.nan}
    return {f"{prefix}_nees": c.nees, f"{prefix}_nees_in_band": c.in_band, f"{prefix}_within_2sigma": c.within_2sigma}


def score_trace(trace: Trace, name: str, settle_s: float = 10.0, vehicle: VehicleParams | None = None) -> dict[str, Any]:
    """Run estimator ``name`` (default options, no tuning; given ``vehicle``'s file, the project's by default) over
    ``trace`` and score it (one protocol row)."""
    est = make(name) if vehicle is None else make(name, vehicle=vehicle)
    t0 = time.perf_counter()
    s = est.run(trace)
    seconds = time.perf_counter() - t0
    t = trace["t_s"]
    mass_true = trace.get("mass_kg")
    slope_true = trace.get("slope_deg")
    train = train_slope_deg(trace)
    has_mass, has_slope = "mass" in est.provides, "slope" in est.provides
    slope_deg, slope_std_deg = s.slope_deg, s.slope_std_deg
    row: dict[str, Any] = {
        "estimator": name, "provides_mass": has_mass, "provides_slope": has_slope, "seconds": seconds,
        "finite": bool(np.all(np.isfinite(s.mass_kg)) and np.all(np.isfinite(s.slope_rad))
                       and np.all(np.isfinite(s.mass_std_kg)) and np.all(np.isfinite(s.slope_std_rad))),
    }
    m_truth = mass_true if has_mass else None
    s_truth, tr_truth = (slope_true, train) if has_slope else (None, None)
    row.update(_stats("mass", t, s.mass_kg, m_truth, settle_s, relative=True))
    row["mass_rmse_pct"], row["mass_max_pct"] = row.pop("mass_rmse"), row.pop("mass_max")
    row["mass_rmse_kg"] = _stats("m", t, s.mass_kg, m_truth, settle_s)["m_rmse"]
    row.update({k + "_deg": v for k, v in _stats("slope", t, slope_deg, s_truth, settle_s).items()})
    row.update({k + "_deg": v for k, v in _stats("slope_train", t, slope_deg, tr_truth, settle_s).items()})
    row["mass_settle_s"] = (settling_time_s(t, s.mass_kg, m_truth, MASS_SETTLE_TOL_PCT, relative=True)
                            if m_truth is not None else math.nan)
    row.update(_consistency("mass", t, s.mass_kg, s.mass_std_kg, m_truth, settle_s))
    row.update(_consistency("slope", t, slope_deg, slope_std_deg, tr_truth, settle_s))
    row.update(_consistency("slope_local", t, slope_deg, slope_std_deg, s_truth, settle_s))
    nis = s.extras.get("nis")
    c_nis = nis_consistency(t, nis, settle_s) if nis is not None else None
    row["speed_nis"] = c_nis.mean if c_nis is not None else math.nan
    row["speed_nis_in_band"] = c_nis.in_band if c_nis is not None else None
    fault_end = trace.meta.get("fault_end_s")
    if fault_end is not None:
        after = float(fault_end) + RECOVERY_S - float(t[0])
        rec_m = _stats("m", t, s.mass_kg, m_truth, after, relative=True)
        rec_s = _stats("s", t, slope_deg, tr_truth, after)
        row.update(recovered_mass_max_pct=rec_m["m_max"], recovered_slope_train_rmse_deg=rec_s["s_rmse"])
    return row


def _meta_row(trace: Trace) -> dict[str, Any]:
    return {k: trace.meta.get(k, "") for k in ("run", "group", "world", "scenario", "fault")} | {
        "load_kg": float(trace.meta.get("load_kg", "nan")), "true_mass_kg": float(np.nanmax(trace["mass_kg"]))}


def _work(job: tuple[Any, Sequence[str], float, Callable[[Any], Trace]]) -> list[dict[str, Any]]:
    spec, names, settle_s, make_trace = job
    trace = make_trace(spec)
    base = _meta_row(trace)
    out = []
    for name in names:
        try:
            row = score_trace(trace, name, settle_s)
        except Exception as exc:  # an estimator that raises is a result (a failure), not a crash of the protocol
            row = {"estimator": name, "error": f"{type(exc).__name__}: {exc}".splitlines()[0], "finite": False}
        out.append(base | row)
    return out


def _json_default(o: Any) -> Any:
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.bool_):
        return bool(o)
    raise TypeError(type(o).__name__)


def run_protocol(
    specs: Sequence[Any],
    make_trace: Callable[[Any], Trace],
    names: Sequence[str],
    *,
    settle_s: float = 10.0,
    workers: int = 1,
    cache: str | Path | None = None,
    world_version: str = "",
    progress: Callable[[str], None] | None = None,
    compute: bool = True,
) -> list[dict[str, Any]]:
    """Score ``names`` on every run of ``specs``; rows in the order of ``specs`` then ``names``.

    Parameters
    ----------
    specs : sequence
        Run specifications with a unique ``name`` attribute, passed to ``make_trace``.
    make_trace : callable
        ``spec -> Trace`` with ``mass_kg``, ``slope_deg`` (and optionally ``effective_slope_deg``) truth columns;
        must be picklable (a module-level function) when ``workers > 1``.
    workers : int
        Processes (each regenerates its runs' traces; nothing large crosses processes).
    cache : path, optional
        JSON-lines file of rows; rows whose key (run, estimator, estimator fingerprint, scoring and
        ``world_version`` fingerprints) is there are not recomputed, new rows are appended as they finish.
    compute : bool
        False: score nothing, return only the rows the cache already holds (for reports of a partial run).
    """
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    prints = [fingerprint(n) for n in names]
    scoring = _scoring_fingerprint() + world_version

    def key(run: str, name: str, fp: str) -> str:
        return f"{run}|{name}|{fp}|{scoring}"

    done: dict[str, dict[str, Any]] = {}
    if cache is not None and Path(cache).exists():
        for line in Path(cache).read_text(encoding="utf-8").splitlines():
            if line.strip():
                row = json.loads(line)
                done[row["key"]] = row
    jobs = []
    for spec in specs:
        todo = [n for n, fp in zip(names, prints) if key(spec.name, n, fp) not in done]
        if todo and compute:
            jobs.append((spec, todo, settle_s, make_trace))
    fh = open(cache, "a", encoding="utf-8") if cache is not None else None
    fps = dict(zip(names, prints))
    try:
        results: Iterable[list[dict[str, Any]]]
        if workers == 1 or len(jobs) <= 1:
            results = map(_work, jobs)
        else:
            import multiprocessing as mp

            pool = mp.get_context("fork").Pool(workers)
            results = pool.imap_unordered(_work, jobs)
        t0 = time.monotonic()
        for i, rows in enumerate(results, 1):
            for row in rows:
                row["key"] = key(row["run"], row["estimator"], fps[row["estimator"]])
                done[row["key"]] = row
                if fh is not None:
                    fh.write(json.dumps(row, default=_json_default) + "\n")
            if fh is not None:
                fh.flush()
            if progress is not None:
                progress(f"{i}/{len(jobs)} runs scored ({rows[0]['run']}), {time.monotonic() - t0:.0f} s")
        if workers > 1 and len(jobs) > 1:
            pool.close()
            pool.join()
    finally:
        if fh is not None:
            fh.close()
    return [done[k] for spec in specs for n, fp in zip(names, prints) if (k := key(spec.name, n, fp)) in done]


def cached_rows(cache: str | Path, specs: Sequence[Any], names: Sequence[str]) -> list[dict[str, Any]]:
    """Rows of ``specs`` x ``names`` from a cache whatever the code version, one version per estimator.

    For each estimator the version (estimator, scoring and world fingerprints of the key) that covers the most of
    ``specs`` is taken, the later one on a tie, so a report never mixes two versions of one estimator. Each row's
    ``key`` names its version.
    """
    wanted = {s.name for s in specs}
    by_version: dict[tuple[str, str], dict[str, dict[str, Any]]] = {}
    for line in Path(cache).read_text(encoding="utf-8").splitlines():
        if not line.strip():
            continue
        row = json.loads(line)
        run, name, version = row["key"].split("|", 2)
        if run in wanted and name in names:
            by_version.setdefault((name, version), {})[run] = row
    out: list[dict[str, Any]] = []
    chosen: dict[str, dict[str, dict[str, Any]]] = {}
    for (name, _), rows in by_version.items():  # insertion order = first appearance in the file
        if name not in chosen or len(rows) >= len(chosen[name]):
            chosen[name] = rows
    for spec in specs:
        for name in names:
            row = chosen.get(name, {}).get(spec.name)
            if row is not None:
                out.append(row)
    return out
