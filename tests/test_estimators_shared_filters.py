"""The 2x2 filter primitives live once, in :mod:`estimators.filters` (issue 9), and the estimators that used to
inline them (``rls``/``ffrls``/``dffrls``, ``ekf``'s slope filter via ``rls-ekf``, ``sf-kf``) give the same
results as before the move.

``tests/data/estimators_shared_filters_pinned.npz`` was written by the code *before* the move (commit af309c5,
with the update and repair inlined) on the trace below; the estimators now call
:func:`~estimators.filters.kalman_update_2x2_h1` and :func:`~estimators.filters.repair_pd_2x2`. On the machine
that moved them the outputs were bitwise equal; the tolerance (1e-12 relative) only absorbs another libm.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pathlib import Path

import estimators
from estimators.filters import joseph_update, kalman_update_2x2_h1, repair_pd_2x2
from uuom_core.synthetic import synthetic_trace
from uuom_core.trace import Trace

PINNED = Path(__file__).parent / "data" / "estimators_shared_filters_pinned.npz"
NAMES = ("rls", "ffrls", "dffrls", "ekf", "rls-ekf", "sf-kf")
EVERY = 10
# the estimators as they were when the pin was written: sf-kf's residual gate (session 49) is newer than the move
AS_PINNED = {"sf-kf": {"residual_gate_sigma": 0.0}}


def faulty_trace() -> Trace:
    """30 s of the varying-grade synthetic run with 2 % dropouts and 0.2 % spikes on every channel."""
    base = synthetic_trace("varying", seed=3, duration_s=30.0)
    rng = np.random.default_rng(3)
    cols = {k: v.copy() for k, v in base.columns.items()}
    for k, spike in (("torque_nm", 5000.0), ("speed_mps", 2.0), ("accel_mps2", 5.0)):
        x = cols[k]
        x[rng.random(x.size) < 0.002] += spike
        x[rng.random(x.size) < 0.02] = np.nan
    return Trace(cols, source="shared-filters pin")


def outputs(name: str, trace: Trace) -> np.ndarray:
    s = estimators.make(name, **AS_PINNED.get(name, {})).run(trace)
    return np.c_[s.mass_kg, s.slope_rad, s.mass_std_kg, s.slope_std_rad][::EVERY]


@pytest.fixture(scope="module")
def trace() -> Trace:
    return faulty_trace()


@pytest.mark.parametrize("name", NAMES)
def test_outputs_unchanged_by_the_shared_primitives(name: str, trace: Trace) -> None:
    with np.load(PINNED) as data:
        want = data[name]
    got = outputs(name, trace)
    assert np.ptp(want[:, 1]) > math.radians(0.5), "pin on a trace that does not move the estimate"
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15, err_msg=name)


def test_kalman_update_2x2_h1_is_the_joseph_update() -> None:
    rng = np.random.default_rng(0)
    H = np.array([[1.0, 0.0]])
    for _ in range(200):
        A = rng.normal(size=(2, 2))
        P = A @ A.T + 1e-6 * np.eye(2)
        r = float(rng.uniform(1e-6, 2.0))
        innov = float(rng.normal())
        dx1, dx2, p11, p12, p22 = kalman_update_2x2_h1(P[0, 0], P[0, 1], P[1, 1], innov, r)
        K = P @ H.T / (P[0, 0] + r)
        np.testing.assert_allclose([dx1, dx2], K[:, 0] * innov, rtol=1e-12, atol=1e-15)
        want = joseph_update(P, K, H, np.array([[r]]))
        np.testing.assert_allclose([[p11, p12], [p12, p22]], want, rtol=1e-9, atol=1e-15)


def test_repair_pd_2x2_gives_spd_on_any_input() -> None:
    bad = (math.nan, math.inf, -math.inf, -1.0, 0.0, 1e300, -1e300, 1e-30)
    for p11 in bad:
        for p12 in bad:
            for p22 in bad:
                a, b, c = repair_pd_2x2(p11, p12, p22, 1e-14, 1e-16, 1e6, 1e6)
                assert all(math.isfinite(x) for x in (a, b, c))
                assert 1e-14 <= a <= 1e6 and 1e-16 <= c <= 1e6
                assert a * c - b * b > 0.0
    # a healthy matrix passes unchanged
    assert repair_pd_2x2(2.0, 0.5, 1.0) == (2.0, 0.5, 1.0)


def test_dead_helpers_are_gone() -> None:
    import estimators.filters as f
    import estimators.imu.attitude_ukf as a

    assert not hasattr(f, "first_order_alpha")
    assert not hasattr(a, "QuaternionUKF")


if __name__ == "__main__":  # pragma: no cover - writes the pin (run with the code *before* a refactoring)
    import sys

    tr = faulty_trace()
    np.savez_compressed(sys.argv[1], **{n: outputs(n, tr) for n in NAMES})
