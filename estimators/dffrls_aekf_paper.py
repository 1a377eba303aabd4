"""``dffrls-aekf-paper``: paper 000's two-layer method with its equations as printed (spec §5.1, §5.3, §5.4).

This is the reference for what the paper's method does on our data, not a method to use: the project's variant is
``dffrls-aekf`` (:mod:`estimators.dffrls_aekf`), and ``docs/estimators.md`` lists every deviation with its measured
effect. Only the typos the spec settles are settled here; nothing else is improved.

**Mass layer, DFFRLS (eqs. 16-22)**::

    y = a,   φ = [T/r − m_rot a,  −g √(1 + μ²)]ᵀ,   χ = [1/M,  sin(θ + θ_μ)]ᵀ,   tan θ_μ = μ
    e_k = y_k − φ_kᵀ χ_{k−1},   λ_k = δ + (1 − δ) exp(−σ |e_k|)
    K_k = P_{k−1} φ_k / (λ_k + φ_kᵀ P_{k−1} φ_k),   χ_k = χ_{k−1} + K_k e_k,   P_k = (I − K_k φ_kᵀ) P_{k−1} / λ_k

``a`` is the accelerometer column, fed in as if it were dv/dt (what the paper does, and the error spec §4 marks:
a real accelerometer measures ``dv/dt + g sin θ``; kept, because it is the paper's). One λ for both parameters, no
normalisation of 1/M ≈ 4e-5 against sin θ ≈ 0.1, no low-pass, no excitation gate: as printed.
*Settled typo*: eqs. 21-22 use λ(k−1) where eq. 19 computes λ(k+1); here λ_k from the current residual is used
in the same update (spec §5.1).

**Slope layer, Sage-Husa AEKF (eqs. 23-30)** on ``x = [v, θ]``, small-angle model, forward Euler, speed
measured (``H = [1, 0]``), with the DFFRLS mass at every step::

    v_k = v_{k−1} + Δt (T_{k−1} / (r M̂ γ) − μ g / γ − g θ_{k−1} / γ),   θ_k = θ_{k−1},   γ = 1 + m_rot / M̂
    d_k = (1 − b) / (1 − b^{k+1}),  b = 0.966,  k = 0, 1, ...  (so d_0 = 1, as printed)
    noise means q̂, r̂ and covariances Q̂, R̂ adapted by the standard recursions of spec §5.3

*Settled typos*: eq. 30's θ in place of x and its signs (the standard form; R̂ uses the prior covariance).

**Guards, not improvements** (the project's rules: no NaN out, covariances symmetric PD, no hang; spec §5.3
names the R̂ fallback as the standard remedy): a non-positive R̂ falls back to the biased form ``(1 − d) R̂ + d ε²``;
Q̂ and P are repaired to symmetric PD (:func:`~estimators.filters.repair_pd_2x2`); the covariance update is
written in Joseph form (equal to the printed ``(I − K H) P`` for the optimal gain); inputs that are not finite
or beyond any physical value (|T| > 10× the maximum drive torque, |v| > 50 m/s, |a| > 50 m/s²) count as missing;
``dt`` NaN/zero/negative ignores the sample and a ``dt`` above :data:`~estimators.filters.MAX_STEP_S` is cut to
it; the reported mass ``1/χ₁`` (which can be negative or infinite) is clipped to the vehicle's mass range, and the
slope layer uses that reported mass; the reported slope is clipped to ±45°; a layer whose state still became non-finite
restarts from its prior.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from uuom_core.vehicle import G_MPS2, VehicleParams

from .base import Estimate, Estimator
from .filters import check_bool_option, effective_dt, kalman_update_2x2_h1, repair_pd_2x2

__all__ = ["DFFRLSAEKFPaper"]

_SLOPE_OUT = math.pi / 4.0
"""The reported slope is clipped to ±45° (a guard: the printed filter's θ is unbounded)."""


class DFFRLSAEKFPaper(Estimator):
    """``dffrls-aekf-paper``: DFFRLS mass → Sage-Husa AEKF slope, paper 000 as printed (module docstring).

    Parameters
    ----------
    vehicle : VehicleParams, optional
    delta : float
        δ of the dynamic forgetting factor, in [0.5, 1) (paper: "slightly below 1"; 0.95).
    sigma : float
        σ of the dynamic forgetting factor, > 0 (the paper gives no value; 5 per (m/s²)).
    fading : float
        Sage-Husa fading factor b in (0, 1) (paper: 0.966).
    adapt_means : bool
        Estimate the noise means q̂, r̂ (True: as printed). On our data the speed-noise mean q̂_v settles where it
        cancels the slope (a constant speed drift and a constant grade are the same thing to this model), which
        is most of this method's slope error; False is one line of the ablation table.
    speed_std_mps, accel_model_std_mps2, grade_rate_std_rps : float
        Initial R̂₀ = speed_std², Q̂₀ = diag((accel_model_std Δt)², grade_rate_std² Δt) at Δt = 5 ms (the paper
        gives no initial values).

    Gives mass (DFFRLS) and slope (AEKF), each with a 1-sigma standard deviation from its layer's covariance.
    """

    name: ClassVar[str] = "dffrls-aekf-paper"
    provides: ClassVar[frozenset[str]] = frozenset({"mass", "slope"})

    def __init__(self, vehicle: VehicleParams | None = None, *, delta: float = 0.95, sigma: float = 5.0,
                 fading: float = 0.966, speed_std_mps: float = 0.01, accel_model_std_mps2: float = 0.3,
                 grade_rate_std_rps: float = 0.01, adapt_means: bool = True,
                 **options: Any) -> None:
        super().__init__(vehicle, **options)
        for key, value in (("sigma", sigma), ("speed_std_mps", speed_std_mps),
                           ("accel_model_std_mps2", accel_model_std_mps2), ("grade_rate_std_rps", grade_rate_std_rps)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not (0.0 < value < math.inf):
                raise ValueError(f"dffrls-aekf-paper: {key} must be a finite number > 0, got {value!r}")
        if not (isinstance(delta, (int, float)) and 0.5 <= delta < 1.0):
            raise ValueError(f"dffrls-aekf-paper: delta must be in [0.5, 1), got {delta!r}")
        if not (isinstance(fading, (int, float)) and 0.0 < fading < 1.0):
            raise ValueError(f"dffrls-aekf-paper: fading must be in (0, 1), got {fading!r}")
        check_bool_option("dffrls-aekf-paper: adapt_means", adapt_means, ValueError)
        v = self.vehicle
        self.delta, self.sigma, self.b = float(delta), float(sigma), float(fading)
        self.adapt_means = bool(adapt_means)
        self.r = v.drive_wheel_radius_m
        self.m_rot = v.rotating_mass_kg
        self.mu = v.running_resistance
        self.theta_mu = math.atan(self.mu)
        self.phi2 = -G_MPS2 * math.sqrt(1.0 + self.mu * self.mu)
        self.m_min, self.m_max = v.empty_mass_kg, v.max_mass_kg
        m0 = v.empty_mass_kg + 0.5 * v.rated_load_kg
        self.m0 = m0
        # P0 on each parameter's own scale (the paper gives none): half the mass range in 1/M, 0.1 in sin
        self.P0 = ((0.5 * (1.0 / self.m_min - 1.0 / self.m_max)) ** 2, 0.1**2)
        self.R0 = float(speed_std_mps) ** 2
        self.Q0 = ((float(accel_model_std_mps2) * 0.005) ** 2, float(grade_rate_std_rps) ** 2 * 0.005)
        self.P0_th = 0.1**2
        self.max_torque = 10.0 * v.max_traction_n * self.r
        self.reset()

    def reset(self) -> None:
        self.chi1 = 1.0 / self.m0
        self.chi2 = math.sin(self.theta_mu)
        self.C11, self.C12, self.C22 = self.P0[0], 0.0, self.P0[1]
        self.lam = 0.98  # paper: initial value of the forgetting factor (reported before the first update)
        self._reset_slope()

    def _reset_slope(self) -> None:
        self.v = math.nan
        self.th = 0.0
        self.P11, self.P12, self.P22 = self.R0, 0.0, self.P0_th
        self.Q11, self.Q12, self.Q22 = self.Q0[0], 0.0, self.Q0[1]
        self.R = self.R0
        self.q_v = self.q_th = self.r_mean = 0.0
        self.k = 0
        self.bk1 = self.b  # b**(k+1)
        self.torque = 0.0

    # mass layer --------------------------------------------------------------------------------------------------
    @property
    def mass_kg(self) -> float:
        return self.mass_from_chi1(self.chi1)

    def mass_from_chi1(self, chi1: float) -> float:
        """The reported mass for the parameter ``chi1 = 1/M``: ``1/chi1`` clipped to the vehicle's mass range (a guard:
        ``chi1`` can be zero or negative)."""
        return self.m_max if not (chi1 > 1.0 / self.m_max) else (self.m_min if chi1 > 1.0 / self.m_min else 1.0 / chi1)

    def plausible_inputs(self, torque_nm: float, speed_mps: float, accel_mps2: float) -> tuple[float, float, float]:
        """The inputs as floats, each beyond any physical value (|T| > 10x the maximum drive torque, |v| > 50 m/s,
        |a| > 50 m/s²) replaced by NaN, i.e. counted as missing (a guard)."""
        T, z, a = float(torque_nm), float(speed_mps), float(accel_mps2)
        return (T if abs(T) <= self.max_torque else math.nan, z if abs(z) <= 50.0 else math.nan,
                a if abs(a) <= 50.0 else math.nan)

    def _dffrls(self, T: float, a: float) -> None:
        f1 = T / self.r - self.m_rot * a
        f2 = self.phi2
        c1, c2 = self.chi1, self.chi2
        e = a - f1 * c1 - f2 * c2
        lam = self.delta + (1.0 - self.delta) * math.exp(-self.sigma * abs(e))
        C11, C12, C22 = self.C11, self.C12, self.C22
        p1 = C11 * f1 + C12 * f2
        p2 = C12 * f1 + C22 * f2
        s = lam + f1 * p1 + f2 * p2
        k1, k2 = p1 / s, p2 / s
        c1 += k1 * e
        c2 += k2 * e
        C11, C12, C22 = repair_pd_2x2((C11 - k1 * p1) / lam, (C12 - k1 * p2) / lam, (C22 - k2 * p2) / lam,
                                      1e-30, 1e-30, 1e30, 1e30)
        if math.isfinite(c1) and math.isfinite(c2):
            self.chi1, self.chi2 = c1, c2
            self.C11, self.C12, self.C22 = C11, C12, C22
            self.lam = lam
        else:  # guard: restart the layer from its prior
            self.chi1, self.chi2 = 1.0 / self.m0, math.sin(self.theta_mu)
            self.C11, self.C12, self.C22 = self.P0[0], 0.0, self.P0[1]

    # slope layer -------------------------------------------------------------------------------------------------
    def _aekf(self, z: float, dt: float, mass: float) -> None:
        if self.v != self.v:
            if z == z:
                self.v = z
            return
        gamma = 1.0 + self.m_rot / mass
        g = G_MPS2
        f12 = -dt * g / gamma
        P11o, P12o, P22o = self.P11, self.P12, self.P22
        # prediction f(x) + q̂ (eq. 24 with the torque of the previous interval)
        fv = self.v + dt * (self.torque / (self.r * mass * gamma) - self.mu * g / gamma - g * self.th / gamma)
        fth = self.th
        v_p, th_p = fv + self.q_v, fth + self.q_th
        p11 = P11o + 2.0 * f12 * P12o + f12 * f12 * P22o + self.Q11
        p12 = P12o + f12 * P22o + self.Q12
        p22 = P22o + self.Q22
        if z == z:
            d = (1.0 - self.b) / (1.0 - self.bk1)  # d_k, k = 0, 1, ... as printed
            self.k += 1
            self.bk1 *= self.b
            innov = z - v_p
            eps = innov - self.r_mean
            r_new = (1.0 - d) * self.R + d * (eps * eps - p11)
            if not (r_new > 0.0):  # guard (spec §5.3): the biased, always positive form
                r_new = (1.0 - d) * self.R + d * eps * eps
            self.R = max(r_new, 1e-12)
            if self.adapt_means:
                self.r_mean = (1.0 - d) * self.r_mean + d * innov
            dv, dth, n11, n12, n22 = kalman_update_2x2_h1(p11, p12, p22, eps, self.R)
            k1, k2 = p11 / (p11 + self.R), p12 / (p11 + self.R)
            v_n, th_n = v_p + dv, th_p + dth
            n11, n12, n22 = repair_pd_2x2(n11, n12, n22, 1e-14, 1e-14)
            # Q̂ = (1-d) Q̂ + d (K ε εᵀ Kᵀ + P_k − F P_{k−1} Fᵀ); q̂ = (1-d) q̂ + d (x̂_k − f(x̂_{k−1}))
            fp11 = P11o + 2.0 * f12 * P12o + f12 * f12 * P22o
            fp12 = P12o + f12 * P22o
            e2 = eps * eps
            self.Q11, self.Q12, self.Q22 = repair_pd_2x2(
                (1.0 - d) * self.Q11 + d * (k1 * k1 * e2 + n11 - fp11),
                (1.0 - d) * self.Q12 + d * (k1 * k2 * e2 + n12 - fp12),
                (1.0 - d) * self.Q22 + d * (k2 * k2 * e2 + n22 - P22o), 1e-14, 1e-14, 1.0, 1.0)
            if self.adapt_means:
                self.q_v = (1.0 - d) * self.q_v + d * (v_n - fv)
                self.q_th = (1.0 - d) * self.q_th + d * (th_n - fth)
            v_p, th_p, p11, p12, p22 = v_n, th_n, n11, n12, n22
        else:
            p11, p12, p22 = repair_pd_2x2(p11, p12, p22, 1e-14, 1e-14)
        if all(math.isfinite(x) for x in (v_p, th_p, self.R, self.q_v, self.q_th, self.r_mean)) and abs(v_p) < 1e6:
            self.v, self.th = v_p, th_p
            self.P11, self.P12, self.P22 = p11, p12, min(p22, 1e6)
        else:  # guard: restart the layer from its prior
            self._reset_slope()

    # Estimator interface ------------------------------------------------------------------------------------------
    def update(self, torque_nm: float, speed_mps: float, accel_mps2: float, dt_s: float,
               motor_speed_radps: float = math.nan, gyro_radps: float = math.nan,
               accel_normal_mps2: float = math.nan) -> Estimate:
        dt = effective_dt(dt_s)
        if dt == 0.0:
            return self.estimate
        T, z, a = self.plausible_inputs(torque_nm, speed_mps, accel_mps2)
        if T == T and a == a:
            self._dffrls(T, a)
        self._aekf(z, dt, self.mass_kg)
        if T == T:
            self.torque = T  # T_{k-1} of the next prediction
        return self.estimate

    @property
    def estimate(self) -> Estimate:
        m = self.mass_kg
        # σ of 1/χ₁ propagated to M (first order), bounded by the mass range
        m_std = min(m * m * math.sqrt(self.C11), self.m_max - self.m_min)
        th = min(max(self.th, -_SLOPE_OUT), _SLOPE_OUT)
        return Estimate(m, th, m_std, math.sqrt(self.P22))

