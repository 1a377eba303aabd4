"""What a controller knows at one policy step, built from ``UUOM-Track-v0``'s observation or ``info`` dict.

:class:`ControlInput` is the controllers' input; :func:`control_input_from_obs` decodes exactly what a learning
agent sees (via :func:`uuom_gym.envs.observation.decode_observation`), :func:`control_input_from_info` reads the
``info`` dict (measured speed, estimates) for callers without an observation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping

import numpy as np

from uuom_core.vehicle import VehicleParams
from uuom_gym.envs.observation import decode_observation


class ControlInputError(ValueError):
    """An ``info`` dict (or input) that lacks what a controller needs, or holds non-finite values."""


@dataclass(frozen=True)
class ControlInput:
    """What a controller knows at one policy step (SI units).

    Attributes
    ----------
    position_m, speed_mps : float
        Position along the track and ground speed.
    distance_to_go_m : float
        Distance left to the stopping point at the far station (negative past it).
    est_mass_kg, est_mass_std_kg, est_slope_rad, est_slope_std_rad : float
        The observer's estimates and their standard deviations.
    dt_s : float
        Policy step (the command is held this long).
    specific_force_mps2 : float or None
        Measured along-track specific force (accelerometer, mean over the last step), ``None`` if not known.
        With the measured speed it gives a model-free grade (:class:`agents.grade_check.GradeCrossCheck`).
    """

    position_m: float
    speed_mps: float
    distance_to_go_m: float
    est_mass_kg: float
    est_mass_std_kg: float
    est_slope_rad: float
    est_slope_std_rad: float
    dt_s: float
    specific_force_mps2: float | None = None


def info_value(info: Mapping[str, Any], *keys: str, default: float | None = None) -> float:
    """The first of ``keys`` present in ``info`` as a finite float (else ``default``).

    Raises
    ------
    ControlInputError
        If the value is not finite, or no key is present and there is no default.
    """
    for k in keys:
        if k in info and info[k] is not None:
            v = float(np.asarray(info[k]).reshape(-1)[0])
            if not math.isfinite(v):
                raise ControlInputError(f"info['{k}'] is not finite ({v!r})")
            return v
    if default is not None:
        return default
    raise ControlInputError(f"info lacks {' / '.join(repr(k) for k in keys)} needed by the controller")


def control_input_from_info(info: Mapping[str, Any], dt_s: float) -> ControlInput:
    """Build a :class:`ControlInput` from ``UUOM-Track-v0``'s ``info`` dict.

    Uses the *measured* speed and the *estimated* mass and slope where the env provides them (the rule-based
    controller must not see the truth); falls back to the true speed / position only when no measured one is
    reported.
    """
    return ControlInput(
        position_m=info_value(info, "position_m", "true_position_m"),
        speed_mps=info_value(info, "measured_speed_mps", "speed_mps", "true_speed_mps"),
        distance_to_go_m=info_value(info, "distance_to_go_m"),
        est_mass_kg=info_value(info, "est_mass_kg"),
        est_mass_std_kg=info_value(info, "est_mass_std_kg", default=0.0),
        est_slope_rad=info_value(info, "est_slope_rad"),
        est_slope_std_rad=info_value(info, "est_slope_std_rad", default=0.0),
        dt_s=dt_s,
    )


def observation_settings(env: Any) -> tuple[float, str] | None:
    """The policy step (s) and the ``near_distance_observation`` shape that ``env``'s observations are built with.

    Read from the env's config, so that a controller and the shield decode an observation the way the env built
    it. None when the env has no UUOM config (the caller keeps its own settings).
    """
    cfg = getattr(getattr(env, "unwrapped", env), "config", None)
    if not isinstance(cfg, Mapping) or "policy_hz" not in cfg:
        return None
    return 1.0 / float(cfg["policy_hz"]), str(cfg.get("near_distance_observation", "clip"))


def control_input_from_obs(
    obs: np.ndarray, vehicle: VehicleParams, track_length_m: float, dt_s: float, near_shape: str = "clip"
) -> ControlInput:
    """Decode ``UUOM-Track-v0``'s (un-normalised) observation vector into a :class:`ControlInput`.

    Uses exactly what a learning agent sees (:func:`uuom_gym.envs.observation.decode_observation`): measured
    speed, estimated mass/slope and their standard deviations, odometry distance to the station. Position is not
    in the observation; it is reported as ``track_length_m - distance_to_go``. ``near_shape`` is the env's
    ``near_distance_observation``.
    """
    try:
        d = decode_observation(obs, vehicle, track_length_m, near_shape)
    except ValueError as exc:
        raise ControlInputError(str(exc)) from None
    return ControlInput(
        position_m=track_length_m - d.distance_to_go_m,
        speed_mps=d.speed_mps,
        distance_to_go_m=d.distance_to_go_m,
        est_mass_kg=d.est_mass_kg,
        est_mass_std_kg=d.est_mass_std_kg,
        est_slope_rad=d.est_slope_rad,
        est_slope_std_rad=d.est_slope_std_rad,
        dt_s=dt_s,
        specific_force_mps2=d.specific_force_mps2,
    )


__all__ = [
    "ControlInput",
    "ControlInputError",
    "control_input_from_info",
    "control_input_from_obs",
    "info_value",
    "observation_settings",
]
