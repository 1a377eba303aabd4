"""The one error metric (estimators.metrics) on hand-made signals whose answers are known."""

from __future__ import annotations

import math

import numpy as np
import pytest

from estimators.metrics import (chi2_band, consistency, distribution, error_after_settling, settled_mask,
                                settling_time_s)

T = np.arange(0.0, 20.0, 0.5)  # 40 samples, 0 .. 19.5 s


def test_error_after_settling_uses_only_samples_after_the_settle_time() -> None:
    truth = np.full(T.size, 100.0)
    est = np.where(T < 10.0, 1e6, 100.0 + np.where(np.arange(T.size) % 2 == 0, 3.0, -4.0))
    e = error_after_settling(T, est, truth, 10.0)
    assert e.samples == 20
    assert e.max_abs == pytest.approx(4.0)
    assert e.mean_abs == pytest.approx(3.5)
    assert e.rmse == pytest.approx(math.sqrt((9 + 16) / 2))
    rel = error_after_settling(T, est, truth, 10.0, relative=True)
    assert rel.max_abs == pytest.approx(4.0)  # percent of 100


def test_settle_time_counts_from_the_first_sample_and_skips_unknown_truth() -> None:
    t = T + 100.0
    truth = np.full(T.size, 1.0)
    truth[-5:] = np.nan
    est = np.full(T.size, 2.0)
    e = error_after_settling(t, est, truth, 10.0)
    assert e.samples == 15 and e.max_abs == 1.0
    assert settled_mask(t, 10.0).sum() == 20
    assert error_after_settling(t, est, truth, 30.0) is None


def test_non_finite_estimate_is_an_infinite_error() -> None:
    est = np.ones(T.size)
    est[-1] = np.nan
    assert math.isinf(error_after_settling(T, est, np.ones(T.size), 0.0).max_abs)


def test_bad_input_is_one_clear_error() -> None:
    with pytest.raises(ValueError, match="settle_s"):
        error_after_settling(T, T, T, -1.0)
    with pytest.raises(ValueError, match="samples"):
        error_after_settling(T, T[:-1], T, 1.0)


def test_settling_time() -> None:
    truth = np.full(T.size, 10.0)
    est = truth.copy()
    est[T < 4.0] = 20.0
    est[T == 7.0] = 10.5  # a last excursion beyond 2 % at 7 s
    assert settling_time_s(T, est, truth, 2.0, relative=True) == pytest.approx(7.5)
    assert settling_time_s(T, truth, truth, 2.0, relative=True) == 0.0
    est[-1] = 0.0
    assert math.isinf(settling_time_s(T, est, truth, 2.0, relative=True))


def test_consistency_of_a_consistent_and_of_an_overconfident_estimate() -> None:
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 400.0, 0.5)
    truth = np.zeros(t.size)
    sigma = np.full(t.size, 2.0)
    est = rng.normal(0.0, 2.0, t.size)
    c = consistency(t, est, sigma, truth, 0.0, every_s=1.0)
    assert c.samples == 400
    assert c.in_band and 0.8 < c.nees < 1.2
    assert 0.93 < c.within_2sigma < 0.98
    over = consistency(t, est, sigma / 5.0, truth, 0.0)
    assert not over.in_band and over.nees > 20 and over.within_2sigma < 0.5
    zero = consistency(t, est, np.zeros(t.size), truth, 0.0)
    assert math.isinf(zero.nees)


def test_chi2_band_contains_one_and_narrows_with_samples() -> None:
    lo1, hi1 = chi2_band(10)
    lo2, hi2 = chi2_band(1000)
    assert lo1 < lo2 < 1.0 < hi2 < hi1


def test_distribution() -> None:
    d = distribution([1.0, 2.0, math.nan, 3.0, math.inf])
    assert d["n"] == 4 and d["median"] == 2.0 and math.isinf(d["max"])
    assert distribution([math.nan])["n"] == 0
    v = distribution(range(1, 101))
    assert v["p95"] == 95.0 and v["p90"] == 90.0 and v["max"] == 100.0
