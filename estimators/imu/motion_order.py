"""The paper's temporal order constraint on motion states (paper 001, §2.3), applied causally.

``s_t = argmax_j A[s_{t-1}, j] · p_rf(j | x_t)`` with ``A`` zero on forbidden transitions and ``stay_prob`` on the
diagonal; see :mod:`estimators.imu.motion_state` for the transition sets and why ``"monorail"`` exists.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .motion_features import MotionStateError

__all__ = ["TRANSITIONS", "apply_temporal_constraint"]

_PAPER = np.array([[1, 1, 0, 0], [0, 1, 1, 0], [0, 0, 1, 1], [1, 0, 0, 1]], dtype=bool)
_MONORAIL = np.array([[1, 1, 0, 0], [0, 1, 1, 1], [0, 1, 1, 1], [1, 1, 1, 1]], dtype=bool)
TRANSITIONS: dict[str, np.ndarray | None] = {"paper": _PAPER, "monorail": _MONORAIL, "none": None}
"""Allowed transitions ``allowed[from, to]`` of each temporal constraint."""


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
