"""Motion-state recognition (paper 001, §2.2–2.3): random forest on window features + temporal order constraint.

States (the paper's S1–S4): 0 standstill, 1 accelerating, 2 cruising, 3 decelerating.

Features of a window of the (wavelet-denoised) motion acceleration ``x`` (paper's F3, F4, F7, F8)::

    impulse factor  max|x| / mean|x|        skewness  E[(x-μ)³] / σ³
    mean energy     mean(x²)                RMS frequency  sqrt(Σ f² |X(f)|² / Σ |X(f)|²)

The monorail IMU's along-track accelerometer reads ``dv/dt + g sin θ``; the recogniser takes the motion
acceleration ``accel - g sin(pitch)`` when a pitch estimate is given (the ``imu-ukf`` slope), else the raw
accelerometer. The ``"paper+speed"`` feature set adds the window's mean speed, its fitted speed slope (dv/dt)
and mean acceleration — a project addition, because the paper's four features cannot tell accelerating from
decelerating by themselves (they are symmetric in the sign of a constant acceleration); ``docs/imu.md`` gives
the accuracy of both sets.

Temporal order constraint: the paper allows only S1→S2→S3→S4→S1. It is applied causally, window by window:
``s_t = argmax_j A[s_{t-1}, j] · p_rf(j | x_t)`` with ``A`` zero on forbidden transitions and ``stay_prob`` on
the diagonal; only when the forest gives every allowed state less than ``override_ratio`` (0.1) of its best
probability does the evidence override the order, so a missed short phase cannot lock the decoder. A monorail
also changes cruise speed (cruise → accelerate/decelerate → cruise), so ``transitions="monorail"`` keeps only
the physical part of the paper's order: no standstill → cruising/decelerating, no accelerating/cruising →
standstill.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np

from uuom_core.trace import Trace
from uuom_core.vehicle import G_MPS2

from ..filters import hold_last_valid
from .denoise import SlidingWaveletDenoiser

__all__ = [
    "ACCELERATING", "CRUISING", "DECELERATING", "STANDSTILL", "STATE_NAMES", "TRANSITIONS",
    "MotionStateError", "MotionStateRecognizer", "apply_temporal_constraint", "label_motion_states",
    "per_state_accuracy", "window_features",
]

STANDSTILL, ACCELERATING, CRUISING, DECELERATING = 0, 1, 2, 3
STATE_NAMES: tuple[str, ...] = ("standstill", "accelerating", "cruising", "decelerating")
FEATURE_SETS: dict[str, tuple[str, ...]] = {
    "paper": ("impulse_factor", "skewness", "mean_energy", "rms_frequency_hz"),
    "paper+speed": ("impulse_factor", "skewness", "mean_energy", "rms_frequency_hz", "mean_speed_mps",
                    "speed_slope_mps2", "mean_accel_mps2"),
}

_PAPER = np.array([[1, 1, 0, 0], [0, 1, 1, 0], [0, 0, 1, 1], [1, 0, 0, 1]], dtype=bool)
_MONORAIL = np.array([[1, 1, 0, 0], [0, 1, 1, 1], [0, 1, 1, 1], [1, 1, 1, 1]], dtype=bool)
TRANSITIONS: dict[str, np.ndarray | None] = {"paper": _PAPER, "monorail": _MONORAIL, "none": None}
"""Allowed transitions ``allowed[from, to]`` of each temporal constraint."""


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


def apply_temporal_constraint(proba: np.ndarray, transitions: str = "paper", *, stay_prob: float = 0.9,
                              class_prior: Sequence[float] | None = None, override_ratio: float = 0.1) -> np.ndarray:
    """Causal forward pass of the temporal order constraint over a sequence of class probabilities.

    Parameters
    ----------
    proba : ndarray, shape (m, 4)
        Forest probabilities per window, in time order.
    transitions : {"paper", "monorail", "none"}
    stay_prob : float
        Probability of staying in a state from one window to the next.
    class_prior : sequence of 4 floats, optional
        Class frequencies of the training set (the forest's probabilities are divided by them).
    override_ratio : float
        The forest overrides the order when every allowed state has less than this share of its best
        probability (0: never).

    Returns
    -------
    ndarray of int, shape (m,)
    """
    proba = np.asarray(proba, dtype=np.float64)
    if proba.ndim != 2 or proba.shape[1] != 4:
        raise MotionStateError(f"proba must have shape (m, 4), got {proba.shape}")
    filt = _ForwardFilter(transitions, stay_prob, class_prior, override_ratio)
    return np.array([filt.step(p) for p in proba], dtype=np.int64)


class _ForwardFilter:
    """Greedy causal decoder of the order constraint: ``s_t = argmax_j A[s_{t-1}, j] p_j / prior_j``.

    If the forest gives every allowed next state less than ``override_ratio`` times its best probability, the
    evidence wins and the decoder jumps to the forest's choice (so a missed short phase cannot lock it in the
    wrong state; ``override_ratio = 0`` makes the constraint absolute).
    """

    def __init__(self, transitions: str, stay_prob: float, class_prior: Sequence[float] | None,
                 override_ratio: float = 0.1) -> None:
        if transitions not in TRANSITIONS:
            raise MotionStateError(f"transitions must be one of {sorted(TRANSITIONS)}, got {transitions!r}")
        if not 0.0 < stay_prob < 1.0:
            raise MotionStateError(f"stay_prob must be in (0, 1), got {stay_prob!r}")
        if not 0.0 <= override_ratio < 1.0:
            raise MotionStateError(f"override_ratio must be in [0, 1), got {override_ratio!r}")
        allowed = TRANSITIONS[transitions]
        self.allowed = allowed
        if allowed is None:
            self.A = None
        else:
            A = np.zeros((4, 4))
            for i in range(4):
                others = [j for j in range(4) if allowed[i, j] and j != i]
                A[i, i] = stay_prob
                for j in others:
                    A[i, j] = (1.0 - stay_prob) / len(others)
            self.A = A
        prior = np.full(4, 0.25) if class_prior is None else np.asarray(class_prior, dtype=np.float64)
        self.inv_prior = 1.0 / np.maximum(prior, 1e-6)
        self.override_ratio = override_ratio
        self.state: int | None = None
        self.overrides = 0

    def reset(self) -> None:
        self.state = None

    def step(self, p: np.ndarray) -> int:
        lik = np.asarray(p, dtype=np.float64) * self.inv_prior
        best = int(np.argmax(lik))
        if self.A is None or self.state is None:
            self.state = best
            return best
        row = self.allowed[self.state]
        best_allowed = float(np.max(np.where(row, lik, 0.0)))
        if self.override_ratio > 0.0 and best_allowed <= self.override_ratio * float(lik[best]):
            self.overrides += 1
            self.state = best
            return best
        score = self.A[self.state] * lik
        if score.max() > 0.0:
            self.state = int(np.argmax(score))
        return self.state


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


class MotionStateRecognizer:
    """Online motion-state recogniser: wavelet denoising → window features → random forest → temporal constraint.

    Parameters
    ----------
    sample_hz : float
        Sample rate of the sensor stream (200 Hz in the environment).
    window : int
        Feature window in samples (default 100 = 0.5 s).
    hop : int
        Samples between two classifications (default 20 = 0.1 s); the state is held in between.
    feature_set : {"paper", "paper+speed"}
    transitions : {"paper", "monorail", "none"}
    stay_prob : float
        Self-transition probability of the constraint's forward filter.
    denoise : bool
        Apply the causal wavelet denoiser (sym4, 5 levels, heursure, window 256) to the acceleration.
    n_estimators, max_depth, seed :
        Random-forest settings for :meth:`fit`.

    Examples
    --------
    >>> rec = MotionStateRecognizer().fit(training_traces)            # doctest: +SKIP
    >>> state = rec.update(accel_mps2, speed_mps, pitch_rad)           # doctest: +SKIP
    >>> if rec.is_standstill: ...  # e.g. hold a mass estimator         # doctest: +SKIP
    """

    def __init__(self, *, sample_hz: float = 200.0, window: int = 100, hop: int = 20,
                 feature_set: str = "paper+speed", transitions: str = "monorail", stay_prob: float = 0.9,
                 denoise: bool = True, n_estimators: int = 40, max_depth: int | None = 12, seed: int = 0) -> None:
        if not (sample_hz > 0 and math.isfinite(sample_hz)):
            raise MotionStateError(f"sample_hz must be finite and > 0, got {sample_hz!r}")
        if not (isinstance(window, int) and window >= 8):
            raise MotionStateError(f"window must be an integer >= 8, got {window!r}")
        if not (isinstance(hop, int) and 1 <= hop <= window):
            raise MotionStateError(f"hop must be an integer in [1, window], got {hop!r}")
        if feature_set not in FEATURE_SETS:
            raise MotionStateError(f"feature_set must be one of {sorted(FEATURE_SETS)}, got {feature_set!r}")
        if transitions not in TRANSITIONS:
            raise MotionStateError(f"transitions must be one of {sorted(TRANSITIONS)}, got {transitions!r}")
        self.sample_hz = float(sample_hz)
        self.window = window
        self.hop = hop
        self.feature_set = feature_set
        self.transitions = transitions
        self.stay_prob = stay_prob
        self.denoise = denoise
        self.n_estimators = n_estimators
        self.max_depth = max_depth
        self.seed = seed
        self.classifier = None
        self.class_prior = np.full(4, 0.25)
        self._filter = _ForwardFilter(transitions, stay_prob, None)
        self.reset()

    # ------------------------------------------------------------------ batch
    def _motion_accel(self, accel: np.ndarray, pitch: np.ndarray | None) -> np.ndarray:
        a = np.asarray(accel, dtype=np.float64)
        if pitch is not None:
            a = a - G_MPS2 * np.sin(np.asarray(pitch, dtype=np.float64))
        return a

    def trace_features(self, accel_mps2: np.ndarray, speed_mps: np.ndarray,
                       pitch_rad: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Features of every classification window of a recorded stream, exactly as :meth:`update` sees them.

        Returns ``(X, ends)``: features, and the index of the last sample of each window.
        """
        a = self._motion_accel(accel_mps2, pitch_rad)
        v = np.asarray(speed_mps, dtype=np.float64)
        if a.shape != v.shape or a.ndim != 1:
            raise MotionStateError(f"accel and speed must be 1-D of equal length, got {a.shape} and {v.shape}")
        if self.denoise:
            den = SlidingWaveletDenoiser(256, self.hop)
            a = den.process(a)
        a = hold_last_valid(np.asarray(a, dtype=np.float64))
        v = hold_last_valid(v)
        n = a.size
        ends = np.arange(self.hop - 1, n, self.hop)
        ends = ends[ends >= self.window - 1]
        if ends.size == 0:
            return np.empty((0, len(FEATURE_SETS[self.feature_set]))), ends
        idx = ends[:, None] - np.arange(self.window - 1, -1, -1)[None, :]
        X = window_features(a[idx], self.sample_hz, v[idx], self.feature_set) if self.feature_set != "paper" \
            else window_features(a[idx], self.sample_hz, None, "paper")
        return X, ends

    def fit_arrays(self, X: np.ndarray, y: np.ndarray) -> "MotionStateRecognizer":
        """Fit the forest on feature rows ``X`` and labels ``y`` (0..3)."""
        from sklearn.ensemble import RandomForestClassifier

        X = np.asarray(X, dtype=np.float64)
        y = np.asarray(y, dtype=np.int64)
        if X.ndim != 2 or X.shape[0] != y.shape[0] or X.shape[0] == 0:
            raise MotionStateError(f"X must be (m, k) with m = len(y) > 0, got {X.shape} and {y.shape}")
        if set(np.unique(y)) - {0, 1, 2, 3}:
            raise MotionStateError(f"labels must be in 0..3, got {sorted(set(np.unique(y)))}")
        clf = RandomForestClassifier(n_estimators=self.n_estimators, max_depth=self.max_depth,
                                     random_state=self.seed, n_jobs=1, class_weight="balanced")
        clf.fit(X, y)
        self.classifier = clf
        counts = np.bincount(y, minlength=4).astype(float)
        self.class_prior = np.maximum(counts / counts.sum(), 1e-3)
        # class_weight="balanced" already equalises the priors the forest's probabilities carry
        self._filter = _ForwardFilter(self.transitions, self.stay_prob, None)
        self.reset()
        return self

    def fit(self, traces: Iterable[Trace], pitches: Iterable[np.ndarray | None] | None = None,
            labels: Iterable[np.ndarray] | None = None) -> "MotionStateRecognizer":
        """Fit on recorded/simulated traces with ``true_speed_mps`` (labels from :func:`label_motion_states`).

        ``pitches`` (optional, per trace) are the pitch estimates used to remove gravity from the accelerometer.
        """
        Xs, ys = [], []
        traces = list(traces)
        pitches = [None] * len(traces) if pitches is None else list(pitches)
        labels_l = [None] * len(traces) if labels is None else list(labels)
        for tr, pitch, lab in zip(traces, pitches, labels_l):
            X, ends = self.trace_features(tr["accel_mps2"], tr["speed_mps"], pitch)
            if lab is None:
                if "true_speed_mps" not in tr:
                    raise MotionStateError(f"{tr.source}: needs a true_speed_mps column (or labels) to train")
                lab = label_motion_states(tr["true_speed_mps"], float(np.median(np.diff(tr["t_s"]))))
            Xs.append(X)
            ys.append(np.asarray(lab)[ends])
        return self.fit_arrays(np.vstack(Xs), np.concatenate(ys))

    def predict_windows(self, X: np.ndarray, constrained: bool = True) -> np.ndarray:
        """States of consecutive windows (in time order), with or without the temporal constraint."""
        self._need_fit()
        proba = self._proba(X)
        if not constrained:
            return np.argmax(proba, axis=1)
        return apply_temporal_constraint(proba, self.transitions, stay_prob=self.stay_prob)

    def predict_trace(self, accel_mps2: np.ndarray, speed_mps: np.ndarray, pitch_rad: np.ndarray | None = None,
                      constrained: bool = True) -> np.ndarray:
        """Per-sample states of a whole stream (the state of the latest finished window, held; standstill before)."""
        X, ends = self.trace_features(accel_mps2, speed_mps, pitch_rad)
        n = np.asarray(accel_mps2).size
        out = np.zeros(n, dtype=np.int64)
        if ends.size == 0:
            return out
        states = self.predict_windows(X, constrained)
        for k, e in enumerate(ends):
            out[e:] = states[k]
        return out

    # ------------------------------------------------------------------ online
    def reset(self) -> None:
        """Forget the stream (buffers, belief); keep the trained forest."""
        self._den = SlidingWaveletDenoiser(256, self.hop) if self.denoise else None
        self._abuf = np.zeros(self.window)
        self._vbuf = np.zeros(self.window)
        self._n = 0
        self._last_a = 0.0
        self._last_v = 0.0
        self._filter.reset()
        self.state = STANDSTILL

    @property
    def is_standstill(self) -> bool:
        return self.state == STANDSTILL

    def update(self, accel_mps2: float, speed_mps: float, pitch_rad: float = math.nan) -> int:
        """Feed one sample; returns the current state (re-classified every ``hop`` samples).

        Same windows and values as :meth:`trace_features` on the whole stream, so online and offline agree.
        """
        self._need_fit()
        a = float(accel_mps2)
        if math.isfinite(pitch_rad) and math.isfinite(a):
            a -= G_MPS2 * math.sin(pitch_rad)
        if not math.isfinite(a):
            a = self._last_a
        v = float(speed_mps)
        if not math.isfinite(v):
            v = self._last_v
        self._last_a, self._last_v = a, v
        self._n += 1
        vbuf = self._vbuf
        vbuf[:-1] = vbuf[1:]
        vbuf[-1] = v
        abuf = self._abuf
        if self._den is not None:
            ready = self._den.push(a)
            k = ready.size
            if k:
                if k >= self.window:
                    abuf[:] = ready[-self.window:]
                else:
                    abuf[:-k] = abuf[k:]
                    abuf[-k:] = ready
        else:
            abuf[:-1] = abuf[1:]
            abuf[-1] = a
        if self._n % self.hop == 0 and self._n >= self.window:
            X = window_features(abuf, self.sample_hz, vbuf if self.feature_set != "paper" else None,
                                self.feature_set)
            self.state = self._filter.step(self._proba(X)[0])
        return self.state

    # ------------------------------------------------------------------ helpers
    def _need_fit(self) -> None:
        if self.classifier is None:
            raise MotionStateError("MotionStateRecognizer is not trained: call fit() first")

    def _proba(self, X: np.ndarray) -> np.ndarray:
        clf = self.classifier
        p = clf.predict_proba(X)
        full = np.zeros((p.shape[0], 4))
        full[:, clf.classes_.astype(int)] = p
        return full
