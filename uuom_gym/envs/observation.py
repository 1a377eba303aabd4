"""The observation layer of ``UUOM-Track-v0``: observers (what the agent is told about mass and slope) and the
normalised observation vector.

Observers (defined in :mod:`uuom_gym.envs.observers`)
-------------------------------------------------
``"dffrls-aekf"`` (default) or any name of :func:`estimators.available`
    The estimator runs on **every** sensor sample (physics rate), fed the measured torque, ground speed,
    accelerometer specific force, motor speed, gyro and normal accelerometer, with ``NaN`` for dropouts.
``"oracle"``
    The true mass and the true slope at the train, standard deviations 0.
``"none"``
    Nothing is learned: the prior (mid-range mass, level track) with the prior's standard deviations, and a
    speed limit for the worst case the train could be in (rated load on the steepest down-grade).

Observation vector (float32, every entry clipped to its finite bounds):

===  =======================  ==================================================================  ============
idx  name                     value                                                               bounds
===  =======================  ==================================================================  ============
0    ``speed``                measured ground speed (mean of the step's last 5 samples) / v_max   [-2, 2]
1    ``accel``                measured specific force, mean over the step / 2.5 m/s^2             [-4, 4]
2    ``last_command``         the action applied during the last step                             [-1, 1]
3    ``est_load``             (estimated mass - empty mass) / rated load                          [-0.5, 1.5]
4    ``est_mass_std``         estimated mass std / rated load                                     [0, 2]
5    ``est_slope``            estimated slope / max grade (15 deg)                                [-2, 2]
6    ``est_slope_std``        estimated slope std / max grade                                     [0, 2]
7    ``est_speed_limit``      v_lim(estimated mass, estimated slope) / v_max                      [0, 1.5]
8    ``speed_margin``         (measured speed - estimated limit) / v_max                          [-2, 2]
9    ``distance_to_go``       (station position - odometry position) / track length               [-0.5, 1.5]
10   ``distance_to_go_near``  (station position - odometry position) / 30 m (fine, near stop)     [-1, 1]
                              (``near_distance_observation="tanh"``: tanh of it, no clip corner)
11   ``wheel_slip``           (motor speed * nominal radius - measured speed) / 0.5 m/s           [-4, 4]
12   ``grade_mf``             model-free grade asin((f - dv/dt) / g), low-passed / max grade      [-2, 2]
13   ``cautious_limit``       v_lim(M + 2 sigma_M, min(slope - 2 sigma, grade_mf)) / v_max       [0, 1.5]
14   ``cautious_margin``      (measured speed - cautious limit) / v_max                           [-2, 2]
15   ``stop_margin``          (measured speed - sqrt(2 * 0.3 m/s^2 * distance to go)) / v_max     [-2, 2]
16   ``idle_clock``           opt-in (``idle_clock_observation=True``): seconds since the train    [0, 1]
                              last got 1 m further / ``idle_limit_s``
+0   ``traction_accel``       opt-in (``vehicle_observation=True``, after all the others): what a  [0, 4]
                              full traction command accelerates the estimated mass by at the
                              measured speed, min(F_max, P / v) / M / 2.5 m/s^2
+1   ``brake_accel``          the same for a full brake command, F_brake / M / 2.5 m/s^2           [0, 4]
===  =======================  ==================================================================  ============

Entries 12-15 (added in v0 rev. 2, see the env's Version History) are functions of the entries above and of the
previous step's speed, given explicitly because a memoryless policy cannot form them: ``grade_mf`` needs dv/dt
(two steps of speed); the estimators' slope can be confidently wrong by 5-12 deg while braking (docs/agents.md),
the model-free grade needs no force model. ``cautious_limit`` is the limit at the pessimistic corner of the
estimate (mass std floored at 2 % of the mass, as the shield does); ``stop_margin`` is the speed above a gentle
braking curve to the station (position from odometry).

``v_max`` is the empty-train speed limit (2 m/s). Position comes from odometry (integrated measured speed) reset
to the true position at track-side position markers (every ``POSITION_MARKER_SPACING_M``) as in mines with RFID
beacons; no grade preview is given: UUOM roadways carry no surveyed grade map, which is why the slope must be
estimated.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping

import numpy as np
from gymnasium import spaces

from uuom_core.limits import speed_limit_mps
from uuom_core.vehicle import G_MPS2, VehicleParams
from uuom_gym.envs.observers import (  # noqa: F401  (re-exported: the observers were defined here before)
    SENSOR_KEYS,
    EstimatorObserver,
    Observer,
    OracleObserver,
    PriorObserver,
    UnknownObserverError,
    make_observer,
    worst_case_speed_limit_mps,
)


POSITION_MARKER_SPACING_M = 25.0
"""Spacing of the track-side position markers that reset the odometry (m)."""

OBS_NAMES: tuple[str, ...] = (
    "speed",
    "accel",
    "last_command",
    "est_load",
    "est_mass_std",
    "est_slope",
    "est_slope_std",
    "est_speed_limit",
    "speed_margin",
    "distance_to_go",
    "distance_to_go_near",
    "wheel_slip",
    "grade_mf",
    "cautious_limit",
    "cautious_margin",
    "stop_margin",
)
IDLE_CLOCK_NAME = "idle_clock"
"""Name of the opt-in 17th entry (config ``idle_clock_observation``), appended after :data:`OBS_NAMES`."""
VEHICLE_OBS_NAMES: tuple[str, ...] = ("traction_accel", "brake_accel")
"""Names of the opt-in vehicle entries (config ``vehicle_observation``), appended last: the acceleration that full
traction at the measured speed and the full service brake give the estimated train, / ``ACCEL_SCALE_MPS2``."""
VEHICLE_OBS_HIGH = 4.0
OBS_LOW = np.array([-2, -4, -1, -0.5, 0, -2, 0, 0, -2, -0.5, -1, -4, -2, 0, -2, -2], dtype=np.float32)
OBS_HIGH = np.array([2, 4, 1, 1.5, 2, 2, 2, 1.5, 2, 1.5, 1, 4, 2, 1.5, 2, 2], dtype=np.float32)
_LOW_LIST = [float(x) for x in OBS_LOW]
_HIGH_LIST = [float(x) for x in OBS_HIGH]
ACCEL_SCALE_MPS2 = 2.5
NEAR_SCALE_M = 30.0
NEAR_SHAPES: tuple[str, ...] = ("clip", "tanh")
"""Shapes of ``distance_to_go_near`` (config ``near_distance_observation``): ``"clip"`` (default) is
``d / NEAR_SCALE_M`` clipped to +-1, flat beyond 30 m with a corner there; ``"tanh"`` is ``tanh(d / NEAR_SCALE_M)``,
which has the same slope at the station and none of the corner (docs/rl.md §37)."""
_NEAR_DECODE_MAX = 0.99
"""Beyond this |value| of the tanh channel (79 m) the decoder trusts the coarse channel instead."""


def _is_tanh_near_shape(near_shape: str) -> bool:
    """Whether ``near_shape`` (one of :data:`NEAR_SHAPES`) is the tanh channel; ValueError naming it otherwise."""
    if near_shape not in NEAR_SHAPES:
        raise ValueError(f"near_shape must be one of {', '.join(map(repr, NEAR_SHAPES))}, got {near_shape!r}")
    return near_shape == "tanh"

SLIP_SCALE_MPS = 0.5
STOP_MARGIN_DECEL_MPS2 = 0.3
"""Deceleration of the braking curve in ``stop_margin``."""
GRADE_MF_SMOOTHING = 0.3
"""Weight of a new sample in the model-free grade's exponential average (per policy step)."""
MASS_STD_FLOOR_FRAC = 0.02
"""``cautious_limit`` never believes a mass std below this fraction of the estimate (as agents.shield)."""

def observation_space(idle_clock: bool = False, vehicle: bool = False) -> spaces.Box:
    """The observation space (float32 Box with the bounds of the module table); ``idle_clock`` appends entry 16,
    ``vehicle`` then the two :data:`VEHICLE_OBS_NAMES` entries, each in [0, 4]."""
    low, high = OBS_LOW.copy(), OBS_HIGH.copy()
    if idle_clock:
        low, high = np.append(low, np.float32(0.0)), np.append(high, np.float32(1.0))
    if vehicle:
        n = len(VEHICLE_OBS_NAMES)
        low = np.append(low, np.zeros(n, np.float32))
        high = np.append(high, np.full(n, VEHICLE_OBS_HIGH, np.float32))
    return spaces.Box(low=low, high=high, dtype=np.float32)


def observation_names(idle_clock: bool = False, vehicle: bool = False) -> tuple[str, ...]:
    """The names of the observation entries, with the opt-in ``idle_clock`` and vehicle entries last when on."""
    return OBS_NAMES + ((IDLE_CLOCK_NAME,) if idle_clock else ()) + (VEHICLE_OBS_NAMES if vehicle else ())


def vehicle_entries(vehicle: VehicleParams, mass_kg: float, speed_mps: float) -> list[float]:
    """The opt-in vehicle entries for a train of ``mass_kg`` at ``speed_mps``: what one unit of the traction command
    (the drive's torque limit or its power limit at this speed) and of the brake command accelerate it by, over
    ``ACCEL_SCALE_MPS2``, clipped to [0, 4]. Why: a traction command is a fraction of *this* vehicle's force, and a
    policy trained on drawn vehicles (config ``vehicle_spread``) cannot tell from the other entries what a command
    does to this train (docs/rl.md §54)."""
    m = min(max(mass_kg, vehicle.empty_mass_kg), 10.0 * vehicle.max_mass_kg) if mass_kg == mass_kg \
        else vehicle.max_mass_kg
    traction = min(vehicle.max_traction_n, vehicle.motor_power_w / max(abs(speed_mps), 0.05))
    return [min(traction / m / ACCEL_SCALE_MPS2, VEHICLE_OBS_HIGH),
            min(vehicle.service_brake_n / m / ACCEL_SCALE_MPS2, VEHICLE_OBS_HIGH)]


class ObservationBuilder:
    """Builds the normalised observation vector from measured signals and the observer's estimate.

    Also keeps the odometry (position from integrated measured speed, reset at position markers) and the last
    valid measurements (used when a whole step's samples are dropouts).
    """

    def __init__(
        self, vehicle: VehicleParams, track_length_m: float, station_m: float, near_shape: str = "clip"
    ) -> None:
        self.near_tanh = _is_tanh_near_shape(near_shape)
        self.vehicle = vehicle
        self.track_length_m = float(track_length_m)
        self.station_m = float(station_m)
        self.v_max = vehicle.max_speed_empty_mps
        self.grade_scale = math.radians(vehicle.max_grade_deg)
        self.reset(0.0)

    def reset(self, position_m: float) -> None:
        self.odometry_m = float(position_m)
        self._marker = math.floor(position_m / POSITION_MARKER_SPACING_M)
        self.speed_mps = 0.0
        self.accel_mps2 = 0.0
        self.slip_mps = 0.0
        self.grade_mf_rad: float | None = None
        self._prev_speed_mps: float | None = None

    def absorb(self, measured: Mapping[str, np.ndarray], dt_s: float, true_position_m: float) -> None:
        """Take in one policy step of measured samples (NaN = dropout) and the true position (for markers)."""
        v = np.asarray(measured["speed_mps"], dtype=float)
        a = np.asarray(measured["accel_mps2"], dtype=float)
        w = np.asarray(measured["motor_speed_radps"], dtype=float)
        r = self.vehicle.drive_wheel_radius_m
        v_sum = float(v.sum())
        if math.isfinite(v_sum):
            # no dropout in the step (the common case): one reduction per channel
            self.odometry_m += v_sum * dt_s
            self.speed_mps = float(v[-5:].mean())
            w_sum = float(w.sum())
            if math.isfinite(w_sum):
                self.slip_mps = (w_sum * r - v_sum) / v.shape[0]
        else:
            ok = np.isfinite(v)
            if ok.any():
                # Odometry integrates the encoder; a dropout sample is bridged with the last valid speed.
                self.odometry_m += float(_forward_fill(v, self.speed_mps).sum()) * dt_s
                self.speed_mps = float(v[ok][-5:].mean())
            else:
                self.odometry_m += self.speed_mps * dt_s * v.shape[0]
            both = np.isfinite(w) & ok
            if both.any():
                self.slip_mps = float((w[both] * r - v[both]).mean())
        a_sum = float(a.sum())
        if math.isfinite(a_sum):
            self.accel_mps2 = a_sum / a.shape[0]
        else:
            good = a[np.isfinite(a)]
            if good.size:
                self.accel_mps2 = float(good.mean())
        if self._prev_speed_mps is not None and v.shape[0] > 0:
            dvdt = (self.speed_mps - self._prev_speed_mps) / (dt_s * v.shape[0])
            sample = math.asin(min(max((self.accel_mps2 - dvdt) / G_MPS2, -1.0), 1.0))
            g = self.grade_mf_rad
            self.grade_mf_rad = sample if g is None else g + GRADE_MF_SMOOTHING * (sample - g)
        self._prev_speed_mps = self.speed_mps
        marker = math.floor(true_position_m / POSITION_MARKER_SPACING_M)
        if marker != self._marker:
            self._marker = marker
            self.odometry_m = float(true_position_m)

    def build(
        self,
        last_command: float,
        mass_kg: float,
        slope_rad: float,
        mass_std_kg: float,
        slope_std_rad: float,
        est_speed_limit_mps: float,
        slip_ratio: float | None = None,
        prior_limit_mps: float | None = None,
    ) -> np.ndarray:
        """The observation vector (float32, clipped to the bounds; NaN would become 0).

        ``slip_ratio`` replaces entry 11 (the sensors' apparent slip velocity) by an estimated slip ratio.
        ``prior_limit_mps`` (the ``none`` observer's worst-case limit) replaces the cautious limit.
        """
        vh = self.vehicle
        to_go = self.station_m - self.odometry_m
        cautious = (
            prior_limit_mps
            if prior_limit_mps is not None
            else self.cautious_limit_mps(mass_kg, slope_rad, mass_std_kg, slope_std_rad)
        )
        stop_curve = math.sqrt(2.0 * STOP_MARGIN_DECEL_MPS2 * max(to_go, 0.0))
        raw = (
            self.speed_mps / self.v_max,
            self.accel_mps2 / ACCEL_SCALE_MPS2,
            last_command,
            (mass_kg - vh.empty_mass_kg) / vh.rated_load_kg,
            mass_std_kg / vh.rated_load_kg,
            slope_rad / self.grade_scale,
            slope_std_rad / self.grade_scale,
            est_speed_limit_mps / self.v_max,
            (self.speed_mps - est_speed_limit_mps) / self.v_max,
            to_go / self.track_length_m,
            math.tanh(to_go / NEAR_SCALE_M) if self.near_tanh else to_go / NEAR_SCALE_M,
            self.slip_mps / SLIP_SCALE_MPS if slip_ratio is None else slip_ratio,
            (self.grade_mf_rad or 0.0) / self.grade_scale,
            cautious / self.v_max,
            (self.speed_mps - cautious) / self.v_max,
            (self.speed_mps - stop_curve) / self.v_max,
        )
        # Python-level clipping: on 16 numbers it is several times faster than three numpy calls.
        out = [min(max(x, lo), hi) if x == x else 0.0 for x, lo, hi in zip(raw, _LOW_LIST, _HIGH_LIST)]
        return np.array(out, dtype=np.float32)

    def cautious_limit_mps(self, mass_kg: float, slope_rad: float, mass_std_kg: float, slope_std_rad: float) -> float:
        """``v_lim`` at the pessimistic corner: mass + 2 sigma (floored), slope - 2 sigma bounded by the
        model-free grade."""
        vh = self.vehicle
        std = max(mass_std_kg, MASS_STD_FLOOR_FRAC * mass_kg)
        mass = min(max(mass_kg + 2.0 * std, 1.0), 10.0 * vh.max_mass_kg)
        slope = slope_rad - 2.0 * slope_std_rad
        if self.grade_mf_rad is not None:
            slope = min(slope, self.grade_mf_rad)
        return speed_limit_mps(vh, mass, min(max(slope, -1.2), 1.2))


def _forward_fill(x: np.ndarray, first: float) -> np.ndarray:
    out = x.copy()
    prev = first
    for i in range(out.shape[0]):
        if math.isnan(out[i]):
            out[i] = prev
        else:
            prev = out[i]
    return out


# --- decoding (inverse of ObservationBuilder.build) ----------------------------------------------------------
@dataclass(frozen=True)
class DecodedObservation:
    """An observation vector turned back into SI units (what an agent can know at one policy step).

    Attributes
    ----------
    speed_mps : float
        Measured ground speed.
    specific_force_mps2 : float
        Measured along-track specific force (accelerometer, mean over the last step).
    last_command : float
        The action applied during the last step.
    est_mass_kg, est_mass_std_kg, est_slope_rad, est_slope_std_rad : float
        The observer's estimates and their standard deviations.
    est_speed_limit_mps : float
        ``v_lim`` of the estimated mass and slope.
    distance_to_go_m : float
        Odometry distance to the stopping point: the fine channel near the stop, else the coarse one.
    """

    speed_mps: float
    specific_force_mps2: float
    last_command: float
    est_mass_kg: float
    est_mass_std_kg: float
    est_slope_rad: float
    est_slope_std_rad: float
    est_speed_limit_mps: float
    distance_to_go_m: float


def decode_observation(
    obs: np.ndarray, vehicle: VehicleParams, track_length_m: float, near_shape: str = "clip"
) -> DecodedObservation:
    """Invert the normalisation of :meth:`ObservationBuilder.build` (un-normalised observation in, SI out).

    Clipped entries stay clipped: e.g. ``distance_to_go_near`` saturates at +-``NEAR_SCALE_M``, so beyond it the
    coarse (track-length) channel is used. ``near_shape`` is the env's ``near_distance_observation``; the tanh
    channel is inverted up to 0.99 (79 m), the coarse channel used beyond.

    Raises
    ------
    ValueError
        If ``obs`` is not ``len(OBS_NAMES)`` finite values (one more with the idle clock, two more with the
        vehicle entries), or ``near_shape`` is not one of :data:`NEAR_SHAPES`.
    """
    o = np.asarray(obs, dtype=float).reshape(-1)
    if o.shape[0] not in _OBS_SIZES or not np.all(np.isfinite(o)):
        raise ValueError(f"observation must be {' or '.join(map(str, _OBS_SIZES))} finite values ({len(OBS_NAMES)}, "
                         f"then the opt-in idle clock and vehicle entries), got shape {o.shape}")
    idx = _OBS_INDEX
    grade = math.radians(vehicle.max_grade_deg)
    near = o[idx["distance_to_go_near"]]
    if _is_tanh_near_shape(near_shape):
        to_go = (math.atanh(near) * NEAR_SCALE_M if abs(near) < _NEAR_DECODE_MAX
                 else o[idx["distance_to_go"]] * track_length_m)
    else:
        to_go = near * NEAR_SCALE_M if abs(near) < 0.999 else o[idx["distance_to_go"]] * track_length_m
    v_max = vehicle.max_speed_empty_mps
    return DecodedObservation(
        speed_mps=o[idx["speed"]] * v_max,
        specific_force_mps2=float(o[idx["accel"]] * ACCEL_SCALE_MPS2),
        last_command=float(o[idx["last_command"]]),
        est_mass_kg=vehicle.empty_mass_kg + o[idx["est_load"]] * vehicle.rated_load_kg,
        est_mass_std_kg=o[idx["est_mass_std"]] * vehicle.rated_load_kg,
        est_slope_rad=o[idx["est_slope"]] * grade,
        est_slope_std_rad=o[idx["est_slope_std"]] * grade,
        est_speed_limit_mps=float(o[idx["est_speed_limit"]] * v_max),
        distance_to_go_m=to_go,
    )


_OBS_INDEX = {n: i for i, n in enumerate(OBS_NAMES)}
_OBS_SIZES = tuple(len(OBS_NAMES) + extra for extra in (0, 1, len(VEHICLE_OBS_NAMES), 1 + len(VEHICLE_OBS_NAMES)))
"""The observation lengths: the 16 entries, with the idle clock, the vehicle entries, or both (appended last)."""


def observation_by_name(obs: np.ndarray) -> dict[str, float]:
    """The (normalised) entries of an observation vector by name, e.g. ``observation_by_name(obs)["speed"]``.

    Raises
    ------
    ValueError
        If ``obs`` does not hold ``len(OBS_NAMES)`` values (one more with the idle clock, two more with the vehicle
        entries).
    """
    o = np.asarray(obs, dtype=float).reshape(-1)
    if o.shape[0] not in _OBS_SIZES:
        raise ValueError(f"observation must hold {' or '.join(map(str, _OBS_SIZES))} values ({len(OBS_NAMES)}, then "
                         f"the opt-in idle clock and vehicle entries), got shape {np.shape(obs)}")
    extra = o.shape[0] - len(OBS_NAMES)
    return dict(zip(observation_names(extra % 2 == 1, extra >= 2), o.tolist()))


__all__ = [
    "DecodedObservation",
    "IDLE_CLOCK_NAME",
    "VEHICLE_OBS_NAMES",
    "OBS_HIGH",
    "OBS_LOW",
    "OBS_NAMES",
    "ObservationBuilder",
    "Observer",
    "POSITION_MARKER_SPACING_M",
    "UnknownObserverError",
    "decode_observation",
    "make_observer",
    "observation_by_name",
    "observation_names",
    "observation_space",
    "worst_case_speed_limit_mps",
]
