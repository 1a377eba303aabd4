"""Sage-Husa adaptive EKF for the slope (paper 000 §3.2, eqs. 23-30; spec §5.3).

The 2-state ``[v, θ]`` filter of :class:`~estimators.ekf.SlopeEKF`, with the noise statistics estimated online by
the Sage-Husa estimator with fading factor ``b`` (paper: 0.966)::

    d_k = (1 − b) / (1 − b^{k+1})
    ε_k = z_k − H x̂_k⁻ − r̂_{k−1}
    r̂_k = (1 − d_k) r̂_{k−1} + d_k (z_k − H x̂_k⁻)
    R̂_k = (1 − d_k) R̂_{k−1} + d_k (ε_k² − H P_k⁻ Hᵀ)
    q̂_k = (1 − d_k) q̂_{k−1} + d_k (x̂_k − f(x̂_{k−1}))
    Q̂_k = (1 − d_k) Q̂_{k−1} + d_k (K ε² Kᵀ + P_k − F P_{k−1} Fᵀ)

The paper prints eq. 30 with typos (θ for x, signs); this is the standard form (R̂ uses the *prior* covariance).

Choices (spec §5.3 pitfalls):

- ``d`` starts at ``k = 1`` (``d_1 ≈ 0.51``), not ``d_0 = 1`` which would discard the prior R̂₀, Q̂₀.
- R̂ falls back to the biased, always-positive form ``(1 − d) R̂ + d ε²`` when the unbiased one is not positive,
  and is clamped to ``[R_min, R_max]``. Q̂ is repaired to symmetric PD with its diagonal in ``[Q_min, Q_max]``.
- The noise *means* q̂ and r̂ are estimated as in the paper but bounded (a mean of the speed noise beyond a few
  sigma, or a slope drift beyond ``grade_rate_max``, would be a model error, not noise).
- Only samples that pass the innovation gate feed the noise estimator (a spike must not inflate R̂).
- Joseph-form covariance update; the state and covariance stay finite and PD.
"""

from __future__ import annotations

import math

from uuom_core.vehicle import VehicleParams

from .ekf import SlopeEKF
from .filters import repair_pd_2x2

__all__ = ["SageHusaAEKF"]


class SageHusaAEKF(SlopeEKF):
    """Slope EKF with Sage-Husa adaptive noise statistics.

    Parameters
    ----------
    vehicle : VehicleParams
    fading : float
        Fading factor ``b`` in (0, 1) (paper: 0.966).
    adapt_r, adapt_q : bool
        Estimate the measurement / process noise covariance (paper: both).
    adapt_means : bool
        Estimate the noise means r̂, q̂ as well (paper: yes).
    r_bounds : (float, float)
        Bounds of R̂ in (m/s)²; default ``(0.1 R₀, 100 R₀)``.
    **kwargs
        As :class:`~estimators.ekf.SlopeEKF` (initial noise, gate, μ).
    """

    def __init__(self, vehicle: VehicleParams, *, fading: float = 0.966, adapt_r: bool = True,
                 adapt_q: bool = True, adapt_means: bool = True, r_bounds: tuple[float, float] | None = None,
                 **kwargs: float) -> None:
        if not (0.0 < fading < 1.0):
            raise ValueError(f"fading must be in (0, 1), got {fading!r}")
        self.b = float(fading)
        self.adapt_r = bool(adapt_r)
        self.adapt_q = bool(adapt_q)
        self.adapt_means = bool(adapt_means)
        super().__init__(vehicle, **kwargs)
        lo, hi = (0.1 * self.R0, 100.0 * self.R0) if r_bounds is None else r_bounds
        if not (0.0 < lo < hi < math.inf):
            raise ValueError(f"r_bounds must be 0 < low < high < inf, got {r_bounds!r}")
        self.r_min, self.r_max = float(lo), float(hi)
        # bounds of Q̂ (per 5 ms step) and of the noise means q̂ (per step: 0.05 m/s^2 speed drift, 0.5 deg/s slope)
        self.q_floor = (0.01 * self.acc_var * 0.005**2, 0.01 * self.grade_var_rate * 0.005)
        self.q_ceil = (100.0 * self.acc_var * 0.005**2, 100.0 * self.grade_var_rate * 0.005)
        self.q_mean_lim = (0.05 * 0.005, math.radians(0.5) * 0.005)

    def reset(self) -> None:
        super().reset()
        self.k = 0
        self.bk = 1.0  # b**k, kept incrementally (no pow per sample)
        self.r_mean = 0.0
        self.q_mean_v = 0.0
        self.q_mean_th = 0.0
        # Q̂ as three numbers (per step); starts at the fixed-noise values of a nominal 5 ms step
        self.Q11 = self.acc_var * 0.005**2
        self.Q12 = 0.0
        self.Q22 = self.grade_var_rate * 0.005
        self._f12 = 0.0
        self._x_pred = (0.0, 0.0)
        self._P_prev = (self.P11, self.P12, self.P22)

    def predict(self, torque_nm: float, mass_kg: float, dt_s: float) -> None:
        self._P_prev = (self.P11, self.P12, self.P22)
        SlopeEKF.predict(self, torque_nm, mass_kg, dt_s)
        if self.v != self.v:
            return
        if self.adapt_q:
            # replace the fixed Q that SlopeEKF added by the adaptive Q̂ (and add the mean q̂)
            self.P11 += self.Q11 - self.acc_var * dt_s * dt_s
            self.P12 += self.Q12
            self.P22 += (self.Q22 - self.grade_var_rate * dt_s) if self.moving else 0.0
            if self.adapt_means and self.moving:
                self.v += self.q_mean_v
                self.th += self.q_mean_th
        self._x_pred = (self.v, self.th)

    def update(self, speed_mps: float) -> float:
        if speed_mps != speed_mps or self.v != self.v:
            return SlopeEKF.update(self, speed_mps)
        r_mean = self.r_mean if self.adapt_means else 0.0
        innov = speed_mps - self.v  # z − H x⁻
        eps = innov - r_mean
        P11m = self.P11
        S = P11m + self.R
        if eps * eps > self.gate2 * S:
            return SlopeEKF.update(self, speed_mps - r_mean)  # gate / relock logic of the base class
        self.rejected = 0
        k = self.k + 1
        self.k = k
        self.bk *= self.b
        d = (1.0 - self.b) / (1.0 - self.bk * self.b)
        if self.adapt_r:
            R = (1.0 - d) * self.R + d * (eps * eps - P11m)
            if R <= self.r_min:
                R = (1.0 - d) * self.R + d * eps * eps  # biased form, always positive
            self.R = min(max(R, self.r_min), self.r_max)
        if self.adapt_means:
            rm = (1.0 - d) * self.r_mean + d * innov
            lim = 3.0 * math.sqrt(self.R0)
            self.r_mean = min(max(rm, -lim), lim)
        S = P11m + self.R
        k1 = P11m / S
        k2 = self.P12 / S
        self._correct(eps, S, self.R)
        if self.adapt_q:
            P11o, P12o, P22o = self._P_prev
            f12 = self._f12
            # F P_{k-1} Fᵀ
            fp11 = P11o + 2.0 * f12 * P12o + f12 * f12 * P22o
            fp12 = P12o + f12 * P22o
            fp22 = P22o
            e2 = eps * eps
            Q11 = (1.0 - d) * self.Q11 + d * (k1 * k1 * e2 + self.P11 - fp11)
            Q12 = (1.0 - d) * self.Q12 + d * (k1 * k2 * e2 + self.P12 - fp12)
            Q22 = (1.0 - d) * self.Q22 + d * (k2 * k2 * e2 + self.P22 - fp22)
            self.Q11, self.Q12, self.Q22 = repair_pd_2x2(Q11, Q12, Q22, *self.q_floor, *self.q_ceil)
            if self.adapt_means:
                # x̂_k − f(x̂_{k−1}) = correction + the q̂ already added in predict
                qv = (1.0 - d) * self.q_mean_v + d * (self.v - (self._x_pred[0] - self.q_mean_v))
                qt = (1.0 - d) * self.q_mean_th + d * (self.th - (self._x_pred[1] - self.q_mean_th))
                lim_v, lim_t = self.q_mean_lim
                self.q_mean_v = min(max(qv, -lim_v), lim_v)
                self.q_mean_th = min(max(qt, -lim_t), lim_t)
        return eps
