"""The compiled per-sample step of ``dffrls-aekf`` and ``fused`` (see :mod:`estimators.dffrls_aekf` for the method).

About 700 lines on purpose: :func:`step` (input gates and the slope layer) and :func:`_regress` (the slope history
and the mass regression) are compiled functions over three arrays (their small helpers inlined by numba); the array
layout is in :mod:`estimators.dffrls_aekf_layout`, the fused regression in :mod:`estimators.fused_kernel`, the
optional fixed-lag smoother that lets :func:`_regress` run behind the slope layer in
:mod:`estimators.fixed_lag_kernel` (``smoothing_lag_s``; with the lag 0, the default, :func:`step` calls
:func:`_regress` at once with the filtered grade).

The whole estimator state lives in two float64 arrays (``S``: scalars, ``H``: the slope history along the distance
travelled, then the smoother's ring) and its settings in a third (``C``), indexed by the module constants below, so
one function, :func:`step`, serves both the online ``update()`` (one call per sample) and the batch :func:`run` (a
compiled loop over a whole trace calling the same :func:`step`): the two paths cannot drift apart. Compiled with
numba when it is installed (``@njit(cache=True)``); without numba the same code runs as plain Python (same results,
~100x slower).

Robust by construction (issue 12): every input passes a finiteness and magnitude check before it can touch the
state; ``dt`` that is NaN, zero or negative leaves the state untouched (a repeated or out-of-order time stamp);
``dt`` above ``C[GAP_S]`` (including +inf and 1e300) is a data gap: the signal filters restart, the speed state
re-initialises from the next valid speed, the slope variance is raised to its prior (the train may have moved)
and nothing is integrated over the gap, so no loop depends on ``dt``. Covariances go through the shared
Joseph-form update and the 2x2 PD repair of :mod:`estimators.filters`.
"""

from __future__ import annotations

import math

import numpy as np

from uuom_core.vehicle import G_MPS2

from . import filters
from .dffrls_aekf_layout import (  # noqa: F401  (the kernel's array layout, re-exported)
    GAP_S, DT_NOM, RADIUS, M_ROT, M_REF, M_RIGID, C_MIN, C_MAX, MU0, MU_MAX, CUT_HZ, FAST_HZ, CHAIN_L, SWAY_DAMP,
    SWAY_H, MIN_SPEED, MIN_FORCE, SETTLE_S, T_MAX, T_RATE, T_BAND, V_MAX, V_RATE, V_BAND, F_MAX, F_RATE, F_BAND,
    RELOCK, GATES, R0, R_MIN, R_MAX, FADING, ADAPT_R, ACC_VAR, MODEL_ACC_VAR, GRADE_VAR_M, P0_TH, GATE2, MAX_SLOPE,
    USE_ACCEL, HIST_DS, N_HIST, R_M, DELTA, SIGMA, MASS_FORGET, P0_C, P0_CD, P0_D, EST_MU, MAX_SPREAD, READY_VAR,
    Q_C, C0, MIN_ACC, OFF_FORGET, FUSED, P0_B, BIAS_VAR, CORR_N, N_BUF, MAX_AMBIG, EARLY_CAP, N_C, V, TH, P11, P12,
    P22, PROJECT_CLAMP, R, K, BK, F_IN, F_OK, REJ,
    FORCE_IN, GT_LAST, GT_REJ, GV_LAST, GV_REJ, GF_LAST, GF_REJ, LF1, LF2, LF_OK, LV1, LV2, LV_OK, LQ1, LQ2, LQ_OK,
    LA1, LA2, LA_OK, LS1, LS2, LS_OK, LC1, LC2, LC_OK, PREV_VF, PREV_VQ, SWAY, SWAY_RATE, T_VALID, T_MISSING,
    ACC_F, A_LOAD, MC, MD, PC, PCD, PD, RES_VAR, LAMBDA, N_MASS, DIST, NEXT_S, HEAD, HSUM, MOVED, TH_TRAIN, SPREAD,
    N_GAPS, TH_WIN, LL1, LL2, LL_OK, MB, PB, PCB, PDB, DIST0, NIS, SCORE, AMBIG, SCORE_EARLY, N_S, N_HIST_MAX, N_EST,
    EST_SCORE, N_CHAIN, WIN_WEAK, SLOPE_VAR_W, CHAIN_SET, CHAIN_SET_W, MAX_CHAINS, CHAIN_ST, CHAIN_ST_W, ACC_REG, LG1,
    LG_OK, G_SHIFT,
    MASS_STD_SCALE, CURV_VAR_M, P0_KAP, KAP_MAX, KAP, P13, P23, P33, WEAK_ACC, WEAK_R, BRAKING, STUCK_N, STUCK_ST,
    T_JUMP, F_JUMP, JUMP_NOISE, T_JUMP_ST, F_JUMP_ST, FILL_SPEED, FUSED_SPREAD, BLEND_EARLY, EARLY_KEPT, B_MEASURED,
    SMOOTH_L, SMOOTH_NB, ACC_PER_NOISE, F_PREV, NOISE_F, RING_HEAD, RING_N, RING0, RING_MAX, RING_W, N_H,
    EVID_MIN, DISAGREE, RATE_R, REFERENCE_DT_S, RES_GATE2, RES_PERSIST, RES_SKIP, WIT_THR, WIT_TAU, WIT_HOLD, TH_G,
    G_OK, WIT_LEFT, WIT_PERSIST, WIT_T, WIT_SETTLE, WEAK_RW,
)
from .fixed_lag_kernel import (
    R_DS, R_DT, R_F12, R_FIN, R_FOK, R_LINK, R_PF, R_PP, R_T, R_XF, R_XP, R_XS, R_Z, smooth_ring,
)
from .fused_kernel import fused_mass_step as _fused_mass_step
from .fused_kernel import grade_noise as _grade_noise
from .fused_kernel import residual_gated
from .fused_kernel import sample_noise as _sample_noise
from .input_faults import JUMP_STATE, STUCK_STATE, jump_reset, jump_step, stuck_reset, stuck_step
from .numba_shim import HAVE_NUMBA, njit  # noqa: F401  (HAVE_NUMBA re-exported)

DISAGREE_ALONE = 1e9
"""DISAGREE of a filter outside a geometry bank: every sample is evidence (a lone filter's score is only reported)."""
ALPHA_PRIOR = 0.5
"""fused: the prior weight of the slope under the sensors in the slope gravity acts on."""

_kf_update = njit(cache=True, inline="always")(filters.kalman_update_2x2_h1)
_repair = njit(cache=True, inline="always")(filters.repair_pd_2x2)
_kf_update3 = njit(cache=True, inline="always")(filters.kalman_update_3x3_h1)
_repair3 = njit(cache=True, inline="always")(filters.repair_pd_3x3)


@njit(cache=True, inline="always")
def _clip(x, lim):
    """``x`` bounded to ``[-lim, lim]``."""
    return lim if x > lim else (-lim if x < -lim else x)


@njit(cache=True, inline="always")
def _lp(S, i, x, a):
    """Two cascaded first-order low-passes at S[i], S[i+1]; S[i+2] = ready. NaN holds the last output."""
    if x != x:
        return S[i + 1]
    if S[i + 2] == 0.0:
        S[i] = x
        S[i + 1] = x
        S[i + 2] = 1.0
        return x
    y1 = S[i] + a * (x - S[i])
    S[i] = y1
    y2 = S[i + 1] + a * (y1 - S[i + 1])
    S[i + 1] = y2
    return y2


@njit(cache=True, inline="always")
def _gate(S, i, x, dt, xmax, rate, band, relock, use_rate):
    """NaN for a non-finite value, |x| > xmax, or (``use_rate``) a jump faster than physics allows."""
    if not (abs(x) <= xmax):
        return math.nan
    if use_rate:
        last = S[i]
        if last == last and abs(x - last) > rate * dt * (S[i + 1] + 1.0) + band:
            S[i + 1] += 1.0
            if S[i + 1] <= relock:
                return math.nan
        S[i + 1] = 0.0
    S[i] = x
    return x


@njit(cache=True)
def reset(S, H, C):
    S[:] = 0.0
    S[V] = math.nan
    S[P11] = C[R0]
    S[P22] = C[P0_TH]
    S[P33] = C[P0_KAP]
    S[R] = C[R0]
    S[BK] = 1.0
    S[GT_LAST] = math.nan
    S[GV_LAST] = math.nan
    S[GF_LAST] = math.nan
    S[PREV_VF] = math.nan
    S[PREV_VQ] = math.nan
    c0 = C[C0]
    S[MC] = c0
    S[MD] = C[MU0] * c0
    S[PC] = C[P0_C]
    S[PCD] = C[P0_CD]
    S[PD] = C[P0_D]
    S[RES_VAR] = C[R_M]
    S[LAMBDA] = 1.0
    S[MB] = ALPHA_PRIOR * c0  # fused: beta = c alpha
    S[PB] = C[P0_B]
    S[NIS] = 1.0  # its expected value until the first speed correction (an output is never NaN)
    S[F_PREV] = math.nan
    S[DISAGREE] = DISAGREE_ALONE
    if C[ACC_PER_NOISE] > 0.0:  # start where the fixed setting is
        S[NOISE_F] = C[ACC_VAR] / (C[ACC_PER_NOISE] * C[ACC_PER_NOISE])
    stuck_reset(S[STUCK_ST:STUCK_ST + STUCK_STATE])
    jump_reset(S[T_JUMP_ST:T_JUMP_ST + JUMP_STATE])
    jump_reset(S[F_JUMP_ST:F_JUMP_ST + JUMP_STATE])
    for k in range(int(C[N_CHAIN])):
        S[CHAIN_ST + CHAIN_ST_W * k + 6] = C[CHAIN_SET + CHAIN_SET_W * k + 3]
    H[:] = 0.0


@njit(cache=True, inline="always")
def _restart_filters(S):
    """Restart the signal low-passes at the next sample, forget the speed differences, stop the load pendulum."""
    for i in (LF_OK, LV_OK, LQ_OK, LA_OK, LS_OK, LC_OK, LL_OK, LG_OK):
        S[i] = 0.0
    S[PREV_VF] = math.nan
    S[PREV_VQ] = math.nan
    S[SWAY] = 0.0
    S[SWAY_RATE] = 0.0
    for k in range(MAX_CHAINS):  # the chain-length bank's pendulums too (their evidence is kept)
        i = CHAIN_ST + CHAIN_ST_W * k
        S[i] = 0.0
        S[i + 1] = 0.0
        S[i + 4] = 0.0


@njit(cache=True)
def _restart_signals(S, H):
    """After a data gap: the filters' held states no longer describe the motion."""
    _restart_filters(S)
    S[T_VALID] = 0.0
    S[GT_LAST] = math.nan
    S[GV_LAST] = math.nan
    S[GF_LAST] = math.nan
    S[F_OK] = 0.0
    S[V] = math.nan
    S[MOVED] = 0.0
    S[HSUM] = 0.0


@njit(cache=True, inline="always")
def _swing(S, i, L, damp, h_max, a_fast, dt):
    """The load on chains of length ``L``: a pendulum forced by the train's acceleration, its angle and rate at
    ``S[i]``, ``S[i + 1]`` (semi-implicit Euler, sub-stepped to ``h_max``; dt is at most GAP_S here, so the
    sub-step count is bounded). Returns the load's along-track acceleration before the step."""
    g = G_MPS2
    sw, sr = S[i], S[i + 1]
    a_load = -g * sw - damp * sr
    n_sub = 1 if dt <= h_max else int(math.ceil(dt / h_max))
    h = dt / n_sub
    for _ in range(n_sub):
        sr += h * (-g * sw - damp * sr - a_fast) / L
        sw += h * sr
    S[i], S[i + 1] = sw, sr
    return a_load


@njit(cache=True, inline="always")
def _chain_bank_accel(S, C, a_fast, dt, a):
    """The chain-length bank: every member's pendulum stepped and low-passed; returns their load accelerations
    weighted by the evidence, ``exp(-score)`` (the swing angle and rate so weighted go to ``S[SWAY]``). The scores
    are relative to the best, whose is 0 (the prior's so set, :func:`_chain_bank_score` keeps it so)."""
    nk = int(C[N_CHAIN])
    w_sum = mix = sw = sr = 0.0
    for k in range(nk):
        i = CHAIN_ST + CHAIN_ST_W * k
        j = CHAIN_SET + CHAIN_SET_W * k
        a_k = _lp(S, i + 2, _swing(S, i, C[j], C[j + 1], C[j + 2], a_fast, dt), a)
        S[i + 5] = a_k
        w = math.exp(-S[i + 6])
        w_sum += w
        mix += w * a_k
        sw += w * S[i]
        sr += w * S[i + 1]
    S[SWAY] = sw / w_sum
    S[SWAY_RATE] = sr / w_sum
    return mix / w_sum


@njit(cache=True, inline="always")
def _chain_bank_score(S, C, e_mix, a_mix, s_var):
    """Add each chain length's evidence: the force-balance residual ``e_mix`` of the weighted swing, moved to
    member k's swing (the load's share of the mass times the difference of the accelerations), as a Gaussian
    negative log-likelihood counted once per ~CORR_N correlated samples and capped per sample (a fault cannot
    decide). Scores are kept relative to the best (bounded numbers)."""
    nk = int(C[N_CHAIN])
    swing_c = C[M_RIGID] / C[M_REF] - S[MC]  # minus the swinging load's mass / M_ref
    lo = math.inf
    for k in range(nk):
        i = CHAIN_ST + CHAIN_ST_W * k
        e = e_mix + swing_c * (S[i + 5] - a_mix)
        S[i + 6] += 0.5 * min(e * e / s_var, 25.0) / C[CORR_N]
        lo = min(lo, S[i + 6])
    for k in range(nk):
        S[CHAIN_ST + CHAIN_ST_W * k + 6] -= lo


@njit(cache=True, inline="always")
def _gravity_slope(S, C, th, th_win):
    """The slope gravity acts on, from the slope under the sensors ``th`` and the window behind them ``th_win``:
    the window's for ``dffrls-aekf``; for ``fused`` their blend with the weight alpha = beta / c learned from the
    force balance (1 for a point mass)."""
    if C[FUSED] != 0.0:
        al = min(max(S[MB] / S[MC], 0.0), 1.0)
        return al * th + (1.0 - al) * th_win
    return th_win


@njit(cache=True)
def _regress(S, H, C, T, z, dt, th, v, p22, f_in, f_ok, use_rate):
    """The slope history and the mass regression for one sample: ``T``, ``z`` the gated torque and speed, ``th``,
    ``v``, ``p22`` the slope layer's grade, speed and grade variance for it (filtered, or smoothed when the
    regression runs behind: :mod:`estimators.fixed_lag_kernel`), ``f_in``/``f_ok`` the accelerometer's last valid
    value."""
    g = G_MPS2
    if S[WIT_LEFT] > 0.0 and S[G_OK] != 0.0:
        # the gyro witness disagrees with the slope layer (witness()): the track's pitch is the gyro's, and the slope
        # window must not keep the faulted grade for a train length after the fault
        th = S[TH_G]
    # ---------------- slope under the whole train: history of theta along the distance travelled ---------------
    n_hist = int(C[N_HIST])
    n_buf = int(C[N_BUF])
    if n_buf > 0:
        if v == v and v > 0.0:
            S[DIST] += v * dt
        if S[MOVED] == 0.0:
            # not moved yet: the track behind is unknown, take the slope the train stands on, until the slope
            # layer has settled and the train has moved one history step (a start-up transient of theta must not
            # be frozen into the history for a whole train length)
            for j in range(n_buf):
                H[j] = th
            S[HSUM] = n_hist * th
            S[HEAD] = 0.0
            S[NEXT_S] = S[DIST] + C[HIST_DS]
            if S[DIST] > C[HIST_DS] and p22 < C[READY_VAR]:
                S[MOVED] = 1.0
                S[DIST0] = S[DIST]
        n_push = 0
        while S[DIST] >= S[NEXT_S] and n_push < n_buf:  # bounded: a huge step refills the buffer at most once
            hd = int(S[HEAD])
            if n_hist > 0:  # the entry n_hist pushes back leaves the window
                S[HSUM] += th - H[(hd - n_hist) % n_buf]
            H[hd] = th
            S[HEAD] = float((hd + 1) % n_buf)
            S[NEXT_S] += C[HIST_DS]
            n_push += 1
        if S[DIST] >= S[NEXT_S]:
            S[NEXT_S] = S[DIST] + C[HIST_DS]
        if n_push > 0 and S[HEAD] == 0.0:  # re-sum once per buffer turn: no drift of the running sum
            acc_sum = 0.0
            for j in range(n_hist):
                acc_sum += H[n_buf - 1 - j]
            S[HSUM] = acc_sum
        oldest = H[int(S[HEAD])]
        S[SPREAD] = abs(th - oldest)
        S[TH_WIN] = (th + S[HSUM]) / (n_hist + 1) if n_hist > 0 else th
    else:
        S[TH_WIN] = th
        S[SPREAD] = 0.0
    # fused: the slope window holds measured slopes only (not the start-up guess)
    window_measured = S[MOVED] != 0.0 and S[DIST] - S[DIST0] > C[N_HIST] * C[HIST_DS]
    if C[FUSED] != 0.0 and C[BLEND_EARLY] != 0.0 and S[B_MEASURED] == 0.0 and window_measured:
        # the window holds measured slopes only for the first time: what alpha learnt while it held the start-up guess
        # (a train that starts across a crest fits that guess badly: plant run 1057, alpha 0.3 -> 1.0 in 3 s) keeps
        # only a lean; checked on every sample, since on a descent no sample may reach the regression again
        S[B_MEASURED] = 1.0
        b0 = ALPHA_PRIOR * S[MC]
        S[MB] = b0 + C[EARLY_KEPT] * (S[MB] - b0)
        S[PB] = max(S[PB], C[P0_B])
        S[PCB] = 0.0
        S[PDB] = 0.0
    S[TH_TRAIN] = _gravity_slope(S, C, th, S[TH_WIN])

    # ---------------- regression front end: F = T/r, v, dv/dt, the swinging load --------------------------------
    a = 1.0 - math.exp(-2.0 * math.pi * C[CUT_HZ] * dt)
    if T == T and z == z and S[T_MISSING] > 0.1:
        # first good sample after a dropout: restart the signal filters at it; a held input jumping to the new
        # value would read as an acceleration and kick the load pendulum, which then rings for tens of seconds
        _restart_filters(S)
    # a missing speed sample is filled with the slope layer's prediction (the accelerometer integrated): a paused
    # speed filter lags behind an acceleration, and the samples after the gap, which the regression uses, would
    # read too large a dv/dt (2 % speed dropouts: mass -1.2 % on the point-mass fault trace; session 24)
    zf = z if z == z or C[FILL_SPEED] == 0.0 else v
    F = _lp(S, LF1, T / C[RADIUS] if T == T else math.nan, a)
    vf = _lp(S, LV1, zf, a)
    if S[LV_OK] == 0.0:  # no valid speed yet
        return
    prev = S[PREV_VF]
    S[PREV_VF] = vf
    acc_f = (vf - prev) / dt if prev == prev else 0.0
    S[ACC_F] = acc_f
    if C[FUSED] != 0.0:
        sin_lp = _lp(S, LS1, math.sin(S[TH_WIN]), a)
        sin_loc_lp = _lp(S, LL1, math.sin(th), a)
        cos_lp = 1.0
    else:
        th_train = S[TH_TRAIN]
        sin_lp = _lp(S, LS1, math.sin(th_train), a)
        cos_lp = _lp(S, LC1, math.cos(th_train), a)
        sin_loc_lp = _lp(S, LL1, math.sin(th), a) if C[ACC_REG] != 0.0 else sin_lp
    if C[ACC_REG] != 0.0:
        # the accelerometer measures dv/dt + g sin(theta) at the sensors: its low-pass minus the same low-passed
        # dv/dt is the gravity term there without the slope layer's lag behind a grade change (its bias is a
        # constant the offset takes); the slope layer then supplies only the geometry, the slope gravity acts on
        # minus the slope under the sensors. Held through accelerometer dropouts (it changes slowly).
        if f_ok != 0.0:
            S[G_SHIFT] = (_lp(S, LG1, f_in, a) - acc_f) / g - sin_loc_lp
        sin_lp += S[G_SHIFT]
        sin_loc_lp += S[G_SHIFT]
    if C[CHAIN_L] > 0.0:
        # the load hangs on chains: a pendulum forced by the train's acceleration (semi-implicit Euler; dt is at
        # most GAP_S here, so the sub-step count is bounded)
        af = 1.0 - math.exp(-2.0 * math.pi * C[FAST_HZ] * dt)
        vq = _lp(S, LQ1, zf, af)
        pq = S[PREV_VQ]
        S[PREV_VQ] = vq
        a_fast = (vq - pq) / dt if pq == pq else 0.0
        if C[N_CHAIN] > 0.0:
            a_load_f = _chain_bank_accel(S, C, a_fast, dt, a)
        else:
            a_load_f = _lp(S, LA1, _swing(S, SWAY, C[CHAIN_L], C[SWAY_DAMP], C[SWAY_H], a_fast, dt), a)
    else:
        a_load_f = acc_f
    S[A_LOAD] = a_load_f
    raw_ok = T == T and z == z
    if raw_ok:
        S[T_VALID] += dt
        S[T_MISSING] = 0.0
    else:
        S[T_MISSING] += dt
        if S[T_MISSING] > 0.1:
            S[T_VALID] = 0.0
    # a measured force, traction or electric braking; near zero torque an unmeasured brake may act (the plant's)
    force_ok = F > C[MIN_FORCE] or (C[BRAKING] != 0.0 and F < -C[MIN_FORCE])
    usable = (raw_ok and S[LF_OK] != 0.0 and S[T_VALID] > C[SETTLE_S] and vf > C[MIN_SPEED] and force_ok
              and p22 < C[READY_VAR])
    if not usable or S[WIT_LEFT] > 0.0:
        # (WIT_LEFT: the gyro witness, witness(): the slope layer moved where the gyro saw no grade change, so the
        # accelerometer, not the track, changed; a force balance on that slope is no evidence for the run's constants,
        # which would keep the error for good, nor for the chain or geometry banks)
        return
    y = (F - C[M_ROT] * acc_f - C[M_RIGID] * (acc_f - a_load_f)) / C[M_REF]
    # the force balance predicted with the current parameters, before they update: the evidence of the chain-length
    # bank and of the geometry bank
    hs = a_load_f + g * sin_lp
    if C[FUSED] != 0.0:
        e_s = y - hs * S[MC] - g * S[MD] - g * (sin_loc_lp - sin_lp) * S[MB]
    else:
        e_s = y - hs * S[MC] - (g * cos_lp if C[OFF_FORGET] == 0.0 else g) * S[MD]
    s_s = max(S[RES_VAR], C[R_M])
    if C[N_CHAIN] > 0.0:
        _chain_bank_score(S, C, e_s, a_load_f, s_s)
    if C[FUSED] == 0.0 and S[MOVED] != 0.0:
        # evidence for this estimator's slope geometry (estimators.geometry_bank): the Gaussian negative
        # log-likelihood of the force balance predicted before the update, counted once per ~CORR_N correlated
        # samples and capped per sample, so a fault cannot decide; also across the grade changes the mass update
        # skips, since they are what tells a point mass from a long train. Kept apart while the history still
        # holds the start-up guess (a window member's slope is then partly an assumption, not its geometry: the
        # bank caps what that early evidence may decide)
        nll = 0.5 * (min(e_s * e_s / s_s, 25.0) + math.log(s_s)) / C[CORR_N]
        if C[EVID_MIN] == 0.0 or S[DISAGREE] >= C[EVID_MIN]:
            if S[DIST] - S[DIST0] > C[N_BUF] * C[HIST_DS]:
                S[SCORE] += nll
            else:
                S[SCORE_EARLY] += nll
    if C[FUSED] == 0.0 and not S[SPREAD] < C[MAX_SPREAD]:
        return
    if C[FUSED] == 0.0 and S[AMBIG] > C[MAX_AMBIG]:
        # the bank's members still disagree on the slope gravity acts on and the evidence has not chosen: a mass
        # learnt now would absorb whichever slope error is the wrong geometry's (0 for a single filter)
        return
    if C[FUSED] != 0.0:
        # the blend learns from the first metre moved (BLEND_EARLY), while the window still holds part of its
        # start-up guess: waiting for a window of measured slopes only left alpha at its prior for the first 12 m
        # and the slope output half the window's lagging average (plant tuning runs 1000-1199: slope RMSE median
        # 0.55 -> 0.29 deg; point-mass runs 1000-1059 0.38 -> 0.14 deg; docs/estimation.md, session 25)
        learn_b = S[MOVED] != 0.0 and (C[BLEND_EARLY] != 0.0 or window_measured)
        _fused_mass_step(S, C, y, a_load_f, sin_lp, sin_loc_lp, use_rate, learn_b, dt, p22)
        return

    # ---------------- mass layer: DFFRLS on the specific-force regression ----------------------------------------
    #   (F - m_rot a - M_rigid (a - a_load)) / M_ref = [a_load + g sin th_train, g cos th_train] . [c, d]
    # The two-parameter RLS in Kalman form with the Schmidt update of estimators.rls._RLSMassBase._rls_step, written
    # out here on purpose: the compiled step cannot call that method, and its variant differs (outlier gate, offset
    # mode, >= bounds). The three-parameter fused step (fused_kernel.py) forgets and bounds the same way.
    h1 = a_load_f + g * sin_lp
    h2 = g * cos_lp if C[OFF_FORGET] == 0.0 else g
    c, dd = S[MC], S[MD]
    pc, pcd, pd = S[PC] + C[Q_C], S[PCD], S[PD]
    if C[EST_MU] == 0.0:
        # mu fixed at the vehicle file's value: one parameter, d = mu0 c
        h1 = h1 + C[MU0] * h2
        h2 = 0.0
    e = y - h1 * c - h2 * dd
    # a weak sample: below the common gate, above a point-mass filter's own gate; or (WIN_WEAK) a window member's
    # below the gate on a grade uniform over its window, where its slope for gravity is the point member's and so is
    # the information of a constant-speed sample (without it the bank mixed a learning point member with a window
    # member frozen at its pull-away value wherever the evidence could not choose)
    weak = C[MIN_ACC] <= abs(a_load_f) < C[WEAK_ACC] or (
        C[WIN_WEAK] > 0.0 and abs(a_load_f) < C[MIN_ACC] and S[SPREAD] < C[WIN_WEAK])
    lam = C[DELTA] + (1.0 - C[DELTA]) * math.exp(-C[SIGMA] * abs(e))
    if C[RATE_R] != 1.0:  # the forgetting per second kept at another sample rate
        lam = lam ** C[RATE_R]
    lam_m = 1.0 - C[MASS_FORGET] * (1.0 - lam)
    if C[OFF_FORGET] > 0.0:
        # offset mode: d is the train's resistance-and-slope offset, forgotten faster than the mass (vector
        # forgetting), each variance bounded by its prior (no wind-up)
        lam_d = 1.0 - C[OFF_FORGET] * (1.0 - lam)
        if pc / lam_m >= C[P0_C]:
            lam_m = 1.0
        if pd / lam_d >= C[P0_D]:
            lam_d = 1.0
        pc /= lam_m
        pd /= lam_d
        if weak and C[WEAK_RW] != 0.0:
            # a weak sample sees only the line c g sin th + o: scaling the offset's covariance row keeps the mass
            # correlated with an offset that forgets, and those samples then pin the mass anywhere along that line.
            # The offset's forgetting as a random walk of the offset alone (its variance grows, the covariance not)
            pcd /= math.sqrt(lam_m)
        else:
            pcd /= math.sqrt(lam_m * lam_d)
    # forgetting in covariance form, never above the prior variance (no wind-up)
    elif pc / lam_m < C[P0_C] and pd / lam_m < C[P0_D]:
        pc /= lam_m
        pcd /= lam_m
        pd /= lam_m
    ph1 = pc * h1 + pcd * h2
    ph2 = pcd * h1 + pd * h2
    # the residual's variance per sample as a white noise's: the same information per second at any rate
    # (SLOPE_VAR_W: the grade's variance as regressor noise; 0 in dffrls-aekf, see fused_kernel.fused_mass_step)
    r_m = _sample_noise(C, c, p22)
    s_m = r_m + h1 * ph1 + h2 * ph2
    if use_rate and e * e > 100.0 * s_m:  # a gross outlier that passed the input gates
        return
    gated = residual_gated(S, C, e, h1 * ph1 + h2 * ph2, dt)
    k2 = ph2 / s_m
    if gated or (abs(a_load_f) < C[MIN_ACC] and not weak):
        # no acceleration: the mass is only a considered parameter (Schmidt update, zero gain, its variance kept);
        # at constant speed a slope error of the upper layer would otherwise be read as mass
        dd += k2 * e
        pcd -= k2 * ph1
        pd -= k2 * ph2
    else:
        if weak:
            # below the common gate (a point-mass filter only): the sample is mostly the grade's level and the offset's
            # prior, and it is correlated with its neighbours over ~CORR_N samples: counted WEAK_R times noisier
            s_m += r_m * (C[WEAK_R] - 1.0)
            k2 = ph2 / s_m
        k1 = ph1 / s_m
        c += k1 * e
        dd += k2 * e
        pc -= k1 * ph1
        pcd -= k1 * ph2
        pd -= k2 * ph2
    pc, pcd, pd = _repair(pc, pcd, pd, 1e-14, 1e-16)
    S[PC], S[PCD], S[PD] = pc, pcd, pd
    c_free = c
    c = min(max(c, C[C_MIN]), C[C_MAX])
    if C[PROJECT_CLAMP] != 0.0 and c != c_free:
        dd += pcd / pc * (c - c_free)
    S[MC] = c
    if C[EST_MU] == 0.0:
        S[MD] = C[MU0] * c
    elif C[OFF_FORGET] > 0.0:  # the offset also holds the slope error of the upper layer: either sign
        S[MD] = min(max(dd, -C[MU_MAX] * c), C[MU_MAX] * c)
    else:
        S[MD] = min(max(dd, 0.0), C[MU_MAX] * c)
    if not gated:
        S[RES_VAR] += min(0.002 * C[RATE_R], 1.0) * (min(e * e, 100.0 * S[RES_VAR]) - S[RES_VAR])
    S[LAMBDA] = lam
    S[N_MASS] += 1.0


@njit(cache=True)
def _flush_ring(S, H, C, m, use_rate):
    """The fixed-lag smoother's backward pass over the ring, then its ``m`` oldest samples through the regression,
    oldest first, each with its smoothed grade and speed (:mod:`estimators.fixed_lag_kernel`)."""
    head = int(S[RING_HEAD])
    n = int(S[RING_N])
    m = min(m, n)
    smooth_ring(H, head, n, C[MAX_SLOPE])
    for i in range(m):
        b = RING0 + RING_W * ((head + i) % RING_MAX)
        _regress(S, H, C, H[b + R_T], H[b + R_Z], H[b + R_DT], H[b + R_XS + 1], H[b + R_XS], H[b + R_PF + 3],
                 H[b + R_FIN], H[b + R_FOK], use_rate)
    S[RING_HEAD] = float((head + m) % RING_MAX)
    S[RING_N] = float(n - m)


@njit(cache=True)
def step(S, H, C, torque, speed, accel, dt):
    """Process one sample. Returns nothing; the estimate is read from ``S`` (:func:`estimate`)."""
    if not (dt > 0.0):  # NaN, 0, negative: a repeated or out-of-order stamp; nothing to integrate
        return
    use_rate = C[GATES] != 0.0
    if dt > C[GAP_S]:  # a gap (inf, 1e300 included): restart, then treat the sample as the first after it
        if S[RING_N] > 0.0:  # the samples before the gap go to the regression first, smoothed up to the gap
            _flush_ring(S, H, C, int(S[RING_N]), use_rate)
        _restart_signals(S, H)
        S[P22] = max(S[P22], C[P0_TH])
        # the curvature of a stretch the train may have moved along unseen: back to its prior, uncorrelated
        S[KAP] = 0.0
        S[P13] = 0.0
        S[P23] = 0.0
        S[P33] = max(S[P33], C[P0_KAP])
        S[N_GAPS] += 1.0
        dt = C[DT_NOM]
    g = G_MPS2
    relock = C[RELOCK]
    # a one-sample spike within the plausibility limits is held back until the next sample shows it was one: no
    # innovation gate sees the inputs, and +-4 m/s^2 spikes on the accelerometer cost the point-mass fault trace
    # 1.4 -> 3.9 % of mass (median of ten sensor seeds; docs/estimation.md, session 24)
    torque = jump_step(S[T_JUMP_ST:T_JUMP_ST + JUMP_STATE], C[T_JUMP], C[JUMP_NOISE], torque)
    accel = jump_step(S[F_JUMP_ST:F_JUMP_ST + JUMP_STATE], C[F_JUMP], C[JUMP_NOISE], accel)
    T = _gate(S, GT_LAST, torque, dt, C[T_MAX], C[T_RATE], C[T_BAND], relock, use_rate)
    z = _gate(S, GV_LAST, speed, dt, C[V_MAX], C[V_RATE], C[V_BAND], relock, use_rate)
    # a frozen accelerometer (one value repeated, after it has shown its noise) counts as missing: it is plausible,
    # and three seconds of it turn the geometry bank's weights (pm-sensor-faults; docs/estimation.md, session 23)
    accel = stuck_step(S[STUCK_ST:STUCK_ST + STUCK_STATE], C[STUCK_N], accel)
    f = _gate(S, GF_LAST, accel, dt, C[F_MAX], C[F_RATE], C[F_BAND], relock, use_rate)

    # ---------------- slope layer: adaptive EKF on [v, theta_sensor] --------------------------------------------
    # for the fixed-lag smoother: this step's prediction, its transition, and whether it continued the last state
    link = 0.0
    xp_v = xp_t = xp_k = f12 = ds = 0.0
    pp11 = pp12 = pp13 = pp22 = pp23 = 0.0
    pp33 = 1.0
    curv = C[CURV_VAR_M] > 0.0
    v = S[V]
    if v != v:
        if z == z:
            S[V] = z
    else:
        th = S[TH]
        sn = math.sin(th)
        cs = math.cos(th)
        c_m = S[MC]
        if C[USE_ACCEL] != 0.0 and S[F_OK] != 0.0:
            # kinematics: the accelerometer measures f = dv/dt + g sin(theta); no mass, torque or mu needed
            acc = S[F_IN] - g * sn
            f12 = -dt * g * cs
            if C[ACC_PER_NOISE] > 0.0:
                q11 = C[ACC_PER_NOISE] * C[ACC_PER_NOISE] * S[NOISE_F] * dt * dt
            else:
                q11 = C[ACC_VAR] * dt * dt
            moving = True
        else:
            # the paper's model (eq. 24) with the mass layer's M and mu: what is left without an accelerometer
            m = c_m * C[M_REF]
            mu = S[MD] / c_m
            g_over = g / (1.0 + C[M_ROT] / m)
            acc = S[FORCE_IN] / (m + C[M_ROT]) - g_over * (sn + mu * cs)
            moving = v > 0.02 or acc > 0.0  # held by static friction / brakes at standstill
            f12 = -dt * g_over * (cs - mu * sn) if moving else 0.0
            q11 = C[MODEL_ACC_VAR] * dt * dt
        if moving:
            S[V] = v + dt * acc
        p11, p12, p22 = S[P11], S[P12], S[P22]
        p13, p23, p33 = S[P13], S[P23], S[P33]
        # the grade is a function of position: it drifts with the distance travelled, not with time
        q22 = C[GRADE_VAR_M] * abs(v) * dt
        if curv:
            # third state: the grade's curvature (roadways are straight grades joined by vertical curves), so a
            # grade that changes along the track is followed without the lag of a random walk
            ds = v * dt if moving else 0.0
            S[TH] = _clip(S[TH] + S[KAP] * ds, C[MAX_SLOPE])
            # P <- F P F^T + Q with F = [[1, f12, 0], [0, 1, ds], [0, 0, 1]]
            n11 = p11 + 2.0 * f12 * p12 + f12 * f12 * p22 + q11
            n12 = p12 + f12 * p22 + ds * (p13 + f12 * p23)
            n13 = p13 + f12 * p23
            n22 = p22 + 2.0 * ds * p23 + ds * ds * p33 + q22
            n23 = p23 + ds * p33
            n33 = p33 + C[CURV_VAR_M] * abs(ds)
            p11, p12, p13, p22, p23, p33 = n11, n12, n13, min(n22, C[P0_TH]), n23, min(n33, C[P0_KAP])
            pp13, pp23, pp33 = p13, p23, p33
        else:
            p11 = p11 + 2.0 * f12 * p12 + f12 * f12 * p22 + q11
            p12 = p12 + f12 * p22
            p22 = min(p22 + q22, C[P0_TH])
        link = 1.0
        xp_v, xp_t, xp_k = S[V], S[TH], S[KAP]
        pp11, pp12, pp22 = p11, p12, p22
        if z == z:
            eps = z - S[V]
            s_inn = p11 + S[R]
            if use_rate and eps * eps > C[GATE2] * s_inn and S[REJ] < relock:
                S[REJ] += 1.0
            elif S[REJ] >= relock and use_rate:
                # persistently "outlying": the state was wrong, restart the speed there
                link = 0.0
                S[REJ] = 0.0
                S[V] = z
                p11 = max(p11, S[R])
            else:
                S[REJ] = 0.0
                # consistency of the speed prediction (R before this sample adapts it): chi2(1) if the filter is right
                S[NIS] = eps * eps / s_inn
                if C[ADAPT_R] != 0.0:
                    # Sage-Husa estimate of R (weights from k = 1: d_1 ~ 0.5 keeps the prior); the unbiased form
                    # eps^2 - H P- H^T falls back to the biased one when not positive, then bounded
                    S[K] += 1.0
                    S[BK] *= C[FADING]
                    d = (1.0 - C[FADING]) / (1.0 - S[BK] * C[FADING])
                    r_new = (1.0 - d) * S[R] + d * (eps * eps - p11)
                    if r_new <= C[R_MIN]:
                        r_new = (1.0 - d) * S[R] + d * eps * eps
                    S[R] = min(max(r_new, C[R_MIN]), C[R_MAX])
                if curv:
                    dv, dth, dk, p11, p12, p13, p22, p23, p33 = _kf_update3(p11, p12, p13, p22, p23, p33, eps,
                                                                            S[R])
                    S[KAP] = _clip(S[KAP] + dk, C[KAP_MAX])
                else:
                    dv, dth, p11, p12, p22 = _kf_update(p11, p12, p22, eps, S[R])
                S[V] += dv
                S[TH] = _clip(S[TH] + dth, C[MAX_SLOPE])
        if curv:
            p11, p12, p13, p22, p23, p33 = _repair3(p11, p12, p13, p22, p23, p33, 1e-14, C[P0_TH])
            S[P13], S[P23], S[P33] = p13, p23, p33
        else:
            p11, p12, p22 = _repair(p11, p12, p22, 1e-14, 1e-14)
        S[P11], S[P12], S[P22] = p11, p12, p22
    if f == f:
        if C[ACC_PER_NOISE] > 0.0 and S[F_PREV] == S[F_PREV]:
            # the accelerometer's noise: half the squared change between samples (the signal moves little in 5 ms),
            # clipped so a spike cannot set it, averaged over ~10 s
            d = f - S[F_PREV]
            S[NOISE_F] += min(5e-4 * C[RATE_R], 1.0) * (min(0.5 * d * d, 0.25) - S[NOISE_F])
        S[F_PREV] = f
        S[F_IN] = f
        S[F_OK] = 1.0
    else:
        S[F_OK] = 0.0
    if T == T:
        S[FORCE_IN] = T / C[RADIUS]
    if C[SMOOTH_L] == 0.0:
        _regress(S, H, C, T, z, dt, S[TH], S[V], S[P22], S[F_IN], S[F_OK], use_rate)
        return
    # fixed-lag smoothing: the sample joins the ring; once it holds the lag and one block, one backward pass, and the
    # block's oldest samples go to the regression, smoothed over at least the lag's later samples
    n = int(S[RING_N])
    b = RING0 + RING_W * ((int(S[RING_HEAD]) + n) % RING_MAX)
    H[b + R_T], H[b + R_Z], H[b + R_DT] = T, z, dt
    H[b + R_FIN], H[b + R_FOK] = S[F_IN], S[F_OK]
    H[b + R_XF], H[b + R_XF + 1], H[b + R_XF + 2] = S[V], S[TH], S[KAP]
    H[b + R_PF], H[b + R_PF + 1], H[b + R_PF + 3] = S[P11], S[P12], S[P22]
    H[b + R_PF + 2] = S[P13] if curv else 0.0
    H[b + R_PF + 4] = S[P23] if curv else 0.0
    H[b + R_PF + 5] = S[P33] if curv else 1.0
    H[b + R_XP], H[b + R_XP + 1], H[b + R_XP + 2] = xp_v, xp_t, xp_k
    H[b + R_PP], H[b + R_PP + 1], H[b + R_PP + 2] = pp11, pp12, pp13
    H[b + R_PP + 3], H[b + R_PP + 4], H[b + R_PP + 5] = pp22, pp23, pp33
    H[b + R_F12], H[b + R_DS], H[b + R_LINK] = f12, ds, link
    S[RING_N] = n + 1.0
    if n + 1 >= C[SMOOTH_L] + C[SMOOTH_NB]:
        _flush_ring(S, H, C, int(C[SMOOTH_NB]), use_rate)


GYRO_MAX_RADPS = 1.0
"""A pitch rate above this is not the track's (a monorail's vertical curves turn it by v/R, under 0.2 rad/s): the
witness treats the sample as missing."""


@njit(cache=True)
def witness(S, C, gyro, dt):
    """The gyro witness (``WIT_THR > 0``), after a :func:`step`: the gyro's pitch, integrated, must agree with the
    slope layer's grade within ``WIT_THR``. While they agree it is pulled towards that grade with time constant
    ``WIT_TAU`` (so that the gyro's bias and drift stay bounded); while they disagree it follows the gyro alone,
    so it stays the track's pitch through an accelerometer fault, and the regression holds (``WIT_LEFT``)
    until ``WIT_HOLD`` after the last disagreement. A disagreement lasting ``WIT_PERSIST`` is a lasting change (a
    bias that stays): the witness re-locks to the grade. Locked to the grade (no disagreement) until the regression
    starts (``MOVED``: the slope layer's start-up transient is not a fault) and after a missing or implausible
    gyro sample; so a trace without a gyro (NaN) runs as without the witness."""
    if not (C[WIT_THR] > 0.0) or not (dt > 0.0):
        return
    if S[WIT_LEFT] > 0.0:
        S[WIT_LEFT] = max(S[WIT_LEFT] - min(dt, C[GAP_S]), 0.0)
    th = S[TH]
    if S[MOVED] == 0.0 or not (abs(gyro) <= GYRO_MAX_RADPS) or not (abs(th) < math.inf) or dt > C[GAP_S]:
        S[G_OK] = 0.0
        S[WIT_T] = 0.0
        return
    if S[G_OK] < C[WIT_SETTLE]:
        # (re)locked: follow the grade until the slope layer has settled again (after a dropout it converges back to
        # the track, which the gyro, locked to its stale value, would call a disagreement)
        S[TH_G] = th
        S[G_OK] += dt
        return
    tg = S[TH_G] + gyro * dt
    if abs(th - tg) > C[WIT_THR]:
        S[WIT_T] += dt
        if S[WIT_T] >= C[WIT_PERSIST]:
            tg = th
            S[WIT_T] = 0.0
        else:
            S[WIT_LEFT] = C[WIT_HOLD]
    else:
        S[WIT_T] = 0.0
        tg += (th - tg) * min(dt / C[WIT_TAU], 1.0)
    S[TH_G] = tg


@njit(cache=True)
def estimate(S, C, out):
    """Write (mass, slope, mass_std, slope_std, mu, mu_std, alpha, nis, score) into ``out`` (alpha: fused only,
    else 0; nis: that of the last speed correction, held between corrections; score: the geometry evidence)."""
    c = S[MC]
    # the regression counts every 5 ms sample as independent, but its low-passed signals are correlated over
    # ~CORR_N samples: the parameter variance is that much too small
    infl = max(1.0, S[RES_VAR] / C[R_M]) * C[CORR_N] * C[RATE_R]  # (the count at the reference rate)
    if C[SLOPE_VAR_W] > 0.0:
        # the grade's share of the per-sample noise (SLOPE_VAR_W) is already counted as correlated: only the white
        # share is inflated
        x = _grade_noise(C, c, S[P22])
        infl = (infl * C[R_M] + x * C[RATE_R]) / (C[R_M] + x)
    out[0] = c * C[M_REF]
    if C[SMOOTH_L] == 0.0:
        out[1] = S[TH_TRAIN]
    else:
        # the regression (and TH_TRAIN) runs behind: the reported slope is the slope layer's now, over the window
        # the history holds up to the regression's sample (until the train has moved, the slope it stands on: before
        # the first backward pass the history is still empty)
        th = S[TH]
        n_hist = C[N_HIST]
        moved = S[MOVED] != 0.0
        th_win = (th + S[HSUM]) / (n_hist + 1.0) if C[N_BUF] > 0.0 and n_hist > 0.0 and moved else th
        out[1] = _gravity_slope(S, C, th, th_win)
    # the calibration of the data part (MASS_STD_SCALE, chosen on plant runs) before the cap: what the data have not
    # told stays the prior's
    out[2] = math.sqrt(min(S[PC] * infl * C[MASS_STD_SCALE] ** 2, C[P0_C])) * C[M_REF]  # never above the prior
    var_th = S[P22]
    if C[FUSED] != 0.0:
        # + the accelerometer bias (not separable from the resistance, so never learned) + the blend weight
        d_th = S[TH] - S[TH_WIN]
        var_th += C[BIAS_VAR] / (G_MPS2 * G_MPS2) + S[PB] / (c * c) * d_th * d_th
    out[3] = math.sqrt(var_th)
    mu = S[MD] / c
    out[4] = mu
    var_mu = (S[PD] - 2.0 * mu * S[PCD] + mu * mu * S[PC]) / (c * c)
    out[5] = math.sqrt(max(var_mu * infl, 0.0))
    out[6] = min(max(S[MB] / c, 0.0), 1.0) if C[FUSED] != 0.0 else 0.0
    out[7] = S[NIS]
    out[EST_SCORE] = S[SCORE]


@njit(cache=True)
def steps(S, H, C, torque, speed, accel, dt):
    """:func:`step` over a block of samples ``dt`` apart, without the per-sample estimates (the env's path)."""
    for i in range(torque.shape[0]):
        step(S, H, C, torque[i], speed[i], accel[i], dt)


@njit(cache=True)
def steps_witnessed(S, H, C, torque, speed, accel, gyro, dt):
    """:func:`steps` with the gyro witness after each sample."""
    for i in range(torque.shape[0]):
        step(S, H, C, torque[i], speed[i], accel[i], dt)
        witness(S, C, gyro[i], dt)


@njit(cache=True)
def run_witnessed(S, H, C, torque, speed, accel, gyro, dts, out):
    """:func:`run` with the gyro witness after each sample."""
    row = np.empty(N_EST)
    for i in range(torque.shape[0]):
        step(S, H, C, torque[i], speed[i], accel[i], dts[i])
        witness(S, C, gyro[i], dts[i])
        estimate(S, C, row)
        for j in range(N_EST):
            out[i, j] = row[j]


@njit(cache=True)
def run(S, H, C, torque, speed, accel, dts, out):
    """The batch path: :func:`step` + :func:`estimate` over whole arrays; ``out`` has shape (n, N_EST)."""
    row = np.empty(N_EST)
    for i in range(torque.shape[0]):
        step(S, H, C, torque[i], speed[i], accel[i], dts[i])
        estimate(S, C, row)
        for j in range(N_EST):
            out[i, j] = row[j]
