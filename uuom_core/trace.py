"""Recorded traces: the CSV contract of ``shared/spec/trace-format.md``.

A :class:`Trace` is a set of equally long float columns, one row per sensor sample. Empty cells are missing samples
and become ``NaN`` in memory; literal ``nan``/``inf`` text in a file is an error (a logger that wrote it is broken).
Writing is atomic: the file appears whole or not at all.
"""

from __future__ import annotations

import csv
import math
import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable, Mapping

import numpy as np

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


class TraceFormatError(ValueError):
    """A trace file that breaks the contract. The message names the file, the line and the column."""


@dataclass
class Trace:
    """Sensor samples (and, where known, truth) as float64 columns of equal length.

    Parameters
    ----------
    columns : mapping of str to array_like
        Must contain :data:`REQUIRED_COLUMNS`. Missing samples are ``NaN``.
    source : str, optional
        Where the trace came from (file path or a description), used in messages.
    """

    columns: dict[str, np.ndarray]
    source: str = "<memory>"
    meta: dict[str, str] = field(default_factory=dict)

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


def _parse_cell(text: str, path: str, line: int, column: str) -> float:
    text = text.strip()
    if text == "":
        return math.nan
    try:
        value = float(text)
    except ValueError:
        raise TraceFormatError(f"{path}:{line}: column '{column}': not a number: {text!r}") from None
    if not math.isfinite(value):
        raise TraceFormatError(f"{path}:{line}: column '{column}': value must be finite, got {text!r}")
    return value


def read_trace_csv(path: str | Path) -> Trace:
    """Read and validate a trace CSV.

    Raises
    ------
    TraceFormatError
        With a one-line message naming the file, line (1-based, header is line 1) and column, for a missing file,
        an empty file, a missing required column, text in a number column, NaN/inf, or time not strictly increasing.
    """
    path_s = str(path)
    try:
        fh = open(path, newline="", encoding="utf-8")
    except FileNotFoundError:
        raise TraceFormatError(f"{path_s}: no such trace file") from None
    except OSError as exc:
        raise TraceFormatError(f"{path_s}: cannot read: {exc.strerror}") from None
    with fh:
        reader = csv.reader(fh)
        try:
            header = next(reader)
        except StopIteration:
            raise TraceFormatError(f"{path_s}:1: empty file (no header row)") from None
        except (UnicodeDecodeError, csv.Error) as exc:
            raise TraceFormatError(f"{path_s}:1: not a CSV text file: {exc}") from None
        header = [h.strip() for h in header]
        missing = [c for c in REQUIRED_COLUMNS if c not in header]
        if missing:
            raise TraceFormatError(f"{path_s}:1: missing required column(s): {', '.join(missing)}")
        dupes = sorted({h for h in header if header.count(h) > 1 and h})
        if dupes:
            raise TraceFormatError(f"{path_s}:1: duplicate column(s): {', '.join(dupes)}")
        known = REQUIRED_COLUMNS + OPTIONAL_COLUMNS + EXTRA_COLUMNS
        wanted = [(i, h) for i, h in enumerate(header) if h in known]
        data: dict[str, list[float]] = {h: [] for _, h in wanted}
        t_index = header.index("t_s")
        prev_t = -math.inf
        line = 1
        try:
            for line, row in enumerate(reader, start=2):
                if not row or all(not c.strip() for c in row):
                    continue  # blank line
                if len(row) < len(header):
                    row = row + [""] * (len(header) - len(row))
                elif len(row) > len(header):
                    raise TraceFormatError(
                        f"{path_s}:{line}: {len(row)} fields, header has {len(header)}"
                    )
                for i, name in wanted:
                    value = _parse_cell(row[i], path_s, line, name)
                    if i == t_index:
                        if math.isnan(value):
                            raise TraceFormatError(f"{path_s}:{line}: column 't_s': time is empty")
                        if value <= prev_t:
                            raise TraceFormatError(
                                f"{path_s}:{line}: column 't_s': time not strictly increasing "
                                f"({value!r} after {prev_t!r})"
                            )
                        prev_t = value
                    data[name].append(value)
        except (UnicodeDecodeError, csv.Error) as exc:
            raise TraceFormatError(f"{path_s}:{line}: not a CSV text file: {exc}") from None
    if not data["t_s"]:
        raise TraceFormatError(f"{path_s}:2: empty file (header but no samples)")
    return Trace({k: np.array(v) for k, v in data.items()}, source=path_s)


def write_csv_atomic(path: str | Path, header: Iterable[str], columns: Iterable[np.ndarray]) -> None:
    """Write columns to CSV via a temporary file in the same directory and an atomic rename.

    NaN cells are written empty (missing samples), so every file this writes reads back with
    :func:`read_trace_csv`.
    """
    path = Path(path)
    header = list(header)
    cols = [np.asarray(c, dtype=np.float64) for c in columns]
    directory = path.parent if str(path.parent) else Path(".")
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=directory)
    try:
        with os.fdopen(fd, "w", newline="", encoding="utf-8") as fh:
            fh.write(",".join(header) + "\n")
            if cols:
                stacked = np.column_stack(cols)
                for row in stacked:
                    fh.write(",".join("" if math.isnan(x) else repr(float(x)) for x in row) + "\n")
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def write_trace_csv(trace: Trace | Mapping[str, np.ndarray], path: str | Path) -> None:
    """Write a trace (contract columns first, then the project's extra columns) atomically."""
    cols = trace.columns if isinstance(trace, Trace) else {k: np.asarray(v) for k, v in trace.items()}
    order = [c for c in REQUIRED_COLUMNS + OPTIONAL_COLUMNS + EXTRA_COLUMNS if c in cols]
    write_csv_atomic(path, order, [cols[c] for c in order])


__all__ = [
    "EXTRA_COLUMNS",
    "OPTIONAL_COLUMNS",
    "REQUIRED_COLUMNS",
    "TRUTH_COLUMNS",
    "Trace",
    "TraceFormatError",
    "read_trace_csv",
    "write_csv_atomic",
    "write_trace_csv",
]
