"""Wavelet threshold denoising (paper 001 §2.1): heursure rule, threshold function, batch and online forms."""

import math

import numpy as np
import pytest

from estimators.imu.denoise import (DenoiseError, SlidingWaveletDenoiser, heursure_threshold, rigrsure_threshold,
                                    threshold_coefficients, wavelet_denoise)


def _signal(n=4000, seed=0, noise=0.2):
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 200.0
    clean = np.sin(2 * np.pi * 0.3 * t) + 0.5 * (t > 8.0)
    return clean, clean + noise * rng.standard_normal(n)


def _rms(a):
    return float(np.sqrt(np.mean(np.square(a))))


def test_rigrsure_matches_brute_force_sure():
    x = np.random.default_rng(1).normal(0, 1, 64) + np.r_[np.full(8, 4.0), np.zeros(56)]
    n = x.size

    def sure(t):  # Stein's unbiased risk of soft thresholding at t, unit noise
        return n - 2 * np.sum(np.abs(x) <= t) + np.sum(np.minimum(np.abs(x), t) ** 2)

    candidates = np.sort(np.abs(x))
    best = candidates[np.argmin([sure(t) for t in candidates])]
    assert rigrsure_threshold(x) == pytest.approx(best)


def test_heursure_uses_universal_threshold_for_pure_noise():
    x = np.random.default_rng(2).normal(0, 1, 512)
    assert heursure_threshold(x) == pytest.approx(math.sqrt(2 * math.log(512)))


def test_heursure_uses_sure_for_strong_signal():
    x = np.random.default_rng(3).normal(0, 1, 512)
    x[:200] += 6.0
    thr = heursure_threshold(x)
    assert thr == pytest.approx(min(rigrsure_threshold(x), math.sqrt(2 * math.log(512))))
    assert thr < math.sqrt(2 * math.log(512))


def test_threshold_function_between_soft_and_hard():
    w = np.linspace(-5, 5, 101)
    lam = 1.0
    imp = threshold_coefficients(w, lam, "improved", alpha=2.0)
    soft = threshold_coefficients(w, lam, "soft")
    hard = threshold_coefficients(w, lam, "hard")
    assert np.all(imp[np.abs(w) < lam] == 0.0)
    # continuous at the threshold, no shrinkage bias for large coefficients
    assert threshold_coefficients(np.array([1.0 + 1e-9]), lam, "improved")[0] == pytest.approx(0.0, abs=1e-6)
    big = np.abs(w) > 4
    assert np.all(np.abs(imp[big] - w[big]) < 0.01)
    above = np.abs(w) >= lam
    assert np.all(np.abs(imp[above]) >= np.abs(soft[above]) - 1e-12)
    assert np.all(np.abs(imp[above]) <= np.abs(hard[above]) + 1e-12)
    np.testing.assert_allclose(threshold_coefficients(w, lam, "improved", alpha=0.0), soft)


@pytest.mark.parametrize("function", ["improved", "soft", "hard"])
def test_batch_denoise_reduces_error(function):
    clean, noisy = _signal()
    out = wavelet_denoise(noisy, function=function)
    assert out.shape == noisy.shape
    assert _rms(out - clean) < 0.3 * _rms(noisy - clean)


def test_nan_samples_are_bridged():
    clean, noisy = _signal(seed=4)
    noisy[100:130] = np.nan
    noisy[0] = np.nan
    out = wavelet_denoise(noisy)
    assert np.all(np.isfinite(out))
    assert _rms(out - clean) < 0.5 * 0.2


def test_online_denoiser_is_causal_and_denoises():
    clean, noisy = _signal(seed=5)
    den = SlidingWaveletDenoiser(window=256, hop=16)
    out = den.process(noisy)
    assert _rms(out[256:] - clean[256:]) < 0.5 * _rms(noisy - clean)
    # changing the future does not change what was already emitted
    altered = noisy.copy()
    altered[2000:] += 5.0
    out2 = SlidingWaveletDenoiser(window=256, hop=16).process(altered)
    np.testing.assert_array_equal(out[:2000], out2[:2000])


def test_online_emits_every_hop():
    den = SlidingWaveletDenoiser(window=64, hop=8)
    sizes = [den.push(float(v)).size for v in np.arange(40.0)]
    assert sizes == [8 if (k + 1) % 8 == 0 else 0 for k in range(40)]
    assert math.isfinite(den.last_value)


@pytest.mark.parametrize("kwargs, word", [
    ({"wavelet": "nope"}, "wavelet"), ({"level": 0}, "level"), ({"function": "odd"}, "threshold function"),
    ({"noise_scaling": "x"}, "noise_scaling"), ({"alpha": -1.0}, "alpha"),
])
def test_bad_settings_are_named(kwargs, word):
    with pytest.raises(DenoiseError, match=word):
        wavelet_denoise(np.zeros(64), **kwargs)


def test_bad_shapes_and_windows():
    with pytest.raises(DenoiseError, match="one-dimensional"):
        wavelet_denoise(np.zeros((4, 4)))
    with pytest.raises(DenoiseError, match="hop"):
        SlidingWaveletDenoiser(window=64, hop=65)
    with pytest.raises(DenoiseError, match="window"):
        SlidingWaveletDenoiser(window=8)
