"""Fixed-lag smoothing of the slope layer for the mass regression of ``dffrls-aekf`` / ``fused`` (compiled helpers).

Why: the slope layer's filtered grade trails every grade change by 0.5–1 s, and the mass regression read that lag
as mass (with perfect sensors, stop-and-go and section 2 of the point-mass world: 3.4 / 2.6 % of max error; a
delay of the regression behind the filtered slope does not remove it, since the lag is not a constant delay:
docs/estimation.md, sessions 20 and 25). With ``smoothing_lag_s`` > 0 the kernel keeps the last samples in a ring
and runs the regression ``lag`` samples behind the slope layer on the Rauch–Tung–Striebel smoothed state: the
grade at that sample given the samples after it too. Per block of ``nb`` new samples one backward pass runs over
the ring (``lag + nb`` records) and the oldest ``nb`` go to the regression, so each is smoothed over at least
``lag`` later samples, at ``(lag + nb) / nb`` backward steps per sample.

The ring lives in the kernel's ``H`` array after the slope history (:data:`RING0`), one record of :data:`RING_W`
floats per sample; its oldest record's slot is ``S[RING_HEAD]`` and its length ``S[RING_N]``
(:mod:`estimators.dffrls_aekf_layout`).

The backward step, for the slope layer's model ``x_{k+1} = F_{k+1} x_k + w`` with ``F = [[1, f12, 0], [0, 1, ds],
[0, 0, 1]]`` on ``x = [v, θ, κ]``: ``x_s(k) = x_f(k) + P_f(k) F_{k+1}^T P_p(k+1)^{-1} (x_s(k+1) − x_p(k+1))``,
``x_p``/``P_p`` the prediction the filter made at ``k + 1``. Only the means are smoothed (the regression needs no
smoothed covariance). The chain is cut where the filter restarted (its first sample, a speed restart after
persistent outliers, a data gap): there the smoothed state is the filtered one.
"""

from __future__ import annotations

from .dffrls_aekf_layout import RING0, RING_MAX, RING_W
from .numba_shim import njit

__all__ = ["ldl_solve3", "smooth_ring"]

# --- one ring record ----------------------------------------------------------------------------------------------
R_T = 0  # gated torque (NaN: missing)
R_Z = 1  # gated speed
R_DT = 2  # the sample's dt (a gap's already replaced by the nominal step)
R_FIN = 3  # the accelerometer value the regression's ACC_REG term reads, and whether it is valid
R_FOK = 4
R_XF = 5  # filtered v, theta, kappa (3)
R_PF = 8  # filtered covariance p11, p12, p13, p22, p23, p33 (6)
R_XP = 14  # predicted v, theta, kappa (3)
R_PP = 17  # predicted covariance (6)
R_F12 = 23  # transition: d v / d theta over the step, and the distance moved (d theta / d kappa)
R_DS = 24
R_LINK = 25  # 1: this sample's prediction came from the previous sample's filtered state (smoothing may pass)
R_XS = 26  # smoothed v, theta (2), written by smooth_ring
assert R_XS + 2 == RING_W, "the record layout must fill RING_W (estimators.dffrls_aekf_layout)"


@njit(cache=True, inline="always")
def ldl_solve3(a11, a12, a13, a22, a23, a33, b1, b2, b3):
    """Solve the symmetric positive definite 3x3 system ``A y = b`` by an LDL^T factorisation. Returns ``(y1, y2,
    y3, ok)``; ``ok`` False (and y 0) when a pivot is not positive and finite (the chain is then cut)."""
    d1 = a11
    if not (d1 > 0.0 and d1 < 1e300):
        return 0.0, 0.0, 0.0, False
    l21 = a12 / d1
    l31 = a13 / d1
    d2 = a22 - l21 * a12
    if not (d2 > 0.0 and d2 < 1e300):
        return 0.0, 0.0, 0.0, False
    l32 = (a23 - l31 * a12) / d2
    d3 = a33 - l31 * a13 - l32 * l32 * d2
    if not (d3 > 0.0 and d3 < 1e300):
        return 0.0, 0.0, 0.0, False
    z1 = b1
    z2 = b2 - l21 * z1
    z3 = b3 - l31 * z1 - l32 * z2
    y3 = z3 / d3
    y2 = z2 / d2 - l32 * y3
    y1 = z1 / d1 - l21 * y2 - l31 * y3
    if not (abs(y1) < 1e300 and abs(y2) < 1e300 and abs(y3) < 1e300):
        return 0.0, 0.0, 0.0, False
    return y1, y2, y3, True


@njit(cache=True)
def smooth_ring(H, head, n, max_slope):
    """The backward pass over the ``n`` records from slot ``head`` (oldest) on: each record's smoothed ``v, θ``
    into its ``R_XS`` slots; the newest's is its filtered state. ``θ`` stays within ``±max_slope``."""
    j = (head + n - 1) % RING_MAX
    b = RING0 + RING_W * j
    xs_v, xs_t, xs_k = H[b + R_XF], H[b + R_XF + 1], H[b + R_XF + 2]
    H[b + R_XS] = xs_v
    H[b + R_XS + 1] = xs_t
    for i in range(n - 2, -1, -1):
        jn = j  # the record after this one
        bn = b
        j = (head + i) % RING_MAX
        b = RING0 + RING_W * j
        xf_v, xf_t, xf_k = H[b + R_XF], H[b + R_XF + 1], H[b + R_XF + 2]
        ok = H[bn + R_LINK] != 0.0
        if ok:
            # y = P_p(k+1)^-1 (x_s(k+1) - x_p(k+1))
            p = bn + R_PP
            y1, y2, y3, ok = ldl_solve3(H[p], H[p + 1], H[p + 2], H[p + 3], H[p + 4], H[p + 5],
                                        xs_v - H[bn + R_XP], xs_t - H[bn + R_XP + 1], xs_k - H[bn + R_XP + 2])
        if ok:
            # x_s(k) = x_f(k) + P_f(k) F^T y,  F^T y = [y1, f12 y1 + y2, ds y2 + y3]
            u1 = y1
            u2 = H[bn + R_F12] * y1 + y2
            u3 = H[bn + R_DS] * y2 + y3
            q = b + R_PF
            p11, p12, p13, p22, p23, p33 = H[q], H[q + 1], H[q + 2], H[q + 3], H[q + 4], H[q + 5]
            nv = xf_v + p11 * u1 + p12 * u2 + p13 * u3
            nt = xf_t + p12 * u1 + p22 * u2 + p23 * u3
            nk = xf_k + p13 * u1 + p23 * u2 + p33 * u3
            if nv == nv and nt == nt and nk == nk:
                xs_v, xs_t, xs_k = nv, min(max(nt, -max_slope), max_slope), nk
            else:
                xs_v, xs_t, xs_k = xf_v, xf_t, xf_k
        else:
            xs_v, xs_t, xs_k = xf_v, xf_t, xf_k
        H[b + R_XS] = xs_v
        H[b + R_XS + 1] = xs_t
