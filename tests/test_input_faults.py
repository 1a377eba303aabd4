"""The sensor-fault detectors of :mod:`estimators.input_faults`: a one-sample spike and a frozen channel."""

from __future__ import annotations

import math

import numpy as np
import pytest

from estimators.input_faults import JumpGate, StuckDetector


def _feed(det, values) -> np.ndarray:
    return np.array([det(float(v)) for v in values])


def test_jump_gate_drops_a_one_sample_spike_and_takes_a_step_one_sample_late() -> None:
    gate = JumpGate(100.0)
    out = _feed(gate, [0, 10, 5000, 20, 30, 2000, 2010, 2005, math.nan, 2000])
    assert np.isnan(out[2]), "the spike is held back"
    assert out[3] == 20 and out[4] == 30, "the old level goes on after the spike"
    assert np.isnan(out[5]), "the first sample of a step is held"
    np.testing.assert_array_equal(out[6:8], [2010, 2005])  # confirmed by the next sample: a real step
    assert np.isnan(out[8]) and out[9] == 2000, "a missing sample passes and breaks nothing"
    assert gate.n_held == 2


def test_jump_gate_takes_the_first_sample_and_is_off_at_zero() -> None:
    assert JumpGate(1.0)(1e4) == 1e4
    off = JumpGate(0.0)
    np.testing.assert_array_equal(_feed(off, [0, 1e4, 0]), [0, 1e4, 0])
    for bad in (-1.0, math.nan, math.inf):
        with pytest.raises(ValueError, match="max_jump"):
            JumpGate(bad)


def test_jump_gate_threshold_grows_with_a_noisier_channel_than_expected() -> None:
    """A fixed threshold below a channel's noise would hold back every other sample; with ``noise_factor`` the
    threshold follows the channel's mean change, and a spike far above the noise is still held back."""
    noisy = np.random.default_rng(1).normal(0.0, 1.0, 2000)
    fixed = JumpGate(0.5)
    _feed(fixed, noisy)
    adaptive = JumpGate(0.5, noise_factor=8.0)
    out = _feed(adaptive, np.concatenate([noisy, [40.0], noisy[:10]]))
    assert fixed.n_held > 500
    assert np.isnan(out[:500]).sum() < 100, "it learns the noise within a few hundred samples"
    assert np.isnan(out[500:2000]).sum() < 5 and np.isnan(out[2000])
    with pytest.raises(ValueError, match="noise_factor"):
        JumpGate(1.0, noise_factor=-1.0)


def test_stuck_detector_drops_a_frozen_noisy_channel_until_it_moves_again() -> None:
    rng = np.random.default_rng(0)
    noisy = rng.normal(0.0, 0.05, 400)
    frozen = np.full(300, noisy[-1])
    after = rng.normal(0.0, 0.05, 50)
    det = StuckDetector(20)
    out = _feed(det, np.concatenate([noisy, frozen, after]))
    assert np.isfinite(out[:400]).all(), "a noisy channel is data"
    run = out[400:700]
    # the frozen value is the last noisy one: it has been seen once already, so the run counts from there
    assert np.isfinite(run[:18]).all() and np.isnan(run[18:]).all()
    assert np.isfinite(out[700:]).all(), "data again as soon as the value changes"
    assert det.n_stuck == 300 - 18


def test_stuck_detector_leaves_noise_free_data_alone() -> None:
    """Simulated data without noise repeat for long stretches: a channel that never showed noise is not judged."""
    values = np.concatenate([np.zeros(500), np.full(500, 0.3), np.linspace(0.3, 1.0, 200), np.ones(500)])
    det = StuckDetector(20)
    assert np.isfinite(_feed(det, values)).all() and det.n_stuck == 0


def test_stuck_detector_passes_nan_and_is_off_at_zero() -> None:
    det = StuckDetector(3)
    assert math.isnan(det(math.nan))
    off = StuckDetector(0)
    assert np.isfinite(_feed(off, np.zeros(100))).all()
    for bad in (-1, 2.5, True):
        with pytest.raises(ValueError, match="min_repeats"):
            StuckDetector(bad)
