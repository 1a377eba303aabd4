"""Shared numerical helpers of the estimators: low-pass filters, input gating, forgetting, PD-safe updates.

Everything here is written for speed in pure Python on scalars (the estimators run one sample at a time, where
numpy's per-call overhead dominates for 2x2 matrices), with numpy variants for the larger filters. The other
estimator modules (MMAE, IMU-UKF, AUPF) may use them as well.

2x2 symmetric matrices are passed as the three floats ``(p11, p12, p22)``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

__all__ = [
    "LowPass2",
    "SpikeGate",
    "dynamic_forgetting",
    "sage_husa_weight",
    "joseph_update",
    "repair_pd",
    "repair_pd_2x2",
    "check_dt",
    "check_dt_non_negative",
    "capped_dt",
    "MAX_STEP_S",
    "check_number_options",
    "check_int_option",
    "check_positive",
    "kalman_update_2x2_h1",
    "kalman_update_3x3_h1",
    "repair_pd_3x3",
    "effective_dt",
    "hold_last_valid",
]


def check_dt(dt_s: float) -> float:
    """Validate a sample interval: finite and > 0 (a zero or negative step is a caller bug, not a dropout)."""
    if not (dt_s > 0.0 and dt_s < math.inf):
        raise ValueError(f"dt_s must be a finite number > 0, got {dt_s!r}")
    return dt_s


def check_dt_non_negative(dt_s: float, who: str) -> float:
    """Validate a sample interval that may be zero (a repeated time stamp: the estimator then only returns its
    current estimate): finite and >= 0. ``who`` (the registry name) starts the message."""
    if not (dt_s >= 0.0) or not math.isfinite(dt_s):
        raise ValueError(f"{who}: dt_s must be a finite number >= 0, got {dt_s!r}")
    return dt_s


MAX_STEP_S = 1.0
"""Longest sample interval integrated as one step; a longer one is a data gap (see :func:`effective_dt`)."""


def capped_dt(dt_s: float) -> float:
    """:func:`check_dt`, then at most :data:`MAX_STEP_S`: a longer interval is a data gap, integrated as that long."""
    if not (dt_s > 0.0 and dt_s < math.inf):
        check_dt(dt_s)  # raises
    return dt_s if dt_s <= MAX_STEP_S else MAX_STEP_S


def effective_dt(dt_s: float) -> float:
    """The step the filters integrate for a sample interval ``dt_s``, by the estimators' common contract.

    NaN, zero or negative (a repeated or out-of-order time stamp) -> 0.0: the sample is not processed and the
    estimate is returned unchanged. Above :data:`MAX_STEP_S` (a gap; +inf and 1e300 included) -> ``MAX_STEP_S``:
    the filters predict over at most that long (their covariances are bounded by their priors) and restart their
    signal filters. Never raises; no loop anywhere depends on the raw ``dt_s``.
    """
    if not (dt_s > 0.0):
        return 0.0
    return dt_s if dt_s <= MAX_STEP_S else MAX_STEP_S


def check_number_options(
    values: dict[str, object],
    error: type[Exception],
    *,
    positive: Iterable[str] = (),
    non_negative: Iterable[str] = (),
    reject_bool: bool = False,
) -> None:
    """Validate numeric constructor options, raising ``error`` with a message that names the first bad one.

    Every entry of ``values`` must be a finite ``int``/``float``/``np.floating`` (``bool`` too unless
    ``reject_bool``); then the keys in ``positive`` must be > 0 and those in ``non_negative`` >= 0, checked in
    that order.
    """
    for key, value in values.items():
        if (reject_bool and isinstance(value, bool)) or not isinstance(value, (int, float, np.floating)) or (
            not math.isfinite(value)
        ):
            raise error(f"{key} must be a finite number, got {value!r}")
    for key in positive:
        if values[key] <= 0:
            raise error(f"{key} must be > 0, got {values[key]!r}")
    for key in non_negative:
        if values[key] < 0:
            raise error(f"{key} must be >= 0, got {values[key]!r}")


def check_positive(prefix: str = "", /, **values: float) -> None:
    """Raise ``ValueError`` naming the first of ``values`` that is not a finite number > 0 (message after ``prefix``)."""
    for name, value in values.items():
        if not (value > 0.0 and math.isfinite(value)):
            raise ValueError(f"{prefix}{name} must be a finite number > 0, got {value!r}")


def check_int_option(name: str, value: object, error: type[Exception], minimum: int | None = None) -> None:
    """Validate an integer option (``int`` or ``np.integer``, never ``bool``; ``>= minimum`` when given), raising
    ``error`` with a message that names it."""
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or (
        minimum is not None and value < minimum
    ):
        bound = "" if minimum is None else f" >= {minimum}"
        raise error(f"{name} must be an integer{bound}, got {value!r}")


def check_bool_option(name: str, value: object, error: type[Exception]) -> None:
    """Validate a switch (``bool`` or ``np.bool_``; not 1, not ``"false"``, which Python reads as true), raising
    ``error`` with a message that names it."""
    if not isinstance(value, (bool, np.bool_)):
        raise error(f"{name} must be True or False, got {value!r}")


def hold_last_valid(x: np.ndarray) -> np.ndarray:
    """Hold the last valid value of a 1-D float array over its missing (non-finite) samples.

    Samples before the first valid one take that first valid value; an all-missing array gives zeros. The
    offline counterpart of the zero-order hold of :class:`LowPass2`. Returns ``x`` itself (not a copy) when
    nothing is missing, else a new array.
    """
    bad = ~np.isfinite(x)
    if not bad.any():
        return x
    if bad.all():
        return np.zeros_like(x)
    idx = np.where(~bad, np.arange(x.size), 0)
    np.maximum.accumulate(idx, out=idx)
    first = int(np.argmax(~bad))
    filled = x[idx]
    filled[:first] = x[first]
    return filled


class LowPass2:
    """Second-order (two cascaded first-order sections) low-pass filter of one signal.

    Used on *both* sides of a regression so that the phase lag is the same on the output and on the regressors
    (a linear filter commutes with a linear model), and on speed before differentiating it.

    Parameters
    ----------
    cutoff_hz : float
        Corner frequency of each section, > 0.

    Notes
    -----
    A missing (NaN) input holds the last valid input (zero-order hold), so the output stays finite and the
    filter keeps its phase relation with the other filtered channels. Until the first valid input the output
    is NaN-free zero and :attr:`ready` is False.
    """

    __slots__ = ("cutoff_hz", "y1", "y2", "last", "ready", "_dt", "_alpha")

    def __init__(self, cutoff_hz: float) -> None:
        if not (cutoff_hz > 0.0 and math.isfinite(cutoff_hz)):
            raise ValueError(f"cutoff_hz must be a finite number > 0, got {cutoff_hz!r}")
        self.cutoff_hz = float(cutoff_hz)
        self._dt = -1.0
        self._alpha = 1.0
        self.reset()

    def reset(self) -> None:
        self.y1 = 0.0
        self.y2 = 0.0
        self.last = 0.0
        self.ready = False

    def __call__(self, x: float, dt_s: float) -> float:
        if x != x:  # NaN: hold the last valid input
            if not self.ready:
                return 0.0
            x = self.last
        elif not self.ready:
            # start at the first value instead of ramping up from zero (no start-up transient to forget)
            self.y1 = self.y2 = self.last = x
            self.ready = True
            return x
        self.last = x
        if dt_s != self._dt:
            self._dt = dt_s
            self._alpha = 1.0 - math.exp(-2.0 * math.pi * self.cutoff_hz * dt_s)
        a = self._alpha
        y1 = self.y1 + a * (x - self.y1)
        self.y1 = y1
        y2 = self.y2 + a * (y1 - self.y2)
        self.y2 = y2
        return y2


class SpikeGate:
    """Rejects physically impossible jumps of a sensor channel (spikes) and impossible values.

    A sample is a spike when it differs from the last accepted one by more than ``max_rate * dt + noise_band``,
    or when ``|x| > max_abs``. A spike is returned as NaN (treated as missing by the estimators). After
    ``relock_after`` consecutive rejections the gate accepts again, so a real step (or a sensor whose offset
    really changed) cannot lock the channel out forever.

    Parameters
    ----------
    max_rate : float
        Largest physical rate of change of the signal, in its unit per second.
    noise_band : float
        Allowance for measurement noise and quantisation, in the signal's unit.
    max_abs : float
        Largest physical magnitude.
    relock_after : int
        Consecutive rejections after which the next sample is accepted.
    """

    __slots__ = ("max_rate", "noise_band", "max_abs", "relock_after", "last", "rejected", "total_rejected")

    def __init__(self, max_rate: float, noise_band: float, max_abs: float, relock_after: int = 40) -> None:
        check_positive("SpikeGate: ", max_rate=max_rate, noise_band=noise_band, max_abs=max_abs)
        self.max_rate = float(max_rate)
        self.noise_band = float(noise_band)
        self.max_abs = float(max_abs)
        self.relock_after = int(relock_after)
        self.reset()

    def reset(self) -> None:
        self.last = math.nan
        self.rejected = 0
        self.total_rejected = 0

    def __call__(self, x: float, dt_s: float) -> float:
        if x != x:
            return x
        if abs(x) > self.max_abs:
            self.total_rejected += 1
            return math.nan
        last = self.last
        if last == last and abs(x - last) > self.max_rate * dt_s * (self.rejected + 1) + self.noise_band:
            self.rejected += 1
            self.total_rejected += 1
            if self.rejected <= self.relock_after:
                return math.nan
        self.rejected = 0
        self.last = x
        return x


def dynamic_forgetting(residual: float, delta: float, sigma: float) -> float:
    """Paper 000 eq. 19: ``lambda = delta + (1 - delta) exp(-sigma |e|)``, in [delta, 1]."""
    return delta + (1.0 - delta) * math.exp(-sigma * abs(residual))


def sage_husa_weight(b: float, k: int) -> float:
    """Sage-Husa weight ``d_k = (1 - b) / (1 - b**(k+1))`` for the k-th update (k = 0, 1, ...).

    ``d_0 = 1`` would throw the prior noise statistics away on the first sample; callers start at ``k >= 1``.
    """
    return (1.0 - b) / (1.0 - b ** (k + 1))


def repair_pd_2x2(p11: float, p12: float, p22: float, floor11: float = 1e-18, floor22: float = 1e-18,
                  ceil11: float = math.inf, ceil22: float = math.inf) -> tuple[float, float, float]:
    """Make a symmetric 2x2 matrix ``(p11, p12, p22)`` positive definite with its diagonal in ``[floor, ceil]``.

    Non-finite diagonal entries become the floor (NaN fails every comparison), a non-finite off-diagonal 0; the
    off-diagonal is then shrunk so that the correlation stays below 0.999 (determinant > 0). The one PD repair of
    every 2x2 filter here (slope EKFs, RLS layers, the compiled ``dffrls-aekf`` kernel, which jit-compiles this
    same function).
    """
    if not (p11 >= floor11):
        p11 = floor11
    elif p11 > ceil11:
        p11 = ceil11
    if not (p22 >= floor22):
        p22 = floor22
    elif p22 > ceil22:
        p22 = ceil22
    if not (abs(p12) < math.inf):
        p12 = 0.0
    lim = 0.999 * math.sqrt(p11 * p22)
    if p12 > lim:
        p12 = lim
    elif p12 < -lim:
        p12 = -lim
    return p11, p12, p22


def kalman_update_2x2_h1(p11: float, p12: float, p22: float, innov: float,
                         r: float) -> tuple[float, float, float, float, float]:
    """Kalman correction of a 2-state filter measuring its first state (``H = [1, 0]``), Joseph form.

    Returns ``(dx1, dx2, p11, p12, p22)``: the state correction ``K innov`` and the updated covariance
    ``(I - K H) P (I - K H)^T + K r K^T`` written on the three distinct entries (symmetric by construction, PSD
    for any gain). Pair it with :func:`repair_pd_2x2`.
    """
    s = p11 + r
    k1 = p11 / s
    k2 = p12 / s
    a = 1.0 - k1
    n11 = a * a * p11 + k1 * k1 * r
    n12 = a * (p12 - k2 * p11) + k1 * k2 * r
    n22 = k2 * k2 * p11 - 2.0 * k2 * p12 + p22 + k2 * k2 * r
    return k1 * innov, k2 * innov, n11, n12, n22


def kalman_update_3x3_h1(p11: float, p12: float, p13: float, p22: float, p23: float, p33: float, innov: float,
                         r: float) -> tuple[float, float, float, float, float, float, float, float, float]:
    """Kalman correction of a 3-state filter measuring its first state (``H = [1, 0, 0]``), Joseph form.

    Returns ``(dx1, dx2, dx3, p11, p12, p13, p22, p23, p33)``: the correction ``K innov`` and the six distinct
    entries of ``(I - K H) P (I - K H)^T + K r K^T`` (symmetric by construction, PSD for any gain). Pair it with
    :func:`repair_pd_3x3`. The 3-state sibling of :func:`kalman_update_2x2_h1`.
    """
    s = p11 + r
    k1 = p11 / s
    k2 = p12 / s
    k3 = p13 / s
    # (I - K H) P (I - K H)^T + K r K^T, entry by entry: P_ij - k_i P_1j - k_j P_1i + k_i k_j (p11 + r)
    n11 = p11 - 2.0 * k1 * p11 + k1 * k1 * s
    n12 = p12 - k1 * p12 - k2 * p11 + k1 * k2 * s
    n13 = p13 - k1 * p13 - k3 * p11 + k1 * k3 * s
    n22 = p22 - 2.0 * k2 * p12 + k2 * k2 * s
    n23 = p23 - k2 * p13 - k3 * p12 + k2 * k3 * s
    n33 = p33 - 2.0 * k3 * p13 + k3 * k3 * s
    return k1 * innov, k2 * innov, k3 * innov, n11, n12, n13, n22, n23, n33


def repair_pd_3x3(p11: float, p12: float, p13: float, p22: float, p23: float, p33: float, floor: float = 1e-18,
                  ceil22: float = math.inf) -> tuple[float, float, float, float, float, float]:
    """Make a symmetric 3x3 matrix positive definite: diagonal floored at ``floor`` (``p22`` also capped at
    ``ceil22``; a non-finite diagonal entry becomes the floor, or ``p22`` the cap), non-finite off-diagonals 0, and
    the off-diagonals shrunk by halves until the matrix has a Cholesky factor (zero after 30 halvings: the diagonal
    alone is PD). The 3-state sibling of :func:`repair_pd_2x2`.
    """
    if not (floor <= p11 < math.inf):
        p11 = floor
    if not (p22 >= floor):
        p22 = floor
    elif p22 > ceil22:
        p22 = ceil22 if ceil22 < math.inf else floor
    if not (floor <= p33 < math.inf):
        p33 = floor
    if not (abs(p12) < math.inf):
        p12 = 0.0
    if not (abs(p13) < math.inf):
        p13 = 0.0
    if not (abs(p23) < math.inf):
        p23 = 0.0
    for _ in range(30):
        # pivots of the Cholesky factorisation (a margin so that rounding cannot make them vanish)
        d2 = p22 - p12 * p12 / p11
        if d2 > 1e-9 * p22:
            l32 = (p23 - p13 * p12 / p11) / d2
            d3 = p33 - p13 * p13 / p11 - l32 * l32 * d2
            if d3 > 1e-9 * p33:
                return p11, p12, p13, p22, p23, p33
        p12 *= 0.5
        p13 *= 0.5
        p23 *= 0.5
    return p11, 0.0, 0.0, p22, 0.0, p33


def joseph_update(P: np.ndarray, K: np.ndarray, H: np.ndarray, R: np.ndarray) -> np.ndarray:
    """Joseph-form covariance update ``(I - K H) P (I - K H)^T + K R K^T``, symmetrised.

    Stays symmetric positive semi-definite for any gain, unlike ``(I - K H) P``.
    """
    n = P.shape[0]
    A = np.eye(n) - K @ H
    out = A @ P @ A.T + K @ R @ K.T
    return 0.5 * (out + out.T)


def repair_pd(P: np.ndarray, min_eig: float = 1e-12, max_eig: float = math.inf) -> np.ndarray:
    """Nearest symmetric matrix with eigenvalues clipped into ``[min_eig, max_eig]`` (NaN/inf -> ``min_eig * I``)."""
    P = np.asarray(P, dtype=np.float64)
    if not np.all(np.isfinite(P)):
        return np.eye(P.shape[0]) * min_eig
    S = 0.5 * (P + P.T)
    w, V = np.linalg.eigh(S)
    if w[0] >= min_eig and w[-1] <= max_eig:
        return S
    w = np.clip(w, min_eig, max_eig)
    out = (V * w) @ V.T
    return 0.5 * (out + out.T)
