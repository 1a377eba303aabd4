"""Adaptive unscented particle filter (AUPF) for drive slip and effective drive-wheel radius (paper 004, spec §5.8).

Paper 004 estimates the track slip ratio and the effective drive-wheel radius of a deep-sea crawler with a particle
filter whose importance density comes from an adaptive UKF (AUKF) run per particle, resampling on the effective
sample size. This module transfers the method to the monorail's friction drive.

Quantities
----------
* Slip ratio (traction): ``i = (omega r - v) / (omega r)`` while ``omega r >= v``; in a skid ``i = (omega r - v) / v``
  (negative). ``omega`` is the drive-wheel angular speed (``motor_speed_radps / gear_ratio``), ``v`` the ground speed
  (encoder on a non-driven carrying wheel), ``r`` the effective drive-wheel radius (nominal minus wear).
* Measurement: ``v = omega r (1 - i)`` (``omega r / (1 + i)`` for ``i < 0``); its noise variance ``R`` mixes the two
  encoders' noise and quantisation and is adapted online per particle (Sage-Husa, fading factor ``b``): the
  "adaptive" of the AUKF.

Model of the slip (what the particles sample)
---------------------------------------------
Each particle carries a slip ratio ``i``, an adhesion regime ``s`` (0: adhering, 1: macro-slip), and a Gaussian
belief ``N(rho, Sigma)`` of the radius.

* Adhering: ``i`` relaxes with time constant ``slip_time_constant_s`` to the creep curve of the friction drive,
  ``i* = -i_c ln(1 - u / mu_a)``, ``u = |T| / (r N_clamp)`` (the saturating shear law paper 004 uses for the track,
  eq. 1; ``mu_a`` the dry adhesion), with small process noise (``slip_process_std``).
* Macro-slip: ``i`` is a fast random walk (``macro_slip_process_std``), bounded by ``max_slip``.
* Regime switches are a Markov chain: adhering -> slipping at rate ``slip_onset_rate_hz`` times a logistic
  function of how far ``u`` is above ``0.8 x`` the wet-rail adhesion (slip needs traction beyond the adhesion), plus
  ``spontaneous_slip_rate_hz``; slipping -> adhering at ``slip_recovery_rate_hz``.
* Radius: a slow random walk (``radius_process_std_m_per_sqrt_s``). Given a particle's slip, the measurement is
  *linear* in ``r``, so the radius is not sampled but Kalman-filtered exactly per particle (Rao-Blackwellised). A
  sampled radius, updated from the sample, diffused by the proposal's spread on every sample (measured: the
  radius wandered by +-4 mm and followed the slip), which is why it is marginalised.

One step, all particles at once (numpy)
---------------------------------------
1. Draw each particle's regime from the Markov chain.
2. AUKF per particle on ``[i, r]`` from ``([i_j, rho_j], diag(0, Sigma_j))``: unscented prediction through the
   regime's slip model plus process noise, unscented update with the measured ``v`` (sigma-point weights with
   ``lambda = n (alpha^2 - 1)``, ``beta = 2``, paper 004 eq. 15), adaptation of ``R_j``. Its slip marginal
   ``N(ihat_j, Phat_j)`` is the importance density.
3. Draw ``i_j ~ N(ihat_j, Phat_j)``; Kalman-update the radius given ``i_j``; log-weight
   ``+= log p(v | i_j, rho_j, Sigma_j) + log p(i_j | i_j^-, s_j) - log q(i_j)``.
4. Normalise in the log domain. If no particle explains the sample (every log-likelihood below
   ``underflow_log_likelihood`` or non-finite: the weights would all underflow to 0), treat the sample as an
   outlier: learn nothing from it, reset the weights to uniform and widen the radius beliefs instead of dividing
   by zero. Resample (systematic) when the effective sample size
   falls below ``resample_ess_fraction * n_particles``.

Below ``min_speed_mps`` ground speed the filter does not weight particles: with the drive wheel's rim speed above
twice the ground speed and twice ``min_speed_mps`` the train has stalled with the wheel spinning and the slip is set
from plain kinematics (about 1; no radius information); with the wheel at rest too, it only predicts. The radius
belief is kept within ``[0.5, 1.02] x`` nominal. The filter does not estimate mass or slope: it reports
the prior (mid-range mass, level track) with large standard deviations. Its results are in ``extras``:
``slip_ratio``, ``slip_ratio_std``, ``drive_radius_m``, ``drive_radius_m_std``, ``macro_slip_prob`` (posterior
probability of the macro-slip regime) and ``ess_fraction``.

(Module length, ~430 lines: one filter class whose docstrings are its manual, one method per step above; the tuning
lives in :mod:`estimators.aupf_config`.)
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from uuom_core.vehicle import VehicleParams

from .aupf_config import AUPFConfig, AUPFConfigError
from .base import Estimate, Estimator
from .config import split_options
from .filters import MAX_STEP_S, check_dt_non_negative, sage_husa_weight
from .input_limits import InputLimits, plausible

_LOG_2PI = math.log(2.0 * math.pi)
_N_STATE = 2


def _unscented_weights(n: int, alpha: float, beta: float) -> tuple[float, np.ndarray, np.ndarray]:
    """Sigma-point spread ``sqrt(n + lambda)`` and mean / covariance weights, ``lambda = n (alpha^2 - 1)``."""
    lam = n * (alpha**2 - 1.0)
    wm = np.full(2 * n + 1, 1.0 / (2.0 * (n + lam)))
    wc = wm.copy()
    wm[0] = lam / (n + lam)
    wc[0] = lam / (n + lam) + (1.0 - alpha**2 + beta)
    return math.sqrt(n + lam), wm, wc


class AUPFEstimator(Estimator):
    """Adaptive unscented particle filter for the drive slip ratio and the effective drive-wheel radius.

    Parameters
    ----------
    vehicle : VehicleParams, optional
        Nominal drive-wheel radius, clamp force, dry and wet adhesion come from here.
    config : AUPFConfig, optional
        The filter's tuning (see :class:`~estimators.aupf_config.AUPFConfig` for every field and its default).
    **options
        Fields of :class:`~estimators.aupf_config.AUPFConfig` given by name (``n_particles=128``); they override
        ``config``. Unknown names raise ``TypeError``, bad values :class:`AUPFConfigError`.

    Attributes
    ----------
    config : AUPFConfig
        The validated tuning.
    slip : ndarray, shape (n_particles,)
        Every particle's slip ratio.
    regime : ndarray of int8, shape (n_particles,)
        0 adhering, 1 macro-slip.
    radius_mean_m, radius_var_m2 : ndarray, shape (n_particles,)
        Every particle's Gaussian belief of the radius.
    weights : ndarray, shape (n_particles,)
        Normalised particle weights.
    R : ndarray, shape (n_particles,)
        Every particle's adapted measurement-noise variance.
    n_resamples, n_underflow_recoveries : int
        Diagnostics counters.
    """

    name = "aupf"
    provides = frozenset({"slip", "radius"})

    def __init__(self, vehicle: VehicleParams | None = None, config: AUPFConfig | None = None,
                 **options: Any) -> None:
        cfg, rest = split_options(AUPFConfig, config, options)
        super().__init__(vehicle, **rest)
        veh = self.vehicle
        self.config = cfg
        self.n_particles = int(cfg.n_particles)
        self.seed = int(cfg.seed)
        self._gear = float(cfg.gear_ratio)
        self._r_nom = veh.drive_wheel_radius_m
        self._clamp_n = veh.clamp_force_n
        self._sigma0 = float(cfg.initial_radius_std_m) ** 2
        self._r_model_var = cfg.radius_model_std_for(veh) ** 2
        # slip and radius dynamics
        self._q_r = float(cfg.radius_process_std_m_per_sqrt_s) ** 2
        self._q_adh = float(cfg.slip_process_std) ** 2
        self._q_macro = float(cfg.macro_slip_process_std) ** 2
        self._tau = float(cfg.slip_time_constant_s)
        self._i_c = float(cfg.creep_slip)
        self._mu_a = cfg.adhesion_for(veh)
        self._u_onset = 0.8 * veh.adhesion_wet
        self._rate_onset = float(cfg.slip_onset_rate_hz)
        self._rate_spont = float(cfg.spontaneous_slip_rate_hz)
        self._rate_recover = float(cfg.slip_recovery_rate_hz)
        self._max_slip = float(cfg.max_slip)
        # both encoders' noise enter the one measurement equation; the adaptation refines the sum
        self._r0 = float(cfg.speed_std_mps) ** 2 + (float(cfg.motor_speed_std_radps) * self._r_nom) ** 2
        self._r_min = 0.05 * self._r0
        self._b = float(cfg.noise_fading)
        self._ess_min = float(cfg.resample_ess_fraction) * self.n_particles
        self._v_min = float(cfg.min_speed_mps)
        self._ll_floor = float(cfg.underflow_log_likelihood)
        self._gamma, self._wm, self._wc = _unscented_weights(_N_STATE, cfg.alpha, cfg.beta)
        self._limits = InputLimits.for_vehicle(veh)
        self._prior = Estimate(
            mass_kg=veh.empty_mass_kg + 0.5 * veh.rated_load_kg,
            slope_rad=0.0,
            mass_std_kg=max(veh.rated_load_kg, 1.0) / math.sqrt(12.0),
            slope_std_rad=math.radians(veh.max_grade_deg) / math.sqrt(3.0),
        )
        self.reset()

    # ------------------------------------------------------------------------------------------------------
    def reset(self) -> None:
        n = self.n_particles
        self._rng = np.random.default_rng(self.seed)
        self._i = np.zeros(n)
        self._s = np.zeros(n, dtype=np.int8)
        self._rho = np.full(n, self._r_nom)
        self._sig = np.full(n, self._sigma0)
        self._R = np.full(n, self._r0)
        self._logw = np.full(n, -math.log(n))
        self._k = 0
        self._last_torque = 0.0
        self._ess = float(n)
        self.n_resamples = 0
        self.n_underflow_recoveries = 0
        self._estimate = self._summary()

    @property
    def slip(self) -> np.ndarray:
        return self._i.copy()

    @property
    def regime(self) -> np.ndarray:
        return self._s.copy()

    @property
    def radius_mean_m(self) -> np.ndarray:
        return self._rho.copy()

    @property
    def radius_var_m2(self) -> np.ndarray:
        return self._sig.copy()

    @property
    def weights(self) -> np.ndarray:
        return np.exp(self._logw)

    @property
    def R(self) -> np.ndarray:
        return self._R.copy()

    @property
    def estimate(self) -> Estimate:
        return self._estimate

    # ------------------------------------------------------------------------------------------------------
    def creep_slip_target(self, torque_nm: float, radius_m: np.ndarray | float) -> np.ndarray:
        """Slip ratio of the dry creep curve for a drive torque at the given radius (sign of the torque)."""
        u = abs(torque_nm) / (np.maximum(np.asarray(radius_m, dtype=float), 1e-3) * self._clamp_n)
        ratio = np.minimum(u / self._mu_a, 1.0 - 1e-9)
        target = np.minimum(-self._i_c * np.log1p(-ratio), self._max_slip)
        return target if torque_nm >= 0 else -target

    def _slip_mean(self, i: np.ndarray, r: np.ndarray, macro: np.ndarray, torque: float, a: float) -> np.ndarray:
        """Predicted slip (before process noise): relaxation to the creep curve, or hold in macro-slip."""
        relaxed = i + a * (self.creep_slip_target(torque, r) - i)
        return np.where(macro, i, relaxed)

    def _h(self, i: np.ndarray, r: np.ndarray, omega: float) -> np.ndarray:
        rim = omega * r
        return np.where(i >= 0.0, rim * (1.0 - i), rim / (1.0 + i))

    def update(self, torque_nm: float, speed_mps: float, accel_mps2: float, dt_s: float,
               motor_speed_radps: float = math.nan, gyro_radps: float = math.nan,
               accel_normal_mps2: float = math.nan) -> Estimate:
        """Process one sample (torque, ground speed and motor speed are used); NaN = missing (predict only).

        A value beyond :class:`~estimators.input_limits.InputLimits` (``inf``, ``1e300``) counts as missing too. A
        ``dt_s`` above :data:`~estimators.filters.MAX_STEP_S` is a data gap: the particles predict over that long.
        Raises ``ValueError`` for a ``dt_s`` that is NaN, infinite or negative.
        """
        check_dt_non_negative(dt_s, "aupf")
        dt_s = min(dt_s, MAX_STEP_S)
        lim = self._limits
        torque_nm = plausible(torque_nm, lim.torque_nm)
        speed_mps = plausible(speed_mps, lim.speed_mps)
        motor_speed_radps = plausible(motor_speed_radps, lim.motor_speed_radps)
        if math.isfinite(torque_nm):
            self._last_torque = float(torque_nm)
        torque = self._last_torque
        omega = motor_speed_radps / self._gear if math.isfinite(motor_speed_radps) else math.nan
        # at (near) standstill a spinning wheel has slip ~1 and the ratio carries no radius information
        can_update = math.isfinite(speed_mps) and math.isfinite(omega) and abs(speed_mps) >= self._v_min
        if dt_s <= 0.0:
            return self._estimate
        macro = self._switch_regimes(torque, dt_s)
        a = min(dt_s / self._tau, 1.0)
        q_i = np.where(macro, self._q_macro, self._q_adh) * dt_s
        q_r = self._q_r * dt_s
        m_i = self._slip_mean(self._i, self._rho, macro, torque, a)
        if not can_update:
            self._predict_only(speed_mps, omega, m_i, q_i, q_r)
        else:
            y = float(speed_mps)
            hat_i, hat_p = self._aukf_proposal(y, omega, macro, torque, a, q_i, q_r)
            self._sample_and_weigh(y, omega, m_i, hat_i, hat_p, q_i, q_r)
        self._estimate = self._summary()
        return self._estimate

    def _switch_regimes(self, torque: float, dt_s: float) -> np.ndarray:
        """Step 1: draw every particle's regime from the Markov chain; returns the macro-slip mask.

        Onset is more likely when the traction exceeds the wet-rail adhesion.
        """
        u = abs(torque) / (self._rho * self._clamp_n)
        logistic_arg = np.clip((u - self._u_onset) / 0.01, -50.0, 50.0)
        onset = self._rate_spont + self._rate_onset / (1.0 + np.exp(-logistic_arg))
        p_switch = np.where(self._s == 1, -math.expm1(-self._rate_recover * dt_s), -np.expm1(-onset * dt_s))
        flip = self._rng.random(self.n_particles) < p_switch
        self._s = np.where(flip, 1 - self._s, self._s).astype(np.int8)
        return self._s == 1

    def _predict_only(self, speed_mps: float, omega: float, m_i: np.ndarray, q_i: np.ndarray, q_r: float) -> None:
        """No usable measurement (missing, or near standstill): propagate the particles, weights unchanged."""
        n = self.n_particles
        spinning = (
            math.isfinite(speed_mps)
            and math.isfinite(omega)
            and abs(omega) * self._r_nom >= max(2.0 * self._v_min, 2.0 * abs(speed_mps))  # slip > ~0.5
        )
        if spinning:
            # stalled with the wheel spinning: the slip is ~1 and plain kinematics; no radius information
            rim = omega * self._rho
            slip = (rim - speed_mps) / np.maximum(np.abs(rim), abs(speed_mps))
            noise = math.sqrt(self._r0) / np.abs(rim)
            self._i = np.clip(slip + noise * self._rng.standard_normal(n), -self._max_slip, self._max_slip)
            self._s = np.where(slip > 0.0, 1, self._s).astype(np.int8)
        else:
            self._i = np.clip(m_i + np.sqrt(q_i) * self._rng.standard_normal(n), -self._max_slip, self._max_slip)
        self._sig = self._sig + q_r

    def _aukf_proposal(self, y: float, omega: float, macro: np.ndarray, torque: float, a: float, q_i: np.ndarray,
                       q_r: float) -> tuple[np.ndarray, np.ndarray]:
        """Step 2: the adaptive UKF of every particle on ``[i, r]``; returns its slip marginal (mean, variance).

        Prediction from ``([i, rho], diag(0, Sigma))``, unscented update with the measured ground speed (sigma
        points redrawn), then the Sage-Husa adaptation of every particle's ``R``.
        """
        g = self._gamma
        sd_r = np.sqrt(self._sig)
        r_sig = np.stack([self._rho, self._rho + g * sd_r, self._rho - g * sd_r], axis=1)
        i_rep = np.repeat(self._i[:, None], 3, axis=1)
        f_i = self._slip_mean(i_rep, r_sig, macro[:, None], torque, a)
        # sigma points of the slip dimension coincide with the mean (zero variance): only the radius ones spread
        wm, wc = self._wm, self._wc
        w3m = np.array([wm[0] + wm[1] + wm[2], wm[3], wm[4]])
        w3c = np.array([wc[0] + wc[1] + wc[2], wc[3], wc[4]])
        mi = f_i @ w3m
        di = f_i - mi[:, None]
        dr = r_sig - self._rho[:, None]
        c11 = (di * di) @ w3c + q_i
        c12 = (di * dr) @ w3c
        c22 = self._sig + q_r
        mr = self._rho
        l11 = np.sqrt(c11)
        l21 = c12 / l11
        l22 = np.sqrt(np.maximum(c22 - l21 * l21, 1e-300))
        si = np.stack([mi, mi + g * l11, mi - g * l11, mi, mi], axis=1)
        sr = np.stack([mr, mr + g * l21, mr - g * l21, mr + g * l22, mr - g * l22], axis=1)
        ys = self._h(si, sr, omega)
        y_mean = ys @ wm
        dy = ys - y_mean[:, None]
        pyy = (dy * dy) @ wc
        pxy = ((si - mi[:, None]) * dy) @ wc
        s_y = np.maximum(pyy, 0.0) + self._R
        innov = y - y_mean
        k_i = pxy / s_y
        hat_i = mi + k_i * innov
        hat_p = np.maximum(c11 - k_i * k_i * s_y, 1e-12)
        self._k += 1
        d = sage_husa_weight(self._b, self._k)
        self._R = np.clip((1.0 - d) * self._R + d * (innov * innov - pyy), self._r_min, 1e4 * self._r0)
        return hat_i, hat_p

    def _sample_and_weigh(self, y: float, omega: float, m_i: np.ndarray, hat_i: np.ndarray, hat_p: np.ndarray,
                          q_i: np.ndarray, q_r: float) -> None:
        """Steps 3-4: draw the slip from the proposal, Kalman-update the radius given it, weigh, resample."""
        z = self._rng.standard_normal(self.n_particles)
        new_i = np.clip(hat_i + np.sqrt(hat_p) * z, -self._max_slip, self._max_slip)
        h = np.where(new_i >= 0.0, omega * (1.0 - new_i), omega / (1.0 + new_i))
        sig_bar = self._sig + q_r
        s_r = h * h * sig_bar + self._R
        resid = y - h * self._rho
        log_lik = -0.5 * (resid * resid / s_r + np.log(s_r) + _LOG_2PI)
        k_r = sig_bar * h / s_r
        e_t = new_i - m_i
        e_q = new_i - hat_i
        log_trans = -0.5 * (e_t * e_t / q_i + np.log(q_i))
        log_q = -0.5 * (e_q * e_q / hat_p + np.log(hat_p))
        if not np.all(np.isfinite(log_lik)) or float(log_lik.max()) < self._ll_floor:
            # no particle explains the sample: an outlier; learn nothing from it (predicted slip, radius prior)
            self._i = np.clip(m_i, -self._max_slip, self._max_slip)
            self._sig = sig_bar
            self._recover_from_underflow()
        else:
            # physical bounds: a drive wheel cannot grow, nor wear beyond half its radius
            self._rho = np.clip(self._rho + k_r * resid, 0.5 * self._r_nom, 1.02 * self._r_nom)
            self._sig = np.maximum(sig_bar - k_r * k_r * s_r, 1e-16)
            self._i = new_i
            logw = self._logw + log_lik + log_trans - log_q
            logw = np.where(np.isfinite(logw), logw, -np.inf)
            top = float(logw.max())
            if not math.isfinite(top):
                self._recover_from_underflow()
            else:
                self._logw = logw - (top + math.log(float(np.exp(logw - top).sum())))
        w = np.exp(self._logw)
        self._ess = 1.0 / float(w @ w)
        if self._ess < self._ess_min:
            self._resample(w)

    def _recover_from_underflow(self) -> None:
        # no particle explains the sample: restart the weights and widen the radius beliefs, never divide by 0
        self.n_underflow_recoveries += 1
        self._logw = np.full(self.n_particles, -math.log(self.n_particles))
        self._sig = self._sig + 0.01 * self._sigma0
        bad = ~(np.isfinite(self._i) & np.isfinite(self._rho) & np.isfinite(self._sig))
        if bad.any():
            self._i[bad] = 0.0
            self._rho[bad] = self._r_nom
            self._sig[bad] = self._sigma0

    def _resample(self, w: np.ndarray) -> None:
        n = self.n_particles
        positions = (self._rng.random() + np.arange(n)) / n
        cum = np.cumsum(w)
        cum[-1] = 1.0
        idx = np.searchsorted(cum, positions)
        self._i = self._i[idx]
        self._s = self._s[idx]
        self._rho = self._rho[idx]
        self._sig = self._sig[idx]
        self._R = self._R[idx]
        self._logw = np.full(n, -math.log(n))
        self.n_resamples += 1

    def _summary(self) -> Estimate:
        w = np.exp(self._logw)
        w /= w.sum()
        i_mean = float(w @ self._i)
        r_mean = float(w @ self._rho)
        di = self._i - i_mean
        dr = self._rho - r_mean
        var_i = float(w @ (di * di))
        # plus the model term: slip the creep curve cannot tell from wear (see ``radius_model_std_m``)
        var_r = float(w @ (self._sig + dr * dr)) + self._r_model_var
        p = self._prior
        return Estimate(
            p.mass_kg,
            p.slope_rad,
            p.mass_std_kg,
            p.slope_std_rad,
            extras={
                "slip_ratio": i_mean,
                "slip_ratio_std": math.sqrt(max(var_i, 0.0)),
                "drive_radius_m": r_mean,
                "drive_radius_m_std": math.sqrt(max(var_r, 0.0)),
                "macro_slip_prob": float(w @ self._s),
                "ess_fraction": self._ess / self.n_particles,
            },
        )


__all__ = ["AUPFConfig", "AUPFConfigError", "AUPFEstimator"]
