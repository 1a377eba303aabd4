#!/usr/bin/env python
"""Accuracy of the mass/slope estimators where they are used: in ``UUOM-Track-v0`` episodes on random tracks.

Three measurements, each printed per estimator as the mean over episodes of |mass error| % and slope RMSE (deg),
both taken after ``--settle-s`` seconds of the episode:

* ``closed``: each observer runs *inside* the environment (``gym.make("UUOM-Track-v0", observer=NAME)``), the
  episode driven by a reference controller (``rule-based`` uses the observer's estimate, so the driving differs
  per observer; ``oracle`` drives the same for all). Mass error is ``|est/true − 1|`` averaged over the policy
  steps after the settle time; slope truth is the slope at the drive section at each policy step.
* ``replay``: one episode per seed is recorded (sensor samples of every physics tick, the controller driving on
  ``--drive-observer``), then every estimator is run on the same samples (open loop; fast, for tuning).
* ``offline``: :func:`uuom_gym.sim.recording.simulate_run` on :func:`uuom_gym.sim.track.random_track` tracks
  (150-250 m, random load), the plant's own speed-tracking driver; RMSE of mass % after the settle time.

Tune on one seed set, report on another (the agents' evaluation uses 100000-100099: do not tune on those).

Usage::

    python scripts/estimator_env_accuracy.py --mode closed --seeds 200000:200020 --controller rule-based
    python scripts/estimator_env_accuracy.py --mode replay --seeds 310000:310030 --cache /tmp/eea_cache \
        --figure docs/img/estimators_env_mass.png
    python scripts/estimator_env_accuracy.py --mode offline --seeds 0:8
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import numpy as np

from estimators.cli import names_argument
from estimators.metrics import error_after_settling
from uuom_core.trace import SENSOR_COLUMNS

DEFAULT_ESTIMATORS = "none,dffrls-aekf,sf-kf@before,sf-kf"
SENSOR_KEYS = SENSOR_COLUMNS


def _seeds(spec: str) -> list[int]:
    if ":" in spec:
        a, b = spec.split(":")
        return list(range(int(a), int(b)))
    return [int(s) for s in spec.split(",") if s.strip()]


# "NAME@before": the estimator as it was before the load-swing model and retuning (same code, options).
# "dffrls-aekf@before" is gone: the class lost those switches when the geometry bank replaced it as the default
# (docs/estimators.md keeps the rows it produced, marked historical).
BEFORE_OPTIONS = {
    "dffrls": {"chain_length_m": 0.0, "cutoff_hz": 0.5, "residual_std_mps2": 0.3, "min_accel_mps2": 0.0},
    "sf-kf": {"chain_length_m": 0.0},
}


def _split(spec: str) -> tuple[str, dict]:
    if spec.endswith("@before"):
        name = spec[: -len("@before")]
        return name, BEFORE_OPTIONS[name]
    return spec, {}


def _episode(observer: str, seed: int, controller: str, record: bool = False,
             observer_options: dict | None = None) -> dict:
    """Run one env episode; return per-step truth/estimates (and the raw sensor samples if ``record``)."""
    import gymnasium as gym

    import uuom_gym  # noqa: F401
    from agents.controllers import CONTROLLERS

    kw = {"observer": observer}
    if observer_options:
        kw["observer_options"] = observer_options
    env = gym.make("UUOM-Track-v0", **kw)
    base = env.unwrapped
    ctrl = CONTROLLERS[controller](base.vehicle)
    samples: dict[str, list[np.ndarray]] = {k: [] for k in SENSOR_KEYS}
    slope_ticks: list[float] = []
    if record:
        obs_fn = base.observer.observe

        def spy(measured, dt_s, true_mass_kg, true_slope_rad):
            for k in SENSOR_KEYS:
                samples[k].append(np.asarray(measured[k], dtype=float))
            slope_ticks.extend([float(true_slope_rad)] * len(measured["torque_nm"]))
            return obs_fn(measured, dt_s, true_mass_kg, true_slope_rad)

        base.observer.observe = spy
    obs, info = env.reset(seed=seed)
    if hasattr(ctrl, "reset"):
        ctrl.reset(env, info)
    rows = []
    while True:
        obs, _, term, trunc, info = env.step(ctrl.act(obs, info))
        rows.append((info["t_s"], info["true_mass_kg"], info["est_mass_kg"], info["true_slope_rad"],
                     info["est_slope_rad"], info["speed_mps"]))
        if term or trunc:
            break
    env.close()
    out = {"steps": np.array(rows), "load_kg": info["load_kg"], "termination": info["termination"],
           "dt_s": base.dt_s, "track_length_m": info["track_length_m"]}
    if record:
        out["samples"] = {k: np.concatenate(v) for k, v in samples.items()}
        out["slope_true"] = np.array(slope_ticks)
    return out


def _recorded(seed: int) -> dict:
    """A recorded episode, from ``--cache`` when it is there (the recording dominates the run time)."""
    import os
    import pickle

    if ARGS.cache:
        path = os.path.join(ARGS.cache, f"{ARGS.controller}-{ARGS.drive_observer}-{seed}.pkl")
        if os.path.exists(path):
            with open(path, "rb") as fh:
                return pickle.load(fh)
    ep = _episode(ARGS.drive_observer, seed, ARGS.controller, record=True)
    if ARGS.cache:
        os.makedirs(ARGS.cache, exist_ok=True)
        with open(path, "wb") as fh:
            pickle.dump(ep, fh)
    return ep


def _errors(t_s, mass_true, mass_est, slope_true, slope_est, settle_s):
    """Mean |mass error| (%) and slope RMSE (deg) after the settle time (slopes in rad)."""
    mass = error_after_settling(t_s, mass_est, mass_true, settle_s, relative=True)
    slope = error_after_settling(t_s, np.degrees(slope_est), np.degrees(slope_true), settle_s)
    if mass is None or slope is None:
        return math.nan, math.nan
    return mass.mean_abs, slope.rmse


def _replay(ep: dict, name: str) -> tuple[float, float]:
    import estimators
    from uuom_core.vehicle import DEFAULT_VEHICLE

    s = ep["samples"]
    n = len(s["torque_nm"])
    dt = ep["dt_s"]
    t = dt * np.arange(1, n + 1)
    mass_true = np.full(n, DEFAULT_VEHICLE.empty_mass_kg + ep["load_kg"])
    if name == "none":
        m_est = np.full(n, DEFAULT_VEHICLE.empty_mass_kg + 0.5 * DEFAULT_VEHICLE.rated_load_kg)
        th_est = np.zeros(n)
    else:
        est = estimators.make(*_split(name)[:1], **_split(name)[1])
        upd = est.update
        m_est = np.empty(n)
        th_est = np.empty(n)
        cols = [s[k].tolist() for k in SENSOR_KEYS]
        for i, (a, b, c, d, e, f) in enumerate(zip(*cols)):
            r = upd(a, b, c, dt, d, e, f)
            m_est[i] = r.mass_kg
            th_est[i] = r.slope_rad
    return _errors(t, mass_true, m_est, ep["slope_true"], th_est, ARGS.settle_s)


def _figure(ep: dict, names: list[str], path: str) -> None:
    """Mass estimate over one recorded episode (before/after), with the speed and the slope under it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import estimators
    from uuom_core.vehicle import DEFAULT_VEHICLE

    s = ep["samples"]
    dt = ep["dt_s"]
    n = len(s["torque_nm"])
    t = dt * np.arange(1, n + 1)
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(8, 5.5), sharex=True, gridspec_kw={"height_ratios": [2, 1]})
    ax1.axhline((DEFAULT_VEHICLE.empty_mass_kg + ep["load_kg"]) / 1000, color="k", lw=2, label="true mass")
    ax1.axhline((DEFAULT_VEHICLE.empty_mass_kg + 0.5 * DEFAULT_VEHICLE.rated_load_kg) / 1000, color="0.6", ls=":",
                label="prior (none)")
    for name in names:
        if name == "none":
            continue
        base, opts = _split(name)
        est = estimators.make(base, **opts)
        m = np.empty(n)
        for i, row in enumerate(zip(*[s[k].tolist() for k in SENSOR_KEYS])):
            m[i] = est.update(row[0], row[1], row[2], dt, row[3], row[4], row[5]).mass_kg
        ax1.plot(t, m / 1000, label=name.replace("@before", " (before)"))
    ax1.set_ylabel("mass (t)")
    ax1.legend(fontsize=8, ncol=2)
    ax1.set_title(f"UUOM-Track-v0 episode (rule-based controller), load {ep['load_kg'] / 1000:.1f} t")
    ax2.plot(t, s["speed_mps"], color="C0", lw=0.8)
    ax2.set_ylabel("speed (m/s)")
    ax3 = ax2.twinx()
    ax3.plot(t, np.degrees(ep["slope_true"]), color="C3", lw=0.8)
    ax3.set_ylabel("slope (deg)", color="C3")
    ax2.set_xlabel("t (s)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    print(f"wrote {path}", file=sys.stderr)


def _table(title: str, names: list[str], res: dict[str, list[tuple[float, float]]]) -> None:
    print(f"\n{title}")
    print("| observer | mean abs mass err % | median | worst | slope RMSE deg (mean) |")
    print("| --- | --- | --- | --- | --- |")
    for n in names:
        arr = np.array(res[n], dtype=float)
        me = arr[:, 0]
        print(f"| {n} | {np.nanmean(me):.1f} | {np.nanmedian(me):.1f} | {np.nanmax(me):.1f} | "
              f"{np.nanmean(arr[:, 1]):.2f} |")


def main(argv: list[str] | None = None) -> int:
    global ARGS
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--mode", choices=("closed", "replay", "offline"), default="closed")
    p.add_argument("--seeds", default="200000:200010", help="a:b (range) or comma list")
    p.add_argument("--estimators", default=DEFAULT_ESTIMATORS, help="names, comma- or space-separated in one argument; 'none' = the fixed prior")
    p.add_argument("--controller", default="rule-based", help="rule-based or oracle")
    p.add_argument("--drive-observer", default="dffrls-aekf", help="replay mode: observer while recording")
    p.add_argument("--settle-s", type=float, default=10.0)
    p.add_argument("--cache", default="", help="replay mode: folder to keep recorded episodes in")
    p.add_argument("--figure", default="", help="replay mode: write a PNG of the first seed's mass estimates")
    p.add_argument("--verbose", action="store_true", help="print every episode")
    ARGS = p.parse_args(argv)
    names = names_argument(p, ARGS.estimators, also=["none", *(f"{k}@before" for k in BEFORE_OPTIONS)])
    seeds = _seeds(ARGS.seeds)
    res: dict[str, list[tuple[float, float]]] = {n: [] for n in names}
    t0 = time.perf_counter()
    trips = {n: 0 for n in names}
    if ARGS.mode == "closed":
        for seed in seeds:
            for n in names:
                obs_name, opts = _split(n)
                ep = _episode(obs_name, seed, ARGS.controller, observer_options=opts)
                st = ep["steps"]
                e = _errors(st[:, 0], st[:, 1], st[:, 2], st[:, 3], st[:, 4], ARGS.settle_s)
                res[n].append(e)
                trips[n] += ep["termination"] == "overspeed_trip"
                if ARGS.verbose:
                    print(f"seed {seed} load {ep['load_kg'] / 1000:.1f} t {n}: mass {e[0]:.1f} % slope {e[1]:.2f} deg"
                          f" ({ep['termination']}, {st[-1, 0]:.0f} s)", flush=True)
        title = f"closed loop, controller {ARGS.controller}, seeds {ARGS.seeds}, after {ARGS.settle_s:g} s"
    elif ARGS.mode == "replay":
        for seed in seeds:
            ep = _recorded(seed)
            line = [f"seed {seed} load {ep['load_kg'] / 1000:.1f} t"]
            for n in names:
                e = _replay(ep, n)
                res[n].append(e)
                line.append(f"{n} {e[0]:.1f}%/{e[1]:.2f}")
            if ARGS.verbose:
                print(" | ".join(line), flush=True)
        if ARGS.figure:
            _figure(_recorded(seeds[0]), names, ARGS.figure)
        title = (f"replay (recorded with {ARGS.controller} on {ARGS.drive_observer}), seeds {ARGS.seeds}, "
                 f"after {ARGS.settle_s:g} s")
    else:
        import estimators
        from uuom_gym.sim.recording import simulate_run
        from uuom_gym.sim.track import random_track

        for seed in seeds:
            rng = np.random.default_rng(seed)
            load = float(rng.uniform(0, 20000))
            prof = random_track(rng, length_m=(150, 250), load_kg=load)
            tr = simulate_run(prof, seed=seed, load_kg=load, duration_s=150)
            line = [f"seed {seed} load {load / 1000:.1f} t"]
            for n in names:
                if n == "none":
                    m_est = np.full(len(tr["t_s"]), 26000.0)
                    th = np.zeros(len(tr["t_s"]))
                else:
                    s = estimators.make(_split(n)[0], **_split(n)[1]).run(tr)
                    m_est, th = s.mass_kg, np.radians(s.slope_deg)
                e = _errors(tr["t_s"], tr["mass_kg"], m_est, np.radians(tr["slope_deg"]), th, ARGS.settle_s)
                res[n].append(e)
                line.append(f"{n} {e[0]:.1f}%/{e[1]:.2f}")
            if ARGS.verbose:
                print(" | ".join(line), flush=True)
        title = f"offline simulate_run random tracks, seeds {ARGS.seeds}, after {ARGS.settle_s:g} s"
    _table(title, names, res)
    if ARGS.mode == "closed":
        print("overspeed trips (episodes): " + ", ".join(f"{n} {trips[n]}" for n in names))
    print(f"({time.perf_counter() - t0:.0f} s wall)", file=sys.stderr)
    return 0


ARGS: argparse.Namespace

if __name__ == "__main__":
    raise SystemExit(main())
