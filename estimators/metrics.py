"""Estimator error metrics, written once: error after settling, settling time, consistency (NEES, ±2σ coverage).

Every script and the ``uuom-estimate`` summary score estimates with these functions, so "mass error after 10 s"
means the same thing everywhere:

- :func:`error_after_settling` -- RMSE, mean and maximum absolute error over the samples at or after
  ``t[0] + settle_s`` where the truth is known (relative errors in percent of the truth when ``relative``);
  :class:`ErrorAccumulator` the same block by block;
- :func:`settling_time_s` -- the time from the start after which the error stays within a tolerance to the end;
- :func:`consistency` -- normalised estimation error squared (NEES) of a scalar estimate against its reported
  standard deviation, its χ² 95 % band, and the fraction of samples whose truth lies inside ±2σ;
- :func:`distribution` -- median / p90 / p95 / max of a per-run metric across runs (NaN-aware);
- :func:`normalised_error_samples`, :func:`pooled_autocorrelation`, :func:`consistent_in_band_share`,
  :func:`effective_samples` -- what the NEES band test can give at all when the errors are correlated in time
  (``scripts/nees_ceiling.py``).

Pure numpy (scipy for the χ² quantiles); no dependency on the simulators.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import NamedTuple

import numpy as np

__all__ = [
    "Consistency",
    "ErrorAccumulator",
    "ErrorStats",
    "chi2_band",
    "consistency",
    "consistent_in_band_share",
    "distribution",
    "effective_samples",
    "normalised_error_samples",
    "pooled_autocorrelation",
    "error_after_settling",
    "NisTest",
    "nis_consistency",
    "settled_mask",
    "settling_time_s",
    "smallest_covering_scale",
    "train_slope_deg",
]


@dataclass(frozen=True)
class ErrorStats:
    """Errors over the scored samples, in the unit of the inputs (percent when relative).

    Attributes
    ----------
    rmse, mean_abs, max_abs : float
        Root-mean-square, mean absolute and maximum absolute error.
    samples : int
        Number of scored samples.
    """

    rmse: float
    mean_abs: float
    max_abs: float
    samples: int

    def as_dict(self) -> dict[str, float | int]:
        return asdict(self)


def train_slope_deg(trace) -> np.ndarray | None:
    """The slope an estimate is scored against: the train-averaged slope (``effective_slope_deg``) where the trace
    has it, else ``slope_deg`` (a point mass, or a recorded trace: the same slope); None if it has neither."""
    train = trace.get("effective_slope_deg")
    return trace.get("slope_deg") if train is None else train


def settled_mask(t_s: np.ndarray, settle_s: float, truth: np.ndarray | None = None) -> np.ndarray:
    """Samples at or after ``t_s[0] + settle_s`` (and, with ``truth``, where the truth is finite)."""
    t = np.asarray(t_s, dtype=float)
    if t.ndim != 1 or len(t) == 0:
        raise ValueError(f"t_s must be a non-empty 1-D array, got shape {t.shape}")
    if not (math.isfinite(settle_s) and settle_s >= 0):
        raise ValueError(f"settle_s must be a finite number >= 0, got {settle_s!r}")
    m = t >= t[0] + settle_s
    if truth is not None:
        m &= np.isfinite(np.asarray(truth, dtype=float))
    return m


def _errors(estimate: np.ndarray, truth: np.ndarray, relative: bool) -> np.ndarray:
    est = np.asarray(estimate, dtype=float)
    tru = np.asarray(truth, dtype=float)
    if est.shape != tru.shape:
        raise ValueError(f"estimate and truth differ in shape: {est.shape} vs {tru.shape}")
    err = est - tru
    if relative:
        with np.errstate(divide="ignore", invalid="ignore"):
            err = 100.0 * err / tru
    return err


class ErrorAccumulator:
    """Errors after the settle time, accumulated block by block (a log too long to hold whole).

    ``add`` the blocks of one trace in order; :meth:`result` gives what :func:`error_after_settling` gives for the
    whole trace (which is this class with one block).

    Parameters
    ----------
    settle_s : float
        Convergence time from the first sample of the first block, excluded from the score.
    relative : bool
        Errors in percent of the truth (for mass).
    """

    def __init__(self, settle_s: float = 10.0, *, relative: bool = False) -> None:
        if not (math.isfinite(settle_s) and settle_s >= 0):
            raise ValueError(f"settle_s must be a finite number >= 0, got {settle_s!r}")
        self.settle_s = settle_s
        self.relative = relative
        self._t_start: float | None = None
        self._sum_sq = 0.0
        self._sum_abs = 0.0
        self._max_abs = 0.0
        self._n = 0

    def add(self, t_s: np.ndarray, estimate: np.ndarray, truth: np.ndarray) -> None:
        """Score one block (equally long 1-D arrays; NaN truth left out; a non-finite estimate is an infinite error)."""
        if self._t_start is None:
            m = settled_mask(t_s, self.settle_s, truth)
            self._t_start = float(np.asarray(t_s, dtype=float)[0]) + self.settle_s
        else:
            m = (np.asarray(t_s, dtype=float) >= self._t_start) & np.isfinite(np.asarray(truth, dtype=float))
        if len(np.asarray(estimate)) != len(m):
            raise ValueError(f"estimate has {len(np.asarray(estimate))} samples, t_s has {len(m)}")
        if not np.any(m):
            return
        err = _errors(np.asarray(estimate)[m], np.asarray(truth)[m], self.relative)
        err = np.where(np.isfinite(err), err, np.inf)
        a = np.abs(err)
        self._sum_sq += float(np.sum(err * err))
        self._sum_abs += float(np.sum(a))
        self._max_abs = max(self._max_abs, float(np.max(a)))
        self._n += int(a.size)

    def result(self) -> ErrorStats | None:
        """The errors so far; None when no sample with known truth lies after the settle time."""
        if self._n == 0:
            return None
        return ErrorStats(math.sqrt(self._sum_sq / self._n), self._sum_abs / self._n, self._max_abs, self._n)


def error_after_settling(
    t_s: np.ndarray,
    estimate: np.ndarray,
    truth: np.ndarray,
    settle_s: float = 10.0,
    *,
    relative: bool = False,
) -> ErrorStats | None:
    """Errors of ``estimate`` against ``truth`` over the samples after the settle time.

    Parameters
    ----------
    t_s, estimate, truth : ndarray
        Equally long 1-D arrays. Samples whose truth is NaN are left out. A non-finite estimate counts as an
        infinite error (an estimator must never output one).
    settle_s : float
        Convergence time from the first sample, excluded from the score.
    relative : bool
        Errors in percent of the truth (for mass).

    Returns
    -------
    ErrorStats or None
        None when no sample with known truth lies after the settle time.
    """
    acc = ErrorAccumulator(settle_s, relative=relative)
    acc.add(t_s, estimate, truth)
    return acc.result()


def settling_time_s(
    t_s: np.ndarray, estimate: np.ndarray, truth: np.ndarray, tol: float, *, relative: bool = False
) -> float:
    """Time from the first sample after which ``|error| <= tol`` holds at every later sample with known truth.

    Returns 0 when the estimate is within tolerance throughout and ``inf`` when it is outside at the last scored
    sample (never settles).
    """
    if not (math.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be a finite number > 0, got {tol!r}")
    t = np.asarray(t_s, dtype=float)
    tru = np.asarray(truth, dtype=float)
    known = np.isfinite(tru)
    if not np.any(known):
        return math.nan
    err = _errors(np.asarray(estimate)[known], tru[known], relative)
    bad = ~(np.abs(err) <= tol)  # NaN counts as outside
    if not np.any(bad):
        return 0.0
    last_bad = int(np.flatnonzero(bad)[-1])
    tk = t[known]
    if last_bad == len(tk) - 1:
        return math.inf
    return float(tk[last_bad + 1] - t[0])


def chi2_band(samples: float, dof: int = 1, level: float = 0.95) -> tuple[float, float]:
    """Two-sided ``level`` band of the average of ``samples`` independent χ²(dof) variables (mean ``dof``);
    ``samples`` may be an effective (non-integer) count."""
    from scipy.stats import chi2

    if samples < 1 or dof < 1:
        raise ValueError(f"samples and dof must be >= 1, got {samples}, {dof}")
    k = samples * dof
    a = (1.0 - level) / 2.0
    return float(chi2.ppf(a, k) / samples), float(chi2.ppf(1.0 - a, k) / samples)


@dataclass(frozen=True)
class Consistency:
    """How well a reported standard deviation describes the actual error of a scalar estimate.

    Attributes
    ----------
    nees : float
        Mean of ``(error / std)**2`` over the decimated samples after settling (1 for a consistent filter).
    band_low, band_high : float
        χ² 95 % band of that mean for ``samples`` independent samples.
    in_band : bool
        ``band_low <= nees <= band_high``.
    within_2sigma : float
        Fraction of all settled samples with ``|error| <= 2 std`` (0.954 for a consistent Gaussian estimate).
    samples : int
        Decimated samples the NEES averages.
    """

    nees: float
    band_low: float
    band_high: float
    in_band: bool
    within_2sigma: float
    samples: int

    def as_dict(self) -> dict[str, float | int | bool]:
        return asdict(self)


def consistency(
    t_s: np.ndarray,
    estimate: np.ndarray,
    std: np.ndarray,
    truth: np.ndarray,
    settle_s: float = 10.0,
    *,
    every_s: float = 1.0,
) -> Consistency | None:
    """NEES of a scalar estimate with its reported 1σ, after settling, against the χ² 95 % band.

    The errors of a filter are correlated over many samples, so averaging all 200 Hz samples and using the band
    for that many independent draws would reject almost everything. The NEES is therefore averaged over samples
    ``every_s`` apart (default one a second), treated as independent; errors that stay correlated longer still
    make the test stricter than the textbook one, which is stated with the results. A zero or non-finite std
    gives an infinite NEES.
    """
    m = settled_mask(t_s, settle_s, truth)
    if not np.any(m):
        return None
    t = np.asarray(t_s, dtype=float)[m]
    err = _errors(np.asarray(estimate)[m], np.asarray(truth)[m], False)
    sd = np.asarray(std, dtype=float)[m]
    with np.errstate(divide="ignore", invalid="ignore"):
        z2 = np.where((sd > 0) & np.isfinite(sd) & np.isfinite(err), (err / sd) ** 2, np.inf)
    within = float(np.mean(z2 <= 4.0))
    idx = _one_per(t, every_s)
    nees = float(np.mean(z2[idx]))
    lo, hi = chi2_band(len(idx))
    return Consistency(nees, lo, hi, bool(lo <= nees <= hi), within, int(len(idx)))


def _one_per(t: np.ndarray, every_s: float) -> np.ndarray:
    """Indices of one sample per ``every_s`` seconds: the first at or after each grid time from ``t[0]``."""
    grid = t[0] + every_s * np.arange(int((t[-1] - t[0]) // every_s) + 1)
    idx = np.unique(np.searchsorted(t, grid))
    return idx[idx < len(t)]


class NisTest(NamedTuple):
    """Result of :func:`nis_consistency`: the mean NIS, its χ² 95 % band, whether it lies inside, samples used."""

    mean: float
    band_low: float
    band_high: float
    in_band: bool
    samples: int


def nis_consistency(t_s: np.ndarray, nis: np.ndarray, settle_s: float = 10.0, *,
                    every_s: float = 1.0) -> NisTest | None:
    """NIS test of a scalar measurement (needs no truth).

    ``nis`` holds each sample's normalised innovation squared (NaN where there was no correction). As for the
    NEES (:func:`consistency`), one sample every ``every_s`` seconds after ``settle_s`` is averaged and compared with
    the χ²(1) 95 % band for that many independent samples. ``None`` when no sample qualifies.
    """
    t = np.asarray(t_s, dtype=float)
    v = np.asarray(nis, dtype=float)
    m = (t >= t[0] + settle_s) & np.isfinite(v) if t.size else np.zeros(0, bool)
    if not np.any(m):
        return None
    t, v = t[m], v[m]
    idx = _one_per(t, every_s)
    mean = float(np.mean(v[idx]))
    lo, hi = chi2_band(len(idx))
    return NisTest(mean, lo, hi, bool(lo <= mean <= hi), int(len(idx)))


def distribution(values) -> dict[str, float]:
    """``median, p90, p95, max`` (nearest rank) and the count of a per-run metric (NaN left out; inf ranks last)."""
    v = np.asarray(list(values), dtype=float)
    v = v[~np.isnan(v)]
    if v.size == 0:
        return {"n": 0, "median": math.nan, "p90": math.nan, "p95": math.nan, "max": math.nan}
    # nearest rank: a percentile is a value some run actually had (and inf survives)
    q = np.percentile(v, [50, 90, 95], method="inverted_cdf")
    return {"n": int(v.size), "median": float(q[0]), "p90": float(q[1]), "p95": float(q[2]), "max": float(v.max())}


def smallest_covering_scale(scales, coverage, target: float = 0.95) -> float | None:
    """The smallest of ``scales`` (factors on a reported σ) whose ±2σ ``coverage`` (share of samples, 0-1) is still
    at least ``target``: a σ calibration that is as tight as the data allow and no tighter. None when no scale reaches
    the target. ``scales`` and ``coverage`` are matched sequences in any order."""
    pairs = [(float(s), float(c)) for s, c in zip(scales, coverage, strict=True)]
    if any(not (math.isfinite(s) and s > 0) for s, _ in pairs):
        raise ValueError(f"scales must be finite and > 0, got {list(scales)!r}")
    ok = [s for s, c in pairs if c >= target]
    return min(ok) if ok else None


def normalised_error_samples(t_s: np.ndarray, estimate: np.ndarray, std: np.ndarray, truth: np.ndarray,
                             settle_s: float = 10.0, *, every_s: float = 1.0) -> np.ndarray:
    """``error / std`` at the samples :func:`consistency` averages (one per ``every_s`` after settling), finite
    values only."""
    m = settled_mask(t_s, settle_s, truth)
    if not np.any(m):
        return np.zeros(0)
    idx = _one_per(np.asarray(t_s, dtype=float)[m], every_s)
    err = _errors(np.asarray(estimate)[m], np.asarray(truth)[m], False)[idx]
    with np.errstate(divide="ignore", invalid="ignore"):
        z = err / np.asarray(std, dtype=float)[m][idx]
    return z[np.isfinite(z)]


def pooled_autocorrelation(sequences, max_lag: int) -> np.ndarray:
    """Autocorrelation at lags ``0..max_lag`` (in samples) pooled over sequences, each first scaled to unit RMS so
    that the shape of the correlation is measured and not the scale. Not demeaned: a bias is part of the error."""
    num = np.zeros(max_lag + 1)
    den = np.zeros(max_lag + 1)
    for z in sequences:
        z = np.asarray(z, dtype=float)
        rms = math.sqrt(float(np.mean(z * z))) if len(z) else 0.0
        if len(z) < 2 or rms == 0.0:
            continue
        u = z / rms
        for k in range(min(max_lag, len(u) - 1) + 1):
            num[k] += float(np.sum(u[:len(u) - k] * u[k:]))
            den[k] += len(u) - k
    if den[0] == 0:
        raise ValueError("pooled_autocorrelation needs at least one sequence of two or more non-zero samples")
    acf = np.where(den > 0, num / np.maximum(den, 1.0), 0.0)
    return acf / acf[0]


def consistent_in_band_share(lengths, acf: np.ndarray, rng: np.random.Generator, draws: int = 20) -> float:
    """Share of runs whose NEES falls in :func:`chi2_band` (independent samples) for a *consistent* estimator:
    unit-variance Gaussian errors with autocorrelation ``acf`` (lags in samples), one run per entry of ``lengths``,
    ``draws`` times each. The ceiling of the NEES band test for errors with that correlation."""
    from scipy.linalg import toeplitz

    hits = total = 0
    roots: dict[int, np.ndarray] = {}  # runs of one length share the factor (most runs have the same length)
    for n in lengths:
        n = int(n)
        if n < 1:
            continue
        if n not in roots:
            r = np.zeros(n)
            k = min(n, len(acf))
            r[:k] = acf[:k]
            w, v = np.linalg.eigh(toeplitz(r))  # a pooled ACF need not be positive definite: clip its spectrum
            roots[n] = v * np.sqrt(np.clip(w, 0.0, None))
        root = roots[n]
        lo, hi = chi2_band(n)
        for _ in range(draws):
            z = root @ rng.standard_normal(n)
            hits += lo <= float(np.mean(z * z)) <= hi
            total += 1
    return hits / total if total else math.nan


def effective_samples(n: int, acf: np.ndarray) -> float:
    """``n / (1 + 2 Σ_k (1 − k/n) ρ_k)``: how many independent samples ``n`` correlated ones are worth (≥ 1)."""
    rho = np.asarray(acf, dtype=float)[1:n]
    lags = np.arange(1, len(rho) + 1)
    return max(1.0, n / (1.0 + 2.0 * float(np.sum(rho * (1.0 - lags / n)))))

