"""The interface every online mass/slope estimator implements.

One :meth:`Estimator.update` per sensor sample (200 Hz in the environment, whatever the trace has offline) returns
an :class:`Estimate`. Missing sensor values are passed as ``NaN``; an estimator must then predict without
correcting, never propagate the NaN. :meth:`Estimator.run` applies the same per-sample loop to a whole
:class:`~uuom_core.trace.Trace`, so offline results are exactly what the environment would see.

Accelerometer convention (spec §4): ``accel_mps2`` is the *specific force* along the track,
``f = dv/dt + g sin(slope)``, as a body-fixed accelerometer measures it. Each estimator says in its docstring how
it uses it.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from collections.abc import Sequence
from typing import Any, ClassVar

import numpy as np

from uuom_core.trace import Trace
from uuom_core.vehicle import DEFAULT_VEHICLE, VehicleParams


@dataclass(frozen=True, slots=True)
class Estimate:
    """One estimate. Standard deviations are 1-sigma, finite and >= 0.

    ``extras`` holds what a method gives beyond mass and slope (``mu``, ``slip_ratio``, ``drive_radius_m``, their
    ``*_std``), always finite floats.
    """

    mass_kg: float
    slope_rad: float
    mass_std_kg: float
    slope_std_rad: float
    extras: dict[str, float] = field(default_factory=dict)

    @property
    def slope_deg(self) -> float:
        return math.degrees(self.slope_rad)

    @property
    def slope_std_deg(self) -> float:
        return math.degrees(self.slope_std_rad)


@dataclass
class EstimateSeries:
    """The estimates of a whole trace, one row per sample (what :meth:`Estimator.run` returns)."""

    t_s: np.ndarray
    mass_kg: np.ndarray
    slope_rad: np.ndarray
    mass_std_kg: np.ndarray
    slope_std_rad: np.ndarray
    extras: dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def slope_deg(self) -> np.ndarray:
        return np.degrees(self.slope_rad)

    @property
    def slope_std_deg(self) -> np.ndarray:
        return np.degrees(self.slope_std_rad)


def first_step_dts(t_s: np.ndarray, t_prev_s: float | None = None) -> np.ndarray:
    """Per-sample time steps of a trace: ``t[i] - t[i-1]``, the first from ``t_prev_s`` or else equal to the second."""
    n = len(t_s)
    if t_prev_s is None:
        t_prev_s = t_s[0] - (t_s[1] - t_s[0] if n > 1 else 0.005)
    return np.diff(t_s, prepend=t_prev_s)


def reference_and_prior_mass(vehicle: VehicleParams, prior_mass_kg: float | None) -> tuple[float, float]:
    """The reference mass (empty plus half the rated load) and the prior mass (``prior_mass_kg``, else the reference).

    Raises ``ValueError`` for a prior outside ``[empty_mass_kg, max_mass_kg]``.
    """
    m_ref = vehicle.empty_mass_kg + 0.5 * vehicle.rated_load_kg
    prior = float(m_ref if prior_mass_kg is None else prior_mass_kg)
    if not (vehicle.empty_mass_kg <= prior <= vehicle.max_mass_kg):
        raise ValueError(f"prior_mass_kg must lie in [{vehicle.empty_mass_kg}, {vehicle.max_mass_kg}], got {prior}")
    return m_ref, prior


_OUTPUT_FIELD = {"mass": "mass", "slope": "slope", "slip": "slip_ratio", "radius": "drive_radius_m"}


class Estimator(ABC):
    """Base class of the online estimators.

    Parameters
    ----------
    vehicle : VehicleParams, optional
        Parameters the estimator's model is built from (radius, rotating mass, nominal running resistance, mass
        range). Defaults to the spec's default vehicle.
    **options
        Method-specific tuning, documented by each subclass. Unknown options raise ``TypeError``.

    Attributes
    ----------
    name : str
        Registry name (class attribute).
    provides : frozenset of str
        What the method estimates itself: a subset of ``{"mass", "slope", "mu", "slip", "radius"}``. For a quantity
        it does not estimate, it reports its prior (e.g. mid-range mass) with a large standard deviation.
    outputs : tuple of str
        The quantities a consumer should write or display for this estimator, in order; derived from
        :attr:`provides` when a subclass is defined (``mu`` is a by-product, not an output). ``"mass"`` means :attr:`Estimate.mass_kg` / ``mass_std_kg``, ``"slope"`` means
        :attr:`Estimate.slope_rad` / ``slope_std_rad``; any other name is a key of :attr:`Estimate.extras`, whose
        standard deviation, when the method gives one, is under ``NAME + "_std"``. A quantity not listed is a prior
        placeholder, not an estimate (e.g. the mass ``imu-ukf`` reports), and must not be presented as a result.
    inputs : tuple of str
        Optional trace columns the method reads besides the required ones (``uuom-estimate`` reads only these:
        less memory on long logs).
    """

    name: ClassVar[str] = "base"
    provides: ClassVar[frozenset[str]] = frozenset()
    outputs: ClassVar[tuple[str, ...]] = ("mass", "slope")
    inputs: ClassVar[tuple[str, ...]] = ("motor_speed_radps", "gyro_radps", "accel_normal_mps2")

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        # One source of truth: ``provides`` says what is estimated, ``outputs`` names where it is in an Estimate.
        cls.outputs = tuple(field for quantity, field in _OUTPUT_FIELD.items() if quantity in cls.provides)

    def __init__(self, vehicle: VehicleParams | None = None, **options: Any) -> None:
        if options:
            raise TypeError(f"{type(self).__name__}: unknown option(s): {', '.join(sorted(options))}")
        self.vehicle = vehicle if vehicle is not None else DEFAULT_VEHICLE

    @abstractmethod
    def reset(self) -> None:
        """Forget everything learned; return to the prior."""

    @abstractmethod
    def update(
        self,
        torque_nm: float,
        speed_mps: float,
        accel_mps2: float,
        dt_s: float,
        motor_speed_radps: float = math.nan,
        gyro_radps: float = math.nan,
        accel_normal_mps2: float = math.nan,
    ) -> Estimate:
        """Process one sensor sample (any value may be NaN = missing) and return the current estimate."""

    @property
    @abstractmethod
    def estimate(self) -> Estimate:
        """The current estimate without processing a sample."""

    def update_block(
        self,
        torque_nm: Sequence[float],
        speed_mps: Sequence[float],
        accel_mps2: Sequence[float],
        dt_s: float,
        motor_speed_radps: Sequence[float] | None = None,
        gyro_radps: Sequence[float] | None = None,
        accel_normal_mps2: Sequence[float] | None = None,
    ) -> Estimate:
        """Process a block of samples ``dt_s`` apart and return the estimate after the last one.

        The same as calling :meth:`update` on each sample in turn (the environment feeds the samples of one policy
        step this way); estimators with a compiled step override it to skip the per-sample estimates.
        """
        n = len(torque_nm)
        nan = [math.nan] * n
        cols = [speed_mps, accel_mps2, motor_speed_radps, gyro_radps, accel_normal_mps2]
        if any(c is not None and len(c) != n for c in cols):
            raise ValueError(f"{self.name}: update_block: the columns must all have {n} samples")
        motor, gyro, acc_n = (nan if c is None else c for c in cols[2:])
        e = self.estimate
        update = self.update
        for i in range(n):
            e = update(float(torque_nm[i]), float(speed_mps[i]), float(accel_mps2[i]), dt_s, float(motor[i]),
                       float(gyro[i]), float(acc_n[i]))
        return e

    def run(self, trace: Trace, reset: bool = True, *, t_prev_s: float | None = None) -> EstimateSeries:
        """Run the estimator over a whole trace, sample by sample, exactly as online.

        Parameters
        ----------
        trace : Trace
        reset : bool
            Start from the prior. ``False`` continues from the current state: a long log can be run block by block
            (``uuom-estimate`` does) with the same result as in one piece.
        t_prev_s : float, optional
            Time of the sample before the trace's first one (the previous block's last), so that the first step's
            ``dt`` is the true one; without it the first ``dt`` is taken equal to the second.
        """
        if reset:
            self.reset()
        n = len(trace)
        t = trace["t_s"]
        nan = np.full(n, np.nan)
        torque, speed, accel = trace["torque_nm"], trace["speed_mps"], trace["accel_mps2"]
        motor = trace.get("motor_speed_radps")
        gyro = trace.get("gyro_radps")
        acc_n = trace.get("accel_normal_mps2")
        motor = nan if motor is None else motor
        gyro = nan if gyro is None else gyro
        acc_n = nan if acc_n is None else acc_n
        dts = first_step_dts(t, t_prev_s)
        out_m = np.empty(n)
        out_s = np.empty(n)
        out_ms = np.empty(n)
        out_ss = np.empty(n)
        extras: dict[str, np.ndarray] = {}
        update = self.update
        for i in range(n):
            e = update(
                float(torque[i]), float(speed[i]), float(accel[i]), float(dts[i]),
                float(motor[i]), float(gyro[i]), float(acc_n[i]),
            )
            out_m[i] = e.mass_kg
            out_s[i] = e.slope_rad
            out_ms[i] = e.mass_std_kg
            out_ss[i] = e.slope_std_rad
            for k, v in e.extras.items():
                arr = extras.get(k)
                if arr is None:
                    arr = extras[k] = np.full(n, np.nan)
                arr[i] = v
        return EstimateSeries(t.copy(), out_m, out_s, out_ms, out_ss, extras)


__all__ = ["Estimate", "EstimateSeries", "Estimator", "first_step_dts", "reference_and_prior_mass"]
