"""Numeric columns out of a trace CSV: a fast columnar path and an exact line-by-line path.

Why two paths: real logs are hours long at 200 Hz (10⁶ rows = 83 min), and Python's ``csv`` module with a float
per cell needs about 10 s and 700 MB for them. The fast path reads the file in blocks of a few MiB and hands each
block to numpy's C parser (``np.loadtxt``) into preallocated columns, so memory stays near the size of the result.
It only takes blocks it can parse *exactly* as the contract says: plain numbers and empty cells, one row per line,
every row as long as the header. Anything else in the file (quotes, blank lines, short or long rows, text, literal
``nan``/``inf``, stray characters) sends the whole file through the exact path: the ``csv`` module line by line,
which knows the line of every row and names it in its errors. Both paths give the same columns (tested).

This module parses; :mod:`uuom_core.trace` checks what the numbers mean (time, ranges, gaps) and builds the
:class:`~uuom_core.trace.Trace`.
"""

from __future__ import annotations

import codecs
import csv
import io
import math
from array import array
from dataclasses import dataclass
from typing import BinaryIO, Iterator

import numpy as np

BLOCK_BYTES = 4 << 20
"""Bytes per block of the fast path (a few MiB: large enough for numpy, small against the result)."""

MAX_HEADER_BYTES = 1 << 20
"""A first line longer than this is not a trace header (and is not read whole into memory)."""

_FAST_BYTES = b"0123456789.eE+-, \r\n"
"""The only bytes the fast path accepts: numbers, separators, line ends."""


class TraceFormatError(ValueError):
    """A trace file that breaks the contract. The message names the file, the line and the column."""


class TraceWarning(UserWarning):
    """Something in a trace that is legal but suspicious (sparse column, dropouts, truncated rows)."""


@dataclass
class RawColumns:
    """Parsed numeric columns, before any check of what they mean.

    Attributes
    ----------
    values : dict of str to ndarray
        One float64 array per wanted column, equal lengths; empty cells are NaN.
    lines : ndarray of int or None
        1-based file line of each row; None when row ``i`` is on line ``i + 2`` (fast path).
    short_rows : int
        Rows with fewer fields than the header (padded with empty cells).
    first_short_line : int
        Line of the first such row (0 if none).
    fast : bool
        Whether the fast path read the file.
    first_line : int
        Line of row 0 when ``lines`` is None (2 for a whole file; a block's own first line when read in blocks).
    """

    values: dict[str, np.ndarray]
    lines: np.ndarray | None = None
    short_rows: int = 0
    first_short_line: int = 0
    fast: bool = True
    first_line: int = 2

    def line_of(self, row: int) -> int:
        """File line (1-based) of row ``row``."""
        return int(self.lines[row]) if self.lines is not None else row + self.first_line

    def __len__(self) -> int:
        return len(next(iter(self.values.values()))) if self.values else 0


def _separator_hint(text: str) -> str:
    for sep, name in ((";", "';'"), ("\t", "tab"), ("|", "'|'")):
        if text.count(sep) >= 3 and text.count(",") < text.count(sep):
            return f"; the header looks {name}-separated (the trace format uses ',')"
    return ""


def read_header(fh: BinaryIO, path: str, required: tuple[str, ...]) -> list[str]:
    """Read and check the header line of an open binary file; leave ``fh`` at the first data byte.

    Accepts a UTF-8 byte-order mark (Excel's "CSV UTF-8"). Raises :class:`TraceFormatError` for an empty file,
    UTF-16, non-UTF-8 bytes, a missing required column (with a hint when another separator is in use) or a
    duplicate column name.
    """
    raw = fh.readline(MAX_HEADER_BYTES + 1)
    if not raw.strip():
        raise TraceFormatError(f"{path}:1: empty file (no header row)")
    if raw.startswith((codecs.BOM_UTF16_LE, codecs.BOM_UTF16_BE)):
        raise TraceFormatError(f"{path}:1: UTF-16 text, not a UTF-8 CSV text file: save the trace as UTF-8 CSV")
    if len(raw) > MAX_HEADER_BYTES:
        raise TraceFormatError(f"{path}:1: first line longer than {MAX_HEADER_BYTES} bytes: not a trace CSV header")
    if raw.startswith(codecs.BOM_UTF8):
        raw = raw[len(codecs.BOM_UTF8):]
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise TraceFormatError(f"{path}:1: not a UTF-8 CSV text file (byte {exc.start + 1} of the header)") from None
    if "\x00" in text:
        raise TraceFormatError(f"{path}:1: not a CSV text file (NUL byte in the header)")
    try:
        header = [h.strip() for h in next(csv.reader([text.rstrip("\r\n")]), [])]
    except csv.Error as exc:
        raise TraceFormatError(f"{path}:1: header is not a CSV row: {exc}") from None
    missing = [c for c in required if c not in header]
    if missing:
        raise TraceFormatError(
            f"{path}:1: missing required column(s): {', '.join(missing)}{_separator_hint(text)}"
        )
    dupes = sorted({h for h in header if h and header.count(h) > 1})
    if dupes:
        raise TraceFormatError(f"{path}:1: duplicate column(s): {', '.join(dupes)}")
    return header


def _fill_empty(block: bytes) -> bytes:
    """Write ``nan`` into the empty cells of a block (only called on blocks without any letter in them)."""
    if not (block.startswith(b",") or block.endswith(b",") or b",," in block or b"\n," in block
            or b",\n" in block or b",\r" in block):
        return block  # no empty cell: spare the copies
    if block.startswith(b","):
        block = b"nan" + block
    block = block.replace(b"\n,", b"\nnan,")
    while b",," in block:  # two passes at most: ",,," -> ",nan,," -> ",nan,nan,"
        block = block.replace(b",,", b",nan,")
    block = block.replace(b",\n", b",nan\n").replace(b",\r", b",nan\r")
    if block.endswith(b","):
        block += b"nan"
    return block


def _blocks(fh: BinaryIO, start: int, block_bytes: int | None = None):
    """Blocks of whole lines from byte ``start`` on; the last one without the file's trailing blank lines."""
    fh.seek(start)
    pending: bytes | None = None
    carry = b""
    while chunk := fh.read(block_bytes or BLOCK_BYTES):
        data = carry + chunk
        cut = data.rfind(b"\n")
        if cut < 0:
            carry = data
            continue
        if pending is not None:
            yield pending
        pending, carry = data[: cut + 1], data[cut + 1:]
    last = ((pending or b"") + carry).rstrip(b"\r\n")
    if last:
        yield last + b"\n"


def _parse_block_fast(block: bytes, ncols: int, idx: list[int]) -> np.ndarray | None:
    """One block of whole lines as a ``(len(idx), rows)`` array, or ``None`` if it needs the exact path."""
    if block.translate(None, _FAST_BYTES):
        return None  # letters, quotes or other characters: let the exact path name them
    raw = np.frombuffer(block, dtype=np.uint8)
    commas_per_line = np.diff(np.searchsorted(np.flatnonzero(raw == 44), np.flatnonzero(raw == 10)), prepend=0)
    if commas_per_line.size == 0 or np.any(commas_per_line != ncols - 1):
        return None  # a row of the wrong length, or a blank line
    try:
        # usecols: the unread columns are split but not converted (a quarter less time on a 9-column log)
        arr = np.loadtxt(io.BytesIO(_fill_empty(block)), delimiter=",", comments=None, dtype=np.float64,
                         ndmin=2, encoding="ascii", usecols=idx)
    except ValueError:
        return None
    if arr.shape != (len(commas_per_line), len(idx)):
        return None
    return arr.T


def parse_fast(fh: BinaryIO, start: int, header: list[str], wanted: list[tuple[int, str]]) -> RawColumns | None:
    """Columnar parse of the data from byte ``start``; ``None`` if the file needs the exact path."""
    fh.seek(start)
    n_lines = 0
    tail = b""
    while chunk := fh.read(BLOCK_BYTES):
        n_lines += chunk.count(b"\n")
        tail = chunk[-1:]
    n_lines += 1 if tail not in (b"", b"\n") else 0
    out = np.empty((len(wanted), n_lines), dtype=np.float64)  # one contiguous row per column
    idx = [i for i, _ in wanted]
    row = 0
    for block in _blocks(fh, start):
        cols = _parse_block_fast(block, len(header), idx)
        if cols is None or row + cols.shape[1] > n_lines:
            return None
        out[:, row:row + cols.shape[1]] = cols
        row += cols.shape[1]
    return RawColumns({name: out[k, :row] for k, (_, name) in enumerate(wanted)})


STREAM_BLOCK_BYTES = 1 << 20
"""Bytes per block when a file is read block by block (:func:`iter_blocks`): each block's parse needs a few times
its size, and nothing else is held, so smaller blocks mean a lower peak; below ~1 MiB numpy's per-call cost shows."""


def iter_blocks(fh: BinaryIO, start: int, path: str, header: list[str],
                wanted: list[tuple[int, str]], block_bytes: int | None = None) -> Iterator[RawColumns]:
    """The data from byte ``start`` as consecutive blocks of rows (a few MiB of text each), for long logs.

    Each block goes through the fast path if it can and through the exact path if not, so one odd line costs only
    its block; line numbers in errors are the file's. The blocks together hold what :func:`parse_fast` or
    :func:`parse_exact` would read from the whole file.
    """
    idx = [i for i, _ in wanted]
    line = 2
    for block in _blocks(fh, start, block_bytes or STREAM_BLOCK_BYTES):
        cols = _parse_block_fast(block, len(header), idx)
        if cols is not None:
            yield RawColumns({name: cols[k] for k, (_, name) in enumerate(wanted)}, first_line=line)
        else:
            yield parse_exact(io.BytesIO(block), 0, path, header, wanted, first_line=line)
        line += block.count(b"\n")


def _cell(text: str, path: str, line: int, column: str) -> float:
    text = text.strip()
    if text == "":
        return math.nan
    try:
        value = float(text)
    except ValueError:
        shown = text if len(text) <= 40 else text[:40] + "..."
        raise TraceFormatError(f"{path}:{line}: column '{column}': not a number: {shown!r}") from None
    if not math.isfinite(value):
        raise TraceFormatError(f"{path}:{line}: column '{column}': value must be finite, got {text!r}")
    return value


def parse_exact(fh: BinaryIO, start: int, path: str, header: list[str],
                wanted: list[tuple[int, str]], first_line: int = 2) -> RawColumns:
    """Line-by-line parse with the ``csv`` module; errors name the line and the column.

    ``first_line`` is the file line at byte ``start`` (2 after the header; a block's own when read in blocks).
    """
    fh.seek(start)
    physical = [first_line - 1]  # lines read so far

    def text_lines():
        for raw in fh:
            physical[0] += 1
            try:
                yield raw.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise TraceFormatError(
                    f"{path}:{physical[0]}: not a UTF-8 CSV text file (byte {exc.start + 1} of the line)"
                ) from None

    data = {name: array("d") for _, name in wanted}
    lines = array("q")
    short = 0
    first_short = 0
    ncols = len(header)
    reader = csv.reader(text_lines())
    try:
        for row in reader:
            line = physical[0]
            if not row or all(not c.strip() for c in row):
                continue  # blank line
            if len(row) < ncols:
                short += 1
                first_short = first_short or line
                row = row + [""] * (ncols - len(row))
            elif len(row) > ncols:
                raise TraceFormatError(f"{path}:{line}: {len(row)} fields, header has {ncols}")
            for i, name in wanted:
                data[name].append(_cell(row[i], path, line, name))
            lines.append(line)
    except csv.Error as exc:
        raise TraceFormatError(f"{path}:{physical[0]}: not a CSV row: {exc}") from None
    values = {k: np.frombuffer(v, dtype=np.float64).copy() for k, v in data.items()}
    return RawColumns(values, lines=np.frombuffer(lines, dtype=np.int64).copy(), short_rows=short,
                      first_short_line=first_short, fast=False)


__all__ = ["BLOCK_BYTES", "STREAM_BLOCK_BYTES", "RawColumns", "TraceFormatError", "TraceWarning", "iter_blocks", "parse_exact",
           "parse_fast", "read_header"]
