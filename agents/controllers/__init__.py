"""Reference speed controllers for UUOM-Track: the oracle minimum-time controller and the rule-based one.

Both map a :class:`ControlInput` (what the controller knows at one policy step) to a command in ``[-1, 1]``
(``> 0`` traction as a fraction of the maximum traction force, ``< 0`` service braking as a fraction of the
service brake force — the plant's convention). :func:`control_input_from_info` builds the input from the
environment's ``info`` dict, so a controller drives ``UUOM-Track-v0`` like a policy::

    ctrl = RuleBasedController(vehicle)
    obs, info = env.reset(seed=0)
    ctrl.reset(env, info)
    while True:
        obs, r, term, trunc, info = env.step(ctrl.act(obs, info))
        ...

- :class:`OracleController` knows the true mass, running resistance, adhesion and the whole track; it follows
  the minimum-time profile of :mod:`agents.speed_profile` — the physical limit of trip time the safety rules
  allow, against which every other controller is measured.
- :class:`RuleBasedController` knows only the estimates (mass, slope, their standard deviations) and the distance
  to the station; it tracks the speed limit computed from a pessimistic estimate (mass ``+ k sigma``, slope
  ``- k sigma``) with a margin, and brakes for the station on a pessimistic braking curve. How much speed it can
  use is therefore decided by how good the estimator is.

- :class:`AccelerationRuleBased` (``rule-based-accel``) is the rule-based controller for the opt-in acceleration
  action (``action_mode="acceleration"``): its reference speed, asked of the env's tracker as an acceleration.

Modules: :mod:`~agents.controllers.base` (base class, force conversion, station stop, full throttle),
:mod:`~agents.controllers.oracle`, :mod:`~agents.controllers.rule_based`, :mod:`~agents.controllers.acceleration`. The controllers' input type lives in
:mod:`agents.control_input`, the model-free grade in :mod:`agents.grade_check`; both are re-exported here.
"""

from __future__ import annotations

from agents.control_input import ControlInput, ControlInputError, control_input_from_info, control_input_from_obs
from agents.controllers.acceleration import AccelerationRuleBased
from agents.controllers.base import FullThrottleController, SpeedController, force_to_command
from agents.controllers.oracle import OracleController
from agents.controllers.rule_based import RuleBasedController
from agents.grade_check import GradeCrossCheck

CONTROLLERS: dict[str, type[SpeedController]] = {
    "oracle": OracleController,
    "rule-based": RuleBasedController,
    "full-throttle": FullThrottleController,
    "rule-based-accel": AccelerationRuleBased,
}
"""Reference controllers by name (``scripts/evaluate.py --controllers``)."""


__all__ = [
    "AccelerationRuleBased",
    "CONTROLLERS",
    "ControlInput",
    "ControlInputError",
    "FullThrottleController",
    "GradeCrossCheck",
    "OracleController",
    "RuleBasedController",
    "SpeedController",
    "control_input_from_info",
    "control_input_from_obs",
    "force_to_command",
]
