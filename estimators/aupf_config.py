"""Tuning of the adaptive unscented particle filter (:class:`~estimators.aupf.AUPFEstimator`): a frozen dataclass."""

from __future__ import annotations

import math
from dataclasses import dataclass

from uuom_core.vehicle import VehicleParams

from .filters import check_int_option, check_number_options


class AUPFConfigError(ValueError):
    """An AUPF option that cannot work (names the option and the value)."""


@dataclass(frozen=True, slots=True)
class AUPFConfig:
    """Tuning of the AUPF. Every field is validated on construction (:class:`AUPFConfigError` names it).

    Parameters
    ----------
    n_particles : int, default 64
        Number of particles (each runs its own adaptive UKF for its proposal), >= 2.
    seed : int, default 0
        Seed of the filter's own random generator (sampling, regime draws, resampling).
    gear_ratio : float, default 1.0
        ``motor_speed_radps / drive-wheel angular speed``.
    initial_radius_std_m : float, default 0.005
        Prior standard deviation of the radius around the nominal (unworn) one.
    radius_process_std_m_per_sqrt_s : float, default 1e-5
        Random-walk intensity of the radius (wear is slow).
    slip_process_std : float, default 0.03
        Slip process noise per sqrt(second) while adhering.
    macro_slip_process_std : float, default 1.0
        Slip process noise per sqrt(second) in macro-slip.
    slip_time_constant_s : float, default 0.3
        Relaxation time of the slip to the creep curve while adhering.
    creep_slip : float, default 0.005
        ``i_c`` of the creep curve.
    adhesion : float, optional
        ``mu_a`` of the creep curve; default the vehicle's dry-rail adhesion.
    slip_onset_rate_hz, spontaneous_slip_rate_hz, slip_recovery_rate_hz : float, default 2.0, 0.01, 1.0
        Regime-switch rates (see :mod:`estimators.aupf`); the first two may be 0.
    max_slip : float, default 0.99
        Bound of the slip ratio, in (0, 1).
    speed_std_mps : float, default 0.02
        Initial ground-speed noise (adapted online).
    motor_speed_std_radps : float, default 0.05
        Drive-wheel speed noise, folded into the initial measurement noise.
    noise_fading : float, default 0.995
        Sage-Husa fading factor ``b``, in (0, 1).
    alpha, beta : float, default 1.0, 2.0
        Unscented-transform parameters (paper 004: ``1e-4 <= alpha <= 1``, ``beta = 2``; ``beta >= 0``).
    resample_ess_fraction : float, default 0.5
        Resample when ESS < this fraction of ``n_particles``, in (0, 1].
    min_speed_mps : float, default 0.05
        Below this ground speed the filter does not weight particles.
    underflow_log_likelihood : float, default -30.0
        Weight-underflow threshold of the best particle's log-likelihood, < 0.
    radius_model_std_m : float, optional
        Added (in quadrature) to the reported radius standard deviation: the filter's own variance only knows the
        sensor noise, but a creep slip that differs from the model's is indistinguishable from wear. Default
        ``0.5 * creep_slip * r_nominal`` (0.43 mm).
    """

    n_particles: int = 64
    seed: int = 0
    gear_ratio: float = 1.0
    initial_radius_std_m: float = 0.005
    radius_process_std_m_per_sqrt_s: float = 1e-5
    slip_process_std: float = 0.03
    macro_slip_process_std: float = 1.0
    slip_time_constant_s: float = 0.3
    creep_slip: float = 0.005
    adhesion: float | None = None
    slip_onset_rate_hz: float = 2.0
    spontaneous_slip_rate_hz: float = 0.01
    slip_recovery_rate_hz: float = 1.0
    max_slip: float = 0.99
    speed_std_mps: float = 0.02
    motor_speed_std_radps: float = 0.05
    noise_fading: float = 0.995
    alpha: float = 1.0
    beta: float = 2.0
    resample_ess_fraction: float = 0.5
    min_speed_mps: float = 0.05
    underflow_log_likelihood: float = -30.0
    radius_model_std_m: float | None = None

    def __post_init__(self) -> None:
        check_int_option("n_particles", self.n_particles, AUPFConfigError, minimum=2)
        check_int_option("seed", self.seed, AUPFConfigError, minimum=0)  # numpy's generator refuses a negative one
        positive = ["gear_ratio", "initial_radius_std_m", "radius_process_std_m_per_sqrt_s", "slip_process_std",
                    "macro_slip_process_std", "slip_time_constant_s", "creep_slip", "adhesion",
                    "slip_recovery_rate_hz", "max_slip", "speed_std_mps", "motor_speed_std_radps", "alpha",
                    "resample_ess_fraction", "min_speed_mps"]
        if self.adhesion is None:
            positive.remove("adhesion")  # the vehicle's, checked by VehicleParams
        others = ("beta", "noise_fading", "underflow_log_likelihood", "slip_onset_rate_hz",
                  "spontaneous_slip_rate_hz")
        check_number_options(
            {k: getattr(self, k) for k in (*positive, *others)},
            AUPFConfigError,
            positive=positive,
            non_negative=("beta", "slip_onset_rate_hz", "spontaneous_slip_rate_hz"),
            reject_bool=True,
        )
        if not (0.0 < self.noise_fading < 1.0):
            raise AUPFConfigError(f"noise_fading must be in (0, 1), got {self.noise_fading!r}")
        if not (1e-4 <= self.alpha <= 1.0):
            raise AUPFConfigError(f"alpha must be in [1e-4, 1] (paper 004), got {self.alpha!r}")
        if self.resample_ess_fraction > 1.0:
            raise AUPFConfigError(f"resample_ess_fraction must be <= 1, got {self.resample_ess_fraction!r}")
        if self.max_slip >= 1.0:
            raise AUPFConfigError(f"max_slip must be < 1, got {self.max_slip!r}")
        if self.underflow_log_likelihood >= 0:
            raise AUPFConfigError(f"underflow_log_likelihood must be < 0, got {self.underflow_log_likelihood!r}")
        r = self.radius_model_std_m
        if r is not None and (isinstance(r, bool) or not isinstance(r, (int, float)) or not (0.0 <= r < math.inf)):
            raise AUPFConfigError(f"radius_model_std_m must be a finite number >= 0, got {r!r}")

    def adhesion_for(self, vehicle: VehicleParams) -> float:
        """``mu_a`` of the creep curve: the vehicle's dry-rail adhesion unless set."""
        return float(vehicle.adhesion_dry if self.adhesion is None else self.adhesion)

    def radius_model_std_for(self, vehicle: VehicleParams) -> float:
        """The model term of the reported radius standard deviation (default ``0.5 * creep_slip * r_nominal``)."""
        if self.radius_model_std_m is None:
            return 0.5 * self.creep_slip * vehicle.drive_wheel_radius_m
        return float(self.radius_model_std_m)


__all__ = ["AUPFConfig", "AUPFConfigError"]
