"""Observers of ``UUOM-Track-v0``: what the agent is told about mass and slope.

``make_observer(name, vehicle)`` gives :class:`OracleObserver` (``"oracle"``: the truth), :class:`PriorObserver`
(``"none"``: the prior only) or :class:`EstimatorObserver` (any registered estimator, updated on every sensor
sample of a policy step). The observation vector built from their output is in :mod:`uuom_gym.envs.observation`.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

from uuom_core.limits import speed_limit_mps
from uuom_core.trace import SENSOR_COLUMNS
from uuom_core.vehicle import VehicleParams

SENSOR_KEYS: tuple[str, ...] = SENSOR_COLUMNS
"""The sensor channels of a policy step, in the order of ``Estimator.update``'s arguments."""


PLANT_GEOMETRY_OPTIONS: dict[str, dict[str, Any]] = {
    "dffrls-aekf": {"train_length_m": 12.0},
    "mmae": {"point_models": False},
}
"""What the env's plant tells an observer about itself unless the observer options say otherwise: where along the
train gravity acts relative to the sensors (for ``dffrls-aekf`` the slope averaged over 12 m behind them, the window
chosen on plant runs; for ``mmae`` the two-section train, no point-mass twins). Offline, where a vehicle file does not
say it, both learn the geometry (``dffrls-aekf`` a bank over a point mass and this window,
:mod:`estimators.geometry_bank`; ``mmae`` its payload bank twice, ``point_models``); in the env it is known, as it is
to whoever mounts the sensors."""

_GEOMETRY_OPTION_NAMES: dict[str, frozenset[str]] = {
    "dffrls-aekf": frozenset({"train_length_m", "windows_m"}),
    "mmae": frozenset({"point_models", "rear_offset_m"}),
}
"""Options that state the geometry themselves: given any of them, the plant's entry above is not added."""

PLANT_SWING_OPTIONS: dict[str, dict[str, Any]] = {
    "dffrls-aekf": {"chain_length_factors": ()},
    "fused": {"chain_length_factors": ()},
}
"""What the env's plant tells an observer about its load's swing unless the observer options say otherwise: its
chains are the vehicle file's (``PlantConfig.chain_length_m`` None), so one pendulum of that length, not the bank
over chain lengths these estimators carry offline (``chain_length_factors``), where the chains are unknown."""

_SWING_OPTION_NAMES = frozenset({"chain_length_factors", "chain_length_m", "chain_prior_std"})

PLANT_GRADE_OPTIONS: dict[str, dict[str, Any]] = {
    "dffrls-aekf": {"grade_curvature_std": 0.0},
    "fused": {"grade_curvature_std": 0.0},
}
"""What the env gives an observer's grade model unless the observer options say otherwise: ``dffrls-aekf``'s and
``fused``'s slope layer without the curvature state they carry offline. On the plant's tuning runs the curvature state
was neutral for ``dffrls-aekf``'s mass and 3 % worse for its slope (docs/estimation.md, session 21); ``fused`` took it
offline in session 62, after the env's observer study had been run with it off. The env keeps the settings its
episodes were made with (and the RL tables computed on them stay as they were)."""

_GRADE_OPTION_NAMES = frozenset({"grade_curvature_std", "prior_curvature_std_per_m"})

PLANT_MASS_GATE_OPTIONS: dict[str, dict[str, Any]] = {
    "dffrls-aekf": {"min_accel_mps2": 0.05, "window_weak_spread_rad": 0.0},
    "fused": {"fused_spread_gate": False, "slope_var_weight": 0.0, "min_accel_mps2": 0.05},
}
"""The acceleration below which ``dffrls-aekf`` in the env holds its mass, unless the observer options say otherwise:
0.05 m/s², the value every RL table was computed with. Offline the default is 0.03 since round 2, session 22, with
the point member learning at constant speed too (chosen on the plant's tuning runs for the two-member bank); for the
env's configuration (one 12 m filter, one pendulum, two slope states) 0.03 is neutral on the same runs (median / p95
mass max error 10.13 / 33.67 → 10.49 / 33.08 %, docs/estimation.md), so the env keeps its episodes. Likewise
``fused`` in the env learns its mass on grade changes as every RL table's ``fused`` rows were computed with; offline
it holds it there since session 24 (``fused_spread_gate``: neutral on the plant's tuning runs, a gain on the
point-mass world). Nor does the env's 12 m ``dffrls-aekf`` count constant-speed samples on a uniform grade as weak ones
(``window_weak_spread_rad``, offline since round 2, session 63), nor does the env's ``fused`` count the grade's
variance in its mass regression's noise (``slope_var_weight``, offline since the same session), and its mass gate
stays 0.05 m/s² (0.03 offline since that session; given by a user, ``min_accel_mps2`` replaces only itself)."""

_MASS_GATE_OPTION_NAMES: dict[str, frozenset[str]] = {
    "dffrls-aekf": frozenset({"min_accel_mps2", "point_min_accel_mps2", "weak_accel_noise_factor",
                              "window_weak_spread_rad"}),
    "fused": frozenset({"fused_spread_gate", "slope_var_weight"}),
}
"""Options that state the mass gate themselves: given any of them, the plant's entry above is not added (per
estimator, so a ``fused`` user's ``min_accel_mps2`` does not turn its spread gate on)."""

PLANT_BLEND_OPTIONS: dict[str, dict[str, Any]] = {
    "fused": {"blend_from_start": False, "evidence_min_disagreement_rad": 0.0},
}
"""``fused`` in the env learns its gravity blend only once its slope window holds measured slopes, and on every
sample there, as every RL table's ``fused`` rows were computed with; offline the blend learns from the first metre
moved since round 2, session 25 (``blend_from_start``: the plant's tuning runs' slope RMSE median 0.55 -> 0.29 deg),
and only where the two slopes differ by 0.002 rad since session 27 (``evidence_min_disagreement_rad``: neutral on the
plant's tuning runs). Each entry is added unless the observer options state that option."""

FAULT_FREE_SENSOR_OPTIONS: dict[str, dict[str, Any]] = {
    "mmae": {"torque_jump_fraction": 0.0, "stuck_repeats": 0},
    "dffrls-aekf": {"stuck_repeats": 0, "torque_jump_fraction": 0.0, "accel_jump_mps2": 0.0},
    "fused": {"stuck_repeats": 0, "torque_jump_fraction": 0.0, "accel_jump_mps2": 0.0},
}
"""What the env tells an observer when its sensors have no faults (``sensor_faults=None``, the default): no spike or
frozen-channel detection (:mod:`estimators.input_faults`). On a fault-free channel a detector can only mistake data
for a fault: the env's traction command steps the drive torque within one sample, which the jump gate holds back for
that sample. With ``sensor_faults`` set, or any of these options given, the estimator's own defaults hold."""


class UnknownObserverError(ValueError):
    """An observer name that is neither an estimator nor ``oracle`` / ``none``."""


class Observer:
    """Base of the observers: turns a policy step's sensor samples into a mass/slope estimate."""

    name = "base"

    def __init__(self, vehicle: VehicleParams) -> None:
        self.vehicle = vehicle
        self.extras: dict[str, float] = {}
        """What the method estimates beyond mass and slope (e.g. ``slip_ratio`` from ``aupf``), finite floats."""

    def reset(self) -> None:
        """Forget the previous episode."""

    def observe(
        self, measured: Mapping[str, np.ndarray], dt_s: float, true_mass_kg: float, true_slope_rad: float
    ) -> tuple[float, float, float, float]:
        """Process one policy step of samples; return ``(mass_kg, slope_rad, mass_std_kg, slope_std_rad)``."""
        raise NotImplementedError


class OracleObserver(Observer):
    """The true mass and slope (the upper bound of what an estimator could give), optionally with a set error.

    Parameters
    ----------
    vehicle : VehicleParams
    mass_error : float
        Relative error added to the true mass (``0.1``: the agent is told 10 % more than the truth).
    slope_error_deg : float
        Error added to the true slope in degrees (positive: told the track rises more, or falls less, than it does).

    The reported standard deviations stay 0: the agent is told the values are exact. With errors this is the
    sensitivity experiment "how good must an estimator be" (``scripts/sensitivity.py``).
    """

    name = "oracle"

    def __init__(self, vehicle: VehicleParams, mass_error: float = 0.0, slope_error_deg: float = 0.0) -> None:
        super().__init__(vehicle)
        for key, value, bound in (("mass_error", mass_error, 0.9), ("slope_error_deg", slope_error_deg, 45.0)):
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not abs(value) <= bound:
                raise ValueError(f"oracle observer: {key} must be a number in [-{bound:g}, {bound:g}], got {value!r}")
        self.mass_error = float(mass_error)
        self.slope_error_rad = math.radians(slope_error_deg)

    def observe(self, measured, dt_s, true_mass_kg, true_slope_rad):  # type: ignore[override]
        return float(true_mass_kg) * (1.0 + self.mass_error), float(true_slope_rad) + self.slope_error_rad, 0.0, 0.0


class PriorObserver(Observer):
    """No estimate: the prior (mid-range load, level track) and its spread."""

    name = "none"

    def observe(self, measured, dt_s, true_mass_kg, true_slope_rad):  # type: ignore[override]
        v = self.vehicle
        grade = math.radians(v.max_grade_deg)
        return (
            v.empty_mass_kg + 0.5 * v.rated_load_kg,
            0.0,
            v.rated_load_kg / math.sqrt(12.0),
            grade / math.sqrt(3.0),
        )


class EstimatorObserver(Observer):
    """A registered estimator, updated on every sensor sample of the step.

    Parameters
    ----------
    vehicle : VehicleParams
        Passed to the estimator.
    name : str
        Registry name (``estimators.available()``).
    options : mapping
        Estimator options.
    """

    def __init__(self, vehicle: VehicleParams, name: str, options: Mapping[str, Any] | None = None) -> None:
        super().__init__(vehicle)
        import estimators

        self.name = name
        self.estimator = estimators.make(name, vehicle, **dict(options or {}))
        self._last = self.estimator.estimate

    def reset(self) -> None:
        self.estimator.reset()
        self._last = self.estimator.estimate
        self.extras = {}

    def observe(self, measured, dt_s, true_mass_kg, true_slope_rad):  # type: ignore[override]
        e = self.estimator.update_block(*(measured[k] for k in SENSOR_KEYS[:3]), dt_s,
                                        *(measured[k] for k in SENSOR_KEYS[3:]))
        self._last = e
        if e.extras:
            self.extras = {k: float(v) for k, v in e.extras.items() if math.isfinite(v)}
        return _finite_or(e.mass_kg, self.vehicle.empty_mass_kg + 0.5 * self.vehicle.rated_load_kg), _finite_or(
            e.slope_rad, 0.0
        ), _finite_or(abs(e.mass_std_kg), self.vehicle.rated_load_kg), _finite_or(abs(e.slope_std_rad), 1.0)


def _finite_or(x: float, fallback: float) -> float:
    # An estimator that breaks the no-NaN contract must not poison the observation; the fallback is the prior.
    return float(x) if math.isfinite(x) else float(fallback)


def make_observer(name: str, vehicle: VehicleParams, options: Mapping[str, Any] | None = None,
                  fault_free_sensors: bool = False) -> Observer:
    """The observer called ``name`` (``"oracle"``, ``"none"`` or a registered estimator).

    The env's plant adds what it knows about itself to the estimator's options: its geometry
    (:data:`PLANT_GEOMETRY_OPTIONS`), its load's chains (:data:`PLANT_SWING_OPTIONS`), its grade model
    (:data:`PLANT_GRADE_OPTIONS`), its mass gate (:data:`PLANT_MASS_GATE_OPTIONS`), ``fused``'s blend
    (:data:`PLANT_BLEND_OPTIONS`) and, with
    ``fault_free_sensors``, that no sensor spikes or freezes (:data:`FAULT_FREE_SENSOR_OPTIONS`); options given by
    name take precedence.

    Raises
    ------
    UnknownObserverError
        If the name is unknown; the message lists every valid name.
    """
    if name == "oracle":
        try:
            return OracleObserver(vehicle, **dict(options or {}))
        except TypeError:
            raise ValueError(f"oracle observer: unknown option(s) {sorted(options or {})}; it takes mass_error and "
                             f"slope_error_deg") from None
    if name == "none":
        if options:
            raise ValueError(f"observer 'none' takes no options, got {sorted(options)}")
        return PriorObserver(vehicle)
    import estimators

    if name not in estimators.available():
        raise UnknownObserverError(
            f"unknown observer {name!r}; choose 'oracle', 'none' or an estimator: {', '.join(estimators.available())}"
        )
    options = _unless_stated(dict(options or {}), PLANT_GEOMETRY_OPTIONS.get(name, {}),
                             _GEOMETRY_OPTION_NAMES.get(name, frozenset()))
    options = _unless_stated(options, PLANT_SWING_OPTIONS.get(name, {}), _SWING_OPTION_NAMES)
    options = _unless_stated(options, PLANT_GRADE_OPTIONS.get(name, {}), _GRADE_OPTION_NAMES)
    options = _unless_stated(options, PLANT_MASS_GATE_OPTIONS.get(name, {}),
                             _MASS_GATE_OPTION_NAMES.get(name, frozenset()))
    for key, value in PLANT_BLEND_OPTIONS.get(name, {}).items():
        options = _unless_stated(options, {key: value}, frozenset({key}))
    if fault_free_sensors:
        fault_free = FAULT_FREE_SENSOR_OPTIONS.get(name, {})
        options = _unless_stated(options, fault_free, frozenset(fault_free))
    return EstimatorObserver(vehicle, name, options)


def _unless_stated(options: dict[str, Any], known: Mapping[str, Any], names: frozenset[str]) -> dict[str, Any]:
    """``known`` added to ``options`` unless ``options`` already state any of ``names`` themselves."""
    return options if names & set(options) else {**known, **options}


def worst_case_speed_limit_mps(vehicle: VehicleParams) -> float:
    """The limit a train that knows nothing must keep: rated load on the steepest down-grade."""
    return speed_limit_mps(vehicle, vehicle.rated_mass_kg, -math.radians(vehicle.max_grade_deg))
