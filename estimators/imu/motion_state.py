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

Layout: states, truth labels and window features in :mod:`estimators.imu.motion_features`; the order constraint
in :mod:`estimators.imu.motion_order`; the online recogniser here (everything is re-exported from this module).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

import numpy as np

from uuom_core.trace import Trace
from uuom_core.vehicle import G_MPS2

from ..filters import hold_last_valid
from .denoise import SlidingWaveletDenoiser
from .motion_features import (ACCELERATING, CRUISING, DECELERATING, FEATURE_SETS, STANDSTILL, STATE_NAMES,
                              MotionStateError, label_motion_states, per_state_accuracy, window_features)
from .motion_order import TRANSITIONS, _ForwardFilter, apply_temporal_constraint

__all__ = [
    "ACCELERATING", "CRUISING", "DECELERATING", "STANDSTILL", "STATE_NAMES", "TRANSITIONS",
    "MotionStateError", "MotionStateRecognizer", "apply_temporal_constraint", "label_motion_states",
    "per_state_accuracy", "window_features",
]


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
