"""The plausible range of every real-valued estimator option, checked by :func:`estimators.make` and
``uuom-estimate --option`` before an estimator sees the value.

Why: each estimator validated its own options, with comparisons that a string or a list broke (``'<' not
supported between 'float' and 'str'``, no option named) and with no upper bounds, so a finite but absurd value
overflowed (a standard deviation of 1e300 squared: ``OverflowError``), divided by zero (a residual std of
1e-300), hung (a history step of 1e-300 m) or turned the output into NaN (a sway damping ratio of 5e4, an offset
forgetting 1000× the mass's). Bad values for every option of every estimator (session 59; ``tests/
test_estimator_options_fuzz.py``) broke 116 of the 244 (estimator, option) pairs. The ranges here are wide — any setting that makes sense,
and the defaults well inside — and an estimator's own checks still apply within them (``delta`` in (0, 1), a
mass prior inside the vehicle's range, ...).

The table is keyed by option name: an option of the same name means the same quantity in every estimator that has
it. ``None`` is accepted where an estimator's default is ``None`` ("derive it from the vehicle file").
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np

__all__ = ["OPTIONAL", "OPTION_RANGES", "ZERO_ALLOWED", "check_option_values"]

# (low, high), closed; units as the option's name says
OPTION_RANGES: dict[str, tuple[float, float]] = {
    # sensor noise and process noise (standard deviations)
    "speed_std_mps": (1e-5, 10.0),
    "accel_std_mps2": (1e-5, 100.0),
    "accel_model_std_mps2": (1e-5, 100.0),
    "model_accel_std_mps2": (1e-5, 100.0),
    "accel_process_std_mps2": (1e-5, 100.0),
    "accel_bias_std_mps2": (0.0, 10.0),
    "residual_std_mps2": (1e-5, 100.0),
    "motor_speed_std_radps": (1e-5, 100.0),
    "grade_rate_std_rps": (0.0, 1.0),
    "grade_std_rad_per_sqrt_m": (0.0, 1.0),
    "grade_curvature_std": (0.0, 1.0),
    "curvature_change_std": (0.0, 1.0),
    "slope_process_floor_radps": (1e-9, 1.0),
    "mass_rate_std": (0.0, 1.0),
    "slip_process_std": (1e-6, 10.0),  # its log-likelihood divides by the variance
    "macro_slip_process_std": (1e-6, 100.0),
    "radius_process_std_m_per_sqrt_s": (0.0, 0.1),
    "radius_model_std_m": (0.0, 0.1),
    "resistance_walk_std": (0.0, 1.0),
    # priors (standard deviations and values)
    "prior_slope_std_rad": (1e-4, 1.5),
    "initial_slope_std_rad": (1e-4, 1.5),
    "slope_ready_std_rad": (1e-5, 1.5),
    "prior_curvature_std_per_m": (1e-6, 1.0),
    "initial_curvature_std_rad_per_m": (1e-6, 1.0),
    "initial_speed_std_mps": (1e-5, 10.0),
    "initial_radius_std_m": (0.0, 0.1),
    "prior_mass_kg": (1.0, 1e7),
    "prior_mass_std_kg": (1.0, 1e7),
    "payload_min_kg": (0.0, 1e7),
    "payload_max_kg": (0.0, 1e7),
    "front_mass_kg": (0.0, 1e7),
    "hook_mass_kg": (0.0, 1e5),
    "mu_prior_std": (1e-6, 1.0),
    "resistance_std": (0.0, 1.0),
    "running_resistance": (0.0, 0.5),
    "mu_max": (1e-3, 1.0),
    "blend_prior_std": (0.0, 10.0),
    "chain_prior_std": (1e-3, math.inf),  # inf: a flat prior over the chain lengths
    # forgetting and adaptation
    "delta": (0.0, 1.0),
    "sigma": (0.0, 1e4),
    "forgetting": (0.0, 1.0),
    "fading": (0.0, 1.0),
    "noise_fading": (0.0, 1.0),
    "mass_forgetting_ratio": (0.0, 10.0),
    "offset_forgetting_ratio": (0.0, 10.0),
    "weak_accel_noise_factor": (1.0, 1e6),
    "early_blend_kept": (0.0, 1.0),
    # the train's geometry and swing
    "chain_length_m": (0.1, 20.0),
    "sway_damping_ratio": (0.0, 2.0),
    "train_length_m": (0.0, 200.0),
    "spread_length_m": (0.0, 200.0),
    "rear_offset_m": (0.0, 200.0),
    "front_mass_fraction": (0.0, 1.0),
    "history_step_m": (0.01, 10.0),
    "max_curvature_per_m": (1e-5, 1.0),
    # gates, thresholds and time constants
    "gate_sigma": (0.5, 1e3),
    "gate_nis": (0.5, 1e6),
    "residual_gate_sigma": (0.0, 1e3),
    "residual_gate_persist_s": (1e-3, 1e4),
    "residual_scale_s": (1e-3, 1e4),
    "cutoff_hz": (1e-3, 100.0),
    "dt_nominal_s": (1e-5, 1.0),
    "gap_s": (1e-3, 1e4),
    "settle_s": (0.0, 1e4),
    "smoothing_lag_s": (0.0, 1e3),
    "min_speed_mps": (0.0, 10.0),
    "learn_min_speed_mps": (0.0, 10.0),
    "standstill_speed_mps": (0.0, 10.0),
    "smooth_speed_mps": (1e-5, 10.0),
    "min_accel_mps2": (0.0, 10.0),
    "point_min_accel_mps2": (0.0, 10.0),
    "window_weak_spread_rad": (0.0, 1.5),
    "slope_var_weight": (0.0, 1e6),
    "min_traction_fraction": (0.0, 1.0),
    "min_traction_n": (0.0, 1e7),
    "max_slope_spread_rad": (1e-5, math.inf),  # inf: the gate off
    "max_geometry_ambiguity_rad": (1e-6, math.inf),
    "max_early_evidence": (0.0, math.inf),  # inf: the early evidence counts fully
    "evidence_min_disagreement_rad": (0.0, 1.5),
    "torque_jump_fraction": (0.0, 100.0),
    "accel_jump_mps2": (0.0, 1e3),
    "jump_noise_factor": (0.0, 1e3),
    "accel_std_per_noise": (0.0, 1e3),  # (0 or >= 0.01: checked by the estimator)
    "gyro_witness_deg": (0.0, 90.0),
    "gyro_witness_tau_s": (1e-3, 1e4),
    "gyro_witness_hold_s": (0.0, 1e4),
    "gyro_witness_persist_s": (1e-3, 1e4),
    "gyro_witness_settle_s": (0.0, 1e4),
    "prob_floor": (0.0, 1.0),
    "mass_std_scale": (1e-3, 1e3),
    # the adaptive unscented particle filter (aupf)
    "gear_ratio": (1e-3, 1e3),
    "alpha": (1e-4, 10.0),
    "beta": (0.0, 10.0),
    "creep_slip": (0.0, 1.0),
    "max_slip": (0.0, 1.0),
    "slip_time_constant_s": (1e-3, 1e3),
    "slip_onset_rate_hz": (0.0, 1e3),
    "slip_recovery_rate_hz": (0.0, 1e3),
    "spontaneous_slip_rate_hz": (0.0, 1e3),
    "resample_ess_fraction": (0.0, 1.0),
    "underflow_log_likelihood": (-1e4, 0.0),
    "adhesion": (0.0, 1.0),
}


OPTIONAL: frozenset[str] = frozenset({
    "prior_mass_kg", "prior_mass_std_kg", "payload_max_kg", "front_mass_kg", "hook_mass_kg", "running_resistance",
    "chain_length_m", "train_length_m", "spread_length_m", "rear_offset_m", "point_min_accel_mps2",
    "radius_model_std_m", "adhesion",
})
"""Options some estimator defaults to ``None`` ("from the vehicle file"); an estimator whose default is a number
refuses ``None`` itself."""


ZERO_ALLOWED: frozenset[str] = frozenset({"chain_length_m"})
"""Options where 0 means something of its own below the range (a chain length of 0: a rigid load, no pendulum)."""


def _is_real(value: Any) -> bool:
    return isinstance(value, (int, float, np.integer, np.floating)) and not isinstance(value, (bool, np.bool_))


def check_option_values(owner: str, options: Mapping[str, Any]) -> None:
    """Raise ``ValueError`` (its message after ``owner: ``, if given) naming the first option of ``options`` that has
    a range in :data:`OPTION_RANGES` and is not a real number inside it: infinite only where the range is (a gate
    switched off, a flat prior), ``None`` only for :data:`OPTIONAL`, 0 also for :data:`ZERO_ALLOWED`. Options
    without a range (switches, integers, tuples, strings) are left to the estimator's own checks."""
    for name, value in options.items():
        bounds = OPTION_RANGES.get(name)
        if bounds is None or (value is None and name in OPTIONAL) or (
                _is_real(value) and value == 0 and name in ZERO_ALLOWED):
            continue
        lo, hi = bounds
        if not _is_real(value) or math.isnan(value) or not lo <= value <= hi:
            zero = " or 0" if name in ZERO_ALLOWED else ""
            prefix = f"{owner}: " if owner else ""
            raise ValueError(f"{prefix}option {name} must be a number in [{lo:g}, {hi:g}]{zero}, got {value!r}")
