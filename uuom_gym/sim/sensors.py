"""Sensors at the physics rate: turn the plant's per-tick truth log into what the vehicle's sensors report.

Channels (named as the trace columns, ``uuom_core.trace``):

================== ======================================================= =============================
column             source                                                  model
================== ======================================================= =============================
torque_nm          torque transducer between the motors and drive wheels   T + bias + white noise
speed_mps          encoder on a non-driven carrying wheel                  omega_c r_c, quantised, noise
accel_mps2         along-track accelerometer on the drive section          specific force + bias + noise
motor_speed_radps  motor / drive-wheel encoder                             omega_d, quantised, noise
gyro_radps         IMU pitch-rate gyro                                     pitch rate + bias + noise
accel_normal_mps2  IMU accelerometer axis normal to the track              specific force + bias + noise
================== ======================================================= =============================

Biases are drawn once per :class:`SensorSuite` from ``N(0, bias_std)``; noise is white Gaussian per sample. Faults
(:class:`FaultConfig`): dropouts (``NaN``), spikes, a stuck channel, bias drift. Everything is vectorised over a
block of ticks and draws only from the ``numpy.random.Generator`` given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields, replace

import numpy as np

from uuom_core.trace import SENSOR_COLUMNS
from uuom_core.vehicle import DEFAULT_VEHICLE, VehicleParams

CHANNELS: tuple[str, ...] = SENSOR_COLUMNS
"""Measured channels, in trace-column names (:data:`uuom_core.trace.SENSOR_COLUMNS`)."""

SPIKE_SCALE: dict[str, float] = {
    "torque_nm": 3000.0,
    "speed_mps": 0.5,
    "accel_mps2": 3.0,
    "motor_speed_radps": 3.0,
    "gyro_radps": 0.2,
    "accel_normal_mps2": 3.0,
}
"""Typical size of a spike on each channel (multiplied by ``FaultConfig.spike_size``)."""


class SensorConfigError(ValueError):
    """Invalid sensor or fault configuration."""


@dataclass(frozen=True)
class SensorConfig:
    """Noise, bias and resolution of each sensor (defaults: plausible industrial sensors at 200 Hz).

    Attributes
    ----------
    torque_noise_std_nm, torque_bias_std_nm : float
        Torque transducer white noise and bias spread (N m; the total drive torque is ~2-14 kN m).
    speed_noise_std_mps, speed_resolution_mps : float
        Ground-speed encoder noise and quantisation step (m/s).
    accel_noise_std_mps2, accel_bias_std_mps2 : float
        Along-track accelerometer noise and bias spread (m/s^2).
    motor_speed_noise_std_radps, motor_speed_resolution_radps : float
        Motor / drive-wheel encoder noise and quantisation (rad/s at the drive wheel).
    gyro_noise_std_radps, gyro_bias_std_radps : float
        Pitch-rate gyro noise and bias spread.
    accel_normal_noise_std_mps2, accel_normal_bias_std_mps2 : float
        Normal-axis accelerometer noise and bias spread.
    """

    torque_noise_std_nm: float = 60.0
    torque_bias_std_nm: float = 20.0
    speed_noise_std_mps: float = 0.01
    speed_resolution_mps: float = 0.005
    accel_noise_std_mps2: float = 0.05
    accel_bias_std_mps2: float = 0.01
    motor_speed_noise_std_radps: float = 0.02
    motor_speed_resolution_radps: float = 0.01
    gyro_noise_std_radps: float = 0.002
    gyro_bias_std_radps: float = 0.0005
    accel_normal_noise_std_mps2: float = 0.05
    accel_normal_bias_std_mps2: float = 0.01

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise SensorConfigError(f"SensorConfig.{f.name} must be a finite number >= 0, got {v!r}")

    @classmethod
    def ideal(cls) -> "SensorConfig":
        """No noise, no bias, no quantisation."""
        return cls(**{f.name: 0.0 for f in fields(cls)})

    @classmethod
    def randomized(cls, rng: np.random.Generator, low: float = 0.5, high: float = 2.0) -> "SensorConfig":
        """Each default value scaled by a log-uniform factor in ``[low, high]`` drawn from ``rng``."""
        if not isinstance(rng, np.random.Generator):
            raise SensorConfigError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        if not 0 < low <= high:
            raise SensorConfigError(f"need 0 < low <= high, got low={low!r}, high={high!r}")
        base = cls()
        names = [f.name for f in fields(cls)]
        factors = np.exp(rng.uniform(math.log(low), math.log(high), size=len(names)))
        return replace(base, **{n: getattr(base, n) * float(k) for n, k in zip(names, factors)})


@dataclass(frozen=True)
class FaultConfig:
    """Sensor faults injected on demand.

    Attributes
    ----------
    channels : tuple of str
        Channels that dropouts and spikes hit (default: all).
    dropout_prob : float
        Probability per sample and channel that the sample is missing (``NaN``).
    spike_prob : float
        Probability per sample and channel of a spike of ``+-spike_size * SPIKE_SCALE[channel]``.
    spike_size : float
        Spike size in units of :data:`SPIKE_SCALE`.
    stuck_channel : str or None
        A channel that freezes at its last value from ``stuck_start_s`` for ``stuck_duration_s``.
    bias_drift_per_s : dict
        Channel -> bias drift rate (channel units per second), accumulating from t = 0.
    """

    channels: tuple[str, ...] = CHANNELS
    dropout_prob: float = 0.0
    spike_prob: float = 0.0
    spike_size: float = 1.0
    stuck_channel: str | None = None
    stuck_start_s: float = 0.0
    stuck_duration_s: float = math.inf
    bias_drift_per_s: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        unknown = [c for c in self.channels if c not in CHANNELS]
        if unknown:
            raise SensorConfigError(f"FaultConfig.channels: unknown channel(s) {unknown}; known: {CHANNELS}")
        for name in ("dropout_prob", "spike_prob"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and 0.0 <= v <= 1.0):
                raise SensorConfigError(f"FaultConfig.{name} must be in [0, 1], got {v!r}")
        if not (math.isfinite(self.spike_size) and self.spike_size >= 0):
            raise SensorConfigError(f"FaultConfig.spike_size must be finite and >= 0, got {self.spike_size!r}")
        if self.stuck_channel is not None and self.stuck_channel not in CHANNELS:
            raise SensorConfigError(f"FaultConfig.stuck_channel: unknown channel {self.stuck_channel!r}")
        if not (math.isfinite(self.stuck_start_s) and self.stuck_duration_s >= 0):
            raise SensorConfigError("FaultConfig.stuck_start_s must be finite and stuck_duration_s >= 0")
        for k, v in self.bias_drift_per_s.items():
            if k not in CHANNELS or not math.isfinite(v):
                raise SensorConfigError(f"FaultConfig.bias_drift_per_s: bad entry {k!r}: {v!r}")


class SensorSuite:
    """The vehicle's sensors. Call :meth:`measure` on consecutive blocks of the plant's truth log.

    Parameters
    ----------
    config : SensorConfig
    rng : numpy.random.Generator
        The only source of randomness (biases at construction, then noise and faults per block).
    vehicle : VehicleParams
        For the carrying-wheel radius of the ground-speed encoder.
    faults : FaultConfig, optional
    """

    def __init__(
        self,
        config: SensorConfig | None = None,
        rng: np.random.Generator | None = None,
        vehicle: VehicleParams = DEFAULT_VEHICLE,
        faults: FaultConfig | None = None,
    ) -> None:
        if not isinstance(rng, np.random.Generator):
            raise SensorConfigError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
        self.config = config or SensorConfig()
        self.faults = faults or FaultConfig()
        self.vehicle = vehicle
        self.rng = rng
        c = self.config
        self.bias = {
            "torque_nm": float(rng.normal(0.0, c.torque_bias_std_nm)),
            "speed_mps": 0.0,
            "accel_mps2": float(rng.normal(0.0, c.accel_bias_std_mps2)),
            "motor_speed_radps": 0.0,
            "gyro_radps": float(rng.normal(0.0, c.gyro_bias_std_radps)),
            "accel_normal_mps2": float(rng.normal(0.0, c.accel_normal_bias_std_mps2)),
        }
        self._stuck_value: float | None = None

    def measure(self, log) -> dict[str, np.ndarray]:
        """Measured channels for a block of truth (a :class:`~uuom_gym.sim.plant.PlantLog` or a mapping).

        Returns a dict of float arrays named as :data:`CHANNELS`; missing samples are ``NaN``.
        """
        c, rng = self.config, self.rng
        t = np.asarray(log["t_s"], dtype=np.float64)
        n = len(t)
        r_c = self.vehicle.carrying_wheel_radius_m

        def noisy(x: np.ndarray, std: float) -> np.ndarray:
            return x + rng.normal(0.0, std, size=n) if std > 0 else x.copy()

        def quant(x: np.ndarray, step: float) -> np.ndarray:
            return np.round(x / step) * step if step > 0 else x

        out = {
            "torque_nm": noisy(np.asarray(log["drive_torque_nm"], float), c.torque_noise_std_nm),
            "speed_mps": quant(
                noisy(np.asarray(log["carry_wheel_speed_radps"], float) * r_c, c.speed_noise_std_mps),
                c.speed_resolution_mps,
            ),
            "accel_mps2": noisy(np.asarray(log["specific_force_mps2"], float), c.accel_noise_std_mps2),
            "motor_speed_radps": quant(
                noisy(np.asarray(log["wheel_speed_radps"], float), c.motor_speed_noise_std_radps),
                c.motor_speed_resolution_radps,
            ),
            "gyro_radps": noisy(np.asarray(log["pitch_rate_radps"], float), c.gyro_noise_std_radps),
            "accel_normal_mps2": noisy(
                np.asarray(log["normal_specific_force_mps2"], float), c.accel_normal_noise_std_mps2
            ),
        }
        for k in CHANNELS:
            out[k] = out[k] + self.bias[k]
        self._apply_faults(out, t)
        return out

    def _apply_faults(self, out: dict[str, np.ndarray], t: np.ndarray) -> None:
        f, rng = self.faults, self.rng
        n = len(t)
        for k, rate in f.bias_drift_per_s.items():
            out[k] = out[k] + rate * t
        if f.spike_prob > 0:
            for k in f.channels:
                hit = rng.random(n) < f.spike_prob
                sign = np.where(rng.random(n) < 0.5, -1.0, 1.0)
                out[k] = np.where(hit, out[k] + sign * f.spike_size * SPIKE_SCALE[k], out[k])
        if f.stuck_channel is not None:
            k = f.stuck_channel
            stuck = (t >= f.stuck_start_s) & (t < f.stuck_start_s + f.stuck_duration_s)
            if np.any(stuck):
                first = int(np.argmax(stuck))
                if self._stuck_value is None:
                    self._stuck_value = float(out[k][first - 1]) if first > 0 else float(out[k][first])
                out[k] = np.where(stuck, self._stuck_value, out[k])
        if f.dropout_prob > 0:
            for k in f.channels:
                drop = rng.random(n) < f.dropout_prob
                out[k] = np.where(drop, np.nan, out[k])


__all__ = ["CHANNELS", "SPIKE_SCALE", "FaultConfig", "SensorConfig", "SensorConfigError", "SensorSuite"]
