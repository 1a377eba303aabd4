"""Tests of the shared numerical helpers in estimators/filters.py."""

from __future__ import annotations

import math

import numpy as np
import pytest

from estimators.filters import (
    LowPass2,
    MAX_STEP_S,
    SpikeGate,
    capped_dt,
    check_dt,
    check_dt_non_negative,
    check_int_option,
    check_positive,
    check_number_options,
    dynamic_forgetting,
    hold_last_valid,
    joseph_update,
    kalman_update_3x3_h1,
    repair_pd,
    repair_pd_2x2,
    repair_pd_3x3,
    sage_husa_weight,
)


def test_lowpass_step_response_and_nan_hold() -> None:
    lp = LowPass2(1.0)
    assert lp(math.nan, 0.005) == 0.0 and not lp.ready
    assert lp(2.0, 0.005) == 2.0  # starts at the first value
    ys = [lp(5.0, 0.005) for _ in range(2000)]
    assert ys[-1] == pytest.approx(5.0, abs=1e-6)
    assert all(b >= a for a, b in zip(ys, ys[1:]))  # monotone step response (two real poles)
    y = lp(math.nan, 0.005)  # missing sample: holds the last input
    assert y == pytest.approx(5.0, abs=1e-6)
    with pytest.raises(ValueError, match="cutoff_hz"):
        LowPass2(0.0)


def test_lowpass_delays_both_sides_alike() -> None:
    # filtering y = k x on both sides keeps the ratio exactly (why the regressions filter both sides)
    a, b = LowPass2(0.7), LowPass2(0.7)
    rng = np.random.default_rng(0)
    for x in rng.normal(size=500):
        ya, yb = a(float(x), 0.005), b(3.0 * float(x), 0.005)
    assert yb == pytest.approx(3.0 * ya)


def test_spike_gate_rejects_and_relocks() -> None:
    g = SpikeGate(max_rate=2.0, noise_band=0.05, max_abs=10.0, relock_after=5)
    assert g(1.0, 0.005) == 1.0
    assert math.isnan(g(4.0, 0.005))  # impossible jump
    assert g(1.01, 0.005) == 1.01
    assert math.isnan(g(50.0, 0.005))  # beyond max_abs
    out = [g(3.0, 0.005) for _ in range(7)]  # a real step: rejected at first, then accepted
    assert math.isnan(out[0]) and out[-1] == 3.0
    assert math.isnan(g(math.nan, 0.005))
    with pytest.raises(ValueError, match="max_rate"):
        SpikeGate(max_rate=-1.0, noise_band=1.0, max_abs=1.0)


def test_forgetting_and_weights() -> None:
    assert dynamic_forgetting(0.0, 0.95, 5.0) == 1.0
    assert dynamic_forgetting(1e9, 0.95, 5.0) == pytest.approx(0.95)
    assert dynamic_forgetting(-0.3, 0.95, 5.0) == dynamic_forgetting(0.3, 0.95, 5.0)
    assert sage_husa_weight(0.966, 0) == pytest.approx(1.0)
    d = [sage_husa_weight(0.966, k) for k in range(1, 500)]
    assert all(b < a for a, b in zip(d, d[1:])) and d[-1] == pytest.approx(1 - 0.966, rel=1e-3)


def test_joseph_and_repair() -> None:
    rng = np.random.default_rng(1)
    for _ in range(200):
        A = rng.normal(size=(3, 3))
        P = A @ A.T + 1e-6 * np.eye(3)
        K = rng.normal(size=(3, 1)) * 10  # any gain, even a bad one
        H = np.array([[1.0, 0.0, 0.0]])
        out = joseph_update(P, K, H, np.array([[0.01]]))
        np.testing.assert_array_equal(out, out.T)
        assert np.linalg.eigvalsh(out).min() > -1e-9
    bad = np.array([[1.0, 2.0], [2.0, 1.0]])  # indefinite
    fixed = repair_pd(bad, 1e-6)
    assert np.linalg.eigvalsh(fixed).min() >= 1e-6 - 1e-12
    assert np.all(repair_pd(np.full((2, 2), np.nan), 1e-3) == np.eye(2) * 1e-3)
    p11, p12, p22 = repair_pd_2x2(1.0, 5.0, 1.0)
    assert p11 * p22 - p12 * p12 > 0
    p11, p12, p22 = repair_pd_2x2(math.nan, 0.0, -1.0, 1e-4, 1e-5)
    assert (p11, p22) == (1e-4, 1e-5)


def _sym3(p11, p12, p13, p22, p23, p33) -> np.ndarray:
    return np.array([[p11, p12, p13], [p12, p22, p23], [p13, p23, p33]])


def test_kalman_update_3x3_is_the_joseph_form() -> None:
    """The slope layer's 3-state correction (speed measured) equals the general Joseph update, entry by entry."""
    rng = np.random.default_rng(3)
    H = np.array([[1.0, 0.0, 0.0]])
    for _ in range(200):
        A = rng.normal(size=(3, 3))
        P = A @ A.T + 1e-6 * np.eye(3)
        r, innov = float(rng.uniform(1e-4, 1.0)), float(rng.normal())
        out = kalman_update_3x3_h1(P[0, 0], P[0, 1], P[0, 2], P[1, 1], P[1, 2], P[2, 2], innov, r)
        K = P[:, :1] / (P[0, 0] + r)
        np.testing.assert_allclose(out[:3], K[:, 0] * innov, rtol=1e-12, atol=1e-15)
        expected = joseph_update(P, K, H, np.array([[r]]))
        np.testing.assert_allclose(_sym3(*out[3:]), expected, rtol=1e-9, atol=1e-12)


def test_repair_pd_3x3_makes_any_input_positive_definite() -> None:
    rng = np.random.default_rng(4)
    for _ in range(500):
        vals = rng.normal(size=6) * rng.choice([1e-6, 1.0, 1e6], size=6)
        vals[rng.random(6) < 0.1] = rng.choice([np.nan, np.inf, -np.inf])
        p = repair_pd_3x3(*vals, 1e-10, 10.0)
        M = _sym3(*p)
        assert np.all(np.isfinite(M)) and M[1, 1] <= 10.0
        assert np.linalg.cholesky(M) is not None  # raises LinAlgError if not positive definite
    good = (2.0, 0.3, 0.1, 1.0, 0.2, 0.5)
    assert repair_pd_3x3(*good) == good  # a PD matrix is returned unchanged


def test_check_dt() -> None:
    assert check_dt(0.005) == 0.005
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="dt_s"):
            check_dt(bad)


def test_capped_dt() -> None:
    assert capped_dt(0.005) == 0.005
    assert capped_dt(MAX_STEP_S) == MAX_STEP_S
    assert capped_dt(1e300) == MAX_STEP_S  # a data gap
    for bad in (0.0, -1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="dt_s must be a finite number > 0"):
            capped_dt(bad)


def test_check_dt_non_negative() -> None:
    assert check_dt_non_negative(0.0, "x") == 0.0
    assert check_dt_non_negative(0.005, "x") == 0.005
    for bad in (-0.001, math.nan, math.inf):
        with pytest.raises(ValueError, match="mmae: dt_s"):
            check_dt_non_negative(bad, "mmae")


class _OptionError(ValueError):
    pass


def test_check_number_options_names_the_first_bad_option() -> None:
    check_number_options({"a": 1, "b": 0.0, "c": np.float64(-2.0)}, _OptionError, positive=("a",),
                         non_negative=("b",))
    with pytest.raises(_OptionError, match="b must be a finite number, got nan"):
        check_number_options({"a": 1.0, "b": math.nan, "c": math.inf}, _OptionError)
    with pytest.raises(_OptionError, match="a must be a finite number"):
        check_number_options({"a": "1"}, _OptionError)
    with pytest.raises(_OptionError, match="a must be > 0, got 0"):
        check_number_options({"a": 0, "b": -1.0}, _OptionError, positive=("a",), non_negative=("b",))
    with pytest.raises(_OptionError, match="b must be >= 0, got -1.0"):
        check_number_options({"a": 1, "b": -1.0}, _OptionError, positive=("a",), non_negative=("b",))
    check_number_options({"flag": True}, _OptionError)  # bool is an int unless told otherwise
    with pytest.raises(_OptionError, match="flag must be a finite number, got True"):
        check_number_options({"flag": True}, _OptionError, reject_bool=True)


def test_hold_last_valid() -> None:
    x = np.array([1.0, 2.0, 3.0])
    assert hold_last_valid(x) is x  # nothing missing: no copy
    y = hold_last_valid(np.array([np.nan, np.inf, 4.0, np.nan, 5.0, -np.inf]))
    assert y.tolist() == [4.0, 4.0, 4.0, 4.0, 5.0, 5.0]  # leading gap takes the first valid value
    assert hold_last_valid(np.full(3, np.nan)).tolist() == [0.0, 0.0, 0.0]


def test_check_int_option() -> None:
    check_int_option("n", 2, _OptionError, minimum=2)
    check_int_option("seed", np.int64(-3), _OptionError)
    with pytest.raises(_OptionError, match=r"n must be an integer >= 2, got 1"):
        check_int_option("n", 1, _OptionError, minimum=2)
    for bad in (True, 1.5, "3", None):
        with pytest.raises(_OptionError, match=r"^seed must be an integer, got"):
            check_int_option("seed", bad, _OptionError)


def test_check_positive_names_the_first_bad_value() -> None:
    check_positive(a=1.0, b=2)
    with pytest.raises(ValueError, match=r"^b must be a finite number > 0, got nan$"):
        check_positive(a=1.0, b=math.nan, c=0.0)
    with pytest.raises(ValueError, match=r"^X: c must be a finite number > 0, got 0.0$"):
        check_positive("X: ", c=0.0)
