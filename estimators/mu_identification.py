"""Running-resistance identification (paper 000 §2.2, eqs. 8-15; spec §5.2) as a calibration routine.

On a calibration run with known total mass and slope (a weighed train on a surveyed track), the model
``T/r = M g sin θ + μ M g cos θ + (M + m_rot) a`` is linear in μ::

    y⁻ = T/(M r) − g sin θ − m_rot a / M − a,     h = g cos θ,     y⁻ = μ h

and a scalar RLS with the paper's dynamic forgetting factor ``φ_k = δ + (1 − δ) exp(−σ |y⁻ − h μ|)``
(eq. 12) identifies μ. ``a`` is the low-passed derivative of the measured ground speed and the torque goes
through the same low-pass (both sides of the regression filtered alike). Only samples with traction and motion
are used (braking adds an unmeasured force; at standstill static friction holds the train).

The paper reports the final RLS value (after averaging its plot). Here :func:`identify_running_resistance`
returns the RLS estimate at the end of the run and, as the calibration result, its mean over the second half of
the used samples (less sensitive to the last few seconds), both in :class:`MuIdentification`.

The paper's value μ ≈ 0.4 is not physical for its vehicle (spec §2); this routine recovers whatever μ the
plant (or the real vehicle) has.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uuom_core.trace import Trace
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2, VehicleParams

from .filters import LowPass2, dynamic_forgetting

__all__ = ["MuIdentification", "MuIdentificationError", "identify_running_resistance"]


class MuIdentificationError(ValueError):
    """The calibration run cannot identify μ (no truth, too few usable samples)."""


@dataclass(frozen=True)
class MuIdentification:
    """Result of :func:`identify_running_resistance`.

    Attributes
    ----------
    mu : float
        Calibrated running-resistance coefficient (mean of the RLS estimate over the second half of the used
        samples).
    mu_final : float
        RLS estimate at the last used sample (what the paper reads off).
    mu_std : float
        Standard deviation of the RLS estimate over the second half (spread, not a formal error bar).
    n_used : int
        Samples that entered the regression.
    history : numpy.ndarray
        RLS estimate per trace sample (NaN before the first used sample).
    """

    mu: float
    mu_final: float
    mu_std: float
    n_used: int
    history: np.ndarray


def identify_running_resistance(
    trace: Trace,
    vehicle: VehicleParams = DEFAULT_VEHICLE,
    *,
    mass_kg: float | np.ndarray | None = None,
    slope_rad: float | np.ndarray | None = None,
    delta: float = 0.999,
    sigma: float = 5.0,
    cutoff_hz: float = 1.0,
    min_speed_mps: float = 0.05,
    min_traction_fraction: float = 0.02,
    mu0: float = 0.05,
) -> MuIdentification:
    """Identify μ from a calibration trace with known mass and slope.

    Parameters
    ----------
    trace : Trace
        Must have ``torque_nm``, ``speed_mps`` and, unless given as arguments, the truth columns ``mass_kg`` and
        ``slope_deg``.
    vehicle : VehicleParams
        Drive-wheel radius and rotating mass.
    mass_kg, slope_rad : float or array, optional
        Known total mass and slope (scalar or per sample); override the trace's truth columns.
    delta, sigma : float
        Dynamic forgetting factor bounds/sensitivity (paper eq. 12); δ in [0.5, 1), σ > 0. The default δ is close
        to 1 because μ is a constant of the run.
    cutoff_hz : float
        Low-pass corner applied to torque and speed (both sides).
    mu0 : float
        Initial estimate.

    Raises
    ------
    MuIdentificationError
        When mass/slope are unknown or fewer than 200 samples are usable.
    """
    if not (0.5 <= delta < 1.0):
        raise ValueError(f"delta must be in [0.5, 1), got {delta!r}")
    if not (sigma > 0 and math.isfinite(sigma)):
        raise ValueError(f"sigma must be a finite number > 0, got {sigma!r}")
    n = len(trace)
    if mass_kg is None:
        if "mass_kg" not in trace:
            raise MuIdentificationError(f"{trace.source}: no mass_kg column and no mass_kg given")
        mass_kg = trace["mass_kg"]
    if slope_rad is None:
        if "slope_deg" not in trace:
            raise MuIdentificationError(f"{trace.source}: no slope_deg column and no slope_rad given")
        slope_rad = np.radians(trace["slope_deg"])
    mass = np.broadcast_to(np.asarray(mass_kg, dtype=float), (n,))
    slope = np.broadcast_to(np.asarray(slope_rad, dtype=float), (n,))
    if np.any(np.isfinite(mass) & (mass <= 0)):
        raise ValueError("mass_kg must be > 0")
    t = trace["t_s"]
    torque = trace["torque_nm"]
    speed = trace["speed_mps"]
    r = vehicle.drive_wheel_radius_m
    m_rot = vehicle.rotating_mass_kg
    f_min = min_traction_fraction * vehicle.max_traction_n
    lp_F = LowPass2(cutoff_hz)
    lp_v = LowPass2(cutoff_hz)
    lp_s = LowPass2(cutoff_hz)  # the slope enters through g sin θ, filtered like the other terms
    mu = float(mu0)
    P = 1.0
    prev_vf = math.nan
    hist = np.full(n, np.nan)
    used_idx: list[int] = []
    settle = max(1, int(round(1.0 / cutoff_hz / max(np.median(np.diff(t)) if n > 1 else 0.005, 1e-6))))
    run = 0
    for i in range(n):
        dt = float(t[i] - t[i - 1]) if i > 0 else float(t[1] - t[0]) if n > 1 else 0.005
        T = float(torque[i])
        v = float(speed[i])
        M = float(mass[i])
        th = float(slope[i])
        ok = T == T and v == v and M == M and th == th
        F = lp_F(T / r if T == T else math.nan, dt)
        vf = lp_v(v, dt)
        sf = lp_s(math.sin(th) if th == th else math.nan, dt)
        a = (vf - prev_vf) / dt if prev_vf == prev_vf else 0.0
        prev_vf = vf
        run = run + 1 if ok else 0
        if not (ok and run > settle and vf > min_speed_mps and F > f_min):
            if used_idx:
                hist[i] = mu
            continue
        y = F / M - G_MPS2 * sf - m_rot * a / M - a
        h = G_MPS2 * math.sqrt(max(1.0 - sf * sf, 0.0))
        e = y - h * mu
        lam = dynamic_forgetting(e, delta, sigma)
        K = P * h / (lam + h * P * h)
        mu += K * e
        P = min((1.0 - K * h) * P / lam, 1.0)
        hist[i] = mu
        used_idx.append(i)
    if len(used_idx) < 200:
        raise MuIdentificationError(
            f"{trace.source}: only {len(used_idx)} usable samples (moving with traction); need at least 200"
        )
    second = hist[used_idx[len(used_idx) // 2:]]
    return MuIdentification(float(np.mean(second)), float(mu), float(np.std(second)), len(used_idx), hist)
