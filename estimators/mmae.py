"""Multiple-model adaptive estimation (MMAE) of the payload, after patent CN101467011 (spec ``model.md`` §5.6).

A bank of ``r`` continuous-discrete extended Kalman filters runs on the same data, model ``j`` assuming the payload
``p_j`` (spread evenly over ``[payload_min_kg, payload_max_kg]``). Each filter tracks ``x_j = [v, theta, kappa]``
(ground speed, track slope at the accelerometer, slope curvature ``d theta / ds``) with the longitudinal model of
spec §2::

    (M_j + m_rot) dv/dt = T/r - m_f g [sin(theta) + mu cos(theta) s(v)] - m_rj g [sin(theta_r) + mu cos(theta_r) s(v)]
    d theta / dt        = kappa v                   (+ a small random walk)
    d kappa / ds        = w_kappa                   (random walk in distance: vertical curves start and end)

with ``s(v) = tanh(v / v_s)``. With ``resistance_std > 0`` every filter also estimates ``dmu``, the offset of ``mu``
from the vehicle file's (a fourth state, a random walk of intensity ``resistance_walk_std``; learnt only while the
train moves faster than 0.1 m/s and the probabilities learn, else held as a Schmidt consider parameter). On level
track at constant speed ``T/r = M g mu`` ties ``dmu`` and the payload one to one; grade changes and accelerations
separate them (docs/estimation.md, session 16).

The train is 18 m long: its front part ``m_f`` (the drive section carrying the accelerometer,
``front_mass_fraction`` of the empty mass) is on the slope ``theta`` at the accelerometer, its rear part ``m_rj``
(the rest of the empty mass plus the payload ``p_j`` hanging from the lifting beams) on the slope ``theta_r``
``rear_offset_m`` metres behind. ``theta_r`` is not a state: the bank remembers a model-free slope
measurement ``asin((f - dv/dt) / g)`` (low-passed) along the distance travelled (odometry from the measured speed)
and looks up where the rear is now. (Remembering the bank's own estimate instead fed its errors back: measured
slope errors of 1.5 deg on level track.) On a short
vertical curve (the road test: 0 to 11 deg in 8 m) a single-slope model put the whole mass on the accelerometer's
slope and drove the payload to the edge of the bank (measured, docs/mmae_aupf.md). The slope reported is
``theta``, at the train's reference point (``position_m`` of the plant). A trace does not say where gravity acts,
so by default (``point_models``) the bank runs every payload twice, as this two-section train and as a point mass
(the whole train on ``theta``), and the same Bayesian update weighs the geometries; the environment, whose plant
is the two-section train, turns the twins off.

The mean is propagated with a fixed-step fourth-order Runge-Kutta step of the speed equation (as the patent does;
over one sample the slope is held and then advanced by ``kappa`` times the distance travelled), the covariance with
the first-order transition matrix of the linearised model. Measurements are

* the ground speed ``v`` (encoder on a carrying wheel), and
* the along-track accelerometer, modelled as what it is, the specific force ``f = dv/dt + g sin(theta)``.

``f`` is what makes the payload identifiable without acceleration excitation: it is the contact force per unit
mass, so ``f (M + m_rot) ~ T/r - mu M g`` ties the mass to the measured torque while the train pulls. The speed
(through ``dv/dt = f - g sin(theta)``) makes the slope observable.

The two measurements are applied one after the other as scalar updates (exactly equivalent to the joint update for
independent noises); the model likelihood is the product of the two scalar innovation densities (chain rule).
Model probabilities are updated in the log domain, floored at ``prob_floor`` (so a model that lost can win again
after a load change at a station) and renormalised. Estimates are the mixture mean and covariance, including the
spread-of-means term.

Two gates keep the probabilities from learning from data that carry no payload information or break the model:
the probabilities are frozen when the drive force ``T/r`` is below ``min_traction_n`` (coasting or braking: the
brake cars act with a force that is not measured) or the train is at standstill, and when even the best model's
normalised innovation squared exceeds ``gate_nis`` (spikes, faults). A measurement that fails that gate in
every model is an outlier and updates no state either, unless it has done so for 40 samples in a row (then it is
a real step and is followed); ``n_outliers`` counts them.

Two sensor faults stay within the plausible range and reach every model's likelihood: a torque spike (the torque
is the model's input, which no innovation gate sees) and a frozen accelerometer. A torque sample that jumps by more
than ``torque_jump_fraction`` of the maximum traction torque is held back until the next one confirms it, and an
accelerometer that repeats one value ``stuck_repeats`` times in a row is dropped while it does
(:mod:`estimators.input_faults`).

Bad input: NaN and physically impossible values (:class:`~estimators.input_limits.InputLimits`: ``inf``,
``1e300``) are missing samples; a ``dt`` above :data:`~estimators.filters.MAX_STEP_S` is a gap predicted over that
long; a model whose state stops being finite is restarted. The tuning is :class:`~estimators.mmae_config.MMAEConfig`;
the per-model arithmetic is one compiled loop in :mod:`estimators.mmae_kernel`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from uuom_core.vehicle import G_MPS2, VehicleParams

from .base import Estimate, Estimator
from .config import split_options
from .filters import MAX_STEP_S, check_dt_non_negative
from .input_faults import JumpGate, StuckDetector
from .input_limits import InputLimits, plausible
from . import mmae_kernel as _kernel
from .mmae_config import MMAEConfig, MMAEConfigError

_REPAIR_EVERY = 50
_MAX_CURVATURE_RAD_PER_M = 0.05  # the bound of the curvature's std (a 20 m vertical radius)
_RELOCK_AFTER = 40  # consecutive outliers of one measurement after which it is believed again (a real step)
_SLOPE_TAU_S = 1.0  # low-pass of the model-free slope that feeds the rear-section slope history
# the resistance offset learns only while the train clearly moves: near standstill the plant's friction is static
# (not mu times the sign of the speed), and a holding torque read through the moving model passed for a smaller mu
# (measured on pm-stop-and-go: mu 0.02 -> 0.005)
_MU_MIN_SPEED_MPS = 0.1


class MMAEEstimator(Estimator):
    """Bank of continuous-discrete EKFs over hypothesised payloads with Bayesian model probabilities.

    Parameters
    ----------
    vehicle : VehicleParams, optional
        Empty mass, rated load, drive radius, rotating mass and nominal running resistance come from here.
    config : MMAEConfig, optional
        The bank's tuning (see :class:`~estimators.mmae_config.MMAEConfig` for every field and its default).
    **options
        Fields of :class:`~estimators.mmae_config.MMAEConfig` given by name (``n_models=50``); they override
        ``config``. Unknown names raise ``TypeError``, bad values :class:`MMAEConfigError`.

    Attributes
    ----------
    config : MMAEConfig
        The validated tuning.
    payloads_kg : ndarray, shape (n_models,)
        The hypothesised payloads.
    dim_x : int
        3, or 4 when the running resistance is estimated (``resistance_std`` or ``resistance_walk_std`` above 0).
    x : ndarray, shape (n_models, dim_x)
        Per-model state ``[v_mps, slope_rad, curvature_rad_per_m]``, plus ``resistance_offset`` (the running
        resistance coefficient minus the model's ``running_resistance``) when it is estimated.
    P : ndarray, shape (n_models, dim_x, dim_x)
        Per-model state covariance.
    probabilities : ndarray, shape (n_models,)
        Current model probabilities (sum to 1).
    """

    name = "mmae"
    provides = frozenset({"mass", "slope"})

    def __init__(self, vehicle: VehicleParams | None = None, config: MMAEConfig | None = None,
                 **options: Any) -> None:
        cfg, rest = split_options(MMAEConfig, config, options)
        super().__init__(vehicle, **rest)
        veh = self.vehicle
        self.config = cfg
        grid = cfg.payloads_kg(veh)
        both = cfg.with_point_models
        # with point models the bank is the payload grid twice: first the two-section train, then the point mass
        self.payloads_kg = np.concatenate([grid, grid]) if both else grid
        self.n_models = len(self.payloads_kg)
        self._mu = cfg.running_resistance_for(veh)
        # per-model mass terms, divided by the effective (translating + rotating) mass once here
        self._mass = veh.empty_mass_kg + self.payloads_kg
        self._m_rot = veh.rotating_mass_kg
        self._inv_meff = 1.0 / (self._mass + self._m_rot)
        self._radius = veh.drive_wheel_radius_m
        m_front = np.full(self.n_models, float(cfg.front_mass_fraction) * veh.empty_mass_kg)
        if cfg.rear_offset_m == 0.0:  # point mass: every part on the accelerometer's slope
            m_front = self._mass.copy()
        elif both:
            m_front[len(grid):] = self._mass[len(grid):]
        m_rear = self._mass - m_front
        self._gf = G_MPS2 * m_front * self._inv_meff
        self._gf_mu = self._gf * self._mu
        self._gr = G_MPS2 * m_rear * self._inv_meff
        self._gr_mu = self._gr * self._mu
        # noise variances and priors
        self._r_v = float(cfg.speed_std_mps) ** 2
        self._r_f = float(cfg.accel_std_mps2) ** 2
        self._q_v = float(cfg.accel_process_std_mps2) ** 2
        self._q_kappa_per_m = float(cfg.curvature_change_std) ** 2
        self._q_th_floor = float(cfg.slope_process_floor_radps) ** 2
        self._p0_kappa = float(cfg.initial_curvature_std_rad_per_m) ** 2
        self._p0_th = float(cfg.initial_slope_std_rad) ** 2
        self._p0_v = float(cfg.initial_speed_std_mps) ** 2
        self._p0_mu = float(cfg.resistance_std) ** 2
        self._q_mu = float(cfg.resistance_walk_std) ** 2
        self._estimates_mu = self._p0_mu > 0.0 or self._q_mu > 0.0
        # what the covariance may grow to over long gaps: the speed's and slope's no worse than twice the prior's std
        # (the speed's at least 5 m/s, faster than any monorail); the curvature's random walk grows past its prior
        # on every run (133x its variance on the project's runs), so it is bounded by a 20 m vertical radius; the
        # offset's is unbounded where it has no prior (it only grows linearly)
        self._p_max = np.array([max(4.0 * self._p0_v, 25.0), 4.0 * self._p0_th,
                                max(4.0 * self._p0_kappa, _MAX_CURVATURE_RAD_PER_M**2),
                                4.0 * self._p0_mu if self._p0_mu > 0.0 else math.inf])
        self.dim_x = 4 if self._estimates_mu else 3
        # rear-slope history along the distance travelled
        self._rear_offset = float(cfg.rear_offset_m)
        self._hist_step = float(cfg.history_step_m)
        self._hist_len = int(math.ceil(self._rear_offset / self._hist_step)) + 16
        # gates and the probability floor
        self._floor = float(cfg.prob_floor)
        self._min_traction_n = float(cfg.min_traction_n)
        self._standstill = float(cfg.standstill_speed_mps)
        self._learn_min_speed = float(cfg.learn_min_speed_mps)
        self._v_s = float(cfg.smooth_speed_mps)
        self._gate_nis = float(cfg.gate_nis)
        self._limits = InputLimits.for_vehicle(veh)
        self._torque_gate = JumpGate(float(cfg.torque_jump_fraction) * veh.max_traction_n * self._radius)
        self._accel_stuck = StuckDetector(int(cfg.stuck_repeats))
        self._consts = _kernel.pack_constants(self._inv_meff, self._gf, self._gf_mu, self._gr, self._gr_mu,
                                              self.payloads_kg)
        self._moments = np.empty(7)
        # half-spacing quantisation of the payload grid: the mixture cannot resolve finer than this
        spacing = self.payloads_kg[1] - self.payloads_kg[0]
        self._grid_var = spacing**2 / 12.0
        self.reset()

    # ------------------------------------------------------------------------------------------------------
    def reset(self) -> None:
        n = self.n_models
        self._x = np.zeros((n, _kernel.N_STATES))
        self._P = np.zeros((n, _kernel.N_STATES, _kernel.N_STATES))
        self._P[:] = self._prior_covariance()
        self._log_prob = np.full(n, -math.log(n))
        self._n_since_repair = 0
        self._s_m = 0.0
        self._hist = np.zeros(self._hist_len)
        self._hist_first = 2**62  # no history yet
        self._hist_last = -(2**62)
        self._v_lp: float | None = None
        self._f_lp = 0.0
        self._slope_lp = 0.0
        self._initialised = False
        self._last_torque = 0.0
        self._torque_gate.reset()
        self._accel_stuck.reset()
        self._n_rejected_v = 0
        self._n_rejected_f = 0
        self.n_outliers = 0
        self._estimate = self._mixture()

    def _prior_covariance(self) -> np.ndarray:
        return np.diag([self._p0_v, self._p0_th, self._p0_kappa, self._p0_mu])

    @property
    def x(self) -> np.ndarray:
        return self._x[:, : self.dim_x].copy()

    @property
    def P(self) -> np.ndarray:
        return self._P[:, : self.dim_x, : self.dim_x].copy()

    @property
    def probabilities(self) -> np.ndarray:
        return np.exp(self._log_prob)

    @property
    def estimate(self) -> Estimate:
        return self._estimate

    # ------------------------------------------------------------------------------------------------------
    def _rear_slope(self) -> float:
        """Slope under the rear section: the slope the accelerometer measured where the rear is now."""
        if self._rear_offset == 0.0:
            return math.nan
        b = math.floor((self._s_m - self._rear_offset) / self._hist_step)
        if b < self._hist_first or self._hist_last - b >= self._hist_len:
            return self._slope_lp  # no history that far back: assume one slope under the whole train
        return float(self._hist[b % self._hist_len])

    def _measure_slope(self, speed_mps: float, accel_mps2: float, dt: float) -> None:
        """Model-free slope at the accelerometer, ``asin((f - dv/dt) / g)``, low-passed (time constant tau).

        The same first-order low-pass on ``f`` and ``v`` keeps them aligned, and the derivative of the filtered
        speed is exactly ``(v - v_lp) / tau``. The result lags by about ``tau``, i.e. ``tau v`` metres, which is
        where it is remembered. It uses no mass hypothesis, so the slope history cannot feed a model's error back.
        """
        if self._v_lp is None:
            self._v_lp, self._f_lp = speed_mps, accel_mps2
        a = min(dt / _SLOPE_TAU_S, 1.0)
        dv = (speed_mps - self._v_lp) / _SLOPE_TAU_S
        self._v_lp += a * (speed_mps - self._v_lp)
        self._f_lp += a * (accel_mps2 - self._f_lp)
        self._slope_lp = math.asin(min(max((self._f_lp - dv) / G_MPS2, -0.9), 0.9))
        self._remember_slope(self._slope_lp, self._s_m - _SLOPE_TAU_S * speed_mps)

    def _remember_slope(self, slope_rad: float, s_m: float) -> None:
        b = math.floor(s_m / self._hist_step)
        if self._hist_first > b:  # first sample
            self._hist_first = self._hist_last = b
            self._hist[b % self._hist_len] = slope_rad
        if b - self._hist_last > self._hist_len:  # moved on farther than the history holds: one slope for it all
            self._hist[:] = slope_rad
            self._hist_last = b
        while self._hist_last < b:  # moving forward: fill every bin passed since the last sample
            self._hist_last += 1
            self._hist[self._hist_last % self._hist_len] = slope_rad

    def _predict(self, torque_nm: float, dt: float, held: bool, speed_abs: float) -> None:
        # fixed-step RK4 of the speed equation (v-dependent through the smooth resistance); over one step the slope
        # is held, then advanced by kappa times the distance travelled (exact for linear v). Held at rest (parking
        # brake / static friction): no motion, only the process noise.
        th_rear = math.nan if held else self._rear_slope()
        _kernel.predict(self._x, self._P, self._consts, torque_nm, dt, held, speed_abs, th_rear, self._radius,
                        1.0 / self._v_s, self._q_v, self._q_th_floor, self._q_kappa_per_m, self._q_mu, self._p_max)

    def _condition(self) -> None:
        # Both the prediction (Phi P Phi^T + Q) and the update (P - g g^T / s) are symmetric by construction;
        # round-off can only creep in slowly, so the repair (symmetrise, floor the variances, clip correlations)
        # runs every ``_REPAIR_EVERY`` samples.
        self._n_since_repair += 1
        if self._n_since_repair < _REPAIR_EVERY:
            return
        self._n_since_repair = 0
        self._heal()
        P = 0.5 * (self._P + np.swapaxes(self._P, 1, 2))
        d = np.einsum("nii->ni", P)
        # the resistance offset's variance stays exactly 0 when it is not estimated (its correlations too)
        floored = d if self._estimates_mu else d[:, :3]
        np.maximum(floored, 1e-14, out=floored)
        for a, b in ((0, 1), (0, 2), (1, 2), (0, 3), (1, 3), (2, 3)):
            lim = 0.999 * np.sqrt(P[:, a, a] * P[:, b, b])
            c = np.clip(P[:, a, b], -lim, lim)
            P[:, a, b] = c
            P[:, b, a] = c
        self._P = P

    def _heal(self) -> bool:
        """Restart every model whose state or covariance is no longer finite; True if one was.

        Inputs are gated (:class:`~estimators.input_limits.InputLimits`), so this is a last line of defence: a
        restarted model takes the prior slope and curvature around the bank's finite speed, and its probability
        is kept (a NaN log-probability restarts all of them uniform).
        """
        bad = ~(np.isfinite(self._x).all(axis=1) & np.isfinite(self._P).all(axis=(1, 2)))
        lp_bad = not np.isfinite(self._log_prob).all()
        if not bad.any() and not lp_bad:
            return False
        good_v = self._x[~bad, 0]
        self._x[bad] = 0.0
        self._x[bad, 0] = float(good_v.mean()) if good_v.size else 0.0
        self._P[bad] = self._prior_covariance()
        if lp_bad:
            self._log_prob = np.full(self.n_models, -math.log(self.n_models))
        return True

    def _finish(self) -> Estimate:
        e = self._mixture()
        if not all(map(math.isfinite, (e.mass_kg, e.slope_rad, e.mass_std_kg, e.slope_std_rad))):
            self._heal()
            e = self._mixture()
        self._estimate = e
        return e

    def update(self, torque_nm: float, speed_mps: float, accel_mps2: float, dt_s: float,
               motor_speed_radps: float = math.nan, gyro_radps: float = math.nan,
               accel_normal_mps2: float = math.nan) -> Estimate:
        """Process one sample; NaN inputs are treated as missing (``accel_mps2`` is the specific force).

        A value beyond :class:`~estimators.input_limits.InputLimits` (``inf``, ``1e300``) counts as missing too. A
        ``dt_s`` above :data:`~estimators.filters.MAX_STEP_S` is a data gap: the bank predicts over that long.
        Raises ``ValueError`` for a ``dt_s`` that is NaN, infinite or negative.
        """
        check_dt_non_negative(dt_s, "mmae")
        dt_s = min(dt_s, MAX_STEP_S)
        lim = self._limits
        torque_nm = plausible(torque_nm, lim.torque_nm)
        speed_mps = plausible(speed_mps, lim.speed_mps)
        accel_mps2 = plausible(accel_mps2, lim.accel_mps2)
        torque_nm = self._torque_gate(torque_nm)
        accel_mps2 = self._accel_stuck(accel_mps2)
        have_v = math.isfinite(speed_mps)
        have_f = math.isfinite(accel_mps2)
        have_t = math.isfinite(torque_nm)
        if have_t:
            self._last_torque = float(torque_nm)
        if not self._initialised:
            if not have_v:
                return self._estimate
            self._x[:, 0] = speed_mps
            self._initialised = True
        held = have_v and abs(speed_mps) < self._standstill and abs(self._last_torque) / self._radius < (
            self._min_traction_n
        )
        saved = (self._s_m, self._v_lp, self._f_lp, self._slope_lp, self._hist_first, self._hist_last)
        if dt_s > 0.0:
            speed = speed_mps if have_v else float(np.exp(self._log_prob) @ self._x[:, 0])
            self._s_m += speed * dt_s  # odometry for the slope history
            self._predict(self._last_torque, dt_s, held, abs(speed))
        # with the torque missing the measurement model is unknown: predict only, and keep a sample the bank cannot
        # check out of the model-free slope history (an outlier there would bias the rear slope 9 m later)
        if not have_t:
            if have_v and dt_s > 0.0:
                nis_v = (speed_mps - self._x[:, 0]) ** 2 / (self._P[:, 0, 0] + self._r_v)
                if float(nis_v.min()) > self._gate_nis:  # a speed outlier: odometry from the bank instead
                    self._s_m = saved[0] + float(np.exp(self._log_prob) @ self._x[:, 0]) * dt_s
            self._condition()
            return self._finish()
        if have_v and have_f and self._rear_offset > 0.0 and dt_s > 0.0:
            self._measure_slope(speed_mps, accel_mps2, dt_s)
        th_rear = self._rear_slope()
        informative = (
            have_v and have_f and not held and abs(torque_nm) / self._radius >= self._min_traction_n
            and abs(speed_mps) >= self._learn_min_speed
        )
        rejected = _kernel.correct(
            self._x, self._P, self._log_prob, self._consts, torque_nm, speed_mps, accel_mps2, have_v, have_f,
            th_rear, self._radius, self._v_s, self._r_v, self._r_f, informative, self._gate_nis, self._floor,
            self._n_rejected_v >= _RELOCK_AFTER, self._n_rejected_f >= _RELOCK_AFTER,
            informative and abs(speed_mps) >= _MU_MIN_SPEED_MPS,
        )
        self._n_rejected_v = self._n_rejected_v + 1 if rejected & 1 else 0
        self._n_rejected_f = self._n_rejected_f + 1 if rejected & 2 else 0
        self.n_outliers += rejected.bit_count()
        if rejected:
            # an outlier must not enter the model-free slope history nor the odometry either: take them back
            # (bins written meanwhile lie beyond the restored end and are never read before being rewritten)
            s_prev = saved[0]
            self._s_m, self._v_lp, self._f_lp, self._slope_lp, self._hist_first, self._hist_last = saved
            if dt_s > 0.0:
                self._s_m = s_prev + float(np.exp(self._log_prob) @ self._x[:, 0]) * dt_s
        self._condition()
        return self._finish()

    def _mixture(self) -> Estimate:
        out = self._moments
        _kernel.mixture(self._x, self._P, self._log_prob, self._consts, out)
        payload, payload_var, slope, slope_var, speed, p_max, dmu = out.tolist()
        # the slope at the accelerometer = the train's reference point (the plant's truth convention)
        extras = {"speed_mps": speed, "model_prob_max": p_max}
        if self._estimates_mu:
            extras["running_resistance"] = self._mu + dmu
        return Estimate(
            mass_kg=self.vehicle.empty_mass_kg + payload,
            slope_rad=slope,
            mass_std_kg=math.sqrt(payload_var + self._grid_var),
            slope_std_rad=math.sqrt(max(slope_var, 0.0)),
            extras=extras,
        )

    def mixture_covariance(self) -> np.ndarray:
        """Mixture covariance of the state: ``sum_j mu_j (P_j + (x_j - x)(x_j - x)^T)``."""
        prob = self.probabilities
        prob = prob / prob.sum()
        x = self.x
        mean = prob @ x
        d = x - mean
        return np.einsum("j,jab->ab", prob, self.P) + np.einsum("j,ja,jb->ab", prob, d, d)


__all__ = ["MMAEConfig", "MMAEConfigError", "MMAEEstimator"]
