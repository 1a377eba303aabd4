"""``imu-ukf``: slope from the drive unit's IMU through the quaternion attitude UKF (paper 001, spec §5.7).

Per sample:

1. a two-state constant-acceleration Kalman filter on the ground-speed encoder gives the along-track motion
   acceleration ``a_lin`` and its variance (an accelerometer on a grade reads ``f = dv/dt + g sin θ``; the UKF
   needs ``dv/dt`` to see gravity alone);
2. the pitch-quaternion UKF (:class:`~estimators.imu.attitude_ukf.PitchQuaternionUKF`) predicts with the gyro and
   corrects with both accelerometer axes, the along-track residual variance widened by the variance of
   ``a_lin``;
3. slope = the UKF's pitch (the drive unit follows the track; the load's sway adds a small oscillation that the
   UKF passes through as pitch).

Mass is not observable from the IMU: the estimator reports the prior (empty mass + half the rated load) with a
standard deviation of half the rated load. To get mass, pair it with a mass estimator (e.g. ``dffrls``) and use
``MotionStateRecognizer`` to gate that one at standstill.

Missing values: NaN gyro -> the attitude is held and its covariance grows; NaN accelerometer -> no correction;
NaN speed -> the speed filter only predicts. Nothing NaN leaves :meth:`update`.
"""

from __future__ import annotations

import math
from typing import Any

from estimators.base import Estimate, Estimator
from uuom_core.vehicle import G_MPS2, VehicleParams

from ..filters import MAX_STEP_S
from ..input_limits import InputLimits, plausible
from .attitude_ukf import PitchQuaternionUKF, UKFConfigError

__all__ = ["IMUUKFEstimator", "IMU_UKF_DEFAULTS"]

IMU_UKF_DEFAULTS: dict[str, float] = {
    "gyro_noise_radps": 2e-3,
    "gyro_bias_walk_radps": 1e-4,
    "accel_noise_mps2": 0.15,
    "accel_normal_noise_mps2": 0.15,
    "speed_noise_mps": 0.01,
    "jerk_std_mps3": 0.5,
}
"""Default noise settings (hand-set; ``scripts/tune_imu_ukf.py`` tunes them, see ``docs/imu.md``)."""

_UNINIT_SLOPE_STD_RAD = math.radians(15.0)


class IMUUKFEstimator(Estimator):
    """Slope from gyro + 2-axis accelerometer (quaternion UKF); mass as a wide prior.

    Parameters
    ----------
    vehicle : VehicleParams, optional
    gyro_noise_radps, gyro_bias_walk_radps, accel_noise_mps2, accel_normal_noise_mps2 : float
        UKF noise settings (see :class:`~estimators.imu.attitude_ukf.PitchQuaternionUKF`).
    speed_noise_mps, jerk_std_mps3 : float
        Noise of the speed encoder and jerk intensity of the motion-acceleration filter.
    ukf_alpha : float
        Unscented-transform spread.

    Notes
    -----
    ``accel_mps2`` is used as the specific force ``dv/dt + g sin θ`` (spec §4); ``accel_normal_mps2`` as
    ``g cos θ`` (+g when level, at rest). ``torque_nm`` and ``motor_speed_radps`` are not used.
    """

    name = "imu-ukf"
    provides = frozenset({"slope"})

    def __init__(self, vehicle: VehicleParams | None = None, **options: Any) -> None:
        settings = dict(IMU_UKF_DEFAULTS)
        alpha = float(options.pop("ukf_alpha", 0.3))
        for key in list(options):
            if key in settings:
                settings[key] = float(options.pop(key))
        super().__init__(vehicle, **options)  # raises TypeError on unknown options
        for key in ("speed_noise_mps", "jerk_std_mps3"):
            if not (settings[key] > 0.0 and math.isfinite(settings[key])):
                raise UKFConfigError(f"{key} must be finite and > 0, got {settings[key]!r}")
        self.settings = settings
        self.ukf = PitchQuaternionUKF(
            settings["gyro_noise_radps"], settings["gyro_bias_walk_radps"], settings["accel_noise_mps2"],
            settings["accel_normal_noise_mps2"], alpha=alpha, g_mps2=G_MPS2,
        )
        veh = self.vehicle
        self._mass_prior = veh.empty_mass_kg + 0.5 * veh.rated_load_kg
        self._mass_std = 0.5 * veh.rated_load_kg
        self._limits = InputLimits.for_vehicle(veh)
        self._r_v = settings["speed_noise_mps"] ** 2
        self._q_j = settings["jerk_std_mps3"] ** 2
        self.reset()

    def reset(self) -> None:
        self.ukf.reset()
        # speed filter [v, a], covariance entries
        self._v = 0.0
        self._a = 0.0
        self._pvv, self._pva, self._paa = 1.0, 0.0, 1.0
        self._v_init = False
        self._estimate = Estimate(self._mass_prior, 0.0, self._mass_std, _UNINIT_SLOPE_STD_RAD,
                                  {"gyro_bias_radps": 0.0, "lin_accel_mps2": 0.0})

    @property
    def estimate(self) -> Estimate:
        return self._estimate

    def _speed_filter(self, speed_mps: float, dt: float) -> None:
        # predict (constant acceleration, white jerk)
        v, a = self._v + self._a * dt, self._a
        pvv, pva, paa = self._pvv, self._pva, self._paa
        q = self._q_j
        pvv = pvv + 2.0 * dt * pva + dt * dt * paa + q * dt ** 3 / 3.0
        pva = pva + dt * paa + q * dt * dt / 2.0
        paa = paa + q * dt
        if math.isfinite(speed_mps):
            if not self._v_init:
                v, pvv, pva = speed_mps, self._r_v, 0.0
                self._v_init = True
            else:
                s = pvv + self._r_v
                kv, ka = pvv / s, pva / s
                y = speed_mps - v
                v += kv * y
                a += ka * y
                pvv, pva, paa = pvv - kv * pvv, pva - kv * pva, paa - ka * pva
        self._v, self._a = v, a
        self._pvv, self._pva, self._paa = pvv, pva, max(paa, 1e-12)

    def update(self, torque_nm: float, speed_mps: float, accel_mps2: float, dt_s: float,
               motor_speed_radps: float = math.nan, gyro_radps: float = math.nan,
               accel_normal_mps2: float = math.nan) -> Estimate:
        """Process one sample (speed, both accelerometer axes and the gyro are used).

        NaN, and a value beyond :class:`~estimators.input_limits.InputLimits` (``inf``, ``1e300``), count as
        missing. A ``dt_s`` above :data:`~estimators.filters.MAX_STEP_S` is a data gap: the filters predict over
        that long. Raises ``ValueError`` for a ``dt_s`` that is not finite and > 0.
        """
        if not (dt_s > 0.0 and math.isfinite(dt_s)):
            raise ValueError(f"imu-ukf: dt_s must be finite and > 0, got {dt_s!r}")
        dt_s = min(dt_s, MAX_STEP_S)
        lim = self._limits
        speed_mps = plausible(speed_mps, lim.speed_mps)
        accel_mps2 = plausible(accel_mps2, lim.accel_mps2)
        accel_normal_mps2 = plausible(accel_normal_mps2, lim.accel_mps2)
        gyro_radps = plausible(gyro_radps, lim.gyro_radps)
        self._speed_filter(speed_mps, dt_s)
        ukf = self.ukf
        a_lin = self._a if self._v_init else 0.0
        if not ukf.initialized:
            if math.isfinite(accel_mps2):
                fx = accel_mps2 - a_lin
                if math.isfinite(accel_normal_mps2):
                    pitch0 = math.atan2(fx, accel_normal_mps2)
                else:
                    pitch0 = math.asin(max(-1.0, min(1.0, fx / G_MPS2)))
                ukf.initialize(pitch0, math.radians(3.0))
            elif math.isfinite(accel_normal_mps2):
                ukf.initialize(math.acos(max(-1.0, min(1.0, accel_normal_mps2 / G_MPS2))), math.radians(10.0))
            else:
                return self._estimate
        else:
            ukf.predict(gyro_radps, dt_s)
            scale = math.sqrt(1.0 + self._paa / ukf.accel_noise_mps2 ** 2) if self._v_init else 3.0
            ukf.update(accel_mps2, accel_normal_mps2, a_lin, scale)
        slope = ukf.pitch_rad
        slope_std = ukf.pitch_std_rad
        if not (math.isfinite(slope) and math.isfinite(slope_std) and math.isfinite(ukf.bias_radps)):
            # last line of defence (inputs are gated): restart the attitude rather than report NaN
            ukf.reset()
            slope, slope_std = 0.0, _UNINIT_SLOPE_STD_RAD
        if not math.isfinite(a_lin):
            self._v, self._a, self._v_init = 0.0, 0.0, False
            self._pvv, self._pva, self._paa = 1.0, 0.0, 1.0
            a_lin = 0.0
        self._estimate = Estimate(self._mass_prior, slope, self._mass_std, slope_std,
                                  {"gyro_bias_radps": ukf.bias_radps, "lin_accel_mps2": a_lin})
        return self._estimate
