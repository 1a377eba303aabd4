"""Statistics for evaluation tables: interquartile mean, bootstrap and Wilson confidence intervals.

Why not rliable: its bootstrap resamples *runs within each task*; a deterministic controller on 100 held-out tracks
has one run per track, where that bootstrap has nothing to resample (and rliable 1.2 fails to import with the
current release of its ``arch`` dependency). Here the tracks are resampled, and, where a row holds
several training seeds, the seeds too (two-level bootstrap); the statistics are rliable's (IQM: the mean of the
middle 50 %, the 25 %-trimmed mean of Agarwal et al. 2021).
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np

Statistic = Callable[[np.ndarray], float]


def iqm(x: Sequence[float] | np.ndarray) -> float:
    """Interquartile mean (25 % trimmed from each end, as ``scipy.stats.trim_mean(x, 0.25)``) of the finite values;
    NaN for none."""
    a = np.asarray(x, dtype=float).reshape(-1)
    return float(_row_iqms(a[None, :])[0]) if a.size else math.nan


def _row_iqms(a: np.ndarray) -> np.ndarray:
    """The IQM of the finite entries of each row of a 2-D array (NaN for a row with none).

    Vectorised because the bootstrap takes thousands of them: ``scipy.stats.trim_mean`` costs ~2 ms a call in its
    argument checks, which made summarising one evaluation table take tens of seconds.
    """
    s = np.sort(np.where(np.isfinite(a), a, np.nan), axis=1)  # the finite values first (±inf as missing, NaN last)
    n = np.isfinite(s).sum(axis=1)
    cut = (n * 0.25).astype(int)  # scipy's int(0.25 * n) from each end
    cs = np.concatenate([np.zeros((len(s), 1)), np.cumsum(np.where(np.isfinite(s), s, 0.0), axis=1)], axis=1)
    rows = np.arange(len(s))
    kept = n - 2 * cut
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(kept > 0, (cs[rows, n - cut] - cs[rows, cut]) / kept, np.nan)


def bootstrap_ci(scores: Sequence[float] | np.ndarray, statistic: Statistic = iqm, *, reps: int = 2000,
                 seed: int = 0, level: float = 0.95) -> tuple[float, float]:
    """Percentile-bootstrap interval of ``statistic`` over ``scores``.

    Parameters
    ----------
    scores : array_like
        1-D (one value per track) or 2-D ``(training seeds, tracks)``; NaN entries (e.g. trip time of a failed
        episode) are left out of each resample.
    statistic : callable
        Maps a 1-D array to a number (default :func:`iqm`).
    reps, seed, level : int, int, float
        Resamples, the seed of their generator (deterministic tables), interval level.

    Returns
    -------
    (lo, hi) : tuple of float
        NaN when there is no finite score.
    """
    a = np.asarray(scores, dtype=float)
    if a.ndim == 1:
        a = a[None, :]
    if a.ndim != 2:
        raise ValueError(f"scores must be 1-D or 2-D (seeds x tracks), got shape {a.shape}")
    if not np.isfinite(a).any():
        return math.nan, math.nan
    rng = np.random.default_rng(seed)
    n_seeds, n_tracks = a.shape
    samples = np.empty((reps, n_seeds * n_tracks))
    for k in range(reps):  # the draws in this order keep every committed interval as it was printed
        rows = rng.integers(0, n_seeds, n_seeds)
        cols = rng.integers(0, n_tracks, n_tracks)
        samples[k] = a[np.ix_(rows, cols)].reshape(-1)
    if statistic is iqm:
        stats = _row_iqms(samples)
    else:
        stats = np.empty(reps)
        for k in range(reps):
            sample = samples[k][np.isfinite(samples[k])]
            stats[k] = statistic(sample) if sample.size else math.nan
    alpha = 100.0 * (1.0 - level) / 2.0
    return float(np.nanpercentile(stats, alpha)), float(np.nanpercentile(stats, 100.0 - alpha))


def wilson_interval(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a proportion ``k / n`` (95 % for ``z = 1.96``); ``(nan, nan)`` for ``n = 0``.

    Unlike the bootstrap it does not collapse to ``[0, 0]`` when no event was seen: 0 trips in 100 episodes is
    ``[0, 3.7 %]``.
    """
    if n == 0:
        return math.nan, math.nan
    p = k / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return max(0.0, centre - half), min(1.0, centre + half)


__all__ = ["bootstrap_ci", "iqm", "wilson_interval"]
