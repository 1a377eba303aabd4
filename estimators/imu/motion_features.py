"""Motion states and window features of the motion-state recogniser (paper 001, §2.2).

States (the paper's S1–S4): 0 standstill, 1 accelerating, 2 cruising, 3 decelerating. Truth labels come from the
true speed (:func:`label_motion_states`); features of a window of the (wavelet-denoised) motion acceleration
``x`` are the paper's F3, F4, F7, F8::

    impulse factor  max|x| / mean|x|        skewness  E[(x-μ)³] / σ³
    mean energy     mean(x²)                RMS frequency  sqrt(Σ f² |X(f)|² / Σ |X(f)|²)

plus, for the ``"paper+speed"`` set, the window's mean speed, fitted speed slope and mean acceleration (see
:mod:`estimators.imu.motion_state`).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "ACCELERATING", "CRUISING", "DECELERATING", "FEATURE_SETS", "STANDSTILL", "STATE_NAMES", "MotionStateError",
    "label_motion_states", "per_state_accuracy", "window_features",
]

STANDSTILL, ACCELERATING, CRUISING, DECELERATING = 0, 1, 2, 3
STATE_NAMES: tuple[str, ...] = ("standstill", "accelerating", "cruising", "decelerating")
FEATURE_SETS: dict[str, tuple[str, ...]] = {
    "paper": ("impulse_factor", "skewness", "mean_energy", "rms_frequency_hz"),
    "paper+speed": ("impulse_factor", "skewness", "mean_energy", "rms_frequency_hz", "mean_speed_mps",
                    "speed_slope_mps2", "mean_accel_mps2"),
}


class MotionStateError(ValueError):
    """Bad input to the motion-state recogniser; the message names it."""


def label_motion_states(true_speed_mps: np.ndarray, dt_s: float, *, standstill_speed_mps: float = 0.01,
                        accel_threshold_mps2: float = 0.02, smooth_s: float = 0.25) -> np.ndarray:
    """Truth labels from the true speed: standstill below ``standstill_speed_mps``, else by the sign of dv/dt.

    ``dv/dt`` is taken from the speed smoothed over ``smooth_s`` (centred), so it is a property of the motion,
    not of the differentiation noise.
    """
    v = np.asarray(true_speed_mps, dtype=np.float64)
    if v.ndim != 1 or v.size == 0:
        raise MotionStateError(f"true_speed_mps must be a non-empty 1-D array, got shape {v.shape}")
    if not np.all(np.isfinite(v)):
        raise MotionStateError("true_speed_mps contains NaN or inf")
    if not (dt_s > 0 and math.isfinite(dt_s)):
        raise MotionStateError(f"dt_s must be finite and > 0, got {dt_s!r}")
    w = max(int(round(smooth_s / dt_s)), 1)
    vs = np.convolve(np.pad(v, (w // 2, w - 1 - w // 2), mode="edge"), np.ones(w) / w, mode="valid")
    a = np.gradient(vs, dt_s) if v.size > 1 else np.zeros(1)
    labels = np.full(v.size, CRUISING, dtype=np.int64)
    labels[a > accel_threshold_mps2] = ACCELERATING
    labels[a < -accel_threshold_mps2] = DECELERATING
    labels[np.abs(v) < standstill_speed_mps] = STANDSTILL
    return labels


def window_features(windows: np.ndarray, sample_hz: float, speed_windows: np.ndarray | None = None,
                    feature_set: str = "paper") -> np.ndarray:
    """Features of each row of ``windows`` (shape (m, w)); see the module docstring.

    Parameters
    ----------
    windows : ndarray, shape (m, w) or (w,)
        Motion-acceleration windows (m/s²).
    sample_hz : float
    speed_windows : ndarray, same shape, optional
        Speed windows; required for ``"paper+speed"``.
    feature_set : {"paper", "paper+speed"}

    Returns
    -------
    ndarray, shape (m, n_features), finite.
    """
    if feature_set not in FEATURE_SETS:
        raise MotionStateError(f"feature_set must be one of {sorted(FEATURE_SETS)}, got {feature_set!r}")
    x = np.atleast_2d(np.asarray(windows, dtype=np.float64))
    m, w = x.shape
    if w < 4:
        raise MotionStateError(f"windows need at least 4 samples, got {w}")
    ax = np.abs(x)
    mean_abs = ax.mean(axis=1)
    impulse = ax.max(axis=1) / np.maximum(mean_abs, 1e-9)
    mu = x.mean(axis=1, keepdims=True)
    d = x - mu
    var = (d * d).mean(axis=1)
    sd = np.sqrt(var)
    skew = np.where(sd > 1e-9, (d ** 3).mean(axis=1) / np.maximum(sd, 1e-9) ** 3, 0.0)
    energy = (x * x).mean(axis=1)
    spec = np.abs(np.fft.rfft(x, axis=1)) ** 2
    f = np.fft.rfftfreq(w, 1.0 / sample_hz)
    tot = spec.sum(axis=1)
    rms_f = np.sqrt(np.where(tot > 0, (spec * f * f).sum(axis=1) / np.maximum(tot, 1e-300), 0.0))
    cols = [impulse, skew, energy, rms_f]
    if feature_set == "paper+speed":
        if speed_windows is None:
            raise MotionStateError("feature_set 'paper+speed' needs speed_windows")
        v = np.atleast_2d(np.asarray(speed_windows, dtype=np.float64))
        if v.shape != x.shape:
            raise MotionStateError(f"speed_windows shape {v.shape} differs from windows shape {x.shape}")
        tt = (np.arange(w) - (w - 1) / 2.0) / sample_hz
        slope = (v - v.mean(axis=1, keepdims=True)) @ tt / float(tt @ tt)
        cols += [v.mean(axis=1), slope, mu[:, 0]]
    return np.nan_to_num(np.column_stack(cols), nan=0.0, posinf=0.0, neginf=0.0)


def per_state_accuracy(true_states: np.ndarray, predicted: np.ndarray) -> dict[str, float]:
    """Per-state recall (share of each true state's samples recognised as that state) and the overall share."""
    t = np.asarray(true_states)
    p = np.asarray(predicted)
    if t.shape != p.shape:
        raise MotionStateError(f"true and predicted states differ in shape: {t.shape} vs {p.shape}")
    out = {}
    for k, name in enumerate(STATE_NAMES):
        mask = t == k
        out[name] = float(np.mean(p[mask] == k)) if mask.any() else math.nan
    out["overall"] = float(np.mean(p == t)) if t.size else math.nan
    return out
