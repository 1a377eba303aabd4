"""Quaternion attitude UKF (paper 001, §3.2) for the monorail's drive-unit IMU.

The paper's filter has the attitude quaternion as its state, propagates it with the gyro through the quaternion
kinematics ``dq/dt = 1/2 q ⊗ (ω - b)`` and corrects it with the accelerometer's gravity direction (and a
magnetometer for heading). On the monorail the IMU has a pitch-rate gyro and a two-axis accelerometer in the
vertical plane of the track and no magnetometer: the attitude is a rotation about the lateral axis,

    q = [q0, q2] = [cos(pitch/2), sin(pitch/2)]        (the unit quaternion cos(θ/2) + sin(θ/2)·e_lateral)

so this filter keeps the two non-zero quaternion components and the gyro bias as its state ``x = [q0, q2, b]``.
Pitch is positive nose-up, which on the track is the slope (positive uphill).

Model (discrete, exact rotation over one step ``T``)::

    Δ = (ω_meas - b) T
    q0' = cos(Δ/2) q0 - sin(Δ/2) q2,   q2' = sin(Δ/2) q0 + cos(Δ/2) q2,   b' = b
    h(x) = [g sin θ + a_lin,  g cos θ],  sin θ = 2 q0 q2 / |q|²,  cos θ = (q0² - q2²) / |q|²

``a_lin`` is the along-track motion acceleration the caller knows (the estimator takes it from the speed
sensor); the accelerometer is the specific force ``f = dv/dt + g sin θ`` of spec §4, the normal axis reads
``+g cos θ`` when the train is at rest.

Process noise (paper eq. 31 reduced to one axis): the gyro's white noise enters the quaternion along the tangent
``t = [-q2, q0]`` as ``(T/2)² σ_ω² t tᵀ``; the bias is a random walk ``σ_b² T``. Both are what the improved
Harris-hawks optimiser tunes.

UKF: scaled sigma points (α, β, κ), additive noise, sigma points re-drawn for the measurement update as in the
paper's step 5. After every step the quaternion is renormalised and its covariance projected onto the tangent
of the unit circle (plus a small radial variance), which keeps ``P`` symmetric positive definite.
Written in scalar Python for a 3-state filter: no numpy call overhead in the per-sample path.
"""

from __future__ import annotations

import math

__all__ = ["PitchQuaternionUKF", "UKFConfigError"]

_RADIAL_VAR = 1e-8  # variance kept along the (unobservable) quaternion norm direction


class UKFConfigError(ValueError):
    """An impossible UKF setting; the message names it."""


def _positive(name: str, value: float) -> float:
    value = float(value)
    if not (value > 0.0 and math.isfinite(value)):
        raise UKFConfigError(f"{name} must be finite and > 0, got {value!r}")
    return value


def _chol3(p: list[float]) -> list[float] | None:
    """Lower Cholesky factor of a symmetric 3x3 (row-major list of 9); None if not positive definite."""
    a00, a01, a02, _, a11, a12, _, _, a22 = p
    if a00 <= 0.0:
        return None
    l00 = math.sqrt(a00)
    l10 = a01 / l00
    l20 = a02 / l00
    d1 = a11 - l10 * l10
    if d1 <= 0.0:
        return None
    l11 = math.sqrt(d1)
    l21 = (a12 - l20 * l10) / l11
    d2 = a22 - l20 * l20 - l21 * l21
    if d2 <= 0.0:
        return None
    l22 = math.sqrt(d2)
    return [l00, l10, l20, l11, l21, l22]


class PitchQuaternionUKF:
    """Unscented Kalman filter of the pitch quaternion and gyro bias (filterpy-like).

    Parameters
    ----------
    gyro_noise_radps : float
        σ_ω, gyro white noise as a rate standard deviation per sample (process noise of the quaternion).
    gyro_bias_walk_radps : float
        σ_b, random-walk intensity of the gyro bias (rad/s per √s).
    accel_noise_mps2 : float
        Standard deviation of the along-track accelerometer residual (noise, vibration, error of ``a_lin``).
    accel_normal_noise_mps2 : float
        Standard deviation of the normal-axis accelerometer residual.
    alpha, beta, kappa : float
        Unscented-transform parameters (paper: α = 0.01, β = 2, κ = 0; default α = 0.3 keeps the central weight
        moderate, the filter is the same otherwise).
    g_mps2 : float
        Gravitational acceleration.

    Attributes
    ----------
    x : list of float
        State ``[q0, q2, b]``.
    P : list of float
        Covariance, row-major 3x3.
    initialized : bool
        False until :meth:`initialize` (or the first accelerometer sample through :meth:`step`).
    """

    dim_x = 3

    def __init__(self, gyro_noise_radps: float = 2e-3, gyro_bias_walk_radps: float = 1e-4,
                 accel_noise_mps2: float = 0.2, accel_normal_noise_mps2: float = 0.2, *, alpha: float = 0.3,
                 beta: float = 2.0, kappa: float = 0.0, g_mps2: float = 9.81,
                 initial_bias_std_radps: float = 0.005) -> None:
        self.gyro_noise_radps = _positive("gyro_noise_radps", gyro_noise_radps)
        self.gyro_bias_walk_radps = _positive("gyro_bias_walk_radps", gyro_bias_walk_radps)
        self.accel_noise_mps2 = _positive("accel_noise_mps2", accel_noise_mps2)
        self.accel_normal_noise_mps2 = _positive("accel_normal_noise_mps2", accel_normal_noise_mps2)
        self.initial_bias_std_radps = _positive("initial_bias_std_radps", initial_bias_std_radps)
        self.g = _positive("g_mps2", g_mps2)
        alpha = _positive("alpha", alpha)
        n = self.dim_x
        lam = alpha * alpha * (n + kappa) - n
        if not n + lam > 0.0:
            raise UKFConfigError(f"alpha={alpha}, kappa={kappa} give n + lambda <= 0")
        self._gamma = math.sqrt(n + lam)
        self._wm0 = lam / (n + lam)
        self._wc0 = self._wm0 + (1.0 - alpha * alpha + beta)
        self._wi = 0.5 / (n + lam)
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Back to the uninitialised prior (level, zero bias)."""
        self.x = [1.0, 0.0, 0.0]
        self.P = [1e-2, 0.0, 0.0, 0.0, 1e-2, 0.0, 0.0, 0.0, self.initial_bias_std_radps ** 2]
        self.initialized = False
        self.nis = 0.0

    def initialize(self, pitch_rad: float, pitch_std_rad: float = math.radians(2.0), bias_radps: float = 0.0) -> None:
        """Start from a known pitch (e.g. from the accelerometer at rest, paper §3.2.1)."""
        h = 0.5 * pitch_rad
        q0, q2 = math.cos(h), math.sin(h)
        self.x = [q0, q2, float(bias_radps)]
        var_t = (0.5 * pitch_std_rad) ** 2  # pitch = 2 * angle along the tangent
        # covariance: var_t along t = [-q2, q0], small along r = [q0, q2]
        p00 = var_t * q2 * q2 + _RADIAL_VAR * q0 * q0
        p01 = -var_t * q2 * q0 + _RADIAL_VAR * q0 * q2
        p11 = var_t * q0 * q0 + _RADIAL_VAR * q2 * q2
        vb = self.initial_bias_std_radps ** 2
        self.P = [p00, p01, 0.0, p01, p11, 0.0, 0.0, 0.0, vb]
        self.initialized = True

    @property
    def pitch_rad(self) -> float:
        """Pitch angle of the state quaternion (positive nose-up)."""
        return 2.0 * math.atan2(self.x[1], self.x[0])

    @property
    def pitch_std_rad(self) -> float:
        """1-σ of the pitch, from the quaternion covariance (θ = 2 atan2(q2, q0))."""
        q0, q2, _ = self.x
        n2 = q0 * q0 + q2 * q2
        j0, j1 = -2.0 * q2 / n2, 2.0 * q0 / n2
        P = self.P
        var = j0 * j0 * P[0] + 2.0 * j0 * j1 * P[1] + j1 * j1 * P[4]
        return math.sqrt(max(var, 0.0))

    @property
    def bias_radps(self) -> float:
        return self.x[2]

    # ------------------------------------------------------------------ helpers
    def _sigma_points(self) -> list[tuple[float, float, float]]:
        L = _chol3(self.P)
        if L is None:
            self._repair()
            L = _chol3(self.P)
            if L is None:  # pragma: no cover - _repair makes P diagonal dominant
                raise FloatingPointError("UKF covariance could not be repaired")
        g = self._gamma
        l00, l10, l20, l11, l21, l22 = (g * v for v in L)
        x0, x1, x2 = self.x
        # columns of L: c0 = (l00, l10, l20), c1 = (0, l11, l21), c2 = (0, 0, l22)
        return [
            (x0, x1, x2),
            (x0 + l00, x1 + l10, x2 + l20), (x0, x1 + l11, x2 + l21), (x0, x1, x2 + l22),
            (x0 - l00, x1 - l10, x2 - l20), (x0, x1 - l11, x2 - l21), (x0, x1, x2 - l22),
        ]

    def _repair(self) -> None:
        P = self.P
        d = [max(P[0], 1e-12), max(P[4], 1e-12), max(P[8], 1e-14)]
        self.P = [d[0], 0.0, 0.0, 0.0, d[1], 0.0, 0.0, 0.0, d[2]]

    def _project(self) -> None:
        """Renormalise the quaternion; keep its covariance on the tangent plus a small radial part."""
        q0, q2, b = self.x
        n = math.hypot(q0, q2)
        if not (n > 0.0 and math.isfinite(n)):
            q0, q2, n = 1.0, 0.0, 1.0
        q0 /= n
        q2 /= n
        self.x = [q0, q2, b]
        P = self.P
        t0, t1 = -q2, q0
        vt = t0 * t0 * P[0] + 2.0 * t0 * t1 * P[1] + t1 * t1 * P[4]
        cb = t0 * P[2] + t1 * P[5]
        vb = P[8]
        vt = max(vt, 1e-16)
        vb = max(vb, 1e-16)
        # keep the t-b correlation a valid one
        lim = 0.999 * math.sqrt(vt * vb)
        cb = max(-lim, min(lim, cb))
        r = _RADIAL_VAR
        p00 = vt * t0 * t0 + r * q0 * q0
        p01 = vt * t0 * t1 + r * q0 * q2
        p11 = vt * t1 * t1 + r * q2 * q2
        self.P = [p00, p01, cb * t0, p01, p11, cb * t1, cb * t0, cb * t1, vb]

    # ------------------------------------------------------------------ filter
    def predict(self, gyro_radps: float, dt_s: float, extra_rate_std_radps: float = 0.0) -> None:
        """Propagate with one gyro sample (NaN gyro: hold the attitude, grow the covariance)."""
        if not math.isfinite(gyro_radps):
            extra_rate_std_radps = max(extra_rate_std_radps, 0.05)
        pts = self._sigma_points()
        wm0, wi, wc0 = self._wm0, self._wi, self._wc0
        prop = []
        for (q0, q2, b) in pts:
            w = (gyro_radps - b) if math.isfinite(gyro_radps) else 0.0
            h = 0.5 * w * dt_s
            c, s = math.cos(h), math.sin(h)
            prop.append((c * q0 - s * q2, s * q0 + c * q2, b))
        m0 = wm0 * prop[0][0] + wi * sum(p[0] for p in prop[1:])
        m1 = wm0 * prop[0][1] + wi * sum(p[1] for p in prop[1:])
        m2 = wm0 * prop[0][2] + wi * sum(p[2] for p in prop[1:])
        P = [0.0] * 9
        for k, (a0, a1, a2) in enumerate(prop):
            wgt = wc0 if k == 0 else wi
            d0, d1, d2 = a0 - m0, a1 - m1, a2 - m2
            P[0] += wgt * d0 * d0
            P[1] += wgt * d0 * d1
            P[2] += wgt * d0 * d2
            P[4] += wgt * d1 * d1
            P[5] += wgt * d1 * d2
            P[8] += wgt * d2 * d2
        # process noise: gyro white noise along the quaternion tangent, bias random walk
        n = math.hypot(m0, m1) or 1.0
        t0, t1 = -m1 / n, m0 / n
        sw = self.gyro_noise_radps ** 2 + extra_rate_std_radps ** 2
        qv = 0.25 * dt_s * dt_s * sw
        P[0] += qv * t0 * t0
        P[1] += qv * t0 * t1
        P[4] += qv * t1 * t1
        P[8] += self.gyro_bias_walk_radps ** 2 * dt_s
        P[3], P[6], P[7] = P[1], P[2], P[5]
        self.x = [m0, m1, m2]
        self.P = P
        self._project()

    def update(self, accel_mps2: float, accel_normal_mps2: float = math.nan, accel_offset_mps2: float = 0.0,
               accel_noise_scale: float = 1.0) -> None:
        """Correct with the accelerometer (either axis may be NaN; both NaN: no correction).

        Parameters
        ----------
        accel_mps2 : float
            Along-track specific force.
        accel_normal_mps2 : float
            Normal-axis specific force.
        accel_offset_mps2 : float
            Known along-track motion acceleration ``a_lin`` (subtracted via the model).
        accel_noise_scale : float
            Multiplies the along-track measurement standard deviation (e.g. while accelerating).
        """
        use_x = math.isfinite(accel_mps2) and math.isfinite(accel_offset_mps2)
        use_z = math.isfinite(accel_normal_mps2)
        if not (use_x or use_z):
            return
        g = self.g
        pts = self._sigma_points()
        wm0, wi, wc0 = self._wm0, self._wi, self._wc0
        zs = []
        for (q0, q2, _) in pts:
            n2 = q0 * q0 + q2 * q2
            zs.append((g * 2.0 * q0 * q2 / n2, g * (q0 * q0 - q2 * q2) / n2))
        x0, x1, x2 = self.x
        zx = wm0 * zs[0][0] + wi * sum(z[0] for z in zs[1:])
        zz = wm0 * zs[0][1] + wi * sum(z[1] for z in zs[1:])
        sxx = sxz = szz = 0.0
        cx = [0.0, 0.0, 0.0]  # cross-covariance with the x (along-track) channel
        cz = [0.0, 0.0, 0.0]
        for k in range(7):
            wgt = wc0 if k == 0 else wi
            dx, dz = zs[k][0] - zx, zs[k][1] - zz
            p = pts[k]
            e0, e1, e2 = p[0] - x0, p[1] - x1, p[2] - x2
            sxx += wgt * dx * dx
            sxz += wgt * dx * dz
            szz += wgt * dz * dz
            cx[0] += wgt * e0 * dx
            cx[1] += wgt * e1 * dx
            cx[2] += wgt * e2 * dx
            cz[0] += wgt * e0 * dz
            cz[1] += wgt * e1 * dz
            cz[2] += wgt * e2 * dz
        rx = (self.accel_noise_mps2 * accel_noise_scale) ** 2
        rz = self.accel_normal_noise_mps2 ** 2
        if use_x and use_z:
            s00, s01, s11 = sxx + rx, sxz, szz + rz
            det = s00 * s11 - s01 * s01
            if not det > 0.0:
                return
            i00, i01, i11 = s11 / det, -s01 / det, s00 / det
            y0 = accel_mps2 - accel_offset_mps2 - zx
            y1 = accel_normal_mps2 - zz
            K = [(cx[i] * i00 + cz[i] * i01, cx[i] * i01 + cz[i] * i11) for i in range(3)]
            self.x = [self.x[i] + K[i][0] * y0 + K[i][1] * y1 for i in range(3)]
            self.nis = y0 * (i00 * y0 + i01 * y1) + y1 * (i01 * y0 + i11 * y1)
            # P -= K S K^T  ==  P -= K C^T  with C = [cx cz]
            P = self.P
            for i in range(3):
                for j in range(3):
                    P[3 * i + j] -= K[i][0] * cx[j] + K[i][1] * cz[j]
        else:
            c, s, y = (cx, sxx + rx, accel_mps2 - accel_offset_mps2 - zx) if use_x else (cz, szz + rz,
                                                                                       accel_normal_mps2 - zz)
            if not s > 0.0:
                return
            K = [ci / s for ci in c]
            self.x = [self.x[i] + K[i] * y for i in range(3)]
            self.nis = y * y / s
            P = self.P
            for i in range(3):
                for j in range(3):
                    P[3 * i + j] -= K[i] * c[j]
        P = self.P
        P[1] = P[3] = 0.5 * (P[1] + P[3])
        P[2] = P[6] = 0.5 * (P[2] + P[6])
        P[5] = P[7] = 0.5 * (P[5] + P[7])
        self._project()
