"""The two-layer estimators of paper 000 §3.3 (Fig. 4): a recursive-least-squares layer for the mass feeding
an extended Kalman filter for the slope.

- ``dffrls-aekf`` (:class:`DFFRLSAEKF`): DFFRLS mass (:class:`~estimators.rls.DFFRLSMassEstimator`) → Sage-Husa
  AEKF slope (:class:`~estimators.aekf.SageHusaAEKF`). The paper's method and the environment's default
  observation layer.
- ``rls-ekf`` (:class:`RLSEKF`): RLS (λ = 1) mass → fixed-noise EKF slope (paper baseline).

Both report the mass of the RLS layer and the slope of the EKF layer, with their 1-sigma standard deviations.
Accelerometer: like the paper, neither uses the accelerometer column; the RLS layer uses the low-passed derivative
of the measured ground speed as the acceleration ``dv/dt`` and the EKF layer measures speed only (see
:mod:`estimators.rls` and :mod:`estimators.ekf`). The estimator that does use the accelerometer (specific force)
is ``sf-kf`` (:mod:`estimators.specific_force`).

Options are routed by prefix: ``mass_<option>`` goes to the RLS layer, ``slope_<option>`` to the EKF layer
(e.g. ``make("dffrls-aekf", mass_delta=0.97, slope_fading=0.95)``).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from uuom_core.vehicle import VehicleParams

from .aekf import SageHusaAEKF
from .base import Estimate, Estimator
from .ekf import SlopeEKF
from .filters import check_dt
from .rls import DFFRLSMassEstimator, RLSMassEstimator, _RLSMassBase

__all__ = ["RLSEKF", "DFFRLSAEKF"]


def _split_options(options: dict[str, Any]) -> tuple[dict[str, Any], dict[str, Any], dict[str, Any]]:
    mass = {k[5:]: v for k, v in options.items() if k.startswith("mass_")}
    slope = {k[6:]: v for k, v in options.items() if k.startswith("slope_")}
    rest = {k: v for k, v in options.items() if not (k.startswith("mass_") or k.startswith("slope_"))}
    return mass, slope, rest


class _TwoLayer(Estimator):
    provides: ClassVar[frozenset[str]] = frozenset({"mass", "slope"})
    _mass_cls: ClassVar[type[_RLSMassBase]]
    _slope_cls: ClassVar[type[SlopeEKF]]

    def __init__(self, vehicle: VehicleParams | None = None, **options: Any) -> None:
        mass_opts, slope_opts, rest = _split_options(options)
        super().__init__(vehicle, **rest)
        self.mass_layer = self._mass_cls(self.vehicle, **mass_opts)
        self.slope_layer = self._slope_cls(self.vehicle, **slope_opts)
        self.reset()

    def reset(self) -> None:
        self.mass_layer.reset()
        self.slope_layer.reset()

    def update(self, torque_nm: float, speed_mps: float, accel_mps2: float, dt_s: float,
               motor_speed_radps: float = math.nan, gyro_radps: float = math.nan,
               accel_normal_mps2: float = math.nan) -> Estimate:
        if not (dt_s > 0.0 and dt_s < math.inf):
            check_dt(dt_s)
        ml = self.mass_layer
        if ml.front.step(torque_nm, speed_mps, dt_s):
            ml._rls_step()
        p1 = ml.p1
        mass = ml.m_ref / p1
        sl = self.slope_layer
        sl.predict(torque_nm, mass, dt_s)
        sl.update(speed_mps)
        rv = ml.res_var / ml.R
        mass_std = mass / p1 * math.sqrt(ml.P11 * (rv if rv > 1.0 else 1.0))  # = RLS layer's mass_std_kg
        return Estimate(mass, sl.th, mass_std, math.sqrt(sl.P22))

    @property
    def estimate(self) -> Estimate:
        ml = self.mass_layer
        return Estimate(ml.mass_kg, self.slope_layer.th, ml.mass_std_kg, math.sqrt(self.slope_layer.P22))


class RLSEKF(_TwoLayer):
    """``rls-ekf``: RLS (λ = 1) mass layer → fixed-noise EKF slope layer (paper 000 baseline).

    Gives mass (RLS layer) and slope (EKF layer). Options: ``mass_*`` as
    :class:`~estimators.rls.RLSMassEstimator`, ``slope_*`` as :class:`~estimators.ekf.SlopeEKF`.
    """

    name: ClassVar[str] = "rls-ekf"
    _mass_cls = RLSMassEstimator
    _slope_cls = SlopeEKF


class DFFRLSAEKF(_TwoLayer):
    """``dffrls-aekf``: the paper's two-layer method — DFFRLS mass → Sage-Husa AEKF slope.

    Gives mass (DFFRLS layer, dynamic forgetting, vector forgetting, bounded covariance, clamped to the vehicle's
    mass range; the regression models the load swinging on its chains and corrects the mass only from samples
    with |dv/dt| >= 0.05 m/s², see :mod:`estimators.rls`) and slope (Sage-Husa AEKF, fading factor 0.966, using the DFFRLS mass at every step), each with
    its 1-sigma standard deviation. Options: ``mass_*`` as :class:`~estimators.rls.DFFRLSMassEstimator`
    (``mass_delta``, ``mass_sigma``, ``mass_vector_forgetting`` ...), ``slope_*`` as
    :class:`~estimators.aekf.SageHusaAEKF` (``slope_fading``, ``slope_adapt_q`` ...).

    The accelerometer is not used (the paper's model takes dv/dt, here the low-passed derivative of the measured
    speed); see ``sf-kf`` for the estimator that uses the specific force.
    """

    name: ClassVar[str] = "dffrls-aekf"
    _mass_cls = DFFRLSMassEstimator
    _slope_cls = SageHusaAEKF
