"""Numerical robustness of the estimators: covariances stay symmetric PD and outputs finite over long random
input sequences (dropouts, absurd values, varying steps)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import estimators


def _pd2(p11: float, p12: float, p22: float) -> bool:
    return p11 > 0 and p22 > 0 and p11 * p22 - p12 * p12 > 0


def _random_inputs(rng: np.random.Generator, n: int) -> np.ndarray:
    x = np.column_stack([
        rng.normal(8000.0, 8000.0, n),  # torque
        np.abs(rng.normal(1.0, 1.0, n)),  # speed
        rng.normal(0.5, 3.0, n),  # specific force
        rng.uniform(0.001, 0.05, n),  # dt
    ])
    x[rng.random((n, 4)) < 0.02] = np.nan
    x[:, 3] = np.where(np.isnan(x[:, 3]), 0.005, x[:, 3])
    wild = rng.random(n) < 0.01
    x[wild, 0] = rng.choice([-1e7, 1e7, 0.0], wild.sum())
    return x


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_kernel_covariances_pd_over_1e6_random_updates(name: str) -> None:
    from estimators import dffrls_aekf_kernel as kern

    rng = np.random.default_rng(2024)
    est = estimators.make(name)
    update = est.update
    members = getattr(est, "members", [est])  # dffrls-aekf: every member of the geometry bank
    n_chunks, chunk = 100, 10_000
    for _ in range(n_chunks):
        x = _random_inputs(rng, chunk).tolist()
        for T, v, f, dt in x:
            update(T, v, f, dt)
        for m in members:
            assert np.linalg.eigvalsh(m.regression_P).min() > 0.0
            assert _pd2(*m.slope_P[[0, 0, 1], [0, 1, 1]])
            assert m.C[kern.R_MIN] <= m.S[kern.R] <= m.C[kern.R_MAX]
        e = est.estimate
        assert all(math.isfinite(v) for v in (e.mass_kg, e.slope_rad, e.mass_std_kg, e.slope_std_rad))


@pytest.mark.parametrize("name", ["sf-kf", "ekf", "rls-ekf", "ffrls"])
def test_other_covariances_pd_over_random_updates(name: str) -> None:
    rng = np.random.default_rng(7)
    est = estimators.make(name)
    n = 20_000 if name == "ekf" else 100_000
    for T, v, f, dt in _random_inputs(rng, n).tolist():
        e = est.update(T, v, f, dt)
    assert all(math.isfinite(v) for v in (e.mass_kg, e.slope_rad, e.mass_std_kg, e.slope_std_rad))
    if name == "sf-kf":
        assert _pd2(est.P11, est.P12, est.P22) and _pd2(est.Pc, est.Pcd, est.Pd)
    elif name == "ekf":
        assert np.all(np.linalg.eigvalsh(est.P) > 0)
        np.testing.assert_array_equal(est.P, est.P.T)
    elif name == "rls-ekf":
        assert _pd2(est.mass_layer.P11, est.mass_layer.P12, est.mass_layer.P22)
        assert _pd2(est.slope_layer.P11, est.slope_layer.P12, est.slope_layer.P22)
    else:
        assert _pd2(est.P11, est.P12, est.P22)
