"""The paper-000 baseline two-layer estimator (§3.3, Fig. 4 with the baselines' layers): a recursive-least-squares
layer for the mass feeding an extended Kalman filter for the slope.

- ``rls-ekf`` (:class:`RLSEKF`): RLS (λ = 1) mass → fixed-noise EKF slope (paper baseline).

The paper's own two-layer method is ``dffrls-aekf-paper`` (:mod:`estimators.dffrls_aekf_paper`, as printed) and
``dffrls-aekf`` (:mod:`estimators.dffrls_aekf`, the project's variant). ``rls-ekf`` reports the mass of the RLS
layer and the slope of the EKF layer, with their 1-sigma standard deviations.

Accelerometer: like the paper, it does not use the accelerometer column; the RLS layer uses the low-passed derivative
of the measured ground speed as the acceleration ``dv/dt`` and the EKF layer measures speed only (see
:mod:`estimators.rls` and :mod:`estimators.ekf`). The estimator that does use the accelerometer (specific force)
is ``sf-kf`` (:mod:`estimators.specific_force`).

Options are routed by prefix: ``mass_<option>`` goes to the RLS layer, ``slope_<option>`` to the EKF layer
(e.g. ``make("rls-ekf", mass_cutoff_hz=1.0, slope_gate_sigma=5.0)``).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from uuom_core.vehicle import VehicleParams

from .base import Estimate, Estimator
from .ekf import SlopeEKF
from .filters import capped_dt
from .rls import RLSMassEstimator, _RLSMassBase

__all__ = ["RLSEKF"]


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
        dt_s = capped_dt(dt_s)  # a data gap: integrate at most MAX_STEP_S (the front end restarts)
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
