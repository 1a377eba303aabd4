"""Tests of ``uuom-estimate`` (estimators.cli): the contract of shared/spec/trace-format.md."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import numpy as np
import pytest

import estimators
from estimators.cli import EXIT_BAD_INPUT, main, summarize
from uuom_core.synthetic import synthetic_trace
from uuom_core.trace import read_trace_csv, write_trace_csv

HEADER = "t_s,torque_nm,speed_mps,accel_mps2,mass_kg,slope_deg"


@pytest.fixture(scope="module")
def good_trace(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("traces") / "run.csv"
    write_trace_csv(synthetic_trace("section1", seed=2, duration_s=20.0), p)
    return p


def _run(capsys, *argv: str) -> tuple[int, str, str]:
    rc = main(list(argv))
    out, err = capsys.readouterr()
    return rc, out, err


def _bad(capsys, *argv: str) -> str:
    rc, out, err = _run(capsys, *argv)
    assert rc == EXIT_BAD_INPUT
    lines = err.strip().splitlines()
    assert len(lines) == 1, err  # one line
    assert lines[0].startswith("uuom-estimate: error: ")
    return lines[0]


def test_writes_estimates_and_summary(good_trace: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "est.csv"
    rc, stdout, err = _run(capsys, str(good_trace), "--estimator", "sf-kf", "--out", str(out))
    assert rc == 0, err
    text = out.read_text().splitlines()
    assert text[0] == "t_s,mass_kg,slope_deg,mass_std_kg,slope_std_deg"
    assert len(text) - 1 == len(read_trace_csv(good_trace))  # one row per input row
    assert "RMSE" in stdout and "%" in stdout and "max |error|" in stdout
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]  # atomic: no temp file left


def test_json_summary_matches_direct_computation(good_trace: Path, tmp_path: Path, capsys) -> None:
    rc, stdout, _ = _run(capsys, str(good_trace), "--estimator", "dffrls-aekf", "--json", "--settle-s", "5")
    assert rc == 0
    s = json.loads(stdout)
    tr = read_trace_csv(good_trace)
    series = estimators.make("dffrls-aekf").run(tr)
    m = tr["t_s"] >= 5.0
    rmse = math.sqrt(np.mean((series.mass_kg[m] - tr["mass_kg"][m]) ** 2))
    assert s["mass"]["rmse_kg"] == pytest.approx(rmse)
    assert s["mass"]["rmse_pct"] == pytest.approx(100 * math.sqrt(np.mean((series.mass_kg[m] / tr["mass_kg"][m] - 1) ** 2)))
    smax = np.max(np.abs(series.slope_deg[m] - tr["slope_deg"][m]))
    assert s["slope"]["max_abs_error_deg"] == pytest.approx(smax)
    assert s["settle_s"] == 5.0 and s["estimator"] == "dffrls-aekf"


def test_speed_nis_in_the_summary_needs_no_truth(good_trace: Path, tmp_path: Path, capsys) -> None:
    """The NIS of the speed corrections is reported for the estimators that expose them, with or without truth
    columns, and block-by-block reading gives the protocol's number (one sample a second after the settle time)."""
    from estimators.metrics import nis_consistency

    rc, stdout, _ = _run(capsys, str(good_trace), "--estimator", "fused", "--json", "--settle-s", "5")
    assert rc == 0
    nis = json.loads(stdout)["speed_nis"]
    tr = read_trace_csv(good_trace)
    ref = nis_consistency(tr["t_s"], estimators.make("fused").run(tr).extras["nis"], 5.0)
    assert nis["samples"] == ref.samples and nis["mean"] == pytest.approx(ref.mean) and nis["in_band"] == ref.in_band
    bare = tmp_path / "bare.csv"
    cols = ["t_s", "torque_nm", "speed_mps", "accel_mps2"]  # no truth columns
    np.savetxt(bare, np.column_stack([tr[c] for c in cols]), delimiter=",", header=",".join(cols), comments="",
               fmt="%.10g")
    rc, stdout, _ = _run(capsys, str(bare), "--estimator", "dffrls-aekf")
    assert rc == 0 and "speed NIS (no truth needed)" in stdout
    rc, stdout, _ = _run(capsys, str(good_trace), "--estimator", "rls", "--json")
    assert "speed_nis" not in json.loads(stdout)


def test_output_roundtrip_matches_run(good_trace: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "e.csv"
    assert _run(capsys, str(good_trace), "--estimator", "ffrls", "--out", str(out))[0] == 0
    rows = np.genfromtxt(out, delimiter=",", names=True)
    series = estimators.make("ffrls").run(read_trace_csv(good_trace))
    np.testing.assert_allclose(rows["mass_kg"], series.mass_kg)
    np.testing.assert_allclose(rows["slope_deg"], series.slope_deg)


def test_list(capsys) -> None:
    rc, out, _ = _run(capsys, "--list")
    assert rc == 0
    names = out.split()
    for n in ("rls", "ffrls", "dffrls", "ekf", "rls-ekf", "dffrls-aekf", "sf-kf"):
        assert n in names


def test_no_truth_no_summary(tmp_path: Path, capsys) -> None:
    p = tmp_path / "nt.csv"
    p.write_text("t_s,torque_nm,speed_mps,accel_mps2\n0,100,0,0\n0.005,100,0,0\n")
    rc, out, _ = _run(capsys, str(p), "--json")
    assert rc == 0
    s = json.loads(out)
    assert "mass" not in s and "slope" not in s


# --- bad input: one line naming file, line and column; non-zero exit; output untouched ------------------------

def _write(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize(
    "text, line, what",
    [
        ("t_s,torque_nm,speed_mps\n0,1,2\n", 1, "accel_mps2"),  # missing required column
        (HEADER + "\n0,1,2,3,26000,0\n0.005,1,abc,3,26000,0\n", 3, "speed_mps"),  # text in a number column
        (HEADER + "\n0,1,2,3,26000,0\n0,1,2,3,26000,0\n", 3, "t_s"),  # time not increasing
        (HEADER + "\n0,1,2,3,26000,0\n0.005,nan,2,3,26000,0\n", 3, "torque_nm"),  # NaN
        (HEADER + "\n0,1,2,3,26000,0\n0.005,1,2,inf,26000,0\n", 3, "accel_mps2"),  # infinite
        ("", 1, "empty"),  # empty file
        (HEADER + "\n", 2, "empty"),  # header only
    ],
)
def test_bad_trace(tmp_path: Path, capsys, text: str, line: int, what: str) -> None:
    p = _write(tmp_path, "bad.csv", text)
    out = tmp_path / "out.csv"
    out.write_text("previous")
    msg = _bad(capsys, str(p), "--out", str(out))
    assert f"{p}:{line}:" in msg
    assert what in msg
    assert out.read_text() == "previous"  # written whole or not at all


def test_unknown_estimator(good_trace: Path, capsys) -> None:
    msg = _bad(capsys, str(good_trace), "--estimator", "kalman-magic")
    assert "kalman-magic" in msg and "dffrls-aekf" in msg


@pytest.mark.parametrize(
    "toml, line, key",
    [
        ("[vehicle]\nempty_mass_kg = 16000.0\nwheel_size = 3\n", 3, "wheel_size"),  # unknown key
        ("[vehicle]\nempty_mass_kg = 16000.0\ndrive_wheel_radius_m = 0.0\n", 3, "drive_wheel_radius_m"),
        ("[vehicle]\n\nempty_mass_kg = -5.0\n", 3, "empty_mass_kg"),  # negative mass
        ("[vehicle]\ncarrying_wheel_radius_m = -0.1\n", 2, "carrying_wheel_radius_m"),
        ("[vehicle]\nrunning_resistance = \"high\"\n", 2, "running_resistance"),
    ],
)
def test_bad_vehicle(good_trace: Path, tmp_path: Path, capsys, toml: str, line: int, key: str) -> None:
    v = _write(tmp_path, "veh.toml", toml)
    msg = _bad(capsys, str(good_trace), "--vehicle", str(v))
    assert f"{v}:{line}:" in msg and key in msg


def test_bad_vehicle_syntax_and_missing(good_trace: Path, tmp_path: Path, capsys) -> None:
    v = _write(tmp_path, "veh.toml", "[vehicle\n")
    msg = _bad(capsys, str(good_trace), "--vehicle", str(v))
    assert re.search(rf"{re.escape(str(v))}:1: column \d+", msg)
    msg = _bad(capsys, str(good_trace), "--vehicle", str(tmp_path / "nope.toml"))
    assert "nope.toml" in msg


def test_good_vehicle_file_is_used(good_trace: Path, tmp_path: Path, capsys) -> None:
    v = _write(tmp_path, "veh.toml", "[vehicle]\nempty_mass_kg = 20000.0\nrated_load_kg = 10000.0\n")
    rc, out, _ = _run(capsys, str(good_trace), "--vehicle", str(v), "--estimator", "ffrls", "--json")
    assert rc == 0
    rc, out_default, _ = _run(capsys, str(good_trace), "--estimator", "ffrls", "--json")
    assert rc == 0
    # the same trace under another vehicle must give other estimates: the file is read and used, not ignored
    with_file, default = json.loads(out)["mass"], json.loads(out_default)["mass"]
    assert abs(with_file["rmse_kg"] - default["rmse_kg"]) > 1.0, (with_file, default)


def test_missing_trace_and_bad_settle(tmp_path: Path, capsys) -> None:
    msg = _bad(capsys, str(tmp_path / "none.csv"))
    assert "none.csv" in msg
    p = _write(tmp_path, "t.csv", HEADER + "\n0,1,2,3,26000,0\n")
    assert "--settle-s" in _bad(capsys, str(p), "--settle-s", "-1")
    assert "directory" in _bad(capsys, str(p), "--out", str(tmp_path / "no" / "dir" / "o.csv"))


def test_summary_after_settle_only() -> None:
    tr = synthetic_trace("level", seed=1, duration_s=12.0)
    series = estimators.make("rls").run(tr)
    s = summarize(tr, series, settle_s=100.0)
    assert s["mass"] is None and s["slope"] is None and s["samples_after_settle"] == 0


def test_console_script_exists() -> None:
    # the console script declared in pyproject resolves to estimators.cli:main
    import importlib.metadata as md

    eps = [e for e in md.entry_points(group="console_scripts") if e.name == "uuom-estimate"]
    assert eps and eps[0].value == "estimators.cli:main"


# --- real-world files: one line each, or a warning with the count ---------------------------------------------

def _rows(n: int, dt: float = 0.005, t0: float = 0.0) -> str:
    return "".join(f"{t0 + i * dt!r},1200,{1.0 + 0.001 * i!r},0.3,26000,0\n" for i in range(n))


@pytest.mark.parametrize(
    "text, expected",
    [
        (HEADER.replace(",", ";") + "\n" + _rows(3).replace(",", ";"), ":1: missing required column(s)"),
        (HEADER + "\n" + _rows(30, dt=5.0), "milliseconds"),
        (HEADER + "\n" + _rows(5) + "0.03,1200,1e300,0.3,26000,0\n", ":7: column 'speed_mps': 1e+300 is outside"),
        (HEADER + "\n" + _rows(5) + _rows(5, t0=1e9), ":7: column 't_s': time jumps by"),
    ],
)
def test_real_world_bad_traces(tmp_path: Path, capsys, text: str, expected: str) -> None:
    p = _write(tmp_path, "bad.csv", text)
    out = tmp_path / "out.csv"
    out.write_text("previous")
    msg = _bad(capsys, str(p), "--out", str(out))
    assert expected in msg and str(p) in msg
    assert out.read_text() == "previous"
    if "';'" in text or ";" in text.splitlines()[0]:
        assert "';'-separated" in msg


def test_excel_bom_trace_is_read(tmp_path: Path, capsys) -> None:
    p = tmp_path / "excel.csv"
    p.write_bytes(b"\xef\xbb\xbf" + (HEADER + "\n" + _rows(20)).encode())
    rc, out, err = _run(capsys, str(p), "--estimator", "rls", "--json")
    assert rc == 0, err
    assert json.loads(out)["samples"] == 20


def test_warnings_go_to_stderr_with_counts_and_the_run_completes(tmp_path: Path, capsys) -> None:
    rows = _rows(200).splitlines()
    rows = [r if i % 20 == 0 else ",".join(r.split(",")[:2] + [""] + r.split(",")[3:])  # speed 95 % empty
            for i, r in enumerate(rows)]
    p = _write(tmp_path, "sparse.csv", HEADER + "\n" + "\n".join(rows) + "\n0.999,1200\n")
    out = tmp_path / "o.csv"
    rc, _, err = _run(capsys, str(p), "--estimator", "rls", "--out", str(out))
    assert rc == 0
    lines = err.strip().splitlines()
    assert any("warning:" in x and "'speed_mps': empty in 95." in x for x in lines), err
    assert any("warning:" in x and ":202: 1 row(s) shorter than the header" in x for x in lines), err
    assert len(out.read_text().splitlines()) == 202


def test_list_says_what_each_estimator_estimates(capsys) -> None:
    rc, out, _ = _run(capsys, "--list")
    rows = dict(line.split("\t") for line in out.strip().splitlines())
    assert {"mass", "slope"} <= set(rows["dffrls-aekf"].split(",")) and rows["imu-ukf"] == "slope" and "slip" in rows["aupf"]


def test_estimator_that_does_not_estimate_mass_writes_only_its_own_columns(tmp_path: Path, capsys) -> None:
    tr = synthetic_trace("section1", seed=2, duration_s=5.0)
    tr.columns["motor_speed_radps"] = tr["speed_mps"] / 0.17
    p = tmp_path / "m.csv"
    write_trace_csv(tr, p)
    out = tmp_path / "o.csv"
    rc, stdout, err = _run(capsys, str(p), "--estimator", "aupf", "--out", str(out), "--json")
    assert rc == 0, err
    assert out.read_text().splitlines()[0] == "t_s,slip_ratio,slip_ratio_std,drive_radius_m,drive_radius_m_std"
    s = json.loads(stdout)
    assert "mass" not in s and "slope" not in s  # the prior is not scored as an estimate
    assert "note: aupf estimates" in err


def test_estimator_without_its_input_columns_is_refused(good_trace: Path, tmp_path: Path, capsys) -> None:
    msg = _bad(capsys, str(good_trace), "--estimator", "imu-ukf", "--out", str(tmp_path / "o.csv"))
    assert "imu-ukf needs column(s) gyro_radps" in msg
    assert not (tmp_path / "o.csv").exists()


def test_estimator_options(good_trace: Path, tmp_path: Path, capsys) -> None:
    # --option KEY=VALUE reaches the estimator: the fixed-window dffrls-aekf writes what the class gives directly
    out = tmp_path / "fixed.csv"
    rc, _, err = _run(capsys, str(good_trace), "--option", "train_length_m=12", "--out", str(out))
    assert rc == 0, err
    header = out.read_text().splitlines()[0].split(",")
    got = np.loadtxt(out, delimiter=",", skiprows=1)[:, header.index("mass_kg")]
    ref = estimators.make("dffrls-aekf", train_length_m=12.0).run(read_trace_csv(good_trace))
    np.testing.assert_allclose(got, ref.mass_kg, rtol=1e-6)
    default = estimators.make("dffrls-aekf").run(read_trace_csv(good_trace)).mass_kg
    assert np.max(np.abs(got - default)) > 50.0  # the option changed something (the bank differs on this trace)
    rc, _, err = _run(capsys, str(good_trace), "--option", "windows_m=(0, 12)", "--option", "gates=False")
    assert rc == 0, err
    # a switch may be written as JSON writes it: false is False, not the (truthy) string "false"
    rc, _, err = _run(capsys, str(good_trace), "--option", "weak_offset_random_walk=false", "--out", str(out))
    assert rc == 0, err
    got = np.loadtxt(out, delimiter=",", skiprows=1)[:, header.index("mass_kg")]
    ref = estimators.make("dffrls-aekf", weak_offset_random_walk=False).run(read_trace_csv(good_trace))
    np.testing.assert_allclose(got, ref.mass_kg, rtol=1e-6)


@pytest.mark.parametrize("option, what", [
    ("no_such=1", "unknown option"),
    ("train_length_m=-3", "train_length_m must be a number in"),
    ("=3", "KEY=VALUE"),
    ("train_length_m", "KEY=VALUE"),
    ("gates=maybe", "gates must be True or False"),
])
def test_bad_estimator_option(good_trace: Path, tmp_path: Path, capsys, option: str, what: str) -> None:
    out = tmp_path / "never.csv"
    line = _bad(capsys, str(good_trace), "--option", option, "--out", str(out))
    assert "--option" in line and what in line
    assert not out.exists()  # refused before anything is written


def test_the_sample_rate_is_reported_and_a_log_far_from_200_hz_gets_a_note(good_trace: Path, tmp_path: Path,
                                                                          capsys) -> None:
    """The estimators are tuned per 200 Hz sample: the summary gives the trace's median rate, and a log at another
    rate (here every 4th row: 50 Hz) is estimated all the same, with one note on stderr that names its rate."""
    rc, stdout, err = _run(capsys, str(good_trace), "--json")
    assert rc == 0 and json.loads(stdout)["sample_hz"] == pytest.approx(200.0, rel=1e-3) and "note" not in err
    tr = read_trace_csv(good_trace)
    slow = tmp_path / "slow.csv"
    write_trace_csv({c: v[::4] for c, v in tr.columns.items()}, slow)
    out = tmp_path / "est.csv"
    rc, stdout, err = _run(capsys, str(slow), "--json", "--out", str(out))
    assert rc == 0 and json.loads(stdout)["sample_hz"] == pytest.approx(50.0, rel=1e-3)
    notes = [line for line in err.splitlines() if "note" in line]
    assert len(notes) == 1 and "50 Hz" in notes[0] and "200 Hz" in notes[0]
    assert len(out.read_text().splitlines()) - 1 == len(tr["t_s"][::4])


def test_a_log_that_begins_in_motion_gets_a_note(good_trace: Path, tmp_path: Path, capsys) -> None:
    """The estimators learn the mass mostly from a pull-away (docs/estimation.md, "Where the mass comes from"): a log
    that begins moving is told so once, on stderr; one that begins at rest is not; the JSON summary carries the start
    speed."""
    rc, stdout, err = _run(capsys, str(good_trace), "--estimator", "dffrls-aekf", "--json")
    assert rc == 0 and "begins in motion" not in err
    assert abs(json.loads(stdout)["start_speed_mps"]) < 0.1
    tr = read_trace_csv(good_trace)
    late_t = float(tr["t_s"][np.argmax(tr["speed_mps"] > 0.5)])  # past the pull-away
    late = tmp_path / "late.csv"
    write_trace_csv(tr.from_time(late_t), late)
    rc, stdout, err = _run(capsys, str(late), "--estimator", "dffrls-aekf", "--json")
    notes = [line for line in err.splitlines() if "begins in motion" in line]
    assert rc == 0 and len(notes) == 1 and notes[0].startswith("uuom-estimate: note: ")
    assert json.loads(stdout)["start_speed_mps"] > 0.1
