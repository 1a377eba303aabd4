"""Recorded traces: the CSV contract of ``shared/spec/trace-format.md``.

A :class:`Trace` is a set of equally long float columns, one row per sensor sample. Empty cells are missing samples
and become ``NaN`` in memory; literal ``nan``/``inf`` text in a file is an error (a logger that wrote it is broken),
and so are numbers no sensor gives (:data:`PLAUSIBLE_ABS_MAX`) and a time column in other units than seconds.
Parsing is in :mod:`uuom_core.trace_csv` (a fast columnar path, an exact fallback); writing is atomic
(:mod:`uuom_core.trace_write`, :mod:`uuom_core.atomic_write`): the file appears whole or not at all. Long logs can be
read block by block (:class:`TraceBlocks`) with the same checks.
"""

from __future__ import annotations

import math
import os
import stat
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO, Iterable, Iterator, Mapping

import numpy as np

from uuom_core.trace_csv import (RawColumns, TraceFormatError, TraceWarning, iter_blocks, parse_exact, parse_fast,
                                 read_header)
from uuom_core.trace_write import CsvColumnWriter, csv_writer_atomic, write_csv_atomic

REQUIRED_COLUMNS: tuple[str, ...] = ("t_s", "torque_nm", "speed_mps", "accel_mps2")
"""Columns every trace must have."""

OPTIONAL_COLUMNS: tuple[str, ...] = ("motor_speed_radps", "mass_kg", "slope_deg")
"""Columns of the contract that a trace may have."""

EXTRA_COLUMNS: tuple[str, ...] = (
    "gyro_radps",  # pitch-rate gyro of the vehicle IMU (project extension, issue 6)
    "accel_normal_mps2",  # IMU accelerometer axis normal to the track (project extension)
    "slip_ratio",  # true drive slip (simulation only)
    "drive_radius_m",  # true effective drive-wheel radius (simulation only)
    "true_speed_mps",  # true ground speed (simulation only)
    "sway_rad",  # true load swing angle (simulation only)
    "position_m",  # true distance along the track (simulation only)
)
"""Columns the project's own recordings add; other readers ignore them."""

TRUTH_COLUMNS: tuple[str, ...] = ("mass_kg", "slope_deg")

SENSOR_COLUMNS: tuple[str, ...] = (
    "torque_nm",
    "speed_mps",
    "accel_mps2",
    "motor_speed_radps",
    "gyro_radps",
    "accel_normal_mps2",
)
"""The measured channels (what the simulated sensors report), in the order of ``Estimator.update``'s arguments."""


@dataclass
class Trace:
    """Sensor samples (and, where known, truth) as float64 columns of equal length.

    Parameters
    ----------
    columns : mapping of str to array_like
        Must contain :data:`REQUIRED_COLUMNS`. Missing samples are ``NaN``.
    source : str, optional
        Where the trace came from (file path or a description), used in messages.
    meta : dict of str to str, optional
        Free-form annotations.
    warnings : list of str, optional
        What the reader found legal but suspicious (one line each).
    """

    columns: dict[str, np.ndarray]
    source: str = "<memory>"
    meta: dict[str, str] = field(default_factory=dict)
    warnings: list[str] = field(default_factory=list)

    def __post_init__(self) -> None:
        self.columns = {k: np.asarray(v, dtype=np.float64) for k, v in self.columns.items()}
        missing = [c for c in REQUIRED_COLUMNS if c not in self.columns]
        if missing:
            raise TraceFormatError(f"{self.source}: missing required column(s): {', '.join(missing)}")
        lengths = {k: len(v) for k, v in self.columns.items()}
        if len(set(lengths.values())) > 1:
            raise TraceFormatError(f"{self.source}: columns differ in length: {lengths}")

    def __len__(self) -> int:
        return len(self.columns["t_s"])

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def __contains__(self, name: object) -> bool:
        return name in self.columns

    def get(self, name: str) -> np.ndarray | None:
        return self.columns.get(name)

    @property
    def has_truth(self) -> bool:
        return all(c in self.columns for c in TRUTH_COLUMNS)

    @property
    def duration_s(self) -> float:
        t = self.columns["t_s"]
        return float(t[-1] - t[0]) if len(t) > 1 else 0.0

    def from_time(self, t_s: float) -> Trace:
        """The samples at or after ``t_s``: a log that begins there (a logger switched on with the train in motion).

        Raises ``ValueError`` when ``t_s`` is not finite or no sample is left."""
        if not math.isfinite(t_s):
            raise ValueError(f"{self.source}: from_time needs a finite time, got {t_s!r}")
        keep = self.columns["t_s"] >= t_s
        if not keep.any():
            raise ValueError(f"{self.source}: no sample at or after t = {t_s} s (the trace ends at "
                             f"{self.columns['t_s'][-1] if len(self) else 'its start'})")
        return Trace({k: v[keep] for k, v in self.columns.items()}, self.source,
                     {**self.meta, "from_time_s": f"{t_s:g}"}, list(self.warnings))


PLAUSIBLE_ABS_MAX: dict[str, float] = {
    "t_s": 1e10,  # Unix time in seconds is 1.7e9; milliseconds are caught by the sample-interval check
    "torque_nm": 1e7,
    "speed_mps": 1e3,
    "accel_mps2": 1e4,
    "motor_speed_radps": 1e5,
    "mass_kg": 1e8,
    "slope_deg": 90.0,
    "gyro_radps": 1e3,
    "accel_normal_mps2": 1e4,
    "slip_ratio": 1e3,
    "drive_radius_m": 1e2,
    "true_speed_mps": 1e3,
    "sway_rad": 1e2,
    "position_m": 1e9,
}
"""Largest magnitude each column may take. Far beyond any monorail (a sensor glitch such as ``1e300`` is an
error, not a sample): their job is to keep absurd numbers away from the estimators, not to judge the physics."""

SAMPLE_INTERVAL_RANGE_S: tuple[float, float] = (1e-3, 1.0)
"""The median sample interval must lie in this range (1 kHz to 1 Hz); outside it the time column is in other
units (milliseconds) or the file is not a sensor log."""

DROPOUT_WARN_S = 1.0
"""Time steps longer than this are reported as dropouts (a warning)."""

MAX_GAP_S = 86_400.0
"""A time step longer than this (a day) is an error: two logs joined, or a broken clock."""

SPARSE_WARN_FRACTION = 0.5
"""A required column empty in more than this fraction of rows gets a warning."""


class _Checker:
    """Checks what the parsed numbers mean, one block of rows at a time (a whole file is one block).

    :meth:`check` raises :class:`TraceFormatError` at the first bad row of a block; :meth:`finish` raises what only
    the whole file can show (no rows, the median sample interval, a column with no values) and returns the
    warning lines. Reading in blocks and reading whole give the same errors and warnings.
    """

    def __init__(self, path: str) -> None:
        self.path = path
        self.rows = 0
        self._last_t: float | None = None
        self._last_line = 0
        self._line_row1 = 0
        self._dts: list[np.ndarray] = []
        self._gaps = 0
        self._longest_gap = (0.0, 0)  # (dt, line after the gap)
        self._empty = dict.fromkeys(REQUIRED_COLUMNS[1:], 0)
        self._short = 0
        self._first_short = 0
        self.median_dt_s = math.nan  # set by finish() (two rows or more)

    def check(self, raw: RawColumns) -> None:
        path, cols = self.path, raw.values
        t = cols["t_s"]
        n = len(t)
        if n == 0:
            return
        for name, v in cols.items():
            bad = np.flatnonzero(np.isinf(v))
            if bad.size:
                raise TraceFormatError(
                    f"{path}:{raw.line_of(bad[0])}: column '{name}': value must be finite, "
                    f"got {float(v[bad[0]])!r}"
                )
        missing_t = np.flatnonzero(np.isnan(t))
        if missing_t.size:
            raise TraceFormatError(f"{path}:{raw.line_of(missing_t[0])}: column 't_s': time is empty")
        for name, v in cols.items():
            limit = PLAUSIBLE_ABS_MAX.get(name, math.inf)
            with np.errstate(invalid="ignore"):
                bad = np.flatnonzero(np.abs(v) > limit)
            if bad.size:
                i = bad[0]
                raise TraceFormatError(
                    f"{path}:{raw.line_of(i)}: column '{name}': {float(v[i])!r} is outside the plausible range "
                    f"[-{limit:g}, {limit:g}]" + (f" ({bad.size} such rows)" if bad.size > 1 else "")
                )
        first = self._last_t is None
        dt = np.diff(t) if first else np.diff(t, prepend=self._last_t)
        offset = 1 if first else 0  # dt[k] is the step into row k + offset

        def line(row: int) -> int:  # row -1: the previous block's last
            return raw.line_of(row) if row >= 0 else self._last_line

        back = np.flatnonzero(dt <= 0.0)
        if back.size:
            i = back[0] + offset
            before = float(t[i - 1]) if i >= 1 else self._last_t
            raise TraceFormatError(
                f"{path}:{line(i)}: column 't_s': time not strictly increasing ({float(t[i])!r} after {before!r})"
            )
        huge = np.flatnonzero(dt > MAX_GAP_S)
        if huge.size:
            i = huge[0] + offset
            raise TraceFormatError(
                f"{path}:{line(i)}: column 't_s': time jumps by {dt[huge[0]]:g} s (more than a day) "
                f"after line {line(i - 1)}: two logs joined? split the file there"
            )
        gaps = np.flatnonzero(dt > DROPOUT_WARN_S)
        if gaps.size:
            self._gaps += gaps.size
            j = gaps[np.argmax(dt[gaps])]
            if dt[j] > self._longest_gap[0]:
                self._longest_gap = (float(dt[j]), line(j + offset))
        if not self._line_row1 and self.rows + n >= 2:
            self._line_row1 = raw.line_of(1 - self.rows)
        self._dts.append(dt.astype(np.float32))  # only for the median: half the memory of a long log
        for name in self._empty:
            self._empty[name] += int(np.count_nonzero(np.isnan(cols[name])))
        if raw.short_rows:
            self._short += raw.short_rows
            self._first_short = self._first_short or raw.first_short_line
        self.rows += n
        self._last_t = float(t[-1])
        self._last_line = raw.line_of(n - 1)

    def finish(self) -> list[str]:
        path, n = self.path, self.rows
        if n == 0:
            raise TraceFormatError(f"{path}:2: empty file (header but no samples)")
        warnings_out: list[str] = []
        if n >= 2:
            med = float(np.median(np.concatenate(self._dts)))
            self.median_dt_s = med
            lo, hi = SAMPLE_INTERVAL_RANGE_S
            if not lo <= med <= hi:
                hint = " (time in milliseconds? the column must be in seconds)" if 1.0 < med <= 1000.0 else ""
                raise TraceFormatError(
                    f"{path}:{self._line_row1}: column 't_s': median sample interval {med:g} s is outside "
                    f"{lo:g}-{hi:g} s{hint}"
                )
            if self._gaps:
                longest, line = self._longest_gap
                warnings_out.append(
                    f"{path}: column 't_s': {self._gaps} dropout(s) longer than {DROPOUT_WARN_S:g} s "
                    f"(longest {longest:g} s before line {line})"
                )
        for name, empty in self._empty.items():
            if empty == n:
                raise TraceFormatError(f"{path}:2: column '{name}': no values (every cell is empty)")
            if empty > SPARSE_WARN_FRACTION * n:
                warnings_out.append(
                    f"{path}: column '{name}': empty in {100.0 * empty / n:.1f} % of rows ({empty} of {n})"
                )
        if self._short:
            warnings_out.append(
                f"{path}:{self._first_short}: {self._short} row(s) shorter than the header (first on this "
                f"line); their missing cells read as empty"
            )
        return warnings_out


def _open_trace(path: str | Path) -> BinaryIO:
    path_s = str(path)
    try:
        st = os.stat(path)  # before open(): opening a FIFO would block until someone writes to it
        if stat.S_ISDIR(st.st_mode):
            raise TraceFormatError(f"{path_s}: is a directory, not a trace file")
        if not stat.S_ISREG(st.st_mode):
            raise TraceFormatError(f"{path_s}: not a regular file (FIFO, device or socket)")
        return open(path, "rb")
    except FileNotFoundError:
        raise TraceFormatError(f"{path_s}: no such trace file") from None
    except OSError as exc:
        raise TraceFormatError(f"{path_s}: cannot read: {exc.strerror or exc}") from None


def _wanted(header: list[str], columns: Iterable[str] | None) -> list[tuple[int, str]]:
    known = set(REQUIRED_COLUMNS + OPTIONAL_COLUMNS + EXTRA_COLUMNS)
    if columns is not None:
        known &= set(REQUIRED_COLUMNS) | set(columns)
    return [(i, h) for i, h in enumerate(header) if h in known]


def read_trace_csv(path: str | Path, *, columns: Iterable[str] | None = None) -> Trace:
    """Read and validate a trace CSV.

    Parameters
    ----------
    path : str or Path
    columns : iterable of str, optional
        Read only these of the known columns (the required ones are always read): less memory for long logs.

    Returns
    -------
    Trace
        Its ``warnings`` list the legal but suspicious things found (dropouts, sparse columns, short rows); each
        is also issued as a :class:`TraceWarning`.

    Raises
    ------
    TraceFormatError
        With a one-line message naming the file, line (1-based, header is line 1) and column, for a missing file,
        an empty file, a missing required column (with a hint for ``;``/tab separators), text in a number column,
        NaN/inf, a value outside :data:`PLAUSIBLE_ABS_MAX`, time not strictly increasing, a median sample interval
        outside :data:`SAMPLE_INTERVAL_RANGE_S` (time in milliseconds) or a time gap over :data:`MAX_GAP_S`.
    """
    path_s = str(path)
    with _open_trace(path) as fh:
        header = read_header(fh, path_s, REQUIRED_COLUMNS)
        wanted = _wanted(header, columns)
        start = fh.tell()
        raw = parse_fast(fh, start, header, wanted)
        if raw is None:
            raw = parse_exact(fh, start, path_s, header, wanted)
    checker = _Checker(path_s)
    checker.check(raw)
    notes = checker.finish()
    for note in notes:
        warnings.warn(note, TraceWarning, stacklevel=2)
    return Trace(dict(raw.values), source=path_s, warnings=notes)


class TraceBlocks:
    """A trace file read block by block (a few MiB of text each), checked as :func:`read_trace_csv` checks it.

    For logs too long to hold whole: iterate to get each block as a :class:`Trace` (validated before it is
    yielded); after the last one, :attr:`warnings` holds what :func:`read_trace_csv` would warn about (also issued
    as :class:`TraceWarning`). Errors that only the whole file shows (median sample interval in milliseconds, a
    column with no values) are raised at the end of the iteration, so a consumer must treat its work as
    incomplete until the loop ends without error (``uuom-estimate`` writes atomically).

    Parameters
    ----------
    path : str or Path
    columns : iterable of str, optional
        As in :func:`read_trace_csv`.

    Attributes
    ----------
    header : list of str
        The file's header (read on construction, so a missing column is reported before any block).
    columns : list of str
        The columns each block holds.
    rows : int
        Rows read so far.
    median_dt_s : float
        After the last block: the median sample interval (s); NaN before, or with fewer than two rows.
    """

    def __init__(self, path: str | Path, *, columns: Iterable[str] | None = None) -> None:
        self.path = str(path)
        with _open_trace(path) as fh:
            self.header = read_header(fh, self.path, REQUIRED_COLUMNS)
            self._start = fh.tell()
        self._wanted = _wanted(self.header, columns)
        self.columns = [name for _, name in self._wanted]
        self.warnings: list[str] = []
        self.rows = 0
        self.median_dt_s = math.nan

    def __iter__(self) -> Iterator[Trace]:
        checker = _Checker(self.path)
        with _open_trace(self.path) as fh:
            for raw in iter_blocks(fh, self._start, self.path, self.header, self._wanted):
                checker.check(raw)
                self.rows = checker.rows
                if len(raw):
                    yield Trace(raw.values, source=self.path)
        self.warnings = checker.finish()
        self.median_dt_s = checker.median_dt_s
        for note in self.warnings:
            warnings.warn(note, TraceWarning, stacklevel=2)


def write_trace_csv(trace: Trace | Mapping[str, np.ndarray], path: str | Path) -> None:
    """Write a trace (contract columns first, then the project's extra columns) atomically."""
    cols = trace.columns if isinstance(trace, Trace) else {k: np.asarray(v) for k, v in trace.items()}
    order = [c for c in REQUIRED_COLUMNS + OPTIONAL_COLUMNS + EXTRA_COLUMNS if c in cols]
    write_csv_atomic(path, order, [cols[c] for c in order])


__all__ = [
    "EXTRA_COLUMNS",
    "OPTIONAL_COLUMNS",
    "REQUIRED_COLUMNS",
    "SENSOR_COLUMNS",
    "DROPOUT_WARN_S",
    "MAX_GAP_S",
    "PLAUSIBLE_ABS_MAX",
    "SAMPLE_INTERVAL_RANGE_S",
    "TRUTH_COLUMNS",
    "CsvColumnWriter",
    "Trace",
    "TraceBlocks",
    "TraceFormatError",
    "TraceWarning",
    "csv_writer_atomic",
    "read_trace_csv",
    "write_csv_atomic",
    "write_trace_csv",
]
