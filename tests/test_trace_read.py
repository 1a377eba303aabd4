"""The trace reader on real-world files: Excel exports, other separators, other units, glitches, long logs.

Each case is one line naming file, line and column (an error) or a :class:`TraceWarning` with the count; and the
fast columnar path reads exactly what the line-by-line path reads.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import uuom_core.trace_csv as trace_csv
from uuom_core.synthetic import synthetic_trace
from uuom_core.trace import TraceFormatError, TraceWarning, read_trace_csv, write_trace_csv
from uuom_core.trace_csv import parse_exact, parse_fast, read_header

HEADER = "t_s,torque_nm,speed_mps,accel_mps2"


def _rows(n: int, dt: float = 0.005, t0: float = 0.0) -> list[str]:
    return [f"{t0 + i * dt!r},{1000 + i},{0.5 + 0.001 * i!r},0.1" for i in range(n)]


def _file(tmp_path, text: str | bytes, name: str = "t.csv"):
    p = tmp_path / name
    if isinstance(text, bytes):
        p.write_bytes(text)
    else:
        p.write_text(text, encoding="utf-8")
    return p


def _error(p) -> str:
    with pytest.raises(TraceFormatError) as err:
        read_trace_csv(p)
    msg = str(err.value)
    assert msg.startswith(str(p)) and "\n" not in msg
    return msg


def test_utf8_bom_is_accepted(tmp_path):
    text = "\ufeff" + HEADER + "\n" + "\n".join(_rows(5)) + "\n"
    tr = read_trace_csv(_file(tmp_path, text))
    assert len(tr) == 5 and tr["torque_nm"][4] == 1004.0


@pytest.mark.parametrize("sep, hint", [(";", "';'-separated"), ("\t", "tab-separated")])
def test_other_separator_gets_a_hint(tmp_path, sep, hint):
    text = HEADER.replace(",", sep) + "\n" + "\n".join(r.replace(",", sep) for r in _rows(3)) + "\n"
    msg = _error(_file(tmp_path, text))
    assert ":1: missing required column(s)" in msg and hint in msg


def test_time_in_milliseconds_is_an_error_naming_the_column(tmp_path):
    msg = _error(_file(tmp_path, HEADER + "\n" + "\n".join(_rows(50, dt=5.0)) + "\n"))
    assert ":3: column 't_s': median sample interval 5 s" in msg and "milliseconds" in msg


def test_time_too_fine_is_an_error(tmp_path):
    msg = _error(_file(tmp_path, HEADER + "\n" + "\n".join(_rows(50, dt=1e-6)) + "\n"))
    assert "column 't_s': median sample interval" in msg


def test_absurd_value_is_an_error_with_its_line(tmp_path):
    rows = _rows(20)
    rows[6] = rows[6].replace(",0.1", ",1e300")
    msg = _error(_file(tmp_path, HEADER + "\n" + "\n".join(rows) + "\n"))
    assert ":8: column 'accel_mps2': 1e+300 is outside the plausible range" in msg


def test_gap_of_a_billion_seconds_is_an_error(tmp_path):
    rows = _rows(10) + _rows(10, t0=1e9)
    msg = _error(_file(tmp_path, HEADER + "\n" + "\n".join(rows) + "\n"))
    assert ":12: column 't_s': time jumps by 1e+09 s" in msg


def test_dropouts_are_a_warning_with_count_and_longest(tmp_path):
    rows = _rows(100) + _rows(100, t0=10.0) + _rows(100, t0=100.0)
    with pytest.warns(TraceWarning, match=r"2 dropout\(s\) longer than 1 s \(longest 89\.5.* s before line 202\)"):
        tr = read_trace_csv(_file(tmp_path, HEADER + "\n" + "\n".join(rows) + "\n"))
    assert len(tr) == 300


def test_sparse_required_column_is_a_warning_with_the_count(tmp_path):
    rows = _rows(100)
    rows = [r if i % 20 == 0 else ",".join(r.split(",")[:2] + ["", "0.1"]) for i, r in enumerate(rows)]
    with pytest.warns(TraceWarning, match=r"column 'speed_mps': empty in 95\.0 % of rows \(95 of 100\)"):
        read_trace_csv(_file(tmp_path, HEADER + "\n" + "\n".join(rows) + "\n"))


def test_required_column_without_any_value_is_an_error(tmp_path):
    rows = [",".join(r.split(",")[:3] + [""]) for r in _rows(10)]
    assert ":2: column 'accel_mps2': no values" in _error(_file(tmp_path, HEADER + "\n" + "\n".join(rows) + "\n"))


def test_truncated_last_row_is_a_warning(tmp_path):
    text = HEADER + "\n" + "\n".join(_rows(10)) + "\n0.05,1000,0.5"  # logger killed mid-row
    with pytest.warns(TraceWarning, match=r":12: 1 row\(s\) shorter than the header"):
        tr = read_trace_csv(_file(tmp_path, text))
    assert len(tr) == 11 and math.isnan(tr["accel_mps2"][-1])


@pytest.mark.parametrize(
    "body, where",
    [
        ('0,1,2,3\n"0.005",1,"x",3\n', ":3: column 'speed_mps': not a number: 'x'"),
        ("0,1,2,3\n0.005,1,2,3\n\n0.01,1,2,NaN\n", ":5: column 'accel_mps2': value must be finite"),
        ("0,1,2,3\n0.005,1,2,1e999\n", ":3: column 'accel_mps2': value must be finite"),
        ("0,1,2,3\n0.005,1 2,2,3\n", ":3: column 'torque_nm': not a number"),
        ("0,1,2,3\n0.005,1,2,3,\n", ":3: 5 fields, header has 4"),
        ("0.005,1,2,3\n0.004,1,2,3\n", ":3: column 't_s': time not strictly increasing"),
    ],
)
def test_errors_keep_their_line_on_both_paths(tmp_path, body, where):
    assert where in _error(_file(tmp_path, HEADER + "\n" + body))


def _both_paths(p):
    with open(p, "rb") as fh:
        header = read_header(fh, str(p), ("t_s", "torque_nm", "speed_mps", "accel_mps2"))
        wanted = list(enumerate(header))
        start = fh.tell()
        fast = parse_fast(fh, start, header, wanted)
        exact = parse_exact(fh, start, str(p), header, wanted)
    return fast, exact


@pytest.mark.parametrize("block_bytes", [64, 1000, 4 << 20])
def test_fast_path_reads_what_the_exact_path_reads(tmp_path, monkeypatch, block_bytes):
    monkeypatch.setattr(trace_csv, "BLOCK_BYTES", block_bytes)
    tr = synthetic_trace("varying", seed=3, duration_s=5.0)
    rng = np.random.default_rng(0)
    for name in ("speed_mps", "accel_mps2", "mass_kg", "torque_nm"):
        tr.columns[name][rng.random(len(tr)) < 0.1] = np.nan  # empty cells at line start, middle and end
    p = tmp_path / "w.csv"
    write_trace_csv(tr, p)
    p.write_bytes(p.read_bytes().replace(b"\n", b"\r\n") + b"\r\n\n")  # CRLF and trailing blank lines
    fast, exact = _both_paths(p)
    assert fast is not None, "a plain numeric file must take the fast path"
    assert fast.values.keys() == exact.values.keys()
    for k in fast.values:
        assert np.array_equal(fast.values[k], exact.values[k], equal_nan=True), k
        assert fast.values[k].flags.c_contiguous
    assert np.array_equal(exact.lines, np.arange(len(tr)) + 2)
    back = read_trace_csv(p)
    for k in tr.columns:
        assert np.array_equal(back[k], tr[k], equal_nan=True), k


@pytest.mark.parametrize(
    "body",
    ['0,1,2,3\n"0.005",1,2,3\n', "0,1,2,3\n\n0.005,1,2,3\n", "0,1,2,3\n0.005,1,2\n", "0,1,2,3\n0.005,1,2,inf\n"],
)
def test_irregular_files_take_the_exact_path(tmp_path, body):
    p = _file(tmp_path, HEADER + "\n" + body)
    with open(p, "rb") as fh:
        header = read_header(fh, str(p), ("t_s",))
        assert parse_fast(fh, fh.tell(), header, list(enumerate(header))) is None


def test_columns_argument_reads_only_those(tmp_path):
    p = tmp_path / "s.csv"
    write_trace_csv(synthetic_trace("level", seed=1, duration_s=1.0), p)
    tr = read_trace_csv(p, columns=["mass_kg"])
    assert set(tr.columns) == {"t_s", "torque_nm", "speed_mps", "accel_mps2", "mass_kg"}


def test_directory_and_fifo_are_not_traces(tmp_path):
    import os

    assert "is a directory" in _error(tmp_path)
    fifo = tmp_path / "f.csv"
    os.mkfifo(fifo)
    os.chmod(fifo, 0o600)
    with pytest.raises(TraceFormatError, match="not a regular file"):
        read_trace_csv(fifo)
