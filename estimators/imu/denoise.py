"""Wavelet threshold denoising of IMU signals (paper 001, §2.1): sym4, 5 levels, heursure rule.

Two forms of the same operation:

* :func:`wavelet_denoise` — batch, for a whole recorded signal;
* :class:`SlidingWaveletDenoiser` — causal online form for the estimators: it denoises the trailing window every
  ``hop`` samples and emits the newest ``hop`` denoised samples, so no output depends on a future sample and the
  latency is at most ``hop`` samples.

Threshold rule: MATLAB's ``heursure`` (``thselect``), applied per level to coefficients scaled by a noise estimate
(``median(|d|) / 0.6745``, per level by default because vibration noise is coloured).

Threshold function: the paper proposes a "new threshold function" between hard and soft thresholding, but its
formula is not in the text the project has (the equations were lost in extraction). The project uses the common
continuous compromise of that family (spec decision, documented in ``docs/imu.md``)::

    w_hat = sign(w) * (|w| - lam * exp(-alpha * (|w| - lam) / lam))   for |w| >= lam,   0 otherwise

It is continuous at ``|w| = lam`` (no hard-threshold ringing), tends to ``w`` for large coefficients (no
soft-threshold bias), and ``alpha`` moves it between soft (``alpha = 0``) and hard (``alpha -> inf``).
"""

from __future__ import annotations

import math

import numpy as np
import pywt

from ..filters import hold_last_valid

__all__ = [
    "DenoiseError",
    "SlidingWaveletDenoiser",
    "heursure_threshold",
    "rigrsure_threshold",
    "threshold_coefficients",
    "wavelet_denoise",
]

_MAD_TO_SIGMA = 0.6745


class DenoiseError(ValueError):
    """Bad input to the wavelet denoiser; the message names the argument."""


def rigrsure_threshold(x: np.ndarray) -> float:
    """Stein's unbiased risk estimate threshold for unit-variance noise (MATLAB ``rigrsure``)."""
    x = np.asarray(x, dtype=np.float64)
    n = x.size
    if n == 0:
        return 0.0
    sx2 = np.sort(np.abs(x)) ** 2
    k = np.arange(1, n + 1)
    risks = (n - 2.0 * k + (np.cumsum(sx2) + (n - k) * sx2)) / n
    return float(math.sqrt(sx2[int(np.argmin(risks))]))


def heursure_threshold(x: np.ndarray) -> float:
    """Heuristic SURE threshold for unit-variance noise (MATLAB ``heursure``).

    Uses the universal threshold ``sqrt(2 ln n)`` when the signal-to-noise ratio is low (the SURE estimate is then
    unreliable), otherwise the smaller of SURE and universal.
    """
    x = np.asarray(x, dtype=np.float64)
    n = x.size
    if n == 0:
        return 0.0
    universal = math.sqrt(2.0 * math.log(n)) if n > 1 else 0.0
    eta = (float(np.dot(x, x)) - n) / n
    crit = math.log2(n) ** 1.5 / math.sqrt(n) if n > 1 else 0.0
    if eta < crit:
        return universal
    return min(rigrsure_threshold(x), universal)


def threshold_coefficients(w: np.ndarray, lam: float, function: str = "improved", alpha: float = 2.0) -> np.ndarray:
    """Apply a threshold function to wavelet coefficients.

    Parameters
    ----------
    w : ndarray
        Coefficients.
    lam : float
        Threshold (>= 0).
    function : {"improved", "soft", "hard"}
        ``"improved"`` is the continuous compromise described in the module docstring.
    alpha : float
        Shape of the improved function (0 = soft, large = hard).
    """
    w = np.asarray(w, dtype=np.float64)
    if lam <= 0.0:
        return w.copy()
    a = np.abs(w)
    keep = a >= lam
    if function == "hard":
        return np.where(keep, w, 0.0)
    if function == "soft":
        return np.where(keep, np.sign(w) * (a - lam), 0.0)
    if function == "improved":
        shrunk = np.sign(w) * (a - lam * np.exp(-alpha * (a - lam) / lam))
        return np.where(keep, shrunk, 0.0)
    raise DenoiseError(f"threshold function must be 'improved', 'soft' or 'hard', got {function!r}")


def _check(wavelet: str, level: int, noise_scaling: str, function: str, alpha: float) -> None:
    if wavelet not in pywt.wavelist(kind="discrete"):
        raise DenoiseError(f"wavelet {wavelet!r} is not a discrete PyWavelets wavelet")
    if not isinstance(level, (int, np.integer)) or level < 1:
        raise DenoiseError(f"level must be a positive integer, got {level!r}")
    if noise_scaling not in ("level", "single"):
        raise DenoiseError(f"noise_scaling must be 'level' or 'single', got {noise_scaling!r}")
    if function not in ("improved", "soft", "hard"):
        raise DenoiseError(f"threshold function must be 'improved', 'soft' or 'hard', got {function!r}")
    if not (alpha >= 0.0 and math.isfinite(alpha)):
        raise DenoiseError(f"alpha must be finite and >= 0, got {alpha!r}")


def _denoise_finite(x: np.ndarray, wavelet: str, level: int, noise_scaling: str, function: str,
                    alpha: float) -> np.ndarray:
    n = x.size
    max_level = pywt.dwt_max_level(n, pywt.Wavelet(wavelet).dec_len)
    lev = max(1, min(level, max_level))
    coeffs = pywt.wavedec(x, wavelet, level=lev, mode="symmetric")
    sigma_single = float(np.median(np.abs(coeffs[-1]))) / _MAD_TO_SIGMA
    out = [coeffs[0]]
    for d in coeffs[1:]:
        sigma = float(np.median(np.abs(d))) / _MAD_TO_SIGMA if noise_scaling == "level" else sigma_single
        if sigma <= 0.0 or not math.isfinite(sigma):
            out.append(d)
            continue
        lam = heursure_threshold(d / sigma) * sigma
        out.append(threshold_coefficients(d, lam, function, alpha))
    return pywt.waverec(out, wavelet, mode="symmetric")[:n]


def wavelet_denoise(x: np.ndarray, wavelet: str = "sym4", level: int = 5, *, noise_scaling: str = "level",
                    function: str = "improved", alpha: float = 2.0) -> np.ndarray:
    """Denoise a whole signal (batch form).

    Parameters
    ----------
    x : array_like, shape (n,)
        Signal. Missing samples (NaN) are bridged by holding the last valid value; the output is finite.
    wavelet : str
        PyWavelets discrete wavelet (paper: ``"sym4"``).
    level : int
        Decomposition levels (paper: 5); reduced to what the signal length allows.
    noise_scaling : {"level", "single"}
        Noise estimate per level (coloured noise) or from the finest level only.
    function : {"improved", "soft", "hard"}
        Threshold function.
    alpha : float
        Shape of the improved threshold function.

    Returns
    -------
    ndarray, shape (n,)
    """
    _check(wavelet, level, noise_scaling, function, alpha)
    x = np.asarray(x, dtype=np.float64)
    if x.ndim != 1:
        raise DenoiseError(f"signal must be one-dimensional, got shape {x.shape}")
    if x.size < 2:
        return np.nan_to_num(x.copy())
    return _denoise_finite(hold_last_valid(x), wavelet, level, noise_scaling, function, alpha)


class SlidingWaveletDenoiser:
    """Causal sliding-window wavelet denoiser (online form of :func:`wavelet_denoise`).

    Every ``hop`` pushed samples it denoises the last ``window`` samples and emits the denoised values of the
    newest ``hop`` of them. Before the window has filled it denoises what it has (at least ``hop`` samples).

    Parameters
    ----------
    window : int
        Samples per denoising window (>= 32; 256 allows the paper's 5 sym4 levels).
    hop : int
        Samples between two denoising runs (1 <= hop <= window): the latency and the amortised cost.
    **kwargs
        ``wavelet``, ``level``, ``noise_scaling``, ``function``, ``alpha`` as in :func:`wavelet_denoise`.

    Attributes
    ----------
    last_value : float
        The newest denoised sample (0.0 before the first emission).
    """

    def __init__(self, window: int = 256, hop: int = 16, *, wavelet: str = "sym4", level: int = 5,
                 noise_scaling: str = "level", function: str = "improved", alpha: float = 2.0) -> None:
        if not isinstance(window, (int, np.integer)) or window < 32:
            raise DenoiseError(f"window must be an integer >= 32, got {window!r}")
        if not isinstance(hop, (int, np.integer)) or not 1 <= hop <= window:
            raise DenoiseError(f"hop must be an integer in [1, window={window}], got {hop!r}")
        _check(wavelet, level, noise_scaling, function, alpha)
        self.window = int(window)
        self.hop = int(hop)
        self._kw = dict(wavelet=wavelet, level=level, noise_scaling=noise_scaling, function=function, alpha=alpha)
        self._buf = np.zeros(self.window)
        self.reset()

    def reset(self) -> None:
        """Forget the buffered samples."""
        self._buf[:] = 0.0
        self._count = 0
        self._since = 0
        self._last_valid = math.nan
        self.last_value = 0.0

    def push(self, x: float) -> np.ndarray:
        """Add one sample; return the denoised samples that became ready (empty, or ``hop`` values)."""
        x = float(x)
        if math.isfinite(x):
            self._last_valid = x
        elif math.isfinite(self._last_valid):
            x = self._last_valid
        else:
            x = 0.0
        buf = self._buf
        buf[:-1] = buf[1:]
        buf[-1] = x
        self._count += 1
        self._since += 1
        if self._since < self.hop:
            return np.empty(0)
        self._since = 0
        m = min(self._count, self.window)
        seg = buf[self.window - m:]
        den = _denoise_finite(seg, **self._kw) if m >= 16 else seg.copy()
        out = den[-self.hop:].copy()
        self.last_value = float(out[-1])
        return out

    def process(self, x: np.ndarray) -> np.ndarray:
        """Run a whole signal through the online form; sample i of the result is emitted at or after input i.

        Returns an array as long as ``x`` where the last ``len(x) % hop`` samples (not yet emitted) are NaN-free
        copies of the held input.
        """
        x = np.asarray(x, dtype=np.float64)
        out = hold_last_valid(x.copy()) if x.size else x.copy()
        pos = 0
        for v in x:
            ready = self.push(v)
            if ready.size:
                out[pos:pos + ready.size] = ready
                pos += ready.size
        return out
