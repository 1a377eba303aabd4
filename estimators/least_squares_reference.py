"""A least-squares reference for the mass: what the history of a trace allows, not an estimator for the env.

:func:`expanding_ls_mass` fits ``T/r - m_rot dv/dt = M f + c`` (``f``: the accelerometer's specific force, ``c``:
running resistance and biases, unknown) by ordinary least squares over all samples so far, at every instant: no
prior, no forgetting, no gates. The model is exact for a point mass without sway, so on such a world this is about
the most a linear regression can extract from the first seconds of a run (``scripts/mass_information_bound.py``).
It is wrong where the brake force is not measured or gravity acts along a long train (the pymunk plant).
"""

from __future__ import annotations

import numpy as np

from uuom_core.trace import Trace
from uuom_core.vehicle import DEFAULT_VEHICLE, VehicleParams

__all__ = ["expanding_ls_mass", "ls_mass_errors"]


def _box(x: np.ndarray, n: int) -> np.ndarray:
    c = np.cumsum(np.insert(x, 0, 0.0))
    y = np.full_like(x, np.nan)
    y[n - 1:] = (c[n:] - c[:-n]) / n
    return y


def expanding_ls_mass(trace: Trace, vehicle: VehicleParams = DEFAULT_VEHICLE, window_s: float = 1.0,
                      min_speed_mps: float = 0.05, every: int = 20) -> np.ndarray:
    """Mass (kg) from the least-squares fit of ``T/r - m_rot a = M f + c`` over all samples so far (NaN before
    the fit is determined); evaluated every ``every`` samples, NaN in between."""
    v = vehicle
    t = trace["t_s"]
    cols = [np.asarray(trace[k], dtype=float) for k in ("torque_nm", "speed_mps", "accel_mps2")]
    ok = np.logical_and.reduce([np.isfinite(c) for c in cols])
    torque, speed, accel = (np.interp(t, t[ok], c[ok]) for c in cols)  # dropouts: hold by interpolation
    fs = 1.0 / float(np.median(np.diff(t)))
    n = max(2, int(round(window_s * fs)))
    force = _box(torque / v.drive_wheel_radius_m, n)
    f = _box(accel, n)
    speed_f = _box(speed, n)
    dvdt = np.full_like(speed, np.nan)
    dvdt[n:] = (speed[n:] - speed[:-n]) * fs / n  # over the same window as the box filter
    y = force - v.rotating_mass_kg * dvdt
    use = np.isfinite(y) & np.isfinite(f) & (speed_f > min_speed_mps)
    X = np.where(use[:, None], np.stack([f, np.ones_like(f)], 1), 0.0)
    yu = np.where(use, y, 0.0)
    A = np.cumsum(X[:, :, None] * X[:, None, :], 0)
    b = np.cumsum(X * yu[:, None], 0)
    out = np.full(len(t), np.nan)
    for i in range(0, len(t), every):
        det = A[i, 0, 0] * A[i, 1, 1] - A[i, 0, 1] ** 2
        if det > 1e-9 * max(A[i, 0, 0] * A[i, 1, 1], 1e-300):
            out[i] = (A[i, 1, 1] * b[i, 0] - A[i, 0, 1] * b[i, 1]) / det
    return out


def ls_mass_errors(trace: Trace, settle_s: float = 10.0) -> tuple[float, float]:
    """(max |error| % after ``settle_s``, |error| % at the last evaluated sample)."""
    m = expanding_ls_mass(trace)
    t, truth = trace["t_s"], trace["mass_kg"]
    k = (t >= t[0] + settle_s) & np.isfinite(m)
    if not k.any():
        return float("nan"), float("nan")
    err = np.abs(m[k] - truth[k]) / truth[k] * 100.0
    return float(err.max()), float(err[-1])
