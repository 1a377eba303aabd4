"""Trace CSV contract: round trip, missing samples, and one-line errors naming file, line and column."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

from uuom_core.trace import (
    Trace,
    TraceFormatError,
    TraceWarning,
    read_trace_csv,
    write_csv_atomic,
    write_trace_csv,
)


def make_trace(n: int = 50) -> Trace:
    t = np.arange(n) * 0.005
    rng = np.random.default_rng(0)
    cols = {
        "t_s": t, "torque_nm": rng.normal(1000, 50, n), "speed_mps": rng.normal(1, 0.01, n),
        "accel_mps2": rng.normal(0, 0.1, n), "mass_kg": np.full(n, 26_000.0), "slope_deg": np.linspace(0, 8, n),
        "sway_rad": rng.normal(0, 0.01, n),
    }
    cols["speed_mps"][[3, 7]] = np.nan
    return Trace(cols)


def test_roundtrip_is_exact_with_missing_samples(tmp_path):
    tr = make_trace()
    p = tmp_path / "t.csv"
    write_trace_csv(tr, p)
    back = read_trace_csv(p)
    assert set(back.columns) == set(tr.columns)
    for k in tr.columns:
        assert np.array_equal(back[k], tr[k], equal_nan=True), k
    assert back.has_truth and len(back) == 50 and back.duration_s == pytest.approx(49 * 0.005)
    header = p.read_text().splitlines()[0].split(",")
    assert header[:4] == ["t_s", "torque_nm", "speed_mps", "accel_mps2"]
    assert ",," in p.read_text()  # NaN written as an empty cell
    assert [f for f in os.listdir(tmp_path) if f.endswith(".tmp")] == []


def test_unknown_columns_are_ignored_and_short_rows_padded_with_a_warning(tmp_path):
    p = tmp_path / "x.csv"
    p.write_text("t_s,torque_nm,speed_mps,accel_mps2,whatever\n0,1,2,3,zz\n0.1,1,2\n")
    with pytest.warns(TraceWarning, match=r"x.csv:3: 1 row\(s\) shorter than the header"):
        tr = read_trace_csv(p)
    assert len(tr.warnings) == 1
    assert "whatever" not in tr and math.isnan(tr["accel_mps2"][1])
    assert not tr.has_truth


@pytest.mark.parametrize(
    "text, where",
    [
        ("", ":1: empty file"),
        ("t_s,torque_nm,speed_mps,accel_mps2\n", ":2: empty file"),
        ("t_s,torque_nm,speed_mps\n0,1,2\n", ":1: missing required column(s): accel_mps2"),
        ("t_s,torque_nm,speed_mps,accel_mps2\n0,1,x,3\n", ":2: column 'speed_mps': not a number"),
        ("t_s,torque_nm,speed_mps,accel_mps2\n0,1,nan,3\n", ":2: column 'speed_mps': value must be finite"),
        ("t_s,torque_nm,speed_mps,accel_mps2\n0,1,inf,3\n", ":2: column 'speed_mps': value must be finite"),
        ("t_s,torque_nm,speed_mps,accel_mps2\n0,1,2,3\n0,1,2,3\n", ":3: column 't_s': time not strictly"),
        ("t_s,torque_nm,speed_mps,accel_mps2\n,1,2,3\n", ":2: column 't_s': time is empty"),
        ("t_s,torque_nm,speed_mps,accel_mps2\n0,1,2,3,4\n", ":2: 5 fields"),
        ("t_s,t_s,torque_nm,speed_mps,accel_mps2\n0,0,1,2,3\n", ":1: duplicate column"),
    ],
)
def test_bad_files_give_one_line_errors(tmp_path, text, where):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(TraceFormatError) as err:
        read_trace_csv(p)
    msg = str(err.value)
    assert msg.startswith(str(p)) and where in msg and "\n" not in msg


def test_missing_and_binary_files(tmp_path):
    with pytest.raises(TraceFormatError, match="no such trace file"):
        read_trace_csv(tmp_path / "nope.csv")
    p = tmp_path / "bin.csv"
    p.write_bytes(b"\xff\xfe\x00\x01garbage")
    with pytest.raises(TraceFormatError, match="UTF-16 text, not a UTF-8 CSV text file"):
        read_trace_csv(p)
    p.write_bytes(b"t_s,torque\xe9\n")
    with pytest.raises(TraceFormatError, match=r":1: not a UTF-8 CSV text file"):
        read_trace_csv(p)
    p.write_bytes(b"t_s,torque_nm,speed_mps,accel_mps2\n0,1,2,3\n0.005,1,\xe9,3\n")
    with pytest.raises(TraceFormatError, match=r":3: not a UTF-8 CSV text file"):
        read_trace_csv(p)


def test_trace_object_checks():
    with pytest.raises(TraceFormatError, match="missing required column"):
        Trace({"t_s": [0.0], "torque_nm": [1.0], "speed_mps": [1.0]})
    with pytest.raises(TraceFormatError, match="differ in length"):
        Trace({"t_s": [0.0, 1.0], "torque_nm": [1.0], "speed_mps": [1.0], "accel_mps2": [0.0]})


def test_from_time_is_the_log_a_logger_switched_on_later_records():
    tr = make_trace(50)
    tr.meta["run"] = "r1"
    late = tr.from_time(0.1)  # samples 20..49
    assert len(late) == 30 and late["t_s"][0] == pytest.approx(0.1)
    for name, col in tr.columns.items():
        np.testing.assert_array_equal(late[name], col[20:])
    assert late.meta == {"run": "r1", "from_time_s": "0.1"} and "from_time_s" not in tr.meta
    assert len(tr.from_time(-5.0)) == 50
    with pytest.raises(ValueError, match="no sample at or after"):
        tr.from_time(1.0)
    with pytest.raises(ValueError, match="finite"):
        tr.from_time(float("nan"))


def test_atomic_write_leaves_nothing_on_failure(tmp_path):
    p = tmp_path / "a.csv"
    with pytest.raises(ValueError):
        write_csv_atomic(p, ["a", "b"], [np.zeros(3), np.zeros(4)])
    assert os.listdir(tmp_path) == []


def test_interrupted_atomic_write_keeps_the_previous_file(tmp_path):
    from uuom_core.atomic_write import atomic_text_writer

    p = tmp_path / "a.csv"
    p.write_text("previous\n")
    with pytest.raises(KeyboardInterrupt):
        with atomic_text_writer(p) as fh:
            fh.write("half a fi")
            raise KeyboardInterrupt
    assert p.read_text() == "previous\n" and os.listdir(tmp_path) == ["a.csv"]


def test_writer_refuses_infinite_values_before_touching_the_file(tmp_path):
    p = tmp_path / "a.csv"
    p.write_text("previous\n")
    with pytest.raises(ValueError, match="infinite"):
        write_csv_atomic(p, ["a"], [np.array([1.0, np.inf])])
    assert p.read_text() == "previous\n" and os.listdir(tmp_path) == ["a.csv"]
