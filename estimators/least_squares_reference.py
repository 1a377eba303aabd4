"""A least-squares reference for the mass: what the history of a trace allows, not an estimator for the env.

:func:`expanding_ls_mass` fits ``T/r - m_rot dv/dt = M f + c`` (``f``: the accelerometer's specific force, ``c``:
running resistance and biases, unknown) by ordinary least squares over all samples so far, at every instant: no
prior, no forgetting, no gates. The model is exact for a point mass without sway, so on such a world this is about
the most a linear regression can extract from the first seconds of a run (``scripts/mass_information_bound.py``).
It is wrong where the brake force is not measured or gravity acts along a long train (the pymunk plant).

With ``offset_prior`` the fit is Bayesian: the offset is written ``c = M k`` (``k = μ g − b``, per unit mass) and
``k`` gets a Gaussian prior, which is what an estimator can know beforehand about the running resistance and the
sensor biases. Given the *true* mass for the prior's width and the residual noise of the exact model, it is an
optimistic reference: what the first seconds of data plus correct prior knowledge allow.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uuom_core.trace import Trace
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2, VehicleParams

__all__ = ["OffsetPrior", "expanding_ls_mass", "ls_mass_errors", "scenario_offset_prior"]


@dataclass(frozen=True)
class OffsetPrior:
    """Gaussian prior on the offset per unit mass ``k = μ g cos θ − b_accel − b_force / M`` (m/s²).

    Attributes
    ----------
    mean_mps2, std_mps2 : float
        Its mean and standard deviation.
    mass_kg : float
        The mass that turns the per-unit-mass std into a force std (``c = M k``); the truth, for a reference.
    residual_std_n : float or None
        Standard deviation of the 1 s-averaged force residual (None: from the whole run's fit).
    """

    mean_mps2: float
    std_mps2: float
    mass_kg: float
    residual_std_n: float | None = None


def scenario_offset_prior(mass_kg: float, mu_range: tuple[float, float] = (0.015, 0.03),
                          accel_bias_std_mps2: float = 0.012, torque_bias_std_nm: float = 30.0,
                          vehicle: VehicleParams = DEFAULT_VEHICLE) -> OffsetPrior:
    """The prior an estimator may hold on the point-mass world: μ uniform on ``mu_range`` (the random runs' draw),
    the sensor-bias spreads of :class:`uuom_gym.sim.point_mass.PointMassSensors` (not imported: estimators do not
    depend on the simulator)."""
    lo, hi = mu_range
    mu_mean, mu_std = 0.5 * (lo + hi), (hi - lo) / math.sqrt(12.0)
    force_bias_std = torque_bias_std_nm / vehicle.drive_wheel_radius_m / mass_kg
    std = math.sqrt((G_MPS2 * mu_std) ** 2 + accel_bias_std_mps2 ** 2 + force_bias_std ** 2)
    return OffsetPrior(G_MPS2 * mu_mean, std, mass_kg)


def _box(x: np.ndarray, n: int) -> np.ndarray:
    c = np.cumsum(np.insert(x, 0, 0.0))
    y = np.full_like(x, np.nan)
    y[n - 1:] = (c[n:] - c[:-n]) / n
    return y


def expanding_ls_mass(trace: Trace, vehicle: VehicleParams = DEFAULT_VEHICLE, window_s: float = 1.0,
                      min_speed_mps: float = 0.05, every: int = 20,
                      offset_prior: OffsetPrior | None = None) -> np.ndarray:
    """Mass (kg) from the least-squares fit of ``T/r - m_rot a = M f + c`` over all samples so far (NaN before
    the fit is determined); evaluated every ``every`` samples, NaN in between. With ``offset_prior``: the
    Bayesian fit of ``y = M (f + k0) + c'`` with ``c' ~ N(0, (M σ_k)²)`` over one 1 s-averaged sample per window
    (the averaged samples of one window are not independent evidence)."""
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
    if offset_prior is not None:
        use &= (np.arange(len(t)) % n) == 0
    k0 = 0.0 if offset_prior is None else offset_prior.mean_mps2  # y = M (f + k0) + c'
    X = np.where(use[:, None], np.stack([f + k0, np.ones_like(f)], 1), 0.0)
    yu = np.where(use, y, 0.0)
    A = np.cumsum(X[:, :, None] * X[:, None, :], 0)
    b = np.cumsum(X * yu[:, None], 0)
    if offset_prior is not None:
        sigma = offset_prior.residual_std_n
        if sigma is None:  # the exact model's residual over the whole run
            rows = np.flatnonzero(use)
            coef, *_ = np.linalg.lstsq(X[rows], yu[rows], rcond=None)
            sigma = float(np.std(yu[rows] - X[rows] @ coef))
        A /= sigma ** 2
        b /= sigma ** 2
        A[:, 1, 1] += 1.0 / (offset_prior.mass_kg * offset_prior.std_mps2) ** 2
    out = np.full(len(t), np.nan)
    for i in range(0, len(t), every):
        det = A[i, 0, 0] * A[i, 1, 1] - A[i, 0, 1] ** 2
        if det > 1e-9 * max(A[i, 0, 0] * A[i, 1, 1], 1e-300):
            out[i] = (A[i, 1, 1] * b[i, 0] - A[i, 0, 1] * b[i, 1]) / det
    return out


def ls_mass_errors(trace: Trace, settle_s: float = 10.0,
                   offset_prior: OffsetPrior | None = None) -> tuple[float, float]:
    """(max |error| % after ``settle_s``, |error| % at the last evaluated sample)."""
    m = expanding_ls_mass(trace, offset_prior=offset_prior)
    t, truth = trace["t_s"], trace["mass_kg"]
    k = (t >= t[0] + settle_s) & np.isfinite(m)
    if not k.any():
        return float("nan"), float("nan")
    err = np.abs(m[k] - truth[k]) / truth[k] * 100.0
    return float(err.max()), float(err[-1])
