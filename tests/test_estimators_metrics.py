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


# --- what the NEES band test can give with correlated errors ----------------------------------------------------


def test_consistent_share_is_the_band_level_for_independent_errors() -> None:
    from estimators.metrics import consistent_in_band_share

    rng = np.random.default_rng(0)
    acf = np.r_[1.0, np.zeros(49)]
    share = consistent_in_band_share([50] * 200, acf, rng, draws=5)
    assert 0.92 <= share <= 0.98  # 95 % band, 1000 draws


def test_consistent_share_collapses_for_a_bias() -> None:
    # an error that is one draw for the whole run (ρ = 1): the average of 50 "samples" is χ²(1), which falls in the
    # band of 50 independent samples [0.65, 1.43] with probability ~0.16
    from scipy.stats import chi2

    from estimators.metrics import chi2_band, consistent_in_band_share

    lo, hi = chi2_band(50)
    expected = chi2.cdf(hi, 1) - chi2.cdf(lo, 1)
    share = consistent_in_band_share([50] * 200, np.ones(50), np.random.default_rng(1), draws=5)
    assert abs(share - expected) < 0.05 and share < 0.3


def test_pooled_autocorrelation_of_an_ar1_process() -> None:
    from estimators.metrics import effective_samples, pooled_autocorrelation

    rng = np.random.default_rng(2)
    phi = 0.8
    seqs = []
    for _ in range(200):
        z = np.empty(60)
        z[0] = rng.standard_normal()
        for k in range(1, 60):
            z[k] = phi * z[k - 1] + np.sqrt(1 - phi**2) * rng.standard_normal()
        seqs.append(3.0 * z)  # the scale must not matter
    acf = pooled_autocorrelation(seqs, 10)
    assert acf[0] == 1.0
    np.testing.assert_allclose(acf[1:4], phi ** np.arange(1, 4), atol=0.06)
    assert effective_samples(60, np.ones(60)) == 1.0
    assert effective_samples(60, np.r_[1.0, np.zeros(59)]) == 60.0
    assert 5.0 < effective_samples(60, phi ** np.arange(60)) < 15.0  # ~ n (1 - φ) / (1 + φ) = 6.7 plus edge terms


def test_pooled_autocorrelation_refuses_empty_input() -> None:
    from estimators.metrics import pooled_autocorrelation

    with pytest.raises(ValueError, match="at least one sequence"):
        pooled_autocorrelation([np.zeros(5), np.ones(1)], 3)


def test_normalised_error_samples_match_consistency() -> None:
    from estimators.metrics import consistency, normalised_error_samples

    t = np.arange(0.0, 60.0, 0.005)
    truth = np.full_like(t, 20_000.0)
    rng = np.random.default_rng(3)
    est = truth + 300.0 * rng.standard_normal(len(t))
    sd = np.full_like(t, 300.0)
    z = normalised_error_samples(t, est, sd, truth)
    c = consistency(t, est, sd, truth)
    assert len(z) == c.samples and np.mean(z * z) == pytest.approx(c.nees)


def test_nees_ceiling_script_runs(tmp_path) -> None:
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    r = subprocess.run([sys.executable, str(root / "scripts" / "nees_ceiling.py"), "--runs", "2", "--draws", "2",
                        "--max-lag", "5"], capture_output=True, text=True, cwd=root, timeout=300)
    assert r.returncode == 0, r.stderr
    rows = [line for line in r.stdout.splitlines() if line.startswith("| plant") or line.startswith("| point")]
    assert len(rows) == 4  # two worlds x mass, slope
    bad = subprocess.run([sys.executable, str(root / "scripts" / "nees_ceiling.py"), "--runs", "0"],
                         capture_output=True, text=True, cwd=root, timeout=60)
    assert bad.returncode == 2 and "--runs" in bad.stderr
