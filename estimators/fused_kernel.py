"""The fused observer's regression step (``fused``, :mod:`estimators.fused`), compiled with the rest of the kernel
(:mod:`estimators.dffrls_aekf_kernel`, which calls it in place of the two-parameter ``dffrls-aekf`` step), and the
residual gate both regression steps call (here, not in the kernel module, which imports this one)."""

from __future__ import annotations

import math

from uuom_core.vehicle import G_MPS2

from .dffrls_aekf_layout import (C_MAX, C_MIN, DELTA, LAMBDA, MASS_FORGET, MAX_AMBIG, MB, MC, MD, MIN_ACC, MU_MAX,
                                 N_MASS, OFF_FORGET, P0_B, P0_C, P0_D, PB, PC, PCB, PCD, PD, PDB, PROJECT_CLAMP, Q_C,
                                 R_M, SLOPE_VAR_W, RES_VAR, SIGMA, FUSED_SPREAD, MAX_SPREAD, SPREAD, EVID_MIN,
                                 RATE_R, RES_GATE2, RES_PERSIST, RES_SKIP)
from .numba_shim import njit

__all__ = ["fused_mass_step", "grade_noise", "residual_gated", "sample_noise"]


@njit(cache=True)
def residual_gated(S, C, e, hph, dt):
    """The regression's residual gate (``residual_gate_sigma``): True when this sample's residual ``e`` is beyond
    the gate of the running residual scale plus the parameters' uncertainty ``hph``, so the mass holds (a considered
    parameter, as at constant speed) while the offset and the blend learn on. A run of gated samples longer than
    RES_PERSIST is a lasting change, not a burst: the residual becomes the scale and the sample is used."""
    if C[RES_GATE2] <= 0.0:
        return False
    if e * e > C[RES_GATE2] * (S[RES_VAR] + hph):
        S[RES_SKIP] += dt
        if S[RES_SKIP] < C[RES_PERSIST]:
            return True
        S[RES_VAR] = e * e
    S[RES_SKIP] = 0.0
    return False


@njit(cache=True, inline="always")
def grade_noise(C, c, p22):
    """The grade's error in the mass regression's residual, ``c g δθ``, as per-sample noise at the reference rate:
    ``SLOPE_VAR_W c² g² P22`` (``p22``: the slope layer's grade variance; 0 unless the option is on)."""
    return C[SLOPE_VAR_W] * c * c * G_MPS2 * G_MPS2 * p22


@njit(cache=True, inline="always")
def sample_noise(C, c, p22):
    """The mass regression's per-sample noise at this sample rate: the residual's white noise ``R_M`` plus
    :func:`grade_noise`, scaled so that a second carries the same information at any rate."""
    return (C[R_M] + grade_noise(C, c, p22)) / C[RATE_R]


@njit(cache=True)
def fused_mass_step(S, C, y, a_l, sin_win, sin_loc, use_rate, learn_b, dt, p22_th):
    """Fused observer's regression on three parameters ``[c, o, beta]`` (c = M/M_ref, o = resistance-and-bias
    offset, beta = c alpha, alpha = weight of the slope under the sensors in the slope gravity acts on)::

        y = c (a_load + g sin th_win) + o g + beta g (sin th_loc - sin th_win)

    Vector forgetting (c and beta: constants of a run; o: the dynamic lambda), c only from accelerations and while
    the blend leaves the slope for gravity certain enough (Schmidt update otherwise), covariance bounded by the
    prior and repaired to symmetric PD. ``p22_th``: the slope layer's grade variance for this sample
    (``SLOPE_VAR_W``)."""
    g = G_MPS2
    h1 = a_l + g * sin_win
    h2 = g
    h3 = g * (sin_loc - sin_win)
    c, o, b = S[MC], S[MD], S[MB]
    p11, p12, p22 = S[PC] + C[Q_C], S[PCD], S[PD]
    p13, p23, p33 = S[PCB], S[PDB], S[PB] + C[Q_C]
    e = y - h1 * c - h2 * o - h3 * b
    lam = C[DELTA] + (1.0 - C[DELTA]) * math.exp(-C[SIGMA] * abs(e))
    if C[RATE_R] != 1.0:  # the forgetting per second kept at another sample rate
        lam = lam ** C[RATE_R]
    lm = 1.0 - C[MASS_FORGET] * (1.0 - lam)
    ld = 1.0 - C[OFF_FORGET] * (1.0 - lam)
    lb = lm
    # vector forgetting bounded by the prior: the two-parameter step of dffrls_aekf_kernel with a third parameter,
    # written out for the compiled loop
    if p11 / lm >= C[P0_C]:
        lm = 1.0
    if p22 / ld >= C[P0_D]:
        ld = 1.0
    if p33 / lb >= C[P0_B]:
        lb = 1.0
    p11 /= lm
    p22 /= ld
    p33 /= lb
    p12 /= math.sqrt(lm * ld)
    p13 /= math.sqrt(lm * lb)
    p23 /= math.sqrt(ld * lb)
    q1 = p11 * h1 + p12 * h2 + p13 * h3
    q2 = p12 * h1 + p22 * h2 + p23 * h3
    q3 = p13 * h1 + p23 * h2 + p33 * h3
    # per-sample noise: a white noise's (dffrls_aekf_kernel), plus the grade's error in the regressor, c g δθ, counted
    # SLOPE_VAR_W times (it is correlated over many samples): a sample read while the slope layer is unsure of the
    # grade, as over a crest or before it has settled, teaches the mass less (session 63)
    s_m = sample_noise(C, c, p22_th) + h1 * q1 + h2 * q2 + h3 * q3
    if use_rate and e * e > 100.0 * s_m:
        return
    gated = residual_gated(S, C, e, h1 * q1 + h2 * q2 + h3 * q3, dt)
    # c only from accelerations, and not while the blend is too uncertain for the slope gravity acts on: std(alpha)
    # |sin th_loc - sin th_win| above MAX_AMBIG, the fused form of the geometry bank's ambiguity gate (a c learnt
    # then would absorb the blend's error); nor (FUSED_SPREAD) on a grade change within the window, where the slope
    # layer's lag is read as mass (dffrls-aekf's spread gate, here for c alone: o and beta learn on)
    consider = gated or abs(a_l) < C[MIN_ACC] or math.sqrt(p33) / c * abs(sin_loc - sin_win) > C[MAX_AMBIG] or (
        C[FUSED_SPREAD] != 0.0 and not S[SPREAD] < C[MAX_SPREAD])
    if not consider:
        c += q1 / s_m * e
        p11 -= q1 * q1 / s_m
    o += q2 / s_m * e
    p12 -= q1 * q2 / s_m
    p13 -= q1 * q3 / s_m
    p22 -= q2 * q2 / s_m
    p23 -= q2 * q3 / s_m
    if learn_b and consider and (C[EVID_MIN] == 0.0 or abs(sin_loc - sin_win) >= C[EVID_MIN]):
        # beta only at steady speed (grade changes are its information), c only from accelerations: a residual
        # of the start or stop dynamics must not be read as a gravity blend; else beta is a considered parameter
        # too (zero gain, variance kept). Nor where the two slopes agree (EVID_MIN): there the regressor h3 is the
        # slope layer's noise alone, and fitting it pulls beta towards 0, the window (the geometry bank's noise
        # ranking in regression form; docs/estimation.md, session 27)
        b += q3 / s_m * e
        p33 -= q3 * q3 / s_m
    # PD repair: floors on the diagonal, then shrink the correlations until every leading minor is positive
    p11 = p11 if p11 >= 1e-14 else 1e-14
    p22 = p22 if p22 >= 1e-16 else 1e-16
    p33 = p33 if p33 >= 1e-14 else 1e-14
    if not (abs(p12) < math.inf and abs(p13) < math.inf and abs(p23) < math.inf):
        p12 = p13 = p23 = 0.0
    for _ in range(60):
        m2 = p11 * p22 - p12 * p12
        det = p11 * (p22 * p33 - p23 * p23) - p12 * (p12 * p33 - p23 * p13) + p13 * (p12 * p23 - p22 * p13)
        if m2 > 1e-6 * p11 * p22 and det > 1e-9 * p11 * p22 * p33:
            break
        p12 *= 0.7
        p13 *= 0.7
        p23 *= 0.7
    S[PC], S[PCD], S[PD], S[PCB], S[PDB], S[PB] = p11, p12, p22, p13, p23, p33
    c_free = c
    c = min(max(c, C[C_MIN]), C[C_MAX])
    if C[PROJECT_CLAMP] != 0.0 and c != c_free:
        o += p12 / p11 * (c - c_free)
        b += p13 / p11 * (c - c_free)
    S[MC] = c
    S[MD] = min(max(o, -C[MU_MAX] * c), C[MU_MAX] * c)
    S[MB] = min(max(b, -0.2 * c), 1.2 * c)
    if not gated:
        S[RES_VAR] += min(0.002 * C[RATE_R], 1.0) * (min(e * e, 100.0 * S[RES_VAR]) - S[RES_VAR])
    S[LAMBDA] = lam
    S[N_MASS] += 1.0


