"""The per-sample arithmetic of the MMAE bank, one loop over the models, compiled with numba.

:class:`~estimators.mmae.MMAEEstimator` keeps the logic (input gates, the slope history, when to update what)
and calls these three functions once per sample each. Why compiled: the numpy version spent its time in the
per-call overhead of some sixty small numpy operations a sample on (n, 3, 3) arrays. Measured with
``OMP_NUM_THREADS=1 python scripts/bench_mmae.py --models 30 50 --samples 5000 --repeat 3`` on the shared 2-core
machine (load ~9): 50 models 193.0 -> 18.3 us/sample (25.9x -> 272.9x real time at 200 Hz), 30 models
179.6 -> 15.3 us/sample. Outputs agree with the numpy version to 2e-14 (relative) on the pinned trace of
``tests/test_estimators_pinned.py``.

Without numba (a dependency, see ``pyproject.toml``) the same functions run as plain Python: same results but
about 2.7 ms a sample at 50 models (1.9x real time), so install numba.

Arrays: ``x`` (n, 4) states ``[v, theta, kappa, dmu]``; ``P`` (n, 4, 4) covariances; ``log_prob`` (n,); all updated in
place. ``c`` is the float vector of model constants built by :func:`pack_constants`.
"""

from __future__ import annotations

import math

import numpy as np

from uuom_core.vehicle import G_MPS2

from .numba_shim import HAVE_NUMBA, njit

_LOG_2PI = math.log(2.0 * math.pi)

# per-model constant arrays, rows of the (6, n) matrix from pack_constants
INV_MEFF, GF, GF_MU, GR, GR_MU, PAYLOAD = range(6)
N_STATES = 4  # v, theta, kappa, dmu (the running-resistance coefficient's offset from the vehicle file's)


def pack_constants(inv_meff: np.ndarray, gf: np.ndarray, gf_mu: np.ndarray, gr: np.ndarray, gr_mu: np.ndarray,
                   payloads_kg: np.ndarray) -> np.ndarray:
    """The per-model constants as one contiguous (6, n) array (rows :data:`INV_MEFF` ... :data:`PAYLOAD`)."""
    n = len(payloads_kg)
    return np.ascontiguousarray(np.vstack([np.broadcast_to(a, (n,)) for a in (inv_meff, gf, gf_mu, gr, gr_mu,
                                                                            payloads_kg)]), dtype=np.float64)


@njit(cache=True)
def predict(x: np.ndarray, P: np.ndarray, m: np.ndarray, torque_nm: float, dt: float, held: bool,
            speed_abs: float, th_rear: float, radius: float, inv_vs: float, q_v: float, q_th: float,
            q_kappa_per_m: float, q_mu: float, p_max: np.ndarray) -> None:  # pragma: no cover - compiled
    """Propagate every model over ``dt``: RK4 of the speed equation, slope advanced by curvature x distance,
    covariance by the first-order transition matrix (identity when ``held`` at rest) plus process noise, each
    variance then bounded by ``p_max`` (its row and column scaled down with it, so P stays positive definite)."""
    n = x.shape[0]
    ns = N_STATES
    h = dt
    rear = not math.isnan(th_rear)
    sin_r = math.sin(th_rear) if rear else 0.0
    cos_r = math.cos(th_rear) if rear else 0.0
    tq = torque_nm / radius
    phi = np.empty((ns, ns))
    tmp = np.empty((ns, ns))
    for j in range(n):
        phi[:] = 0.0
        for a in range(ns):
            phi[a, a] = 1.0
        if not held:
            v = x[j, 0]
            th = x[j, 1]
            kappa = x[j, 2]
            dmu = x[j, 3]
            gf = m[GF, j]
            gf_mu = m[GF_MU, j] + dmu * gf
            sin_f = math.sin(th)
            cos_f = math.cos(th)
            drive = tq * m[INV_MEFF, j] - gf * sin_f
            res = gf_mu * cos_f
            normal = gf * cos_f  # the resistance per unit of the coefficient: d res / d dmu
            if rear:
                drive = drive - m[GR, j] * sin_r
                res = res + (m[GR_MU, j] + dmu * m[GR, j]) * cos_r
                normal = normal + m[GR, j] * cos_r
            k1 = drive - res * math.tanh(v * inv_vs)
            k2 = drive - res * math.tanh((v + 0.5 * h * k1) * inv_vs)
            k3 = drive - res * math.tanh((v + 0.5 * h * k2) * inv_vs)
            k4 = drive - res * math.tanh((v + h * k3) * inv_vs)
            v_new = v + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)
            tanh_v = math.tanh(v * inv_vs)
            phi[0, 0] += h * (-res * (1.0 - tanh_v * tanh_v) * inv_vs)
            phi[0, 1] = -h * (gf * cos_f - gf_mu * sin_f * tanh_v)
            phi[0, 3] = -h * normal * tanh_v
            phi[1, 0] = h * kappa
            phi[1, 2] = h * v
            x[j, 1] = th + kappa * (0.5 * h) * (v + v_new)
            x[j, 0] = v_new
        for a in range(ns):
            for b in range(ns):
                s = 0.0
                for k in range(ns):
                    s += phi[a, k] * P[j, k, b]
                tmp[a, b] = s
        # the upper triangle, mirrored: P stays exactly symmetric. Computing both triangles let their round-off
        # differ, and over a run of long steps (dt = 60 s) the transition's dt-sized entries multiplied that
        # difference ~15x per step, past what the repair every _REPAIR_EVERY samples catches (fuzz, session 59)
        for a in range(ns):
            for b in range(a, ns):
                s = 0.0
                for k in range(ns):
                    s += tmp[a, k] * phi[b, k]
                P[j, a, b] = s
                P[j, b, a] = s
        P[j, 0, 0] += q_v * dt
        P[j, 1, 1] += q_th * dt
        P[j, 2, 2] += q_kappa_per_m * speed_abs * dt
        P[j, 3, 3] += q_mu * dt
        # a run of huge steps (a logger that stalled for minutes, 200 times over) multiplies the speed-slope-curvature
        # block by the transition's dt-sized entries each step: bounded here, it stays finite and symmetric
        for a in range(ns):
            if P[j, a, a] > p_max[a]:
                r = math.sqrt(p_max[a] / P[j, a, a])
                for b in range(ns):
                    P[j, a, b] *= r
                    P[j, b, a] *= r


@njit(cache=True)
def _quad(P: np.ndarray, j: int, h0: float, h1: float, h3: float) -> float:  # pragma: no cover - compiled
    """``h P_j h^T`` for the row ``[h0, h1, 0, h3]``."""
    return (h0 * (P[j, 0, 0] * h0 + P[j, 0, 1] * h1 + P[j, 0, 3] * h3)
            + h1 * (P[j, 1, 0] * h0 + P[j, 1, 1] * h1 + P[j, 1, 3] * h3)
            + h3 * (P[j, 3, 0] * h0 + P[j, 3, 1] * h1 + P[j, 3, 3] * h3))


@njit(cache=True)
def _scalar_update(x: np.ndarray, P: np.ndarray, j: int, resid: float, h0: float, h1: float, h3: float,
                   r: float, g: np.ndarray, learn_mu: bool) -> tuple[float, float]:  # pragma: no cover - compiled
    """Scalar EKF update of model ``j`` with measurement row ``[h0, h1, 0, h3]``; returns (log-likelihood, NIS).

    Without ``learn_mu`` the resistance offset is a consider parameter (Schmidt): its uncertainty enters the
    innovation and the cross-covariances are updated, but the offset and its variance are not."""
    ns = N_STATES
    for a in range(ns):
        g[a] = P[j, a, 0] * h0 + P[j, a, 1] * h1 + P[j, a, 3] * h3
    s = (h0 * g[0] + h1 * g[1]) + h3 * g[3] + r
    for a in range(ns):
        k = g[a] / s
        if a == 3 and not learn_mu:
            for b in range(3):
                P[j, a, b] -= k * g[b]
            continue
        x[j, a] += k * resid
        for b in range(ns):
            P[j, a, b] -= k * g[b]
    nis = resid * resid / s
    return -0.5 * (nis + math.log(s) + _LOG_2PI), nis


@njit(cache=True)
def correct(x: np.ndarray, P: np.ndarray, log_prob: np.ndarray, m: np.ndarray, torque_nm: float,
            speed_mps: float, accel_mps2: float, have_v: bool, have_f: bool, th_rear: float, radius: float,
            v_s: float, r_v: float, r_f: float, learn: bool, gate_nis: float, prob_floor: float,
            force_v: bool, force_f: bool, learn_mu: bool) -> int:  # pragma: no cover - compiled
    """Speed and specific-force updates of every model, then the Bayesian update of the model probabilities.

    A measurement whose normalised innovation squared exceeds ``gate_nis`` in *every* model is an outlier (a
    spike, a fault): it updates no state unless ``force_v`` / ``force_f`` (the caller forces it after a run of
    rejections, so a real step is followed). The probabilities learn only if ``learn``, nothing was rejected and
    the best model's total NIS passes the gate; they are floored at ``prob_floor``.

    Returns a bit mask of the rejected measurements: 1 speed, 2 specific force.
    """
    n = x.shape[0]
    rear = not math.isnan(th_rear)
    sin_r = math.sin(th_rear) if rear else 0.0
    cos_r = math.cos(th_rear) if rear else 0.0
    tq = torque_nm / radius
    g = np.empty(N_STATES)
    loglik = np.zeros(n)
    nis = np.zeros(n)
    rejected = 0
    if have_v:
        worst = math.inf
        for j in range(n):
            e = speed_mps - x[j, 0]
            worst = min(worst, e * e / (P[j, 0, 0] + r_v))
        if worst <= gate_nis or force_v:
            for j in range(n):
                ll, nis1 = _scalar_update(x, P, j, speed_mps - x[j, 0], 1.0, 0.0, 0.0, r_v, g, learn_mu)
                loglik[j] += ll
                nis[j] += nis1
        else:
            rejected |= 1
    if have_f:
        resid = np.empty(n)
        h0 = np.empty(n)
        h1 = np.empty(n)
        h3 = np.empty(n)
        worst = math.inf
        for j in range(n):
            v = x[j, 0]
            th = x[j, 1]
            dmu = x[j, 3]
            gf = m[GF, j]
            gf_mu = m[GF_MU, j] + dmu * gf
            tanh_v = math.tanh(v / v_s)
            sin_f = math.sin(th)
            cos_f = math.cos(th)
            grav = gf * sin_f + gf_mu * cos_f * tanh_v
            d_th = gf * cos_f - gf_mu * sin_f * tanh_v
            res = gf_mu * cos_f
            normal = gf * cos_f
            if rear:
                gr_mu = m[GR_MU, j] + dmu * m[GR, j]
                grav = grav + m[GR, j] * sin_r + gr_mu * cos_r * tanh_v
                res = res + gr_mu * cos_r
                normal = normal + m[GR, j] * cos_r
            resid[j] = accel_mps2 - (tq * m[INV_MEFF, j] - grav + G_MPS2 * sin_f)
            h0[j] = -res * (1.0 - tanh_v * tanh_v) / v_s
            h1[j] = G_MPS2 * cos_f - d_th
            h3[j] = -normal * tanh_v
            worst = min(worst, resid[j] * resid[j] / (_quad(P, j, h0[j], h1[j], h3[j]) + r_f))
        if worst <= gate_nis or force_f:
            for j in range(n):
                ll, nis2 = _scalar_update(x, P, j, resid[j], h0[j], h1[j], h3[j], r_f, g, learn_mu)
                loglik[j] += ll
                nis[j] += nis2
        else:
            rejected |= 2
    if not learn or rejected != 0:
        return rejected
    nis_min = math.inf
    for j in range(n):
        nis_min = min(nis_min, nis[j])
    if not (nis_min <= gate_nis):
        return rejected
    top = -math.inf
    for j in range(n):
        loglik[j] += log_prob[j]
        top = max(top, loglik[j])
    total = 0.0
    for j in range(n):
        loglik[j] = math.exp(loglik[j] - top)
        total += loglik[j]
    total2 = 0.0
    for j in range(n):
        loglik[j] = max(loglik[j] / total, prob_floor)
        total2 += loglik[j]
    for j in range(n):
        log_prob[j] = math.log(loglik[j] / total2)
    return rejected


@njit(cache=True)
def mixture(x: np.ndarray, P: np.ndarray, log_prob: np.ndarray, m: np.ndarray,
            out: np.ndarray) -> None:  # pragma: no cover - compiled
    """Mixture moments into ``out``: payload mean, payload variance (spread of the means), slope mean, slope
    variance (``P`` plus spread), speed mean, largest model probability, running-resistance offset mean."""
    n = x.shape[0]
    payload = 0.0
    slope = 0.0
    speed = 0.0
    dmu = 0.0
    p_max = 0.0
    for j in range(n):
        p = math.exp(log_prob[j])
        payload += p * m[PAYLOAD, j]
        dmu += p * x[j, 3]
        slope += p * x[j, 1]
        speed += p * x[j, 0]
        p_max = max(p_max, p)
    var_p = 0.0
    var_s = 0.0
    for j in range(n):
        p = math.exp(log_prob[j])
        dp = m[PAYLOAD, j] - payload
        ds = x[j, 1] - slope
        var_p += p * (dp * dp)
        var_s += p * (P[j, 1, 1] + ds * ds)
    out[0] = payload
    out[1] = var_p
    out[2] = slope
    out[3] = var_s
    out[4] = speed
    out[5] = p_max
    out[6] = dmu


__all__ = ["HAVE_NUMBA", "N_STATES", "correct", "mixture", "pack_constants", "predict"]
