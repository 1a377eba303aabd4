"""Vehicles other than the project's: a field set made consistent with the vehicle file's relations, and seeded
draws of *sister vehicles* (every field within a factor of the project's) for robustness studies.

Why: the estimators, the controllers and the trained policies were all built on one vehicle (the spec's DX80/176Y).
Whether they hold on another monorail of the same class is a question of its own
(``scripts/vehicle_shift.py``), and the draws must be valid vehicles, seeded, and the same on every machine.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from uuom_core.units import G_MPS2
from uuom_core.vehicle import DEFAULT_VEHICLE, PLAUSIBLE_RANGES, VehicleFileError, VehicleParams

__all__ = ["consistent_vehicle", "draw_sister_vehicle", "sister_vehicles", "vehicle_overrides"]


def consistent_vehicle(fields: dict[str, Any]) -> VehicleParams:
    """``fields`` (every field of :class:`VehicleParams`, each within its plausible range) made consistent with the
    relations the vehicle file checks, then validated.

    Each relation is repaired by moving the field that depends on the others: the wet adhesion to at most the dry
    one, the rated speed to at most the empty one, the emergency brake to at least the service brake, wheel bases and
    chain spacing into their sections, the sections into the train's length (or back to their defaults where even
    the longest train cannot hold them), the hook and the wheels under half the empty mass, and the running
    resistance down until the drive can haul the rated train on a level wet rail.

    Raises
    ------
    VehicleFileError
        What the repair cannot mend (a field outside its range).
    """
    kw = dict(fields)
    kw["adhesion_wet"] = min(kw["adhesion_wet"], kw["adhesion_dry"])
    kw["max_speed_rated_mps"] = min(kw["max_speed_rated_mps"], kw["max_speed_empty_mps"])
    kw["emergency_brake_n"] = max(kw["emergency_brake_n"], kw["service_brake_n"])
    kw["drive_wheel_base_m"] = min(kw["drive_wheel_base_m"], kw["drive_section_length_m"])
    kw["beam_wheel_base_m"] = min(kw["beam_wheel_base_m"], kw["beam_section_length_m"])
    kw["chain_spacing_m"] = min(kw["chain_spacing_m"], kw["beam_section_length_m"])
    sections = kw["drive_section_length_m"] + kw["coupler_gap_m"] + kw["beam_section_length_m"]
    if kw["length_m"] < sections:
        kw["length_m"] = min(sections, PLAUSIBLE_RANGES["length_m"][1])
        if kw["length_m"] < sections:  # the sections do not fit the longest train: back to their defaults
            for k in ("drive_section_length_m", "coupler_gap_m", "beam_section_length_m"):
                kw[k] = getattr(DEFAULT_VEHICLE, k)
            kw["drive_wheel_base_m"] = min(kw["drive_wheel_base_m"], kw["drive_section_length_m"])
            kw["beam_wheel_base_m"] = min(kw["beam_wheel_base_m"], kw["beam_section_length_m"])
            kw["chain_spacing_m"] = min(kw["chain_spacing_m"], kw["beam_section_length_m"])
    # the hook below 20 % and the wheels plus hook below half of the empty mass
    kw["hook_mass_kg"] = max(PLAUSIBLE_RANGES["hook_mass_kg"][0], min(kw["hook_mass_kg"], 0.19 * kw["empty_mass_kg"]))
    room = 0.49 * kw["empty_mass_kg"] - kw["hook_mass_kg"]
    kw["carrying_wheel_mass_kg"] = max(PLAUSIBLE_RANGES["carrying_wheel_mass_kg"][0],
                                       min(kw["carrying_wheel_mass_kg"], room / 4.0))
    haul = min(kw["max_traction_n"], kw["adhesion_wet"] * kw["clamp_force_n"])
    rated_mass = kw["empty_mass_kg"] + kw["rated_load_kg"]
    kw["running_resistance"] = min(kw["running_resistance"], 0.9 * haul / (G_MPS2 * rated_mass))
    return VehicleParams(**kw)


def _check_spread(where: str, spread: Any) -> None:
    if isinstance(spread, bool) or not (isinstance(spread, (int, float)) and math.isfinite(spread) and spread >= 1.0):
        raise ValueError(f"{where}: spread must be a finite factor >= 1, got {spread!r}")


def draw_sister_vehicle(rng: np.random.Generator, spread: float,
                        base: VehicleParams = DEFAULT_VEHICLE, max_draws: int = 1000) -> VehicleParams:
    """One vehicle with every field of ``base`` drawn log-uniformly within ×/÷ ``spread`` (integers rounded, clipped
    to the plausible ranges, then :func:`consistent_vehicle`), from ``rng``; a draw the repair cannot mend is drawn
    again. A zero field stays zero and draws nothing.

    The env's per-reset vehicle draw (config key ``vehicle_spread``) and :func:`sister_vehicles` are this function;
    the fields are drawn in declaration order, so one generator state gives one vehicle on every machine.

    Raises
    ------
    ValueError
        ``spread`` below 1 or not finite, or no valid vehicle in ``max_draws`` draws.
    """
    _check_spread("draw_sister_vehicle", spread)
    log_spread = math.log(spread)
    for _ in range(max_draws):
        fields: dict[str, Any] = {}
        for f in dataclasses.fields(VehicleParams):
            x0 = getattr(base, f.name)
            lo, hi, _ = PLAUSIBLE_RANGES[f.name]
            x = min(max(x0 * math.exp(rng.uniform(-log_spread, log_spread)), lo), hi) if x0 else x0
            fields[f.name] = int(round(x)) if isinstance(x0, int) and not isinstance(x0, bool) else float(x)
        try:
            return consistent_vehicle(fields)
        except VehicleFileError:
            continue
    raise ValueError(f"draw_sister_vehicle: no valid vehicle within x/÷ {spread} of the base in {max_draws} draws")


def sister_vehicles(seed: int, count: int, spread: float,
                    base: VehicleParams = DEFAULT_VEHICLE) -> list[VehicleParams]:
    """``count`` vehicles drawn by :func:`draw_sister_vehicle` from one generator seeded with ``seed``.

    The same ``(seed, count, spread, base)`` gives the same vehicles on every machine.

    Raises
    ------
    ValueError
        ``spread`` below 1 or not finite, ``count`` negative, ``seed`` negative.
    """
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"sister_vehicles: seed must be an integer >= 0, got {seed!r}")
    if isinstance(count, bool) or not isinstance(count, (int, np.integer)) or count < 0:
        raise ValueError(f"sister_vehicles: count must be an integer >= 0, got {count!r}")
    _check_spread("sister_vehicles", spread)
    rng = np.random.default_rng(seed)
    return [draw_sister_vehicle(rng, spread, base) for _ in range(count)]


def vehicle_overrides(vehicle: VehicleParams, base: VehicleParams = DEFAULT_VEHICLE) -> dict[str, Any]:
    """The fields of ``vehicle`` that differ from ``base``: the env's ``vehicle`` config entry, JSON-ready."""
    return {f.name: getattr(vehicle, f.name) for f in dataclasses.fields(VehicleParams)
            if getattr(vehicle, f.name) != getattr(base, f.name)}
