"""The regression front end of the RLS estimators (``rls``, ``ffrls``, ``dffrls``, ``rls-ekf``) and ``sf-kf``:
filtered ``T/r``, speed, ``dv/dt`` and the swinging load's acceleration, with the excitation checks (see
:mod:`estimators.rls` for why each is there)."""

from __future__ import annotations

import math

from uuom_core.vehicle import G_MPS2, VehicleParams

from .filters import MAX_STEP_S, LowPass2, SpikeGate

__all__ = ["RegressionFrontEnd", "swing_geometry"]


def swing_geometry(v: VehicleParams, chain_length_m: float | None, hook_mass_kg: float | None,
                   who: str = "") -> tuple[float, float]:
    """The load swing an estimator models: ``(chain length, hook mass)``, each the estimator's option or, when that
    is None, the vehicle file's (validated; ``who`` prefixes the error)."""
    chain = _checked_chain(v.chain_length_m if chain_length_m is None else chain_length_m, who)
    hook = v.hook_mass_kg if hook_mass_kg is None else hook_mass_kg
    if isinstance(hook, bool) or not isinstance(hook, (int, float)) or not (0.0 <= hook <= v.empty_mass_kg):
        raise ValueError(f"{who}hook_mass_kg must be in [0, empty_mass_kg], got {hook_mass_kg!r}")
    return chain, float(hook)


def _checked_chain(chain: object, who: str = "") -> float:
    if isinstance(chain, bool) or not isinstance(chain, (int, float)) or not (0.0 <= chain < math.inf):
        raise ValueError(f"{who}chain_length_m must be a finite number >= 0 (0: no load-swing model), got {chain!r}")
    return float(chain)


class RegressionFrontEnd:
    """Turns raw (torque, speed) samples into the filtered regression signals ``F = T/r``, ``v``, ``a = dv/dt``.

    Parameters
    ----------
    vehicle : VehicleParams
    cutoff_hz : float
        Corner frequency of the second-order low-pass applied to ``T/r`` and to speed (before differentiating).
    min_speed_mps, min_traction_fraction : float
        Excitation / model-validity thresholds (see module docstring).
    chain_length_m : float
        Pendulum length of the load hanging on chains (0: no load-swing model, ``load_accel_mps2 = accel_mps2``).
    sway_damping_ratio : float
        Damping ratio of the load swing (the plant's anti-sway damper).

    Attributes
    ----------
    force_n, speed_mps, accel_mps2 : float
        The latest filtered traction force, speed and speed derivative.
    sway, sway_rate, load_accel_mps2 : float
        Simulated load swing (rad, rad/s, small angles) and the load's filtered along-track acceleration.
    valid : bool
        Whether the latest sample may be used for a regression update.
    """

    __slots__ = ("r", "lp_force", "lp_speed", "gate_torque", "gate_speed", "min_speed", "min_force",
                 "force_n", "speed_mps", "accel_mps2", "valid", "_prev_vf", "_n_valid_in", "_n_missing",
                 "settle_samples", "swing", "chain_length", "sway_damping", "lp_fast", "lp_aload", "sway",
                 "sway_rate", "_prev_fast", "load_accel_mps2", "sway_h_max")

    def __init__(self, vehicle: VehicleParams, cutoff_hz: float = 1.0, min_speed_mps: float = 0.05,
                 min_traction_fraction: float = 0.02, chain_length_m: float = 2.0,
                 sway_damping_ratio: float = 0.05) -> None:
        self.r = vehicle.drive_wheel_radius_m
        self.lp_force = LowPass2(cutoff_hz)
        self.lp_speed = LowPass2(cutoff_hz)
        chain_length_m = _checked_chain(chain_length_m)
        if not (sway_damping_ratio >= 0.0 and math.isfinite(sway_damping_ratio)):
            raise ValueError(f"sway_damping_ratio must be a finite number >= 0, got {sway_damping_ratio!r}")
        self.swing = chain_length_m > 0.0
        self.chain_length = float(chain_length_m)
        # damping force per unit mass = 2 zeta omega0 L sway_rate, omega0 = sqrt(g / L)
        self.sway_damping = 2.0 * sway_damping_ratio * math.sqrt(G_MPS2 * chain_length_m)
        self.sway_h_max = 0.5 * math.sqrt(chain_length_m / G_MPS2)  # integration step with omega h = 0.5
        self.lp_fast = LowPass2(5.0)  # speed for the pendulum's forcing: well above the swing (0.35 Hz)
        self.lp_aload = LowPass2(cutoff_hz)
        max_torque = vehicle.max_traction_n * self.r
        # torque may step when the driver changes the command; speed may not jump (a <= ~3 m/s^2)
        self.gate_torque = SpikeGate(max_rate=50.0 * max_torque, noise_band=0.5 * max_torque,
                                     max_abs=3.0 * max_torque)
        self.gate_speed = SpikeGate(max_rate=8.0, noise_band=0.1, max_abs=20.0)
        self.min_speed = float(min_speed_mps)
        self.min_force = float(min_traction_fraction) * vehicle.max_traction_n
        # samples (at the nominal 200 Hz) after a (re)start before the low-pass states are trustworthy
        self.settle_samples = max(1, int(round(1.0 / cutoff_hz / 0.005)))
        self.reset()

    def reset(self) -> None:
        self.lp_force.reset()
        self.lp_speed.reset()
        self.gate_torque.reset()
        self.gate_speed.reset()
        self.force_n = 0.0
        self.speed_mps = 0.0
        self.accel_mps2 = 0.0
        self.valid = False
        self._prev_vf = math.nan
        self._n_valid_in = 0
        self._n_missing = 0
        self.lp_fast.reset()
        self.lp_aload.reset()
        self.sway = 0.0
        self.sway_rate = 0.0
        self._prev_fast = math.nan
        self.load_accel_mps2 = 0.0

    def step(self, torque_nm: float, speed_mps: float, dt_s: float) -> bool:
        """Filter one sample; return :attr:`valid`. A ``dt_s`` of :data:`~estimators.filters.MAX_STEP_S` or more is
        a data gap: the filters restart (their held states no longer describe the motion) and at most that long
        is integrated, so the pendulum's sub-step count stays bounded."""
        if dt_s >= MAX_STEP_S:
            self.reset()
            dt_s = MAX_STEP_S
        T = self.gate_torque(torque_nm, dt_s)
        v = self.gate_speed(speed_mps, dt_s)
        raw_ok = T == T and v == v
        F = self.lp_force(T / self.r if T == T else math.nan, dt_s)
        vf = self.lp_speed(v, dt_s)
        prev = self._prev_vf
        self._prev_vf = vf
        if not self.lp_speed.ready:
            self.valid = False
            return False
        a = (vf - prev) / dt_s if prev == prev else 0.0
        self.force_n = F
        self.speed_mps = vf
        self.accel_mps2 = a
        if self.swing:
            # The load hangs on chains: a pendulum forced by the train's acceleration. Its along-track
            # acceleration is -g sway - damping (small angles), not the measured dv/dt of the drive section;
            # after a start the difference is of the order of the acceleration itself for several seconds.
            vfast = self.lp_fast(v, dt_s)
            pf = self._prev_fast
            self._prev_fast = vfast
            a_fast = (vfast - pf) / dt_s if pf == pf else 0.0
            # semi-implicit Euler of L sway'' = a_load - a_train (omega h = 0.011 at 200 Hz); slower sample rates
            # are sub-stepped to omega h <= 0.5 so the pendulum stays stable
            L = self.chain_length
            sw, sr = self.sway, self.sway_rate
            a_load = -G_MPS2 * sw - self.sway_damping * sr
            n_sub = 1 if dt_s <= self.sway_h_max else int(math.ceil(dt_s / self.sway_h_max))
            h = dt_s / n_sub
            for _ in range(n_sub):
                sr += h * (-G_MPS2 * sw - self.sway_damping * sr - a_fast) / L
                sw += h * sr
            self.sway, self.sway_rate = sw, sr
            self.load_accel_mps2 = self.lp_aload(a_load, dt_s)
        else:
            self.load_accel_mps2 = a
        # short dropouts only skip the sample; a gap longer than 0.1 s (20 samples) restarts the settle count,
        # because the held filter states no longer describe the motion
        if raw_ok:
            self._n_valid_in += 1
            self._n_missing = 0
        else:
            self._n_missing += 1
            if self._n_missing > 20:
                self._n_valid_in = 0
        self.valid = (raw_ok and self.lp_force.ready and self._n_valid_in > self.settle_samples
                      and vf > self.min_speed and F > self.min_force)
        return self.valid
