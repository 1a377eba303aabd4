"""``uuom-estimate``: run an online estimator over a recorded trace (``shared/spec/trace-format.md``).

::

    uuom-estimate TRACE.csv --vehicle VEHICLE.toml --estimator NAME --out ESTIMATES.csv [--settle-s 10] [--json]
    uuom-estimate --list

Writes one row per input row (``t_s, mass_kg, slope_deg, mass_std_kg, slope_std_deg``; only what the estimator
estimates; 9 significant digits, time exactly as read) atomically, reading, estimating and writing block by block
so that a log hours long needs no more memory than a short one, and when the trace has truth columns prints per
quantity the RMSE and the maximum absolute error over the samples after the settle time (mass also in percent). Bad
input gives one line ``uuom-estimate: error: FILE:LINE: ...`` on stderr and exit status 2; Ctrl-C one line and
status 130. In every case the output file is untouched unless the run completed, and the input is never written.
``docs/cli.md`` lists the guarantees and every bad input with its message.
"""

from __future__ import annotations

import argparse
import ast
import json
import math
import os
import re
import signal
import sys
import warnings
from contextlib import nullcontext
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from uuom_core.atomic_write import OutputPathError, check_output_path, remove_stale_temps
from uuom_core.trace import TRUTH_COLUMNS as _TRUTH_COLUMNS
from uuom_core.trace import Trace, TraceBlocks, TraceFormatError, TraceWarning, csv_writer_atomic
from uuom_core.vehicle import DEFAULT_VEHICLE, VehicleFileError, VehicleParams

from .base import EstimateSeries
from .metrics import ErrorAccumulator, chi2_band
from .option_ranges import check_option_values
from .registry import UnknownEstimatorError, available, get_class, parse_names

__all__ = ["main", "summarize", "EXIT_BAD_INPUT", "EXIT_INTERRUPTED", "output_columns", "names_argument"]

EXIT_BAD_INPUT = 2
EXIT_INTERRUPTED = 130
"""128 + SIGINT, what a shell reports for Ctrl-C (SIGTERM gives 143)."""
PROG = "uuom-estimate"

ESTIMATE_FORMAT = "%.9g"
"""Estimates are written with 9 significant digits (a mass to 0.1 g, a slope to 1e-7 deg: far below any estimator's
uncertainty), twice as fast to format as the exact shortest form; ``t_s`` is written exactly as read."""

_NEEDS: dict[str, tuple[str, ...]] = {
    "imu-ukf": ("gyro_radps", "accel_normal_mps2"),
    "aupf": ("motor_speed_radps",),
}
"""Trace columns without which an estimator can only report its prior (unless its class says ``needs``)."""

_QUANTITY_COLUMNS: dict[str, tuple[str, ...]] = {
    "mass": ("mass_kg", "mass_std_kg"),
    "slope": ("slope_deg", "slope_std_deg"),
    "mu": ("mu", "mu_std"),
    "slip": ("slip_ratio", "slip_ratio_std"),
    "radius": ("drive_radius_m", "drive_radius_m_std"),
}


class _CliError(Exception):
    """A bad-input error already formatted as one line."""


class _Terminated(BaseException):
    """SIGTERM, turned into an exception so that the same clean-up as for Ctrl-C runs."""


TUNED_SAMPLE_HZ = 200.0
"""The sample rate of the env and of every run the estimators were tuned on."""

RATE_NOTE_TOLERANCE = 0.2
"""A trace whose median rate is more than this fraction away from :data:`TUNED_SAMPLE_HZ` gets a note."""

MOVING_START_MPS = 0.1
"""A log whose first speed readings (the median of the first :data:`START_SAMPLES` valid ones) exceed this begins
in motion and gets a note: the estimators learn the mass mostly from a pull-away from rest (docs/estimation.md,
"Where the mass comes from")."""

START_SAMPLES = 40
"""How many valid speed readings from its start tell how fast a log begins (0.2 s at 200 Hz)."""


def _on_sigterm(signum: int, frame: Any) -> None:
    raise _Terminated()


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


NIS_EVERY_S = 1.0
"""Spacing of the speed-NIS samples the summary averages (as the protocol's NEES and NIS)."""


class _Summary:
    """The error summary accumulated block by block (see :func:`summarize`)."""

    def __init__(self, settle_s: float, provides: frozenset[str] | set[str], columns: Sequence[str]) -> None:
        self.settle_s = settle_s
        self.samples = 0
        self.after = 0
        self._t_start: float | None = None
        self.mass = ("mass_kg" in columns and "mass" in provides)
        self.slope = ("slope_deg" in columns and "slope" in provides)
        self._kg = ErrorAccumulator(settle_s)
        self._pct = ErrorAccumulator(settle_s, relative=True)
        self._deg = ErrorAccumulator(settle_s)
        self._nis: list[float] = []  # one speed NIS a second after the settle time (needs no truth)
        self._nis_next = -math.inf

    def add(self, part: Trace, mass_kg: np.ndarray, slope_deg: np.ndarray, nis: np.ndarray | None = None) -> None:
        t = part["t_s"]
        if self._t_start is None:
            self._t_start = float(t[0]) + self.settle_s
            self._nis_next = self._t_start
        if nis is not None:
            # the first finite value at or after each whole second: the grid of metrics.nis_consistency, per block
            for i in np.flatnonzero(np.isfinite(nis) & (t >= self._nis_next)):
                if t[i] >= self._nis_next:
                    self._nis.append(float(nis[i]))
                    self._nis_next += NIS_EVERY_S * (1 + math.floor((t[i] - self._nis_next) / NIS_EVERY_S))
        self.samples += len(t)
        self.after += int(np.count_nonzero(t >= self._t_start))
        if self.mass:
            self._kg.add(t, mass_kg, part["mass_kg"])
            self._pct.add(t, mass_kg, part["mass_kg"])
        if self.slope:
            self._deg.add(t, slope_deg, part["slope_deg"])

    def result(self) -> dict[str, Any]:
        out: dict[str, Any] = {"samples": self.samples, "settle_s": float(self.settle_s),
                               "samples_after_settle": self.after}
        if self.mass:
            kg, pct = self._kg.result(), self._pct.result()
            out["mass"] = None if kg is None or pct is None else {
                "rmse_kg": kg.rmse, "max_abs_error_kg": kg.max_abs, "rmse_pct": pct.rmse,
                "max_abs_error_pct": pct.max_abs, "samples": kg.samples}
        if self.slope:
            deg = self._deg.result()
            out["slope"] = None if deg is None else {
                "rmse_deg": deg.rmse, "max_abs_error_deg": deg.max_abs, "samples": deg.samples}
        if self._nis:
            lo, hi = chi2_band(len(self._nis))
            mean = float(np.mean(self._nis))
            out["speed_nis"] = {"mean": mean, "band_low": lo, "band_high": hi, "in_band": bool(lo <= mean <= hi),
                                "samples": len(self._nis)}
        return out


def summarize(trace: Trace, series: EstimateSeries, settle_s: float = 10.0,
              provides: frozenset[str] | set[str] = frozenset({"mass", "slope"})) -> dict[str, Any]:
    """Error summary after ``settle_s`` seconds from the start of the trace, for the truth columns present.

    Only quantities in ``provides`` (what the estimator estimates) are scored. Samples where the truth is missing
    (empty cell) are left out (:func:`estimators.metrics.error_after_settling`). Returns a JSON-ready dict.
    """
    summary = _Summary(settle_s, provides, list(trace.columns))
    summary.add(trace, series.mass_kg, series.slope_deg, series.extras.get("nis"))
    return summary.result()


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
        lines.append("  (no error summary: the trace has no truth for what this estimator estimates)")
    if "speed_nis" in s:
        n = s["speed_nis"]
        lines.append(f"  speed NIS (no truth needed): {n['mean']:.2f}, {'inside' if n['in_band'] else 'outside'} its "
                     f"chi2 95 % band [{n['band_low']:.2f}, {n['band_high']:.2f}] ({n['samples']} samples, one a second)")
    return "\n".join(lines)


def output_columns(provides: frozenset[str] | set[str]) -> list[str]:
    """Output CSV columns for an estimator that estimates ``provides`` (see ``Estimator.provides``).

    A mass/slope estimator gets the contract's ``t_s, mass_kg, slope_deg, mass_std_kg, slope_std_deg`` (a quantity
    it does not estimate is left out, not written as its prior); one that estimates neither (``aupf``) gets its own
    quantities instead.
    """
    cols = ["t_s"]
    main = [q for q in ("mass", "slope") if q in provides]
    if main:
        cols += [_QUANTITY_COLUMNS[q][0] for q in main] + [_QUANTITY_COLUMNS[q][1] for q in main]
    else:
        for q in ("mu", "slip", "radius"):
            if q in provides:
                cols += list(_QUANTITY_COLUMNS[q])
    return cols


def _series_column(series: EstimateSeries, name: str) -> np.ndarray:
    if name in ("t_s", "mass_kg", "slope_deg", "mass_std_kg", "slope_std_deg"):
        return np.asarray(getattr(series, name))
    return series.extras[name]


def _estimate_blocks(estimator: Any, blocks: TraceBlocks, columns: list[str], out: str | None,
                     summary: _Summary, needs: Sequence[str], name: str) -> float | None:
    """Read, estimate and write block by block: a long log is never held whole, nor are its estimates.

    Each block continues from the estimator's state and the last time of the block before (the same numbers as one
    ``run()`` over the whole trace, tested). The output is renamed into place only after the last block and the
    end-of-file checks passed. Returns the speed the log begins at (:func:`start_speed_mps`).
    """
    has_values = dict.fromkeys(needs, False)
    t_prev: float | None = None
    start_speed: float | None = None
    formats = ["%r"] + [ESTIMATE_FORMAT] * (len(columns) - 1)  # time exactly as read
    with csv_writer_atomic(out, columns, formats) if out is not None else nullcontext() as writer:
        for part in blocks:
            series = estimator.run(part, reset=t_prev is None, t_prev_s=t_prev)
            t_prev = float(part["t_s"][-1])
            if start_speed is None:  # the first block holding a valid speed (blocks are thousands of rows)
                start_speed = start_speed_mps(part["speed_mps"])
            if writer is not None:
                writer.write([_series_column(series, c) for c in columns])
            summary.add(part, series.mass_kg, series.slope_deg, series.extras.get("nis"))
            for c in has_values:
                has_values[c] = has_values[c] or bool(np.isfinite(part[c]).any())
        lacking = [c for c, ok in has_values.items() if not ok]
        if lacking:
            raise _CliError(f"{blocks.path}:1: --estimator {name} needs column(s) {', '.join(lacking)}, "
                            f"which the trace lacks (or has no values in)")
    return start_speed


def start_speed_mps(speed_mps: np.ndarray) -> float | None:
    """The speed a log begins at: the median of its first :data:`START_SAMPLES` valid readings (None: none valid)."""
    valid = speed_mps[np.isfinite(speed_mps)][:START_SAMPLES]
    return float(np.median(valid)) if len(valid) else None


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog=PROG, description="Estimate mass and slope from a recorded monorail trace.")
    p.add_argument("trace", nargs="?", help="trace CSV (t_s, torque_nm, speed_mps, accel_mps2, ...)")
    p.add_argument("--vehicle", metavar="VEHICLE.toml", help="vehicle file ([vehicle] table); default vehicle if omitted")
    p.add_argument("--estimator", default="dffrls-aekf", metavar="NAME", help="estimator name (default dffrls-aekf)")
    p.add_argument("--out", metavar="ESTIMATES.csv",
                   help="output CSV, written whole or not at all (never a symlink, device or the input)")
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help="estimator option, repeatable; VALUE a Python literal (e.g. train_length_m=12 gives "
                        "dffrls-aekf the 12 m slope window fixed instead of learning the geometry)")
    p.add_argument("--settle-s", type=float, default=10.0, help="convergence time excluded from the errors (s)")
    p.add_argument("--json", action="store_true", help="print the summary as JSON on stdout")
    p.add_argument("--list", action="store_true", help="list the estimators (name and what each estimates) and exit")
    return p


def names_argument(parser: argparse.ArgumentParser, given: str | Sequence[str] | None, *,
                   default: Sequence[str] = (), also: Sequence[str] = (), option: str = "--estimators") -> list[str]:
    """A script's estimator-list option, checked: names comma- or space-separated (``default`` when not given).

    An empty list or an unregistered name is a usage error (``parser.error``: one line naming it, exit status 2)
    before any work starts, instead of a traceback halfway through a benchmark. ``also`` are names the script
    itself understands (e.g. ``"none"``, the fixed prior).
    """
    if given is None:
        return list(default)
    try:
        return parse_names(given, also=also)
    except (ValueError, UnknownEstimatorError) as exc:
        parser.error(f"{option}: {exc}")
        raise  # parser.error exits; this keeps type checkers content


def _list() -> int:
    ok, broken = _usable_estimators()
    for name in ok:
        provides = sorted(get_class(name).provides)
        print(f"{name}\t{','.join(provides)}")
    for name, why in broken.items():
        print(f"{PROG}: note: {name} unavailable ({why})", file=sys.stderr)
    return 0


def _parse_options(items: Sequence[str]) -> dict[str, Any]:
    """``KEY=VALUE`` strings as keyword options; VALUE a Python literal (``true`` / ``false`` as well as ``True`` /
    ``False``), else the string itself (which an option that wants a number or a switch refuses, naming itself)."""
    options: dict[str, Any] = {}
    for item in items:
        key, sep, text = item.partition("=")
        if not sep or not key.strip().isidentifier():
            raise _CliError(f"--option {item!r}: expected KEY=VALUE with KEY an option name")
        text = text.strip()
        try:
            value = ast.literal_eval(text)
        except (ValueError, SyntaxError):
            value = {"true": True, "false": False}.get(text.lower(), text)
        options[key.strip()] = value
    return options


def _make(cls: type, vehicle, name: str, items: Sequence[str]):
    """The estimator with its ``--option`` values; a bad option is a one-line error naming it."""
    options = _parse_options(items)
    try:
        check_option_values("", options)  # (the message below names the estimator)
        return cls(vehicle, **options)
    except (TypeError, ValueError) as exc:
        raise _CliError(f"--option: {name}: {exc}") from None


def _run(args: argparse.Namespace) -> int:
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
    provides = frozenset(cls.provides)
    columns = output_columns(provides)
    if len(columns) == 1:
        raise _CliError(f"--estimator: {args.estimator} estimates nothing uuom-estimate can write")
    vehicle = _load_vehicle(args.vehicle)
    estimator = _make(cls, vehicle, args.estimator, args.option)
    if args.out is not None:
        inputs = [args.trace] + ([args.vehicle] if args.vehicle else [])
        try:
            check_output_path(args.out, inputs)
        except OutputPathError as exc:
            raise _CliError(str(exc)) from None
        remove_stale_temps(args.out)  # left by a run that was killed (SIGKILL) while writing
    try:
        blocks = TraceBlocks(args.trace, columns=tuple(cls.inputs) + _TRUTH_COLUMNS)
    except TraceFormatError as exc:
        raise _CliError(str(exc)) from None
    needs = tuple(getattr(cls, "needs", _NEEDS.get(args.estimator, ())))
    absent = [c for c in needs if c not in blocks.columns]
    if absent:
        raise _CliError(f"{args.trace}:1: --estimator {args.estimator} needs column(s) {', '.join(absent)}, "
                        f"which the trace lacks (or has no values in)")
    if not {"mass", "slope"} <= provides:
        print(f"{PROG}: note: {args.estimator} estimates {', '.join(sorted(provides))}; "
              f"writing {', '.join(columns)}", file=sys.stderr)
    scores = _Summary(args.settle_s, provides, blocks.columns)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", TraceWarning)
        try:
            start_speed = _estimate_blocks(estimator, blocks, columns, args.out, scores, needs, args.estimator)
        except TraceFormatError as exc:
            raise _CliError(str(exc)) from None
        except OSError as exc:
            raise _CliError(f"{args.out}: cannot write: {exc.strerror or exc}") from None
        except ValueError as exc:  # an estimator that output inf: a bug, but the old file stays
            raise _CliError(f"{args.out}: not written: {exc}") from None
    for w in caught:
        print(f"{PROG}: warning: {w.message}", file=sys.stderr)
    summary = scores.result()
    sample_hz = 1.0 / blocks.median_dt_s if blocks.median_dt_s > 0 else None
    summary["sample_hz"] = sample_hz
    if sample_hz is not None and abs(sample_hz / TUNED_SAMPLE_HZ - 1.0) > RATE_NOTE_TOLERANCE:
        print(f"{PROG}: note: {args.trace}: sampled at {sample_hz:.4g} Hz (median interval "
              f"{1000.0 * blocks.median_dt_s:.4g} ms); the estimators' settings are per {TUNED_SAMPLE_HZ:g} Hz "
              f"sample — on 100 / 50 Hz logs expect up to ~2x the mass error; dffrls-aekf and fused take --option "
              f"rate_from_trace=True for settings per second (docs/estimation.md, \"Logs at other sample rates\")",
              file=sys.stderr)
    summary["start_speed_mps"] = start_speed
    if start_speed is not None and abs(start_speed) > MOVING_START_MPS and "mass" in provides:
        print(f"{PROG}: note: {args.trace}: the log begins in motion ({start_speed:.2f} m/s); the estimators learn the "
              f"mass mostly from a pull-away from rest, and on the protocol's runs begun 15 s in the median max mass error "
              f"after 10 s is 14-23 % instead of 2-5 % — read mass_std_kg (docs/estimation.md, \"Where the mass comes "
              f"from\")", file=sys.stderr)
    summary["estimator"] = args.estimator
    summary["trace"] = str(args.trace)
    if args.json:
        print(json.dumps(summary, indent=2))
    else:
        print(_format_summary(summary, args.estimator, str(args.trace)))
    return 0


def main(argv: Sequence[str] | None = None) -> int:
    """Console entry point; returns the exit status.

    Exit status: 0 done, 2 bad input (one line on stderr, output untouched), 130 interrupted by SIGINT and 143 by
    SIGTERM (one line on stderr, output untouched, no temporary file left).
    """
    args = _parser().parse_args(argv)
    if args.list:
        return _list()
    previous = None
    try:
        previous = signal.signal(signal.SIGTERM, _on_sigterm)
    except ValueError:
        pass  # not the main thread: leave SIGTERM alone
    try:
        return _run(args)
    except _CliError as exc:
        print(f"{PROG}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except (KeyboardInterrupt, _Terminated) as exc:
        kept = ""
        if args.out is not None:
            kept = f"; {args.out} " + ("not changed" if os.path.lexists(args.out) else "not written")
        print(f"{PROG}: interrupted{kept}", file=sys.stderr)
        return 143 if isinstance(exc, _Terminated) else EXIT_INTERRUPTED
    except BrokenPipeError:
        # stdout closed early (`uuom-estimate ... | head`): the output file is already complete
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
