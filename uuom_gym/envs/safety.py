"""The safety rules of spec §6, evaluated from the plant's **true** state at every physics tick.

One :meth:`SafetyMonitor.evaluate` per policy step takes the per-tick truth of that step (arrays, vectorised: no
per-tick Python) and returns a :class:`SafetyReport`: which rules were breached, each rule's cost, the weighted
total cost, and whether the overspeed trip fired.

=================  ========================================================  ========================  ==========
rule (key)         breach when (at any tick of the step)                      cost term (per step)      unit
=================  ========================================================  ========================  ==========
``speed_limit``    ``v > v_lim(M, slope)`` (rule 1, true M and slope)         ``sum((v - v_lim)+ dt)``  m
``adhesion``       drive slipping continuously for more than ``slip_grace``   slip time beyond grace    s
``rollback``       ``v < -rollback_speed`` (the action cannot ask to reverse) distance rolled back      m
``sway``           ``|sway| > sway_limit``                                    ``sum((|sway|-lim)+ dt)`` rad s
``overspeed_trip`` ``v > v_lim + overspeed_trip_margin`` (ends the episode)   1 on the trip step        --
``stall``          ``v < stall_speed`` on a grade steeper than the loaded     stalled time              s
                   train can climb (rule 6, true M, mu and adhesion)
=================  ========================================================  ========================  ==========

``cost = sum_rule cost_weights[rule] * cost_term[rule]``; 0 exactly when no rule is breached.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

import numpy as np

from uuom_gym.envs.config import RULES
from uuom_core.limits import (
    load_speed_limit_mps,
    max_climbable_grade_rad,
    speed_limit_mps_array,
    stopping_speed_limit_mps,
)
from uuom_core.vehicle import VehicleParams


@dataclass(frozen=True)
class SafetyParams:
    """Thresholds of the rules (from the env config)."""

    overspeed_trip_margin_mps: float = 0.2
    slip_grace_s: float = 0.5
    rollback_speed_mps: float = 0.02
    sway_limit_rad: float = math.radians(8.0)
    stall_speed_mps: float = 0.05
    cost_weights: Mapping[str, float] = field(default_factory=lambda: {r: 1.0 for r in RULES})

    @classmethod
    def from_config(cls, cfg: Mapping[str, object]) -> "SafetyParams":
        return cls(
            overspeed_trip_margin_mps=float(cfg["overspeed_trip_margin_mps"]),  # type: ignore[arg-type]
            slip_grace_s=float(cfg["slip_grace_s"]),  # type: ignore[arg-type]
            rollback_speed_mps=float(cfg["rollback_speed_mps"]),  # type: ignore[arg-type]
            sway_limit_rad=math.radians(float(cfg["sway_limit_deg"])),  # type: ignore[arg-type]
            stall_speed_mps=float(cfg["stall_speed_mps"]),  # type: ignore[arg-type]
            cost_weights=dict(cfg["cost_weights"]),  # type: ignore[arg-type]
        )


@dataclass
class SafetyReport:
    """The safety outcome of one policy step.

    Attributes
    ----------
    violations : dict of str to bool
        Per rule, whether it was breached during the step.
    costs : dict of str to float
        Per rule, the (unweighted) cost term of the step (see the module table).
    cost : float
        Weighted total cost, ``>= 0``, ``0`` when safe.
    tripped : bool
        The overspeed trip fired (the episode ends as a failure).
    speed_limit_mps : float
        The true speed limit at the last tick.
    max_climbable_grade_rad : float
        The steepest grade the loaded train can climb (true mass, mu, adhesion).
    """

    violations: dict[str, bool]
    costs: dict[str, float]
    cost: float
    tripped: bool
    speed_limit_mps: float
    max_climbable_grade_rad: float


class SafetyMonitor:
    """Evaluates spec §6 from the true state; keeps the slip-duration state across policy steps.

    Parameters
    ----------
    vehicle : VehicleParams
        The vehicle (brake force, speed limits, traction limits).
    params : SafetyParams
        Thresholds and cost weights.
    """

    def __init__(self, vehicle: VehicleParams, params: SafetyParams) -> None:
        self.vehicle = vehicle
        self.params = params
        self.mass_kg = vehicle.empty_mass_kg
        self.climbable_rad = math.pi / 2
        self._slip_ticks = 0
        self._v_load = load_speed_limit_mps(vehicle, self.mass_kg)
        self._slope_crit = -math.pi / 2

    def reset(self, mass_kg: float, running_resistance: float, adhesion: float) -> None:
        """Start a new episode with the true mass, running resistance and adhesion of the plant."""
        if not (math.isfinite(mass_kg) and mass_kg > 0):
            raise ValueError(f"mass_kg must be a finite positive number, got {mass_kg!r}")
        self.mass_kg = float(mass_kg)
        self.climbable_rad = max_climbable_grade_rad(
            self.vehicle, self.mass_kg, running_resistance=running_resistance, adhesion=adhesion
        )
        self._slip_ticks = 0
        # v_stop grows with the slope (gravity helps the brake uphill), so above a critical slope the limit is
        # the load limit alone; finding that slope once lets a step on milder down-grades skip the brake formula.
        self._v_load = load_speed_limit_mps(self.vehicle, self.mass_kg)
        lo, hi = -math.pi / 2, math.pi / 2
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if stopping_speed_limit_mps(self.vehicle, self.mass_kg, mid) >= self._v_load:
                hi = mid
            else:
                lo = mid
        self._slope_crit = hi

    def speed_limit(self, slope_rad: np.ndarray | float) -> np.ndarray:
        """True speed limit(s) for the true mass at the given slope(s)."""
        return speed_limit_mps_array(self.vehicle, self.mass_kg, np.atleast_1d(slope_rad))

    def evaluate(
        self,
        dt_s: float,
        speed_mps: np.ndarray,
        slope_rad: np.ndarray,
        slipping: np.ndarray,
        sway_rad: np.ndarray,
    ) -> SafetyReport:
        """Evaluate one policy step from its per-tick truth arrays (all of the same length).

        Parameters
        ----------
        dt_s : float
            Physics tick length.
        speed_mps, slope_rad, slipping, sway_rad : ndarray
            True speed, slope at the train, drive-slip flag and load swing angle at each tick.
        """
        p = self.params
        v = np.asarray(speed_mps, dtype=float)
        slope = np.asarray(slope_rad, dtype=float)
        slip = np.asarray(slipping, dtype=bool)
        sway = np.abs(np.asarray(sway_rad, dtype=float))
        n = v.shape[0]
        if not (slope.shape[0] == slip.shape[0] == sway.shape[0] == n) or n == 0:
            raise ValueError("speed_mps, slope_rad, slipping and sway_rad must be non-empty and of equal length")

        # Fast paths: on a safe step (the common case) each rule costs one reduction.
        if slope.min() >= self._slope_crit:
            v_lim = np.full(n, self._v_load)
        else:
            v_lim = speed_limit_mps_array(self.vehicle, self.mass_kg, slope)
        over = v - v_lim
        c_speed = 0.0
        tripped = False
        if over.max() > 0.0:
            c_speed = float(over[over > 0.0].sum()) * dt_s
            tripped = bool(over.max() > p.overspeed_trip_margin_mps)

        c_slip = 0.0
        if slip.any():
            # Length of the current run of slipping ticks, carried over from the previous step.
            idx = np.arange(n)
            last_clear = np.maximum.accumulate(np.where(slip, -1, idx))
            run = np.where(last_clear >= 0, idx - last_clear, idx + 1 + self._slip_ticks)
            run = np.where(slip, run, 0)
            c_slip = float(np.count_nonzero(run * dt_s > p.slip_grace_s + 1e-12)) * dt_s
            self._slip_ticks = int(run[-1])
        else:
            self._slip_ticks = 0

        c_roll = 0.0
        rolled = False
        if v.min() < -p.rollback_speed_mps:
            back = v < -p.rollback_speed_mps
            rolled = True
            c_roll = max(0.0, float(-v[back].sum()) * dt_s)

        c_sway = 0.0
        if sway.max() > p.sway_limit_rad:
            c_sway = float((sway[sway > p.sway_limit_rad] - p.sway_limit_rad).sum()) * dt_s

        c_stall = 0.0
        stalled_any = False
        if slope.max() > self.climbable_rad:
            stalled = (slope > self.climbable_rad) & (v < p.stall_speed_mps)
            stalled_any = bool(stalled.any())
            c_stall = float(np.count_nonzero(stalled)) * dt_s

        costs = {
            "speed_limit": c_speed,
            "adhesion": c_slip,
            "rollback": c_roll,
            "sway": c_sway,
            "overspeed_trip": 1.0 if tripped else 0.0,
            "stall": c_stall,
        }
        violations = {
            "speed_limit": bool(c_speed > 0.0),
            "adhesion": bool(c_slip > 0.0),
            "rollback": rolled,
            "sway": bool(c_sway > 0.0),
            "overspeed_trip": tripped,
            "stall": stalled_any,
        }
        w = p.cost_weights
        cost = float(sum(w[r] * costs[r] for r in RULES))
        return SafetyReport(
            violations=violations,
            costs=costs,
            cost=cost,
            tripped=tripped,
            speed_limit_mps=float(v_lim[-1]),
            max_climbable_grade_rad=float(self.climbable_rad),
        )


__all__ = ["SafetyMonitor", "SafetyParams", "SafetyReport"]
