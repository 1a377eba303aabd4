"""``uuom-estimate``: run an online estimator over a recorded trace (``shared/spec/trace-format.md``).

::

    uuom-estimate TRACE.csv --vehicle VEHICLE.toml --estimator NAME --out ESTIMATES.csv [--settle-s 10] [--json]
    uuom-estimate --list

Writes one row per input row (``t_s, mass_kg, slope_deg, mass_std_kg, slope_std_deg``; for an estimator whose
``outputs`` differ, e.g. ``aupf`` or ``imu-ukf``, only its own quantities: see :func:`output_columns`) atomically,
and when the trace has truth columns prints per estimated quantity the RMSE and the maximum absolute error over the
samples after the settle time (mass also in percent). Bad input gives one line ``uuom-estimate: error: FILE:LINE: ...`` on stderr
and exit status 2; the output file is then not touched.
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from uuom_core.trace import Trace, TraceFormatError, read_trace_csv, write_csv_atomic
from uuom_core.vehicle import DEFAULT_VEHICLE, VehicleFileError, VehicleParams

from .base import EstimateSeries
from .metrics import error_after_settling, settled_mask
from .registry import UnknownEstimatorError, available, get_class

__all__ = ["main", "summarize", "EXIT_BAD_INPUT"]

EXIT_BAD_INPUT = 2
PROG = "uuom-estimate"


class _CliError(Exception):
    """A bad-input error already formatted as one line."""


def _usable_estimators() -> tuple[list[str], dict[str, str]]:
    ok: list[str] = []
    broken: dict[str, str] = {}
    for name in available():
        try:
            get_class(name)
            ok.append(name)
        except Exception as exc:  # a method whose module is missing or broken must not hide the others
            broken[name] = f"{type(exc).__name__}: {exc}".splitlines()[0]
    return ok, broken


def _vehicle_error_with_line(path: Path, exc: VehicleFileError) -> str:
    """Add the line of the offending key to a vehicle-file error (``FILE:LINE: ...``)."""
    msg = str(exc)
    prefix = f"{path}: "
    if msg.startswith(prefix):
        msg = msg[len(prefix):]
    try:
        lines = path.read_text(encoding="utf-8", errors="replace").splitlines()
    except OSError:
        return f"{path}: {msg}"
    # TOML decode errors carry "(at line N, column M)"
    m = re.search(r"at line (\d+), column (\d+)", msg)
    if m:
        return f"{path}:{m.group(1)}: column {m.group(2)}: {msg}"
    keys = re.findall(r"\b([a-z_][a-z0-9_]*)\b", msg)
    for key in keys:
        pat = re.compile(rf"^\s*{re.escape(key)}\s*=")
        for i, line in enumerate(lines, start=1):
            if pat.match(line):
                return f"{path}:{i}: key '{key}': {msg}"
    return f"{path}:1: {msg}"


def _load_vehicle(path: str | None) -> VehicleParams:
    if path is None:
        return DEFAULT_VEHICLE
    p = Path(path)
    try:
        return VehicleParams.from_toml(p)
    except VehicleFileError as exc:
        if not p.exists():
            raise _CliError(f"{p}: no such vehicle file") from None
        raise _CliError(_vehicle_error_with_line(p, exc)) from None
    except (OSError, UnicodeDecodeError) as exc:
        raise _CliError(f"{p}:1: cannot read vehicle file: {exc}") from None


def summarize(trace: Trace, series: EstimateSeries, settle_s: float = 10.0) -> dict[str, Any]:
    """Error summary after ``settle_s`` seconds from the start of the trace, for the truth columns present.

    Samples where the truth is missing (empty cell) are left out (:func:`estimators.metrics.error_after_settling`).
    Returns a JSON-ready dict.
    """
    t = trace["t_s"]
    after = settled_mask(t, settle_s)
    out: dict[str, Any] = {"samples": int(len(trace)), "settle_s": float(settle_s),
                           "samples_after_settle": int(np.count_nonzero(after))}
    if "mass_kg" in trace:
        kg = error_after_settling(t, series.mass_kg, trace["mass_kg"], settle_s)
        pct = error_after_settling(t, series.mass_kg, trace["mass_kg"], settle_s, relative=True)
        out["mass"] = None if kg is None or pct is None else {
            "rmse_kg": kg.rmse, "max_abs_error_kg": kg.max_abs, "rmse_pct": pct.rmse,
            "max_abs_error_pct": pct.max_abs, "samples": kg.samples}
    if "slope_deg" in trace:
        deg = error_after_settling(t, series.slope_deg, trace["slope_deg"], settle_s)
        out["slope"] = None if deg is None else {
            "rmse_deg": deg.rmse, "max_abs_error_deg": deg.max_abs, "samples": deg.samples}
    return out


def _format_summary(s: dict[str, Any], name: str, source: str) -> str:
    lines = [f"{source}: {name}, {s['samples']} samples, errors after {s['settle_s']:g} s "
             f"({s['samples_after_settle']} samples)"]
    if "mass" in s:
        m = s["mass"]
        lines.append("  mass : no truth after the settle time" if m is None else
                     f"  mass : RMSE {m['rmse_kg']:.1f} kg ({m['rmse_pct']:.2f} %), "
                     f"max |error| {m['max_abs_error_kg']:.1f} kg ({m['max_abs_error_pct']:.2f} %)")
    if "slope" in s:
        m = s["slope"]
        lines.append("  slope: no truth after the settle time" if m is None else
                     f"  slope: RMSE {m['rmse_deg']:.3f} deg, max |error| {m['max_abs_error_deg']:.3f} deg")
    if "mass" not in s and "slope" not in s:
        lines.append("  (no truth columns: no error summary)")
    return "\n".join(lines)


def output_columns(outputs: Sequence[str], series: EstimateSeries) -> tuple[list[str], list[np.ndarray]]:
    """Header and columns of the estimates file: ``t_s``, then the estimator's declared outputs
    (``Estimator.outputs``), then their standard deviations where it gives them.

    ``mass`` -> ``mass_kg`` / ``mass_std_kg``, ``slope`` -> ``slope_deg`` / ``slope_std_deg``, any other output
    -> its ``extras`` key / ``KEY_std``. A quantity the estimator does not estimate (the prior mass of ``imu-ukf``
    and ``aupf``) is not written.
    """
    values: list[tuple[str, np.ndarray]] = []
    stds: list[tuple[str, np.ndarray]] = []
    for key in outputs:
        if key == "mass":
            values.append(("mass_kg", series.mass_kg))
            stds.append(("mass_std_kg", series.mass_std_kg))
        elif key == "slope":
            values.append(("slope_deg", series.slope_deg))
            stds.append(("slope_std_deg", series.slope_std_deg))
        else:
            values.append((key, series.extras[key]))
            if key + "_std" in series.extras:
                stds.append((key + "_std", series.extras[key + "_std"]))
    pairs = [("t_s", series.t_s), *values, *stds]
    return [k for k, _ in pairs], [v for _, v in pairs]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description="Estimate mass and slope from a recorded monorail trace.")
    p.add_argument("trace", nargs="?", help="trace CSV (t_s, torque_nm, speed_mps, accel_mps2, ...)")
    p.add_argument("--vehicle", metavar="VEHICLE.toml", help="vehicle file ([vehicle] table); default vehicle if omitted")
    p.add_argument("--estimator", default="dffrls-aekf", metavar="NAME", help="estimator name (default dffrls-aekf)")
    p.add_argument("--out", metavar="ESTIMATES.csv", help="output CSV, written atomically")
    p.add_argument("--settle-s", type=float, default=10.0, help="convergence time excluded from the errors (s)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.add_argument("--list", action="store_true", help="list the estimators and exit")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point; returns the exit status."""
    args = _parser().parse_args(argv)
    if args.list:
        ok, broken = _usable_estimators()
        for name in ok:
            print(name)
        for name, why in broken.items():
            print(f"{PROG}: note: {name} unavailable ({why})", file=sys.stderr)
        return 0
    try:
        if args.trace is None:
            raise _CliError("no trace file given (usage: uuom-estimate TRACE.csv --estimator NAME --out OUT.csv)")
        if not (math.isfinite(args.settle_s) and args.settle_s >= 0):
            raise _CliError(f"--settle-s must be a finite number >= 0, got {args.settle_s!r}")
        try:
            cls = get_class(args.estimator)
        except UnknownEstimatorError as exc:
            raise _CliError(f"--estimator: {exc}") from None
        except Exception as exc:
            raise _CliError(f"--estimator: {args.estimator!r} cannot be loaded: {exc}") from None
        vehicle = _load_vehicle(args.vehicle)
        try:
            trace = read_trace_csv(args.trace)
        except TraceFormatError as exc:
            raise _CliError(str(exc)) from None
        if args.out is not None:
            out_dir = Path(args.out).parent
            if str(out_dir) and not out_dir.is_dir():
                raise _CliError(f"{args.out}: output directory {out_dir} does not exist")
        series = cls(vehicle).run(trace)
        if tuple(cls.outputs) != ("mass", "slope"):
            print(f"{PROG}: note: {args.estimator} estimates {', '.join(cls.outputs)} only; "
                  f"only those columns are written and scored", file=sys.stderr)
        if args.out is not None:
            try:
                write_csv_atomic(args.out, *output_columns(cls.outputs, series))
            except OSError as exc:
                raise _CliError(f"{args.out}: cannot write: {exc.strerror or exc}") from None
    except _CliError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    summary = summarize(trace, series, args.settle_s)
    for key in ("mass", "slope"):  # a prior placeholder is not an estimate: no error summary for it
        if key not in cls.outputs:
            summary.pop(key, None)
    summary["estimator"] = args.estimator
    summary["trace"] = str(args.trace)
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(_format_summary(summary, args.estimator, str(args.trace)))
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
