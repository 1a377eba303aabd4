"""Extended Kalman filters on the longitudinal model: the 2-state slope EKF and the joint ``ekf`` baseline.

:class:`SlopeEKF` is the filter of paper 000 §3.2 (eqs. 23-29) with fixed noise: state ``x = [v, θ]``, the mass
given from outside (the lower layer of the two-layer estimators), speed measured. It is written on plain Python
floats (a 2x2 covariance as three numbers), which is several times faster than numpy for this size, and is
filterpy-like: :meth:`predict`, :meth:`update`, attributes ``x`` (property), ``P`` (property), ``R``, ``Q``.

:class:`JointEKF` (registry name ``ekf``) is the paper's EKF baseline: joint state ``[v, θ, M_ref/M]`` with fixed
noise, one filter for mass and slope.

Model (spec §2), with the exact trigonometry (the paper linearises sin θ ≈ θ, cos θ ≈ 1 before discretising;
keeping sin/cos costs nothing and removes a 1 % slope bias at 15°)::

    v_k = v_{k-1} + Δt (F/M − g (sin θ + μ cos θ)) / γ,   γ = 1 + m_rot/M,   F = T/r
    θ_k = θ_{k-1} (+ random walk)

Neither filter uses the accelerometer column: the paper's model has speed as the only measurement.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

import numpy as np

from uuom_core.vehicle import G_MPS2, VehicleParams

from .base import Estimate, Estimator, reference_and_prior_mass
from .filters import (SpikeGate, capped_dt, check_positive, joseph_update, kalman_update_2x2_h1, repair_pd,
                      repair_pd_2x2)

__all__ = ["SlopeEKF", "JointEKF"]


class SlopeEKF:
    """2-state ``[v, θ]`` EKF for the slope given the mass, fixed noise, Joseph-form update.

    Parameters
    ----------
    vehicle : VehicleParams
    speed_std_mps : float
        Speed measurement noise (1 sigma) R = speed_std².
    accel_model_std_mps2 : float
        Process noise on the speed equation (model error, torque noise), per step ``(std · Δt)²``.
    grade_rate_std_rps : float
        Random-walk intensity of the slope: variance ``grade_rate_std² · Δt`` added per step.
    gate_sigma : float
        Innovations beyond this many standard deviations are rejected (spikes); after ``relock_after``
        consecutive rejections the filter resets its speed state to the measurement and accepts again.
    running_resistance : float, optional
        μ of the model (default: the vehicle's nominal value).
    max_slope_rad : float, optional
        Clamp of the slope state (default: vehicle max grade + 5°).
    """

    def __init__(self, vehicle: VehicleParams, *, speed_std_mps: float = 0.01, accel_model_std_mps2: float = 0.3,
                 grade_rate_std_rps: float = 0.01, prior_slope_std_rad: float = 0.1, gate_sigma: float = 6.0,
                 relock_after: int = 40, running_resistance: float | None = None,
                 max_slope_rad: float | None = None) -> None:
        check_positive(speed_std_mps=speed_std_mps, accel_model_std_mps2=accel_model_std_mps2,
                       grade_rate_std_rps=grade_rate_std_rps, prior_slope_std_rad=prior_slope_std_rad,
                       gate_sigma=gate_sigma)
        self.r = vehicle.drive_wheel_radius_m
        self.m_rot = vehicle.rotating_mass_kg
        self.mu = float(vehicle.running_resistance if running_resistance is None else running_resistance)
        if not (0.0 <= self.mu < 1.0):
            raise ValueError(f"running_resistance must be in [0, 1), got {self.mu!r}")
        self.R0 = float(speed_std_mps) ** 2
        self.acc_var = float(accel_model_std_mps2) ** 2
        self.grade_var_rate = float(grade_rate_std_rps) ** 2
        self.P0_22 = float(prior_slope_std_rad) ** 2
        self.gate2 = float(gate_sigma) ** 2
        self.relock_after = int(relock_after)
        self.max_slope = (math.radians(vehicle.max_grade_deg + 5.0) if max_slope_rad is None
                          else float(max_slope_rad))
        max_torque = vehicle.max_traction_n * self.r
        self.gate_torque = SpikeGate(max_rate=50.0 * max_torque, noise_band=0.5 * max_torque,
                                     max_abs=3.0 * max_torque)
        self.reset()

    def reset(self) -> None:
        self.v = math.nan  # set from the first valid speed
        self.th = 0.0
        self.P11 = self.R0
        self.P12 = 0.0
        self.P22 = self.P0_22
        self.R = self.R0
        self.force = 0.0
        self.rejected = 0
        self.n_rejected = 0
        self.moving = False
        self.gate_torque.reset()

    # filterpy-like views -------------------------------------------------------------------------------------
    @property
    def x(self) -> np.ndarray:
        return np.array([0.0 if self.v != self.v else self.v, self.th])

    @property
    def P(self) -> np.ndarray:
        return np.array([[self.P11, self.P12], [self.P12, self.P22]])

    # filter --------------------------------------------------------------------------------------------------
    def predict(self, torque_nm: float, mass_kg: float, dt_s: float) -> None:
        """Propagate over ``dt_s`` with the drive torque of the previous interval and the mass estimate."""
        # v_k is propagated with T_{k-1} (paper eq. 24); the new torque is stored for the next step
        force = self.force
        T = self.gate_torque(torque_nm, dt_s)
        if T == T:
            self.force = T / self.r
        v = self.v
        if v != v:
            return
        th = self.th
        g_over = G_MPS2 / (1.0 + self.m_rot / mass_kg)
        s = math.sin(th)
        c = math.cos(th)
        acc = force / (mass_kg + self.m_rot) - g_over * (s + self.mu * c)
        # the train does not roll back at standstill under static friction / brakes (model invalid there)
        self.moving = v > 0.02 or acc > 0.0
        if self.moving:
            self.v = v + dt_s * acc
            f12 = -dt_s * g_over * (c - self.mu * s)
        else:
            f12 = 0.0
        self._f12 = f12  # kept for the adaptive subclass (F P Fᵀ in the Sage-Husa Q̂ recursion)
        P11, P12, P22 = self.P11, self.P12, self.P22
        q11 = self.acc_var * dt_s * dt_s
        # grade only drifts while moving (it is a function of position): no wind-up at standstill
        q22 = self.grade_var_rate * dt_s if self.moving else 0.0
        self.P11 = P11 + 2.0 * f12 * P12 + f12 * f12 * P22 + q11
        self.P12 = P12 + f12 * P22
        self.P22 = min(P22 + q22, self.P0_22)

    def update(self, speed_mps: float) -> float:
        """Correct with a speed measurement (NaN or ±inf: no correction). Returns the innovation (0.0 when none)."""
        if not (abs(speed_mps) < math.inf):  # NaN fails the comparison too; an infinite speed is no measurement
            return 0.0
        if self.v != self.v:
            self.v = speed_mps
            return 0.0
        eps = speed_mps - self.v
        S = self.P11 + self.R
        if eps * eps > self.gate2 * S:
            self.rejected += 1
            self.n_rejected += 1
            if self.rejected <= self.relock_after:
                return 0.0
            # a persistent "outlier" is the truth: restart the speed state there
            self.v = speed_mps
            self.P11 = max(self.P11, self.R)
            self.rejected = 0
            return 0.0
        self.rejected = 0
        self._correct(eps, S, self.R)
        return eps

    def _correct(self, eps: float, S: float, R: float) -> None:
        dv, dth, n11, n12, n22 = kalman_update_2x2_h1(self.P11, self.P12, self.P22, eps, R)
        self.v += dv
        th = self.th + dth
        ms = self.max_slope
        self.th = ms if th > ms else (-ms if th < -ms else th)
        self.P11, self.P12, self.P22 = repair_pd_2x2(n11, n12, n22, 1e-14, 1e-14)

    @property
    def slope_std_rad(self) -> float:
        return math.sqrt(self.P22)


class JointEKF(Estimator):
    """``ekf``: the paper's EKF baseline, joint state ``[v, θ, c]`` with ``c = M_ref / M``, fixed noise.

    Gives mass and slope from one filter whose only measurement is the ground speed (the accelerometer column is
    not used; see module docstring). Mass is observable only through accelerations; at constant speed the filter
    cannot tell a heavier train from a steeper grade, and its fixed noise cannot follow changing conditions
    (the paper's criticism). Joseph-form update, covariance repaired to symmetric PD, mass clamped to
    ``[empty, max]``, innovation gate against spikes, NaN speed = predict only.

    Parameters
    ----------
    vehicle : VehicleParams, optional
    speed_std_mps, accel_model_std_mps2, grade_rate_std_rps : float
        Fixed noise, as :class:`SlopeEKF`.
    mass_rate_std : float
        Random walk of ``c`` per sqrt(s) (small: mass is constant during a run).
    prior_mass_kg : float, optional
        Initial mass (default mid-range), prior std half the range.
    """

    name: ClassVar[str] = "ekf"
    provides: ClassVar[frozenset[str]] = frozenset({"mass", "slope"})

    def __init__(self, vehicle: VehicleParams | None = None, *, speed_std_mps: float = 0.01,
                 accel_model_std_mps2: float = 0.3, grade_rate_std_rps: float = 0.01, mass_rate_std: float = 1e-3,
                 prior_mass_kg: float | None = None, gate_sigma: float = 6.0, **options: Any) -> None:
        super().__init__(vehicle, **options)
        v = self.vehicle
        check_positive(speed_std_mps=speed_std_mps, accel_model_std_mps2=accel_model_std_mps2,
                       grade_rate_std_rps=grade_rate_std_rps, mass_rate_std=mass_rate_std, gate_sigma=gate_sigma)
        self.r = v.drive_wheel_radius_m
        self.m_rot = v.rotating_mass_kg
        self.mu = v.running_resistance
        self.m_ref, self.prior_mass = reference_and_prior_mass(v, prior_mass_kg)
        self.c_min = self.m_ref / v.max_mass_kg
        self.c_max = self.m_ref / v.empty_mass_kg
        self.R = float(speed_std_mps) ** 2
        self.acc_var = float(accel_model_std_mps2) ** 2
        self.grade_var = float(grade_rate_std_rps) ** 2
        self.c_var = float(mass_rate_std) ** 2
        self.gate2 = float(gate_sigma) ** 2
        self.max_slope = math.radians(v.max_grade_deg + 5.0)
        c0 = self.m_ref / self.prior_mass
        self.P0 = np.diag([self.R, 0.1**2, (c0 * 0.5 * (v.max_mass_kg - v.empty_mass_kg) / self.prior_mass) ** 2])
        max_torque = v.max_traction_n * self.r
        self.gate_torque = SpikeGate(max_rate=50.0 * max_torque, noise_band=0.5 * max_torque, max_abs=3.0 * max_torque)
        self.H = np.array([[1.0, 0.0, 0.0]])
        self.reset()

    def reset(self) -> None:
        self.x = np.array([math.nan, 0.0, self.m_ref / self.prior_mass])
        self.P = self.P0.copy()
        self.force = 0.0
        self.rejected = 0
        self.gate_torque.reset()

    def update(self, torque_nm: float, speed_mps: float, accel_mps2: float, dt_s: float,
               motor_speed_radps: float = math.nan, gyro_radps: float = math.nan,
               accel_normal_mps2: float = math.nan) -> Estimate:
        dt_s = capped_dt(dt_s)  # a data gap: integrate at most MAX_STEP_S (the front end restarts)
        T = self.gate_torque(torque_nm, dt_s)
        if T == T:
            self.force = T / self.r
        x = self.x
        if x[0] != x[0]:
            if abs(speed_mps) < math.inf:
                x[0] = speed_mps
            return self.estimate
        v, th, c = float(x[0]), float(x[1]), float(x[2])
        mr = self.m_ref
        D = 1.0 + self.m_rot * c / mr
        s, co = math.sin(th), math.cos(th)
        num = self.force * c / mr - G_MPS2 * (s + self.mu * co)
        acc = num / D
        moving = v > 0.02 or acc > 0.0
        F = np.eye(3)
        if moving:
            x[0] = v + dt_s * acc
            F[0, 1] = -dt_s * G_MPS2 * (co - self.mu * s) / D
            F[0, 2] = dt_s * ((self.force / mr) / D - num * (self.m_rot / mr) / (D * D))
        Q = np.diag([self.acc_var * dt_s * dt_s, self.grade_var * dt_s if moving else 0.0,
                     self.c_var * dt_s if moving else 0.0])
        P = F @ self.P @ F.T + Q
        if abs(speed_mps) < math.inf:
            eps = speed_mps - x[0]
            S = P[0, 0] + self.R
            if abs(eps) <= math.sqrt(self.gate2 * S) or self.rejected >= 40:  # no overflow for eps ~ 1e300
                if self.rejected >= 40:
                    x[0] = speed_mps
                    eps = 0.0
                self.rejected = 0
                K = P[:, :1] / S
                x += K[:, 0] * eps
                P = joseph_update(P, K, self.H, np.array([[self.R]]))
            else:
                self.rejected += 1
        x[1] = min(max(x[1], -self.max_slope), self.max_slope)
        x[2] = min(max(x[2], self.c_min), self.c_max)
        if not np.all(np.isfinite(x)):
            self.reset()
        self.P = repair_pd(P, 1e-14, 1e6)
        return self.estimate

    @property
    def estimate(self) -> Estimate:
        c = float(self.x[2])
        mass = self.m_ref / c
        mass_std = mass / c * math.sqrt(float(self.P[2, 2]))
        return Estimate(mass, float(self.x[1]), mass_std, math.sqrt(float(self.P[1, 1])))
