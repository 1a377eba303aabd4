"""``UUOM-Track-v0``: drive an underground overhead monorail from one station to the next, safely.

See :class:`UUOMTrackEnv` for the full description (CartPole-style), ``docs/env.md`` for the user guide.
(~490 lines on purpose: one env class whose 150-line docstring is its manual; observation, observers, actions,
safety, reward and shaping live in their own modules beside it.)
"""

from __future__ import annotations

import os
from typing import Any, Mapping

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from uuom_gym.envs.actions import InvalidActionError, accel_demand_mps2, check_action
from uuom_gym.envs.config import CONFIG_DOCS, REWARD_TERMS, ConfigError, default_config, make_config
from uuom_gym.envs.observation import (
    OBS_NAMES,
    SENSOR_KEYS,
    ObservationBuilder,
    PriorObserver,
    make_observer,
    observation_names,
    observation_space,
    vehicle_entries,
    worst_case_speed_limit_mps,
)
from uuom_gym.envs.reward import reward_terms, traction_energy_j
from uuom_gym.envs.reward_shaping import potential, shaping_reward
from uuom_gym.envs.safety import SafetyMonitor, SafetyParams
from uuom_gym.envs.speed_target import SpeedTracker, ramp_target_mps, station_envelope_mps, target_speed_mps
from uuom_core.limits import speed_limit_mps
from uuom_core.vehicle import DEFAULT_VEHICLE, VehicleFileError, VehicleParams
from uuom_core.vehicle_variants import draw_sister_vehicle


IDLE_ADVANCE_M = 1.0
"""``stopped_short``: the train must get this much further than its last mark within ``idle_limit_s``."""


class ResetNeeded(gym.error.ResetNeeded, RuntimeError):
    """``step()`` before the first ``reset()`` or after the episode ended (Gymnasium's ``OrderEnforcing`` rule).

    Derives from :class:`gymnasium.error.ResetNeeded` (what Gymnasium's order enforcing raises) and from
    :class:`RuntimeError` (what this env raised before v0 was hardened).
    """


class UUOMTrackEnv(gym.Env):
    r"""Safety-aware speed control of an underground overhead monorail (UUOM).

    ## Description

    A monorail train (DX80/176Y: 16 t empty, up to 20 t load hanging on chains, 80 kN friction drive, 120 kN
    service brake) stands at rest at a station. It must drive a roadway with grades up to 15 deg up or down and
    stop at the far station within ``stop_tolerance_m``. The plant is a pymunk multi-body model (cars, couplers,
    swinging load, friction drive with an adhesion limit, brakes, motor power/torque limits) simulated at
    ``physics_hz`` (200 Hz); the sensors (torque, ground-speed encoder, motor encoder, accelerometer measuring
    specific force, gyro) are sampled at the same rate with noise, bias and quantisation; an online estimator
    (default DFFRLS-AEKF, Liu et al. 2023) runs on **every** sensor sample and tells the agent the mass and slope
    it believes. The speed limit depends on mass and grade (spec §6), so the agent's safe speed depends on how
    good that estimate is. Safety is judged from the **true** state.

    ## Action Space

    ``Box(-1, 1, (1,), float32)``: the command held for one policy step. ``> 0``: traction as a fraction of the
    available traction force (the plant applies the motor torque and power limits, and the drive slips beyond
    the adhesion limit); ``< 0``: service braking as a fraction of the service brake force. Values outside
    ``[-1, 1]`` are clipped. A plain scalar is taken as one action; NaN/inf or a shape other than ``(1,)`` raise
    :class:`InvalidActionError`.

    ## Observation Space

    ``Box(float32, shape (16,))``, normalised, finite bounds:

    | Num | Observation           | Value                                                        | Min  | Max |
    |-----|-----------------------|--------------------------------------------------------------|------|-----|
    | 0   | speed                 | measured ground speed / 2 m/s                                 | -2   | 2   |
    | 1   | accel                 | accelerometer specific force (mean over step) / 2.5 m/s^2    | -4   | 4   |
    | 2   | last_command          | action applied during the last step                          | -1   | 1   |
    | 3   | est_load              | (estimated mass - 16 t) / 20 t                                | -0.5 | 1.5 |
    | 4   | est_mass_std          | estimated mass std / 20 t                                     | 0    | 2   |
    | 5   | est_slope             | estimated slope / 15 deg                                      | -2   | 2   |
    | 6   | est_slope_std         | estimated slope std / 15 deg                                  | 0    | 2   |
    | 7   | est_speed_limit       | v_lim(estimated mass, estimated slope) / 2 m/s                | 0    | 1.5 |
    | 8   | speed_margin          | (measured speed - estimated limit) / 2 m/s                    | -2   | 2   |
    | 9   | distance_to_go        | (station - odometry position) / track length                  | -0.5 | 1.5 |
    | 10  | distance_to_go_near   | (station - odometry position) / 30 m                          | -1   | 1   |
    | 11  | wheel_slip            | (motor speed x nominal radius - measured speed) / 0.5 m/s     | -4   | 4   |
    | 12  | grade_mf              | model-free grade asin((f - dv/dt)/g), low-passed / 15 deg     | -2   | 2   |
    | 13  | cautious_limit        | v_lim(M + 2 sigma_M, min(slope - 2 sigma, grade_mf)) / 2 m/s  | 0    | 1.5 |
    | 14  | cautious_margin       | (measured speed - cautious limit) / 2 m/s                     | -2   | 2   |
    | 15  | stop_margin           | (measured speed - sqrt(2 x 0.3 m/s^2 x distance to go)) / 2   | -2   | 2   |

    Position is odometry (integrated encoder speed) reset at track-side markers every 25 m. There is no grade
    preview: roadways have no surveyed grade map. The default observer ``dffrls-aekf`` is told the plant's geometry
    (slope averaged over 12 m behind the sensors, ``observers.PLANT_GEOMETRY_OPTIONS``; offline it learns it).
    With ``observer="oracle"`` entries 3-7 are the truth (std 0;
    ``observer_options={"mass_error": e, "slope_error_deg": d}`` adds a set error, for sensitivity studies);
    with ``observer="none"`` they hold the prior and the worst-case limit (rated load, steepest down-grade).
    Entries 12-15 are functions of the others and of the previous step's speed, which a memoryless policy
    cannot form (see :mod:`uuom_gym.envs.observation`). With ``idle_clock_observation=True`` (opt-in) a 17th
    entry, ``idle_clock`` in ``[0, 1]``, is the time since the train last got 1 m further over ``idle_limit_s``:
    how close the ``stopped_short`` ending is. With ``vehicle_observation=True`` (opt-in) two more entries come
    last, ``traction_accel`` and ``brake_accel``: what a full traction or brake command accelerates the estimated
    train by (for policies trained on drawn vehicles). With ``near_distance_observation="tanh"`` (opt-in) entry 10 is
    ``tanh(distance / 30 m)`` instead of clipped at +-1, with no corner at 30 m.

    ## Rewards

    Sum of ``info["rewards"]``: ``progress`` (+10 x fraction of the track covered), ``arrival`` (+10 on
    success, less up to half for the stop error), ``time`` (-0.01 per s), ``energy`` (-0.2 per MJ of traction
    energy), ``safety`` (-1 x ``info["cost"]``), ``failure`` (-10 on every failed ending, see Episode End),
    ``idle`` (-15 more when stopped short: standing must not beat an attempt that trips),
    ``shaping`` (potential-based, ``Phi(s') - Phi(s)`` with ``Phi = -20 x`` the speed in m/s above a gentle
    braking curve to the station and above 0.05 m/s below the true limit, ``Phi = 0`` at every terminal state,
    so it sums to 0 over an episode; :mod:`uuom_gym.envs.reward_shaping`), ``caution`` (off by default: ``-w`` per
    m/s above the cautious limit of entry 13, per second; a training option). Weights: ``reward_weights``,
    ``shaping_gamma``.

    ## Starting State

    At rest at ``s = 0`` (a level run-in) with service brake released. Each ``reset(seed)`` draws the track
    (length in ``track_length_m``, grades to ``max_grade_deg``, feasible for the load unless
    ``allow_infeasible``), the load (0 to rated; uniform, or Beta-weighted with ``load_fraction_beta``), running resistance, dry/wet adhesion, wheel wear, sensor
    noise and bias scales; with ``vehicle_spread`` > 1, first the vehicle itself. ``scenario`` fixes the paper's
    runs instead.

    ## Episode End

    Terminated: success (standing still, ``|v| < stop_speed_mps``, within ``stop_tolerance_m`` of the far
    station); overspeed trip (true speed > v_lim + ``overspeed_trip_margin_mps``: the emergency brake drops);
    overrun (more than ``stop_tolerance_m`` past the station); running back off the start (> 20 m behind it);
    rolled back (more than ``rollback_trip_m`` = 2 m behind the furthest point reached); stopped short (not 1 m
    further along within ``idle_limit_s`` = 20 s, standing or dithering, short of arrival). All but success
    are failures.
    Truncated: simulated time beyond ``max_episode_s`` (default: half the rated-load speed limit over the track
    plus 120 s) and the registry's ``max_episode_steps`` = 30 000.

    ## Arguments

    ``gym.make("UUOM-Track-v0", render_mode=None, **config)``; every key of :meth:`default_config` (see
    ``CONFIG_DOCS`` and ``docs/env.md``), e.g. ``observer="oracle"``, ``scenario="section1"``,
    ``policy_hz=5``, ``allow_infeasible=True``. Unknown keys raise :class:`ConfigError`.

    | Argument          | Default         | Meaning                                                   |
    |-------------------|-----------------|-----------------------------------------------------------|
    | render_mode       | None            | None, "rgb_array" or "human"                              |
    | observer          | "dffrls-aekf"   | estimator name, "oracle" or "none"                        |
    | scenario          | None            | None (random), "section1", "section2", "roadtest"        |
    | policy_hz         | 10              | agent decisions per second                                |
    | physics_hz        | 200             | plant / sensor / estimator rate                           |
    | track_length_m    | (100, 300)      | random track length range                                 |
    | allow_infeasible  | False           | allow grades the load cannot climb                        |
    | action_mode       | "command"       | "command" (traction/brake fraction), "speed_target" or    |
    |                   |                 | "acceleration"                                            |

    ``action_mode="speed_target"`` (opt-in) reads the action as a target speed, ``(a + 1) / 2`` times the cautious
    limit (observation 13), tracked by a PI controller with a grade feed-forward from the estimates inside the env
    (:mod:`uuom_gym.envs.speed_target`): the action's zero then drives gently instead of coasting. Observation 2
    and ``info["command"]`` stay the plant command; ``info["target_speed_mps"]`` is the target. With
    ``speed_target_cap="station"`` (opt-in) the target is ``(a + 1) / 2`` times ``min(cautious limit, braking
    envelope to the station)``, the envelope ``sqrt(2 x 0.3 m/s^2 x (odometry distance to go - 0.5 m))``: every
    action ``a > -1`` then stops at the station (a meta-action over a low-level tracker; the env gives the policy
    the station envelope). ``speed_tracker`` overrides the tracker's gains (e.g. ``{"integral_clamp_m": 2.0}``).
    ``action_mode="acceleration"`` (opt-in) reads the action as an acceleration demand (``accel_demand_mps2``, default
    -0.5..0.5 m/s^2, ``a = 0`` asking for none): it ramps the same tracker's target, which stays within 0.3 m/s of
    the measured speed, and is fed forward as a force. ``a = 0`` holds the speed (at rest: the brake), any ``a > 0``
    starts the train whatever its mass; no cap, no shield: the policy times the start, the cruise and the stop.
    ``info["accel_demand_mps2"]`` is the demand, ``info["target_speed_mps"]`` the ramped target.

    ## Version History

    * v0: initial version.
    * v0 (rev. 2, no id change): observation 12 -> 16 entries (``grade_mf``, ``cautious_limit``,
      ``cautious_margin``, ``stop_margin`` appended; entries 0-11 unchanged); new reward terms ``shaping``
      (potential-based, 0 over every episode) and ``idle``; new failed endings ``rolled_back`` and ``stopped_short``
      (config ``rollback_trip_m``, ``idle_limit_s``). Reason, measured: plain PPO on rev. 1 spent 7 000-step
      episodes rolling back or standing until the time limit (5 episodes in its first 41 000 steps, rollback
      cost ~10^4 violations per km) and never arrived (docs/rl.md). Policies trained on rev. 1 do not load.
    * v0 (rev. 3, no id change, default behaviour unchanged): opt-in config ``action_mode="speed_target"``. Reason:
      bare PPO on rev. 2 held the brake at the start, the action's zero being "coast" (docs/rl.md §3, §6).
    * v0 (rev. 4, no id change, default behaviour unchanged): opt-in configs ``speed_target_cap="station"`` and
      ``speed_tracker``. Reason, measured (docs/rl.md §7): under rev. 3 every constant action overran the station
      (the stop had to be timed by the policy inside a 3 m window, 2 500-8 000 steps into a heavy train's
      episode), and the tracker's small integral stalled a 35 t train on a grade change and overshot the target in
      a sag curve.
    * v0 (rev. 5, no id change, default behaviour unchanged): opt-in config ``speed_target_range=(lo, hi)``, the
      fractions of the cautious limit that ``a = -1`` and ``a = +1`` ask for. Reason (docs/rl.md §8): the rev. 4
      policy stayed near its untrained starting point, 58 % of the cap (1.9x the oracle's trip time); a span
      around 1 starts it at the cautious limit and lets it learn where to go above it. The id
      ``UUOM-Track-SpeedTarget-v0`` registers this class with the rev. 5 speed-target configuration
      (``uuom_gym.registration.SPEED_TARGET_KWARGS``).
    * v0 (rev. 6, no id change, behaviour unchanged): the registered ``dffrls-aekf`` became a geometry bank that
      learns where gravity acts (``estimators.geometry_bank``); the env keeps the plant's known 12 m window
      (``train_length_m=12`` unless ``observer_options`` say otherwise), so episodes are identical.
    * v0 (rev. 7, no id change, behaviour unchanged): the registered ``mmae`` runs every payload also as a point
      mass by default (``point_models``); the env keeps the plant's two-section model (``point_models=False``
      unless ``observer_options`` say otherwise), so episodes are identical.
    * v0 (rev. 8, no id change, behaviour unchanged): the registered ``mmae`` detects torque spikes and a stuck
      accelerometer by default (``estimators.input_faults``); with ``sensor_faults=None`` the env's sensors have
      neither, and it turns the detectors off (``observers.FAULT_FREE_SENSOR_OPTIONS``), so episodes are identical.
    * v0 (rev. 9, no id change, behaviour unchanged): the registered ``dffrls-aekf`` and ``fused`` identify the load's
      chain length (a bank over 0.7-1.4x the vehicle file's, ``chain_length_factors``); the env's plant hangs the
      load on the file's chains and tells them one pendulum of that length (``observers.PLANT_SWING_OPTIONS``), so
      episodes are identical.
    * v0 (rev. 10, no id change, behaviour unchanged): the registered ``dffrls-aekf``'s slope layer carries the
      grade's curvature (``grade_curvature_std``); chosen with the point-mass world in view and neutral to slightly
      worse on this plant, it stays off here (``observers.PLANT_GRADE_OPTIONS``), so episodes are identical.
    * v0 (rev. 11, no id change, behaviour unchanged): the registered ``dffrls-aekf`` learns its mass from
      accelerations down to 0.03 m/s² (was 0.05) and, in its point-mass member, also at constant speed (those samples
      counted 10x noisier); neutral for the env's one 12 m filter, the env keeps 0.05
      (``observers.PLANT_MASS_GATE_OPTIONS``), so episodes are identical.
    * v0 (rev. 12, no id change, behaviour unchanged): the registered ``dffrls-aekf`` uses measured electric braking
      (negative drive torque), drops a frozen accelerometer (``stuck_repeats``, off on the env's fault-free sensors
      as ``mmae``'s detectors are: ``observers.FAULT_FREE_SENSOR_OPTIONS``; ``fused`` likewise) and its geometry
      bank's ambiguity gate is 2.5e-4 rad (was 0.004); this plant's motors
      never brake and the env's observer is one 12 m filter, which has no ambiguity, so episodes are identical (with
      ``sensor_faults``, a torque reading below −2 % of the traction limit now counts as electric braking).
    * v0 (rev. 13, no id change, behaviour unchanged): the registered ``dffrls-aekf`` and ``fused`` hold back a
      one-sample torque or accelerometer spike (jump gates, off on the env's fault-free sensors:
      ``observers.FAULT_FREE_SENSOR_OPTIONS``) and fill a missing speed sample with their predicted speed; the env's
      fault-free sensors have neither spikes nor missing samples, so episodes are identical. ``fused`` offline holds
      its mass on grade changes (``fused_spread_gate``); the env keeps it off (``observers.PLANT_MASS_GATE_OPTIONS``).
    * v0 (rev. 14, no id change, behaviour unchanged): the registered ``fused`` learns its gravity blend from the first
      metre moved (``blend_from_start``, with ``early_blend_kept``); the env keeps the late rule its RL rows were
      computed with (``observers.PLANT_BLEND_OPTIONS``), so episodes are identical.
    * v0 (rev. 15, no id change, behaviour unchanged): a ninth reward term, ``caution`` (speed above the cautious
      limit, per second), weight 0 by default: rewards are unchanged, ``info["rewards"]`` has one more key.
    * v0 (rev. 16, no id change, default behaviour unchanged): opt-in config ``action_mode="acceleration"`` with
      ``accel_demand_mps2``. Reason (docs/rl.md §32): on the traction command a small mean command does not move a
      train at rest (the force is below breakaway), so the policy's mean never learnt to start or stop it (§27-§31).
    * v0 (rev. 17, no id change, default behaviour unchanged): opt-in config ``idle_clock_observation`` (17th entry
      ``idle_clock``). Reason (docs/rl.md §34): the ``stopped_short`` ending ran on a clock outside the observation,
      so a critic could not tell a crawl about to end from one that would not.
    * v0 (rev. 18, no id change, default behaviour unchanged): opt-in config ``near_distance_observation="tanh"``
      (entry 10 is ``tanh(distance / 30 m)`` instead of clipped at +-1). Reason (docs/rl.md §37): a SAC seed stopped
      25-30 m before the station, where the clipped channel has its corner.
    * v0 (rev. 19, no id change, default behaviour unchanged): opt-in config ``load_fraction_beta=(a, b)`` draws
      the load fraction from Beta(a, b) within ``load_fraction_range``, a training curriculum over the load
      (docs/rl.md §38: every failure of the best bare-SAC recipe was a heavy train). None (default) keeps the
      uniform draw, so every seed draws the same episode as before.
    * v0 (rev. 20, no id change, default behaviour unchanged): opt-in config ``load_fraction_uniform_share``: with
      ``load_fraction_beta`` set, that share of the episodes still draws the load uniformly (docs/rl.md §39: the
      Beta(2, 1) draw moved the failures from the heaviest trains to the lightest, which it had made rare).
    * v0 (rev. 21, no id change, default behaviour unchanged): opt-in config ``vehicle_spread`` > 1 draws a sister
      vehicle at every reset (every field of the vehicle file within x/÷ the factor, from ``np_random``; the
      episode's vehicle is ``env.vehicle``, the configured one ``env.base_vehicle``): domain randomisation over the
      vehicle, because policies trained on one vehicle do not transfer (docs/rl.md §53, §54). 1 (default) draws
      nothing, so every seed draws the same episode as before. Opt-in config ``vehicle_observation`` appends
      ``traction_accel`` and ``brake_accel``: a traction command is a fraction of the episode vehicle's force.
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 30}

    def __init__(self, render_mode: str | None = None, config: Mapping[str, Any] | None = None, **kwargs: Any):
        super().__init__()
        self.config = make_config(config, **kwargs)
        cfg = self.config
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ConfigError(
                f"render_mode must be None or one of {', '.join(self.metadata['render_modes'])}, got {render_mode!r}"
            )
        self.render_mode = render_mode
        self.metadata = dict(self.metadata, render_fps=cfg["render_fps"])
        self.base_vehicle = _make_vehicle(cfg["vehicle"])
        self.ticks_per_step = int(round(cfg["physics_hz"] / cfg["policy_hz"]))
        self.dt_s = 1.0 / cfg["physics_hz"]
        self.step_s = self.ticks_per_step * self.dt_s
        self.action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        self._cautious_mps = 0.0
        self._target_mps: float | None = None
        self._accel_demand = 0.0
        self.observation_space = observation_space(cfg["idle_clock_observation"], cfg["vehicle_observation"])
        self.observation_names = observation_names(cfg["idle_clock_observation"], cfg["vehicle_observation"])
        self._use_vehicle(self.base_vehicle)
        self._renderer = None
        self.plant = None
        self.track = None
        self._episode_over = False
        self._end_reason = ""

    def _use_vehicle(self, vehicle: VehicleParams) -> None:
        """Build everything that reads the vehicle file for ``vehicle`` (at construction, and at a reset that draws a
        sister vehicle): the speed tracker of the speed-target and acceleration actions, the observer, the safety
        rules and the no-estimate limit."""
        cfg = self.config
        self.vehicle = vehicle
        self._tracker = (
            SpeedTracker(vehicle, self.step_s, **cfg["speed_tracker"])
            if cfg["action_mode"] in ("speed_target", "acceleration")
            else None
        )
        self.observer = make_observer(cfg["observer"], vehicle, cfg["observer_options"],
                                      fault_free_sensors=cfg["sensor_faults"] is None)
        self.safety = SafetyMonitor(vehicle, SafetyParams.from_config(cfg))
        self._none_limit = worst_case_speed_limit_mps(vehicle)

    # ------------------------------------------------------------------------------------------------------------
    @staticmethod
    def default_config() -> dict[str, Any]:
        """The default configuration (every key documented in ``CONFIG_DOCS``)."""
        return default_config()

    config_docs = CONFIG_DOCS
    observation_names = OBS_NAMES

    # ------------------------------------------------------------------------------------------------------------
    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        super().reset(seed=seed)
        from uuom_gym.envs import _plant_adapter as pa

        cfg = self.config
        rng = self.np_random
        if cfg["vehicle_spread"] > 1.0:
            # drawn first and only when asked, so that the default's random stream is that of earlier revisions
            self._use_vehicle(draw_sister_vehicle(rng, cfg["vehicle_spread"], self.base_vehicle))
        cond = pa.draw_conditions(cfg, self.vehicle, rng)
        self.conditions = cond
        self.track = cond.track
        self.plant, self.sensors = pa.build_plant(self.vehicle, cfg, cond, rng)
        self.station_m = self.track.length_m
        self.true_mass_kg = self.vehicle.empty_mass_kg + cond.load_kg
        self.safety.reset(self.true_mass_kg, cond.running_resistance, cond.adhesion)
        self.observer.reset()
        self.obs_builder = ObservationBuilder(self.vehicle, self.track.length_m, self.station_m,
                                              self.config["near_distance_observation"])
        self.obs_builder.reset(0.0)
        self.max_episode_s = (
            cfg["max_episode_s"]
            if cfg["max_episode_s"] is not None
            else 2.0 * self.track.length_m / self.vehicle.max_speed_rated_mps + 120.0
        )
        st = pa.state_arrays(self.plant)
        self.t_s = 0.0
        self.position_m = st["position_m"]
        self.speed_mps = st["speed_mps"]
        self.sway_rad = st["sway_rad"]
        self.true_slope_rad = float(self.track.slope_at(self.position_m))
        self.last_command = 0.0
        self._target_mps = None
        self._accel_demand = 0.0
        if self._tracker is not None:
            self._tracker.reset()
        self._furthest_m = self.position_m
        self._advance_mark_m = self.position_m
        self._advance_t_s = 0.0
        self.episode_cost = 0.0
        self.episode_energy_j = 0.0
        self.violation_counts = {r: 0 for r in self.safety.params.cost_weights}
        empty = {k: np.empty(0) for k in SENSOR_KEYS}
        self._estimate = self.observer.observe(empty, self.dt_s, self.true_mass_kg, self.true_slope_rad)
        self._est_limit = self._estimated_limit(self._estimate)
        self.true_limit_mps = float(self.safety.speed_limit(self.true_slope_rad)[0])
        self._phi = self._potential()
        self._last_violations: tuple[str, ...] = ()
        self._last_cost = 0.0
        self._episode_over = False
        self._end_reason = ""
        obs = self._observation()
        info = self._info(cost=0.0, costs={r: 0.0 for r in self.violation_counts},
                          violations={r: False for r in self.violation_counts},
                          rewards={t: 0.0 for t in REWARD_TERMS}, success=False, termination="")
        if self.render_mode == "human":
            self.render()
        return obs, info

    def step(self, action: Any):
        if self.plant is None:
            raise ResetNeeded("UUOMTrackEnv.step() called before reset(); call env.reset() first")
        if self._episode_over:
            raise ResetNeeded(
                f"UUOMTrackEnv.step() called after the episode ended ({self._end_reason}); call env.reset() first"
            )
        from uuom_gym.envs import _plant_adapter as pa

        command = check_action(action)
        cfg = self.config
        if cfg["action_mode"] == "acceleration":
            command = self._accelerate(command)
        elif self._tracker is not None:
            command = self._track(command)
        s_start = self.position_m
        log = self.plant.advance(command, self.ticks_per_step)
        tick = pa.log_arrays(log)
        measured = self.sensors.measure(log)
        dt = self.dt_s
        self.t_s += self.step_s
        self.position_m = float(tick["position_m"][-1])
        self.speed_mps = float(tick["speed_mps"][-1])
        self.sway_rad = float(tick["sway_rad"][-1])
        self.true_slope_rad = float(tick["slope_rad"][-1])
        self.last_command = command

        self._estimate = self.observer.observe(measured, dt, self.true_mass_kg, self.true_slope_rad)
        self._est_limit = self._estimated_limit(self._estimate)
        self.obs_builder.absorb(measured, dt, self.position_m)

        rep = self.safety.evaluate(dt, tick["speed_mps"], tick["slope_rad"], tick["slipping"], tick["sway_rad"])
        self.true_limit_mps = rep.speed_limit_mps
        energy = traction_energy_j(tick["drive_torque_nm"], tick["wheel_speed_radps"], dt)
        self.episode_energy_j += energy

        to_go = self.station_m - self.position_m
        tol = cfg["stop_tolerance_m"]
        arrived = abs(to_go) <= tol and abs(self.speed_mps) < cfg["stop_speed_mps"]
        self._furthest_m = max(self._furthest_m, self.position_m)
        if self.position_m >= self._advance_mark_m + IDLE_ADVANCE_M:
            self._advance_mark_m, self._advance_t_s = self.position_m, self.t_s
        termination = ""
        if rep.tripped:
            self.plant.emergency_brake()
            termination = "overspeed_trip"
        elif arrived:
            termination = "arrived"
        elif to_go < -tol:
            termination = "overrun"
        elif self.position_m < -20.0:
            termination = "ran_off_start"
        elif self._furthest_m - self.position_m > cfg["rollback_trip_m"]:
            termination = "rolled_back"
        elif cfg["idle_limit_s"] is not None and self.t_s - self._advance_t_s >= cfg["idle_limit_s"] - 1e-9:
            termination = "stopped_short"
        failed = termination in ("overspeed_trip", "overrun", "ran_off_start", "rolled_back", "stopped_short")
        terminated = termination != ""
        truncated = False
        if not terminated and self.t_s >= self.max_episode_s - 1e-9:
            truncated = True
            termination = "time_limit"

        phi_before, phi_after = self._phi, self._potential()
        self._phi = phi_after
        rewards = reward_terms(
            cfg["reward_weights"],
            progress_m=self.position_m - s_start,
            track_length_m=self.track.length_m,
            step_s=self.step_s,
            energy_j=energy,
            cost=rep.cost,
            arrived=termination == "arrived",
            stop_error_m=to_go,
            stop_tolerance_m=tol,
            failed=failed,
            idle=termination == "stopped_short",
            shaping=shaping_reward(phi_before, phi_after, cfg["shaping_gamma"], terminated),
            # the limit the policy was shown when it chose this action (the observation is rebuilt below)
            over_cautious_mps=self.speed_mps - self._cautious_mps,
        )
        reward = float(sum(rewards.values()))
        self.episode_cost += rep.cost
        for r, hit in rep.violations.items():
            self.violation_counts[r] += int(hit)
        self._last_violations = tuple(r for r, hit in rep.violations.items() if hit)
        self._last_cost = rep.cost
        if terminated or truncated:
            # Stepping on would run physics past an emergency brake or the station; Gymnasium forbids it.
            self._episode_over = True
            self._end_reason = f"{'terminated' if terminated else 'truncated'}: {termination}"
        obs = self._observation()
        info = self._info(rep.cost, rep.costs, rep.violations, rewards, termination == "arrived", termination)
        if self.render_mode == "human":
            self.render()
        return obs, reward, terminated, truncated, info

    # ------------------------------------------------------------------------------------------------------------
    def _estimated_limit(self, est: tuple[float, float, float, float]) -> float:
        if isinstance(self.observer, PriorObserver):
            return self._none_limit
        mass = min(max(est[0], 1.0), 10.0 * self.vehicle.max_mass_kg)
        slope = min(max(est[1], -1.2), 1.2)
        return speed_limit_mps(self.vehicle, mass, slope)

    def _conservative_limit(self) -> float:
        """Limit for the estimate's pessimistic corner: mass + 2 sigma, slope - 2 sigma (for shields)."""
        if isinstance(self.observer, PriorObserver):
            return self._none_limit
        m, th, ms, ts = self._estimate
        mass = min(max(m + 2.0 * ms, 1.0), 10.0 * self.vehicle.max_mass_kg)
        slope = min(max(th - 2.0 * ts, -1.2), 1.2)
        return speed_limit_mps(self.vehicle, mass, slope)

    def _feedforward_estimate(self) -> tuple[float, float]:
        """Mass and slope for the env-side force demands: the estimate, the model-free grade where they differ."""
        m, th, _, _ = self._estimate
        mf = self.obs_builder.grade_mf_rad
        if mf is not None and abs(mf - th) > FEEDFORWARD_CROSS_CHECK_RAD:
            # The estimators' slope can be confidently wrong by 5-12 deg while braking (docs/agents.md).
            th = mf
        return m, th

    def _accelerate(self, action: float) -> float:
        """``action_mode="acceleration"``: the plant command for the acceleration demand of ``action``.

        The demand ramps the tracker's target speed (the tracker's loop, not the estimate alone, gets a train
        whose mass is still unknown past its breakaway force) and is fed forward as a force.
        """
        m, th = self._feedforward_estimate()
        speed = self.obs_builder.speed_mps
        self._accel_demand = accel_demand_mps2(action, self.config["accel_demand_mps2"])
        self._target_mps = ramp_target_mps(self._target_mps or 0.0, self._accel_demand, self.step_s, speed)
        return self._tracker.command(self._target_mps, speed, m, th, self._accel_demand)

    def _track(self, action: float) -> float:
        """``action_mode="speed_target"``: the plant command that tracks the target speed of ``action``."""
        m, th = self._feedforward_estimate()
        span = self.config["speed_target_range"]
        cap = self._cautious_mps
        if self.config["speed_target_cap"] == "station":
            # the envelope divided by the span's top, so that no action asks for more than the envelope
            cap = min(cap, station_envelope_mps(self.station_m - self.obs_builder.odometry_m) / max(span[1], 1.0))
        self._target_mps = target_speed_mps(action, cap, span)
        return self._tracker.command(self._target_mps, self.obs_builder.speed_mps, m, th)

    def _potential(self) -> float:
        return potential(
            self.config["reward_weights"]["shaping"], self.speed_mps, self.station_m - self.position_m,
            self.true_limit_mps,
        )

    def _observation(self) -> np.ndarray:
        m, th, ms, ts = self._estimate
        slip = self.observer.extras.get("slip_ratio") if self.config["slip_observation"] == "estimator" else None
        prior = self._none_limit if isinstance(self.observer, PriorObserver) else None
        obs = self.obs_builder.build(self.last_command, m, th, ms, ts, self._est_limit, slip, prior)
        self._cautious_mps = float(obs[13]) * self.obs_builder.v_max
        if self.config["idle_clock_observation"]:
            limit = self.config["idle_limit_s"]
            clock = min(max((self.t_s - self._advance_t_s) / limit, 0.0), 1.0) if limit is not None else 0.0
            obs = np.append(obs, np.float32(clock))
        if self.config["vehicle_observation"]:
            obs = np.append(obs, np.array(vehicle_entries(self.vehicle, m, self.obs_builder.speed_mps), np.float32))
        return obs

    def _info(self, cost, costs, violations, rewards, success, termination) -> dict[str, Any]:
        m, th, ms, ts = self._estimate
        c = self.conditions
        return {
            "cost": float(cost),
            "costs": dict(costs),
            "violations": dict(violations),
            "rewards": dict(rewards),
            "is_success": bool(success),
            "termination": termination,
            "t_s": self.t_s,
            "position_m": self.position_m,
            "distance_to_go_m": self.station_m - self.position_m,
            "speed_mps": self.speed_mps,
            "command": self.last_command,
            "true_mass_kg": self.true_mass_kg,
            "est_mass_kg": m,
            "est_mass_std_kg": ms,
            "true_slope_rad": self.true_slope_rad,
            "est_slope_rad": th,
            "est_slope_std_rad": ts,
            "est_extras": dict(self.observer.extras),
            "true_speed_limit_mps": self.true_limit_mps,
            "est_speed_limit_mps": self._est_limit,
            "est_speed_limit_2sigma_mps": self._conservative_limit(),
            "sway_rad": self.sway_rad,
            "episode_cost": self.episode_cost,
            "episode_energy_j": self.episode_energy_j,
            "violation_counts": dict(self.violation_counts),
            "track_length_m": self.track.length_m,
            "load_kg": c.load_kg,
            "running_resistance": c.running_resistance,
            "adhesion": c.adhesion,
            "wet_rail": c.wet,
            "wheel_wear_m": c.wheel_wear_m,
            "max_climbable_grade_rad": self.safety.climbable_rad,
            "observer": self.observer.name,
            **({} if self._tracker is None else {"target_speed_mps": self._target_mps}),
            **({"accel_demand_mps2": self._accel_demand} if self.config["action_mode"] == "acceleration" else {}),
        }

    # ------------------------------------------------------------------------------------------------------------
    def render(self):
        if self.render_mode is None:
            gym.logger.warn("render() called without a render_mode; pass render_mode='rgb_array' or 'human'")
            return None
        if self.plant is None:
            raise RuntimeError("UUOMTrackEnv.render() called before reset()")
        from uuom_gym.envs.rendering import Frame, Renderer

        if self._renderer is None:
            cfg = self.config
            self._renderer = Renderer(self.render_mode, cfg["render_size"], cfg["render_window_m"], cfg["render_fps"])
        m, th, ms, ts = self._estimate
        frame = Frame(
            track_s_m=self.track.s_m,
            track_elevation_m=self.track.z_m,
            track_length_m=self.track.length_m,
            position_m=self.position_m,
            sway_rad=self.sway_rad,
            speed_mps=self.speed_mps,
            true_limit_mps=self.true_limit_mps,
            est_limit_mps=self._est_limit,
            true_mass_kg=self.true_mass_kg,
            est_mass_kg=m,
            mass_std_kg=ms,
            true_slope_rad=self.true_slope_rad,
            est_slope_rad=th,
            slope_std_rad=ts,
            command=self.last_command,
            t_s=self.t_s,
            cost=self._last_cost,
            observer=self.observer.name,
            train_length_m=self.vehicle.length_m,
            violations=self._last_violations,
        )
        return self._renderer.draw(frame)

    def close(self):
        if self._renderer is not None:
            self._renderer.close()
            self._renderer = None
        super().close()


FEEDFORWARD_CROSS_CHECK_RAD = 0.035
"""speed_target tracker: use the model-free grade for the feed-forward when it differs more than this (2 deg)."""


def _make_vehicle(spec: Any) -> VehicleParams:
    if spec is None:
        return DEFAULT_VEHICLE
    if isinstance(spec, VehicleParams):
        return spec
    if isinstance(spec, Mapping):
        return DEFAULT_VEHICLE.with_changes(**dict(spec))
    if isinstance(spec, (str, os.PathLike)):  # a vehicle file: JSON-able, so an evaluation's tasks can carry it
        try:
            return VehicleParams.from_toml(spec)
        except VehicleFileError as exc:
            raise ConfigError(f"config key 'vehicle': {exc}") from None
    raise ConfigError(f"config key 'vehicle' must be None, a VehicleParams, a dict of overrides or the path of a "
                      f"TOML vehicle file, got {spec!r}")


__all__ = ["InvalidActionError", "ResetNeeded", "UUOMTrackEnv"]
