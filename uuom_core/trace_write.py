"""Writing float columns as CSV, whole or block by block, atomically (the file appears whole or not at all).

The format is the trace contract's: a header line, one row per sample, NaN as an empty cell, infinite values
refused. :func:`write_csv_atomic` writes columns held in memory; :func:`csv_writer_atomic` gives a writer to append
blocks of rows to, for results too long to hold (``uuom-estimate`` on an hours-long log).
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path
from typing import IO, Iterable, Iterator, Sequence

import numpy as np

from uuom_core.atomic_write import atomic_text_writer

_WRITE_ROWS = 8192


class CsvColumnWriter:
    """Appends rows of float columns to an open text file, in the format :func:`write_csv_atomic` promises.

    NaN cells are written empty, numbers in the shortest form that reads back exactly (``repr``) unless
    ``formats`` says otherwise (one %-format per column, e.g. ``"%.9g"``). Use it through
    :func:`csv_writer_atomic` to write a long result block by block without holding it whole in memory.
    """

    def __init__(self, fh: IO[str], header: Iterable[str], formats: Sequence[str] | None = None) -> None:
        self.header = list(header)
        if formats is not None and len(formats) != len(self.header):
            raise ValueError(f"{len(formats)} formats for a header of {len(self.header)}")
        # "%r" is the shortest exact form; a fixed precision ("%.9g") writes 2-3x faster
        self._row_format = ",".join(formats or ["%r"] * len(self.header)) + "\n"
        self._fh = fh
        self.rows = 0
        fh.write(",".join(self.header) + "\n")

    def write(self, columns: Iterable[np.ndarray]) -> None:
        """Append equally long columns (one per header name); ``ValueError`` for infinite values or bad lengths."""
        cols = [np.asarray(c, dtype=np.float64) for c in columns]
        if len(cols) != len(self.header):
            raise ValueError(f"{len(cols)} columns for a header of {len(self.header)}")
        if len({len(c) for c in cols}) > 1:
            raise ValueError(f"columns differ in length: {[len(c) for c in cols]}")
        for name, c in zip(self.header, cols):
            if np.isinf(c).any():
                raise ValueError(f"column {name!r} has infinite values; the trace format cannot hold them")
        n = len(cols[0]) if cols else 0
        for a in range(0, n, _WRITE_ROWS):
            # tolist() makes Python floats in C; one %-format over the block; "nan" -> empty cell
            cells = np.column_stack([c[a:a + _WRITE_ROWS] for c in cols]).ravel().tolist()
            text = (self._row_format * (len(cells) // len(cols))) % tuple(cells)
            self._fh.write(text.replace("nan", ""))
        self.rows += n


@contextmanager
def csv_writer_atomic(path: str | Path, header: Iterable[str],
                      formats: Sequence[str] | None = None) -> Iterator[CsvColumnWriter]:
    """A :class:`CsvColumnWriter` on a temporary file that replaces ``path`` when the block ends without error.

    ``formats``: one %-format per column (default ``"%r"``, the shortest form that reads back exactly).

    On any exception (a ``ValueError`` from an infinite value, ``KeyboardInterrupt``) ``path`` is untouched and no
    temporary file is left (:func:`uuom_core.atomic_write.atomic_text_writer`).
    """
    with atomic_text_writer(path) as fh:
        yield CsvColumnWriter(fh, header, formats)


def write_csv_atomic(path: str | Path, header: Iterable[str], columns: Iterable[np.ndarray]) -> None:
    """Write columns to CSV via a temporary file in the same directory and an atomic rename.

    NaN cells are written empty (missing samples), numbers in the shortest form that reads back exactly, so every
    file this writes reads back with :func:`read_trace_csv`. Infinite values are refused (``ValueError``) before
    any row is written, and ``path`` is left as it was. See :mod:`uuom_core.atomic_write` for what happens on interruption.
    """
    cols = list(columns)
    with csv_writer_atomic(path, header) as writer:
        if cols:
            writer.write(cols)  # checks lengths and infinite values before writing a row


__all__ = ["CsvColumnWriter", "csv_writer_atomic", "write_csv_atomic"]
