"""Long logs block by block: :class:`TraceBlocks`, ``run(reset=False, t_prev_s=...)``, the block-wise summary and the
streaming ``uuom-estimate`` give what the whole-file path gives (numbers, errors with their lines, warnings)."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

import estimators
import uuom_core.trace_csv as trace_csv
from estimators.cli import main, summarize
from estimators.metrics import ErrorAccumulator, error_after_settling
from uuom_core.synthetic import synthetic_trace
from uuom_core.trace import (Trace, TraceBlocks, TraceFormatError, TraceWarning, csv_writer_atomic, read_trace_csv,
                             write_trace_csv)

SMALL_BLOCK = 8192  # bytes: a 20 s log at 200 Hz becomes ~50 blocks


@pytest.fixture()
def small_blocks(monkeypatch):
    monkeypatch.setattr(trace_csv, "STREAM_BLOCK_BYTES", SMALL_BLOCK)


@pytest.fixture(scope="module")
def log(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("blocks") / "log.csv"
    write_trace_csv(synthetic_trace("varying", seed=5, duration_s=20.0), p)
    return p


def _blocks(path: Path, **kw) -> tuple[list[Trace], list[str]]:
    reader = TraceBlocks(path, **kw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TraceWarning)
        parts = list(reader)
    return parts, reader.warnings


def test_blocks_concatenate_to_the_whole_file(log: Path, small_blocks) -> None:
    whole = read_trace_csv(log)
    parts, notes = _blocks(log)
    assert len(parts) > 20
    for name in whole.columns:
        np.testing.assert_array_equal(np.concatenate([p[name] for p in parts]), whole[name])
    assert notes == whole.warnings


def test_median_sample_interval_is_known_after_the_last_block(log: Path, small_blocks) -> None:
    reader = TraceBlocks(log)
    assert np.isnan(reader.median_dt_s)  # before the iteration
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TraceWarning)
        for _ in reader:
            pass
    assert reader.median_dt_s == pytest.approx(0.005, rel=1e-6)


def _messy(tmp_path: Path, rows: int = 3000) -> tuple[Path, list[str]]:
    """A log whose middle needs the exact path (a quoted cell, a blank line, a short row) and has a dropout."""
    t = np.arange(rows) * 0.005
    t[2000:] += 2.0  # a 2 s dropout
    lines = [f"{float(t[i])!r},{1000 + i},{0.5 + 0.001 * i!r},0.1" for i in range(rows)]
    lines[700] = f'{float(t[700])!r},"1700",0.7,0.1'
    lines[1500] = lines[1500] + "\n"  # blank line after it
    lines[2500] = f"{float(t[2500])!r},3500"  # short row
    p = tmp_path / "messy.csv"
    p.write_text("t_s,torque_nm,speed_mps,accel_mps2\n" + "\n".join(lines) + "\n", encoding="utf-8")
    return p, lines


def test_exact_path_blocks_dropouts_and_short_rows_match_the_whole_file(tmp_path: Path, small_blocks) -> None:
    p, _ = _messy(tmp_path)
    with pytest.warns(TraceWarning):
        whole = read_trace_csv(p)
    parts, notes = _blocks(p)
    for name in whole.columns:
        np.testing.assert_array_equal(np.concatenate([q[name] for q in parts]), whole[name])
    assert notes == whole.warnings
    assert any("dropout" in n for n in notes) and any("shorter than the header" in n for n in notes)


@pytest.mark.parametrize("row, bad, what", [
    (1900, "BACK", "time not strictly increasing"),
    (2600, "inf", "value must be finite"),
    (2700, "1e300", "outside the plausible range"),
    (2800, "abc", "not a number"),
])
def test_errors_in_a_late_block_name_the_same_line(tmp_path: Path, small_blocks, row: int, bad: str,
                                                   what: str) -> None:
    p, lines = _messy(tmp_path)
    fields = lines[row].split(",")
    if bad == "BACK":
        fields[0] = "0.001"
    else:
        fields[2] = bad
    lines[row] = ",".join(fields)
    p.write_text("t_s,torque_nm,speed_mps,accel_mps2\n" + "\n".join(lines) + "\n", encoding="utf-8")
    with pytest.raises(TraceFormatError) as whole:
        read_trace_csv(p)
    with pytest.raises(TraceFormatError) as blocks:
        _blocks(p)
    assert what in str(whole.value)
    assert str(blocks.value).split(": column")[0] == str(whole.value).split(": column")[0]  # same FILE:LINE


def test_time_going_back_across_a_block_boundary(tmp_path: Path, small_blocks) -> None:
    rows = [f"{i * 0.005!r},1000,0.5,0.1" for i in range(4000)]
    text = "t_s,torque_nm,speed_mps,accel_mps2\n" + "\n".join(rows) + "\n"
    h = text.index("\n") + 1
    cut = text.rindex("\n", h, h + SMALL_BLOCK) + 1  # the first row of the second block
    line = text[:cut].count("\n") + 1
    first = text[cut:].split(",", 1)
    text = text[:cut] + "0.0," + first[1]
    p = tmp_path / "back.csv"
    p.write_text(text)
    reader = TraceBlocks(p)
    with pytest.raises(TraceFormatError, match=rf":{line}: column 't_s': time not strictly increasing"):
        for _ in reader:
            pass


def test_whole_file_errors_come_at_the_end(tmp_path: Path, small_blocks) -> None:
    rows = [f"{i * 5.0!r},1000,0.5,0.1" for i in range(3000)]  # milliseconds
    p = tmp_path / "ms.csv"
    p.write_text("t_s,torque_nm,speed_mps,accel_mps2\n" + "\n".join(rows) + "\n")
    reader = TraceBlocks(p)
    seen = 0
    with pytest.raises(TraceFormatError, match=r":3: column 't_s': median sample interval 5 s"):
        for part in reader:
            seen += len(part)
    assert seen == 3000  # every block was handed out before the whole-file check failed


@pytest.mark.parametrize("name", ["dffrls-aekf", "sf-kf", "ffrls"])
def test_run_in_blocks_equals_one_run(name: str) -> None:
    tr = synthetic_trace("section1", seed=3, duration_s=15.0)
    whole = estimators.make(name).run(tr)
    est = estimators.make(name)
    masses, slopes = [], []
    t_prev = None
    for a in range(0, len(tr), 777):
        part = Trace({k: v[a:a + 777] for k, v in tr.columns.items()})
        s = est.run(part, reset=a == 0, t_prev_s=t_prev)
        t_prev = float(part["t_s"][-1])
        masses.append(s.mass_kg)
        slopes.append(s.slope_rad)
    np.testing.assert_array_equal(np.concatenate(masses), whole.mass_kg)
    np.testing.assert_array_equal(np.concatenate(slopes), whole.slope_rad)


def test_error_accumulator_in_blocks_equals_the_whole() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(5000) * 0.01
    truth = rng.uniform(5e3, 3e4, t.size)
    truth[rng.random(t.size) < 0.1] = np.nan
    est = truth * (1 + rng.normal(0, 0.05, t.size))
    whole = error_after_settling(t, est, truth, 7.0, relative=True)
    acc = ErrorAccumulator(7.0, relative=True)
    for a in range(0, t.size, 613):
        acc.add(t[a:a + 613], est[a:a + 613], truth[a:a + 613])
    got = acc.result()
    assert got.samples == whole.samples and got.max_abs == whole.max_abs
    assert got.rmse == pytest.approx(whole.rmse, rel=1e-12) and got.mean_abs == pytest.approx(whole.mean_abs)


@pytest.mark.parametrize("name", ["dffrls-aekf", "sf-kf"])
def test_streaming_cli_equals_one_run(log: Path, tmp_path: Path, small_blocks, capsys, name: str) -> None:
    out = tmp_path / "est.csv"
    assert main([str(log), "--estimator", name, "--out", str(out), "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    tr = read_trace_csv(log)
    series = estimators.make(name).run(tr)
    rows = np.genfromtxt(out, delimiter=",", names=True)
    np.testing.assert_array_equal(rows["t_s"], tr["t_s"])  # time exactly as read
    np.testing.assert_allclose(rows["mass_kg"], series.mass_kg, rtol=1e-8)  # 9 significant digits
    np.testing.assert_allclose(rows["slope_deg"], series.slope_deg, rtol=1e-8, atol=1e-12)
    direct = summarize(tr, series, 10.0, estimators.get_class(name).provides)
    assert summary["samples"] == direct["samples"] == len(tr)
    assert summary["samples_after_settle"] == direct["samples_after_settle"]
    for q, key in (("mass", "max_abs_error_pct"), ("slope", "rmse_deg")):
        assert summary[q][key] == pytest.approx(direct[q][key], rel=1e-12)


def test_a_late_error_leaves_the_previous_output(log: Path, tmp_path: Path, small_blocks, capsys) -> None:
    lines = log.read_text().splitlines()
    fields = lines[3500].split(",")
    fields[1] = "text"
    lines[3500] = ",".join(fields)
    bad = tmp_path / "bad.csv"
    bad.write_text("\n".join(lines) + "\n")
    out = tmp_path / "est.csv"
    out.write_text("previous\n")
    assert main([str(bad), "--out", str(out)]) == 2
    assert ":3501: column 'torque_nm': not a number" in capsys.readouterr().err
    assert out.read_text() == "previous\n"
    assert sorted(q.name for q in tmp_path.iterdir()) == ["bad.csv", "est.csv"]  # no temporary file left


def test_writer_formats(tmp_path: Path) -> None:
    p = tmp_path / "w.csv"
    with csv_writer_atomic(p, ["t_s", "x"], ["%r", "%.3g"]) as w:
        w.write([np.array([0.1, 0.2]), np.array([1.23456, np.nan])])
        w.write([np.array([0.3]), np.array([7.0])])
    assert p.read_text() == "t_s,x\n0.1,1.23\n0.2,\n0.3,7\n"
    with pytest.raises(ValueError, match="formats"):
        with csv_writer_atomic(tmp_path / "v.csv", ["a", "b"], ["%r"]):
            pass
    assert not (tmp_path / "v.csv").exists()
