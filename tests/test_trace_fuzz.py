"""Property-based fuzzing of the trace reader (Hypothesis, derandomized: the same inputs on every run).

Random bytes and random mutations of a valid trace must give either a valid :class:`Trace` or one
:class:`TraceFormatError` line naming the file; never another exception, never a hang. When the reader accepts a
file, its fast path must agree with the exact line-by-line path. A last (slow) test runs what the reader accepts at
the edges of its ranges through every registered estimator: finite output, in bounded time.
"""

from __future__ import annotations

import math
import tempfile
import warnings
from pathlib import Path
from unittest import mock

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import uuom_core.trace as trace_mod
from uuom_core.trace import (
    MAX_GAP_S,
    PLAUSIBLE_ABS_MAX,
    REQUIRED_COLUMNS,
    Trace,
    TraceFormatError,
    TraceWarning,
    read_trace_csv,
)

FUZZ = settings(derandomize=True, max_examples=400, deadline=None, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

HEADER = "t_s,torque_nm,speed_mps,accel_mps2,mass_kg,slope_deg"
_rng = np.random.default_rng(7)
VALID = HEADER + "\n" + "".join(
    f"{i * 0.005!r},{1000 + 50 * _rng.standard_normal()!r},{1 + 0.01 * _rng.standard_normal()!r},"
    f"{0.1 * _rng.standard_normal()!r},26000.0,{i * 0.01!r}\n"
    for i in range(40)
)
TOKENS = ["", " ", "nan", "NaN", "inf", "-inf", "1e300", "-1e300", "1e999", "abc", '"1"', '"', "1,2", "\n", "\r",
          "\r\n", ";", "\t", "\ufeff", "0x10", "1_0", "\x00", "1e-320", "-0", "1e", ".", "+", "é", "1 2", ",,",
          "1e9", "-5", "99999", "#"]

_DIR = Path(tempfile.mkdtemp(prefix="uuom-fuzz-"))


def _check(data: bytes) -> None:
    path = _DIR / "fuzz.csv"
    path.write_bytes(data)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", TraceWarning)
        try:
            tr = read_trace_csv(path)
        except TraceFormatError as exc:
            msg = str(exc)
            assert msg.startswith(str(path)) and "\n" not in msg and len(msg) < 400, msg
            return
        with mock.patch.object(trace_mod, "parse_fast", lambda *a, **k: None):
            exact = read_trace_csv(path)
    assert isinstance(tr, Trace) and len(tr) >= 1
    for c in REQUIRED_COLUMNS:
        assert c in tr
    t = tr["t_s"]
    assert np.all(np.isfinite(t)) and np.all(np.diff(t) > 0) and np.all(np.diff(t) <= MAX_GAP_S)
    for name, v in tr.columns.items():
        assert not np.isinf(v).any()
        assert np.all(np.abs(v[np.isfinite(v)]) <= PLAUSIBLE_ABS_MAX[name])
        assert np.array_equal(v, exact[name], equal_nan=True), name  # fast path == exact path


@FUZZ
@given(st.binary(max_size=3000))
def test_random_bytes(data: bytes) -> None:
    _check(data)


@FUZZ
@given(st.binary(max_size=2000))
def test_random_bytes_after_a_valid_header(data: bytes) -> None:
    _check(HEADER.encode() + b"\n" + data)


@FUZZ
@given(st.text(alphabet="0123456789.,,,,eE+-\n\n\r ;\"nainf", max_size=1500))
def test_random_csv_text_after_a_valid_header(text: str) -> None:
    _check((HEADER + "\n" + text).encode())


@st.composite
def mutated(draw) -> bytes:
    text = VALID
    for _ in range(draw(st.integers(1, 6))):
        kind = draw(st.sampled_from(["token", "delete", "cell", "dupline", "truncate", "crlf", "bom", "swap"]))
        pos = draw(st.integers(0, len(text)))
        if kind == "token":
            text = text[:pos] + draw(st.sampled_from(TOKENS)) + text[pos:]
        elif kind == "delete":
            text = text[:pos] + text[pos + draw(st.integers(1, 30)):]
        elif kind == "cell":
            lines = text.split("\n")
            i = draw(st.integers(0, len(lines) - 1))
            cells = lines[i].split(",")
            j = draw(st.integers(0, len(cells) - 1))
            cells[j] = draw(st.sampled_from(TOKENS) | st.floats(allow_nan=True).map(repr))
            lines[i] = ",".join(cells)
            text = "\n".join(lines)
        elif kind == "dupline" or kind == "swap":
            lines = text.split("\n")
            i, j = draw(st.integers(0, len(lines) - 1)), draw(st.integers(0, len(lines) - 1))
            if kind == "dupline":
                lines.insert(j, lines[i])
            else:
                lines[i], lines[j] = lines[j], lines[i]
            text = "\n".join(lines)
        elif kind == "truncate":
            text = text[:pos]
        elif kind == "crlf":
            text = text.replace("\n", "\r\n")
        else:
            text = "\ufeff" + text
    return text.encode("utf-8", errors="surrogatepass")


@FUZZ
@given(mutated())
def test_mutated_valid_trace(data: bytes) -> None:
    _check(data)


def test_the_fuzz_reaches_both_outcomes() -> None:
    """Guard against a fuzz that only ever produces errors (it would test nothing about valid results)."""
    seen: set[str] = set()

    @settings(FUZZ, max_examples=200)
    @given(mutated())
    def probe(data: bytes) -> None:
        path = _DIR / "probe.csv"
        path.write_bytes(data)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", TraceWarning)
            try:
                read_trace_csv(path)
                seen.add("ok")
            except TraceFormatError:
                seen.add("error")

    probe()
    assert seen == {"ok", "error"}


@pytest.mark.slow
def test_what_the_reader_accepts_runs_through_every_estimator() -> None:
    """Values at the edge of the plausible ranges, bursts and a gap just under a day: finite, bounded time."""
    import time

    import estimators

    n = 3000
    t = np.arange(n) * 0.005
    t[1500:] += MAX_GAP_S * 0.999
    cols = {"t_s": t, "torque_nm": np.full(n, 1200.0), "speed_mps": np.full(n, 1.0), "accel_mps2": np.full(n, 0.3),
            "motor_speed_radps": np.full(n, 6.0), "gyro_radps": np.zeros(n), "accel_normal_mps2": np.full(n, 9.8)}
    for k, (name, sign) in enumerate([("speed_mps", 1), ("speed_mps", -1), ("torque_nm", 1), ("torque_nm", -1),
                                       ("accel_mps2", -1), ("motor_speed_radps", 1), ("gyro_radps", 1),
                                       ("accel_normal_mps2", 1)]):
        cols[name][200 + 150 * k: 260 + 150 * k] = sign * PLAUSIBLE_ABS_MAX[name]
    cols["speed_mps"][2000:2100] = np.nan
    tr = Trace(cols)
    for name in estimators.available():
        start = time.process_time()
        s = estimators.make(name).run(tr)
        used = time.process_time() - start
        for arr in (s.mass_kg, s.slope_rad, s.mass_std_kg, s.slope_std_rad):
            assert np.all(np.isfinite(arr)), name
        assert used < 120.0, f"{name}: {used:.0f} s of CPU for {n} samples"  # a hang guard, not a timing


def test_plausible_ranges_cover_every_known_column() -> None:
    known = trace_mod.REQUIRED_COLUMNS + trace_mod.OPTIONAL_COLUMNS + trace_mod.EXTRA_COLUMNS
    assert set(PLAUSIBLE_ABS_MAX) == set(known)
    assert all(math.isfinite(v) and v > 0 for v in PLAUSIBLE_ABS_MAX.values())
