"""The plant's truth: one tick's :class:`PlantState`, a block's :class:`PlantLog`, and the vectorised derivation of
the log's columns from the raw body states of a block (:func:`derive_truth_log`)."""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from uuom_core.vehicle import G_MPS2


@dataclass
class PlantState:
    """Snapshot of the plant's true state (see :class:`PlantLog` for the meaning of each field)."""

    t_s: float
    position_m: float
    speed_mps: float
    accel_mps2: float
    slope_rad: float
    specific_force_mps2: float
    drive_torque_nm: float
    traction_force_n: float
    wheel_speed_radps: float
    slip_ratio: float
    drive_radius_m: float
    sway_rad: float
    sway_rate_radps: float
    pitch_rad: float
    pitch_rate_radps: float
    normal_specific_force_mps2: float
    total_mass_kg: float
    slipping: bool
    brake_force_n: float
    carry_wheel_speed_radps: float
    effective_slope_rad: float


LOG_FIELDS: tuple[str, ...] = tuple(f.name for f in fields(PlantState))


@dataclass
class PlantLog:
    """Per-tick truth arrays of a block of physics ticks (one row per tick, at the end of the tick).

    Attributes
    ----------
    t_s : time at the end of the tick.
    position_m : arc length of the drive section's reference point (mid-way between its wheels).
    speed_mps : true ground speed along the track. accel_mps2 : its time derivative (finite difference).
    slope_rad : track slope at ``position_m``.
    specific_force_mps2 : what an ideal along-track accelerometer at the drive section's centre of mass reads:
        ``(a_body - g) . e_x`` - includes pitching, coupler and load-sway vibration.
    normal_specific_force_mps2 : the same on the body's normal axis (about ``g cos slope``).
    drive_torque_nm : total motor torque applied to the drive wheels. traction_force_n : force transmitted to
        the rail through adhesion. wheel_speed_radps : drive-wheel angular speed.
    slip_ratio : ``(omega r - v) / max(|omega r|, |v|, 0.01)``. drive_radius_m : effective (worn) drive radius.
    sway_rad, sway_rate_radps : load chain angle from the vertical (positive = load ahead of its hanger).
    pitch_rad, pitch_rate_radps : drive section attitude (equals the rail chord slope).
    total_mass_kg : vehicle + load. slipping : drive in slip. brake_force_n : commanded brake force.
    carry_wheel_speed_radps : angular speed of the front carrying wheel (ground-speed encoder source).
    effective_slope_rad : the slope gravity acts on: ``asin(sum m_i sin(slope_i) / M)`` over the bodies
        (the train is 18 m long, so on short grade features it differs from ``slope_rad`` at the reference point).
    """

    t_s: np.ndarray
    position_m: np.ndarray
    speed_mps: np.ndarray
    accel_mps2: np.ndarray
    slope_rad: np.ndarray
    specific_force_mps2: np.ndarray
    drive_torque_nm: np.ndarray
    traction_force_n: np.ndarray
    wheel_speed_radps: np.ndarray
    slip_ratio: np.ndarray
    drive_radius_m: np.ndarray
    sway_rad: np.ndarray
    sway_rate_radps: np.ndarray
    pitch_rad: np.ndarray
    pitch_rate_radps: np.ndarray
    normal_specific_force_mps2: np.ndarray
    total_mass_kg: np.ndarray
    slipping: np.ndarray
    brake_force_n: np.ndarray
    carry_wheel_speed_radps: np.ndarray
    effective_slope_rad: np.ndarray

    def __len__(self) -> int:
        return len(self.t_s)

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in LOG_FIELDS:
            raise KeyError(f"no plant log field {name!r}; fields: {', '.join(LOG_FIELDS)}")
        return getattr(self, name)

    def as_dict(self) -> dict[str, np.ndarray]:
        return {k: getattr(self, k) for k in LOG_FIELDS}

    def row(self, i: int) -> PlantState:
        """The state at tick ``i`` of the block."""
        vals = [float(getattr(self, k)[i]) for k in LOG_FIELDS]
        state = PlantState(*vals)
        state.slipping = bool(state.slipping)
        return state

    @classmethod
    def concatenate(cls, logs: list["PlantLog"]) -> "PlantLog":
        if not logs:
            raise ValueError("concatenate needs at least one PlantLog")
        return cls(**{k: np.concatenate([getattr(g, k) for g in logs]) for k in LOG_FIELDS})



class TruthLogBuilder:
    """Derives a block's :class:`PlantLog` from the raw body states logged during it (vectorised over its ticks).

    It carries what the derivation needs from one block to the next: the clock (``t_s``), the drive section's
    velocity at the end of the last block (for the finite-difference acceleration) and the last sway angle
    (for the sway rate); the plant resets them when it zeroes the clock or moves the load.

    Parameters
    ----------
    track : TrackProfile
        The rail (positions and slopes).
    dt_s : float
        Physics tick.
    n_bodies : int
        Bodies per tick in the raw log (6 doubles each: ``x, y, angle, vx, vy, w``).
    index : dict
        Position of ``drive``, ``beam``, ``load`` and ``w0`` (front carrying wheel) among them.
    body_mass_share : ndarray
        Each body's share of the total mass (for the effective slope).
    chain_top, chain_bottom : tuple of float
        The front chain's ends in beam and in load coordinates.
    drive_hang_m, carrying_wheel_radius_m : float
        Geometry of the drive section (pivot line above its centre of mass; wheel radius).
    drive_radius_m, total_mass_kg : float
        Constant columns of the log.
    """

    def __init__(self, track, dt_s: float, n_bodies: int, index: dict, body_mass_share: np.ndarray,
                 chain_top: tuple[float, float], chain_bottom: tuple[float, float], drive_hang_m: float,
                 carrying_wheel_radius_m: float, drive_radius_m: float, total_mass_kg: float) -> None:
        self.track = track
        self.dt_s = dt_s
        self.n_bodies = n_bodies
        self.index = index
        sel = [index["drive"], index["beam"], index["load"]]
        # the three bodies are consecutive in the buffer (they are added in this order): a slice is cheaper than
        # fancy indexing and gives the same values
        self.sel_bodies = slice(sel[0], sel[0] + 3) if sel == list(range(sel[0], sel[0] + 3)) else sel
        self.body_mass_share = body_mass_share
        # chain points in body coordinates, as columns for (beam, load): top of the front chain, its bottom
        self.chain_pts = (np.array([[chain_top[0]], [chain_bottom[0]]]), np.array([[chain_top[1]], [chain_bottom[1]]]))
        self.hang = drive_hang_m
        self.r_carry = carrying_wheel_radius_m
        self.drive_radius_m = drive_radius_m
        self.total_mass_kg = total_mass_kg
        self.track_x_range = (float(track.x_m[0]), float(track.x_m[-1]))
        self.tick_offsets_s: dict[int, np.ndarray] = {}
        self.t_s = 0.0
        self.prev_vel = (0.0, 0.0)
        self.prev_sway = 0.0

    def build(self, raw: np.ndarray, torque: np.ndarray, force: np.ndarray, omega: np.ndarray,
              slipping: np.ndarray, brake: float, v_start: float) -> PlantLog:
        """The log of a block of ``n`` ticks from ``raw`` of shape ``(n, n_bodies, 6)`` and the drive's columns.

        Each numpy call costs about a microsecond whatever its size, so the columns of the three bodies we read
        are handled together (one copy, one cos, one sin); the arithmetic and its order are those of the
        per-body formulas, so the results do not change by a bit.
        """
        n = raw.shape[0]
        dt = self.dt_s
        t_offsets = self.tick_offsets_s.get(n)
        if t_offsets is None:
            t_offsets = self.tick_offsets_s[n] = dt * np.arange(1, n + 1)
        t = self.t_s + t_offsets
        self.t_s = float(t[-1])
        # one copy of what we need: S[field, body, tick], fields [x, y, angle, vx, vy, w], bodies drive/beam/load
        S = raw[:, self.sel_bodies, :].transpose(2, 1, 0).copy()
        cos3 = np.cos(S[2])
        sin3 = np.sin(S[2])
        ang = S[2, 0]
        ca, sa = cos3[0], sin3[0]
        w0 = -raw[:, self.index["w0"], 5]  # rolling forward turns the wheel clockwise
        speed = S[3, 0] * ca + S[4, 0] * sa - S[5, 0] * self.hang
        prev = np.empty((3, n + 1))
        prev[:, 0] = (v_start, self.prev_vel[0], self.prev_vel[1])
        prev[0, 1:] = speed
        prev[1:, 1:] = S[3:5, 0]
        d_all = (prev[:, 1:] - prev[:, :-1]) / dt
        accel, ax, ay = d_all[0], d_all[1], d_all[2] + G_MPS2
        fx = ax * ca + ay * sa
        fz = ay * ca - ax * sa
        self.prev_vel = (float(prev[1, -1]), float(prev[2, -1]))
        tr = self.track
        x_rail = S[0, 0] + (self.r_carry - self.hang) * sa
        x_lo, x_hi = self.track_x_range
        if n * dt <= 0.5:
            # both ends of the block 1 m inside the track: no tick in between left it (going 1 m beyond an end
            # and back within 0.5 s would take more than 16 m/s^2), so the cheap test of the ends is exact
            x_first, x_last = float(x_rail[0]), float(x_rail[-1])
            on_track = x_lo + 1.0 <= x_first <= x_hi - 1.0 and x_lo + 1.0 <= x_last <= x_hi - 1.0
        else:
            on_track = x_rail.min() >= x_lo and x_rail.max() <= x_hi
        if on_track:  # s_at_x is this interpolation on the track; beyond its ends it extrapolates
            pos = np.interp(x_rail, tr.x_m, tr.s_m)
        else:
            pos = np.asarray(tr.s_at_x(x_rail), dtype=np.float64).reshape(n)
        slope = np.interp(pos, tr.s_m, tr.slope_rad)
        # front chain: from its top on the beam to its bottom on the load (rows: beam point, load point)
        ox, oz = self.chain_pts
        px = S[0, 1:] + ox * cos3[1:] - oz * sin3[1:]
        py = S[1, 1:] + ox * sin3[1:] + oz * cos3[1:]
        sway = np.arctan2(px[1] - px[0], py[0] - py[1])
        sway_rate = np.empty(n)
        sway_rate[0] = sway[0] - self.prev_sway
        sway_rate[1:] = sway[1:] - sway[:-1]
        sway_rate /= dt
        self.prev_sway = float(sway[-1])
        # gravity over the whole train: mass-weighted sine of the rail slope under each body
        body_x = raw[:, :, 0]
        sin_eff = np.sin(np.interp(body_x, tr.x_m, tr.slope_rad)) @ self.body_mass_share
        eff_slope = np.arcsin(sin_eff)
        r = self.drive_radius_m
        wr = omega * r
        slip = (wr - speed) / np.maximum(np.maximum(np.abs(wr), np.abs(speed)), 0.01)
        const = np.empty((3, n))
        const[0] = r
        const[1] = self.total_mass_kg
        const[2] = brake
        return PlantLog(
            t_s=t, position_m=pos, speed_mps=speed, accel_mps2=accel, slope_rad=slope, specific_force_mps2=fx,
            drive_torque_nm=torque, traction_force_n=force, wheel_speed_radps=omega, slip_ratio=slip,
            drive_radius_m=const[0], sway_rad=sway, sway_rate_radps=sway_rate, pitch_rad=ang,
            pitch_rate_radps=S[5, 0], normal_specific_force_mps2=fz, total_mass_kg=const[1], slipping=slipping,
            brake_force_n=const[2], carry_wheel_speed_radps=w0, effective_slope_rad=eff_slope,
        )


__all__ = ["LOG_FIELDS", "PlantLog", "PlantState", "TruthLogBuilder"]
