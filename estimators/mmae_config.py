"""Tuning of the MMAE payload bank (:class:`~estimators.mmae.MMAEEstimator`): a frozen, validated dataclass."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from uuom_core.vehicle import VehicleParams

from .filters import check_int_option, check_number_options


class MMAEConfigError(ValueError):
    """An MMAE option that cannot work (names the option and the value)."""


@dataclass(frozen=True, slots=True)
class MMAEConfig:
    """Tuning of the MMAE bank. Every field is validated on construction (:class:`MMAEConfigError` names it).

    Parameters
    ----------
    n_models : int, default 30
        Number of payload hypotheses (the patent uses 30; 50 were run in real time).
    payload_min_kg, payload_max_kg : float, optional
        Range of the hypotheses; default 0 to the vehicle's rated load.
    running_resistance : float, optional
        Running-resistance coefficient of the model, in [0, 1); default the vehicle's nominal value.
    speed_std_mps : float, default 0.02
        Standard deviation of the ground-speed measurement.
    accel_std_mps2 : float, default 0.3
        Standard deviation of the specific-force measurement, including the vibration of the swinging load.
    accel_process_std_mps2 : float, default 0.15
        Intensity (m/s^2 per sqrt(Hz)) of the unmodelled longitudinal force per unit mass (couplers, sway).
    curvature_change_std : float, default 6e-3
        Random-walk intensity of the slope curvature ``kappa = d theta / ds`` per sqrt(metre) travelled (rad/m per
        sqrt(m)); loose enough to follow the road test's 0-to-11 deg vertical curve of 8 m (0.024 rad/m).
    initial_curvature_std_rad_per_m : float, default 1e-3
        Prior standard deviation of the slope curvature (prior mean 0).
    front_mass_fraction : float, default 0.55
        Share of the empty mass on the front (drive) section, at the accelerometer, in [0, 1].
    rear_offset_m : float, default 9.0
        Distance from the accelerometer back to the rear section and the payload's suspension (the project plant:
        IMU on the drive section, lifting beams 9 m behind). Without it a 30 m vertical curve biased the payload
        by 20-40 % (measured on the plant). 0 = a point mass (whole train on one slope).
    point_models : bool, default True
        Also run every payload hypothesis as a point mass (the whole train on the accelerometer's slope), so the
        bank holds ``2 n_models`` filters and its probabilities weigh the two geometries as they weigh payloads
        (spec §5.6's Bayesian update, applied to the unknown geometry). Ignored when ``rear_offset_m`` is 0. The
        default since round 2, session 16 (a trace does not say where gravity acts); the environment, whose plant
        is the two-section train, sets it False (``uuom_gym.envs.observers.PLANT_GEOMETRY_OPTIONS``).
    resistance_std : float, default 0.0
        Prior standard deviation of the running-resistance coefficient's offset from ``running_resistance``. Above 0
        every filter estimates that offset as a fourth state (a wet rail, a worn wheel, a vehicle file that is off);
        0 = the coefficient is known (the offset stays exactly 0).
    resistance_walk_std : float, default 0.0
        Random-walk intensity of that offset (per sqrt(second)), for a resistance that changes along the run.
    history_step_m : float, default 0.25
        Distance resolution of the remembered slope profile.
    slope_process_floor_radps : float, default 1e-4
        Slope random-walk intensity (in time) on top of the curvature model.
    initial_slope_std_rad : float, default 0.15
        Prior standard deviation of the slope (prior mean 0).
    initial_speed_std_mps : float, default 0.5
        Prior standard deviation of the speed (prior mean: the first valid speed sample).
    prob_floor : float, default 1e-6
        Lower bound of every model probability, in (0, 1/number of filters) (``2 n_models`` with ``point_models``).
    min_traction_n : float, default 2000.0
        Model probabilities are only updated while the drive force ``T/r`` exceeds this.
    standstill_speed_mps : float, default 0.03
        Below this measured speed the train is taken as held at rest (a = 0, probabilities frozen).
    learn_min_speed_mps : float, default 0.0
        The probabilities learn only above this measured speed (the resistance offset, when estimated, only above
        0.1 m/s in any case). Near standstill the plant's friction is static, not ``mu`` times the sign of the
        speed; with the resistance offset estimated, a holding torque then favoured the models whose offset had
        gone low (measured on pm-stop-and-go with ``resistance_std=0.005``: payload +65 % at 0, +2 % at 0.1).
    smooth_speed_mps : float, default 0.01
        ``v_s`` of the smooth sign ``tanh(v / v_s)`` of the running resistance. Small: the plant's resistance is
        Coulomb friction, and with 0.05 m/s the model under-counted it while the train crawled into a station and
        over-estimated the payload by up to 12 % (measured).
    gate_nis : float, default 36.0
        Freeze the probabilities on a sample whose best-model normalised innovation squared exceeds this.
    torque_jump_fraction : float, default 0.15
        A torque sample that differs from the last accepted one by more than this share of the maximum traction
        torque is held back until the next sample confirms the new level (:class:`~estimators.input_faults.JumpGate`);
        0 = off. The torque is the model's input, which no innovation gate sees: one spike favoured the heavy
        payloads for seconds (docs/estimation.md, session 17). Clean runs change by at most 6 % per 5 ms sample.
    stuck_repeats : int, default 20
        The accelerometer is taken as stuck while it repeats one value this many samples in a row, once it has
        shown its noise (:class:`~estimators.input_faults.StuckDetector`); 0 = off.
    """

    n_models: int = 30
    payload_min_kg: float = 0.0
    payload_max_kg: float | None = None
    running_resistance: float | None = None
    speed_std_mps: float = 0.02
    accel_std_mps2: float = 0.3
    accel_process_std_mps2: float = 0.15
    curvature_change_std: float = 6e-3
    initial_curvature_std_rad_per_m: float = 1e-3
    front_mass_fraction: float = 0.55
    rear_offset_m: float = 9.0
    point_models: bool = True
    resistance_std: float = 0.0
    resistance_walk_std: float = 0.0
    history_step_m: float = 0.25
    slope_process_floor_radps: float = 1e-4
    initial_slope_std_rad: float = 0.15
    initial_speed_std_mps: float = 0.5
    prob_floor: float = 1e-6
    min_traction_n: float = 2000.0
    standstill_speed_mps: float = 0.03
    learn_min_speed_mps: float = 0.0
    smooth_speed_mps: float = 0.01
    gate_nis: float = 36.0
    torque_jump_fraction: float = 0.15
    stuck_repeats: int = 20

    def __post_init__(self) -> None:
        n = self.n_models
        check_int_option("n_models", n, MMAEConfigError, minimum=2)
        check_int_option("stuck_repeats", self.stuck_repeats, MMAEConfigError, minimum=0)
        positive = ("speed_std_mps", "accel_std_mps2", "accel_process_std_mps2", "slope_process_floor_radps",
                    "initial_slope_std_rad", "initial_curvature_std_rad_per_m", "initial_speed_std_mps",
                    "smooth_speed_mps", "history_step_m", "gate_nis")
        non_negative = ("payload_min_kg", "curvature_change_std", "rear_offset_m", "front_mass_fraction",
                        "min_traction_n", "standstill_speed_mps", "learn_min_speed_mps", "resistance_std",
                        "resistance_walk_std", "torque_jump_fraction")
        values = {k: getattr(self, k) for k in (*positive, *non_negative)}
        if self.payload_max_kg is not None:
            values["payload_max_kg"] = self.payload_max_kg
        check_number_options(values, MMAEConfigError, positive=positive, non_negative=non_negative)
        if self.payload_max_kg is not None and self.payload_max_kg <= self.payload_min_kg:
            raise MMAEConfigError(
                f"payload_max_kg ({self.payload_max_kg!r}) must exceed payload_min_kg ({self.payload_min_kg!r})"
            )
        if not isinstance(self.point_models, (bool, np.bool_)):
            raise MMAEConfigError(f"point_models must be True or False, got {self.point_models!r}")
        filters = 2 * n if self.with_point_models else n
        if not (0.0 < self.prob_floor < 1.0 / filters):
            raise MMAEConfigError(
                f"prob_floor must be in (0, 1/{filters}) for {filters} filters, got {self.prob_floor!r}"
            )
        mu = self.running_resistance
        if mu is not None and (isinstance(mu, bool) or not isinstance(mu, (int, float)) or not (0.0 <= mu < 1.0)):
            raise MMAEConfigError(f"running_resistance must be in [0, 1), got {mu!r}")
        if self.front_mass_fraction > 1.0:
            raise MMAEConfigError(f"front_mass_fraction must be in [0, 1], got {self.front_mass_fraction!r}")

    @property
    def with_point_models(self) -> bool:
        """Whether the bank holds the point-mass twin of every payload (``point_models`` on a two-section train)."""
        return bool(self.point_models) and self.rear_offset_m > 0.0

    def payloads_kg(self, vehicle: VehicleParams) -> np.ndarray:
        """The hypothesised payloads, evenly spread; the upper end defaults to the vehicle's rated load."""
        lo = self.payload_min_kg
        hi = self.payload_max_kg
        if hi is None:
            hi = vehicle.rated_load_kg if vehicle.rated_load_kg > lo else lo + 1.0
        return np.linspace(float(lo), float(hi), int(self.n_models))

    def running_resistance_for(self, vehicle: VehicleParams) -> float:
        """The model's running-resistance coefficient (the vehicle's nominal one unless set)."""
        mu = vehicle.running_resistance if self.running_resistance is None else self.running_resistance
        if not (0.0 <= mu < 1.0) or not math.isfinite(mu):
            raise MMAEConfigError(f"running_resistance must be in [0, 1), got {mu!r}")
        return float(mu)


__all__ = ["MMAEConfig", "MMAEConfigError"]
