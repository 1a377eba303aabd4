"""Track profiles: the grade of the roadway as a function of distance along the rail.

A :class:`TrackProfile` holds the slope on a fine, uniform grid of arc length and integrates it into the rail's
shape in the vertical plane (``x_m``, ``z_m``). Between grid points the slope is linear, so grade transitions are
vertical curves. :func:`random_track` draws plausible roadways (level stretches, up and down grades to 15 deg,
vertical-curve transitions, continuously varying sections); :func:`scenario_track` gives the paper's fixed
sections (``section1``, ``section2``, ``roadtest``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from uuom_core.limits import max_climbable_grade_rad, max_descendable_grade_rad
from uuom_core.vehicle import DEFAULT_VEHICLE, VehicleParams


class TrackError(ValueError):
    """A track description that cannot be a real roadway (bad length, grade, grid)."""


GRID_M = 0.5
"""Default spacing of the slope grid (m)."""

MIN_CURVE_RADIUS_M = 60.0
"""Smallest vertical-curve radius the generator uses: a grade change of d rad takes at least R * d metres."""


@dataclass(frozen=True)
class TrackProfile:
    """Grade profile of a track, positive slope = uphill in the direction of travel (+s).

    Parameters
    ----------
    s_m : ndarray
        Arc-length stations, strictly increasing, starting at 0.
    slope_rad : ndarray
        Slope at each station (rad), |slope| < 45 deg. Linear in between.
    name : str
        Label used in plots and traces.
    """

    s_m: np.ndarray
    slope_rad: np.ndarray
    name: str = "track"
    x_m: np.ndarray = field(init=False, repr=False)
    z_m: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        s = np.asarray(self.s_m, dtype=np.float64)
        th = np.asarray(self.slope_rad, dtype=np.float64)
        if s.ndim != 1 or th.shape != s.shape:
            raise TrackError(f"s_m and slope_rad must be 1-D of equal length, got {s.shape} and {th.shape}")
        if len(s) < 2:
            raise TrackError("a track needs at least two stations")
        if not (np.all(np.isfinite(s)) and np.all(np.isfinite(th))):
            raise TrackError("s_m and slope_rad must be finite")
        if s[0] != 0.0:
            raise TrackError(f"s_m must start at 0, got {s[0]!r}")
        if np.any(np.diff(s) <= 0):
            raise TrackError("s_m must be strictly increasing")
        if np.max(np.abs(th)) >= math.radians(45.0):
            raise TrackError(f"|slope_rad| must stay below 45 deg, got {math.degrees(np.max(np.abs(th))):.1f} deg")
        # Exact integration of a slope that is linear between stations would need Fresnel-like integrals; the
        # trapezoid on cos/sin is accurate to well below a millimetre on the 0.5 m grid.
        ds = np.diff(s)
        x = np.concatenate([[0.0], np.cumsum(0.5 * (np.cos(th[1:]) + np.cos(th[:-1])) * ds)])
        z = np.concatenate([[0.0], np.cumsum(0.5 * (np.sin(th[1:]) + np.sin(th[:-1])) * ds)])
        object.__setattr__(self, "s_m", s)
        object.__setattr__(self, "slope_rad", th)
        object.__setattr__(self, "x_m", x)
        object.__setattr__(self, "z_m", z)

    @property
    def length_m(self) -> float:
        """Length of the track along the rail (m)."""
        return float(self.s_m[-1])

    def slope_at(self, s_m: float | np.ndarray) -> float | np.ndarray:
        """Slope (rad) at arc length ``s_m``; beyond the ends the end slopes continue."""
        out = np.interp(s_m, self.s_m, self.slope_rad)
        return float(out) if np.ndim(out) == 0 else out

    def elevation_at(self, s_m: float | np.ndarray) -> float | np.ndarray:
        """Height of the rail above its start (m) at arc length ``s_m`` (extrapolated beyond the ends)."""
        return self._coordinate_at(s_m, self.z_m, math.sin)

    def x_at(self, s_m: float | np.ndarray) -> float | np.ndarray:
        """Horizontal coordinate of the rail (m) at arc length ``s_m`` (extrapolated beyond the ends)."""
        return self._coordinate_at(s_m, self.x_m, math.cos)

    def _coordinate_at(self, s_m: float | np.ndarray, coord: np.ndarray, component) -> float | np.ndarray:
        """``coord`` (``x_m`` or ``z_m``) at arc length ``s_m``, continued straight along the end slopes beyond the
        ends (``component``: ``math.cos`` for x, ``math.sin`` for z)."""
        s = np.asarray(s_m, dtype=np.float64)
        c = np.interp(s, self.s_m, coord)
        c = np.where(s < 0.0, s * component(self.slope_rad[0]), c)
        c = np.where(s > self.length_m, coord[-1] + (s - self.length_m) * component(self.slope_rad[-1]), c)
        return float(c) if np.ndim(c) == 0 else c

    def s_at_x(self, x_m: float | np.ndarray) -> float | np.ndarray:
        """Arc length at horizontal coordinate ``x_m`` (the rail never turns back, so this is unique)."""
        x = np.asarray(x_m, dtype=np.float64)
        s = np.interp(x, self.x_m, self.s_m)
        s = np.where(x < 0.0, x / math.cos(self.slope_rad[0]), s)
        s = np.where(
            x > self.x_m[-1], self.length_m + (x - self.x_m[-1]) / math.cos(self.slope_rad[-1]), s
        )
        return float(s) if np.ndim(s) == 0 else s

    def polyline(self, margin_m: float = 40.0, max_turn_rad: float = 2e-3, max_len_m: float = 20.0) -> np.ndarray:
        """Rail polyline ``(n, 2)`` of (x, z) points, extended straight by ``margin_m`` at both ends.

        Consecutive grid points are merged while the direction changes by less than ``max_turn_rad`` and the
        piece stays shorter than ``max_len_m``, so straight grades cost few segments and curves keep the grid.
        """
        keep = [0]
        th = self.slope_rad
        for i in range(1, len(th) - 1):
            j = keep[-1]
            if abs(th[i] - th[j]) > max_turn_rad or self.s_m[i] - self.s_m[j] >= max_len_m:
                keep.append(i)
        keep.append(len(th) - 1)
        pts = np.column_stack([self.x_m[keep], self.z_m[keep]])
        t0 = self.slope_rad[0]
        t1 = self.slope_rad[-1]
        head = np.array([[-margin_m * math.cos(t0), -margin_m * math.sin(t0)]])
        tail = pts[-1] + margin_m * np.array([[math.cos(t1), math.sin(t1)]])
        return np.vstack([head, pts, tail])

    def max_grade_deg(self) -> float:
        """Steepest |slope| on the track, degrees."""
        return float(np.degrees(np.max(np.abs(self.slope_rad))))


def profile_from_knots(
    knots: list[tuple[float, float]], name: str = "track", grid_m: float = GRID_M
) -> TrackProfile:
    """Piecewise-linear slope through ``(s_m, slope_deg)`` knots, sampled on a uniform grid.

    A constant grade is two knots with the same slope; a vertical curve (transition) is the linear ramp between
    two knots with different slopes.
    """
    ks = np.array([k[0] for k in knots], dtype=np.float64)
    kd = np.array([k[1] for k in knots], dtype=np.float64)
    if ks[0] != 0.0 or np.any(np.diff(ks) <= 0):
        raise TrackError("knot positions must start at 0 and increase strictly")
    n = int(round(ks[-1] / grid_m))
    s = np.linspace(0.0, ks[-1], n + 1)
    return TrackProfile(s, np.radians(np.interp(s, ks, kd)), name=name)


def _transition_length(d_rad: float, rng: np.random.Generator) -> float:
    radius = MIN_CURVE_RADIUS_M * rng.uniform(1.0, 3.0)
    return max(5.0, radius * abs(d_rad))


def random_track(
    rng: np.random.Generator,
    length_m: tuple[float, float] | float = (200.0, 1500.0),
    max_grade_deg: float = 15.0,
    *,
    vehicle: VehicleParams | None = None,
    load_kg: float | None = None,
    running_resistance: float | None = None,
    adhesion: float | None = None,
    feasible: bool = True,
    feasibility_margin: float = 0.85,
    grid_m: float = GRID_M,
    name: str = "random",
) -> TrackProfile:
    """Draw a plausible roadway profile.

    The track starts with a level run-in (so the train stands level at ``s = 0``), then chains pieces: level
    stretches, constant grades up or down, and continuously varying sections (a mean grade with superposed
    undulations), joined by vertical-curve transitions of radius >= :data:`MIN_CURVE_RADIUS_M`.

    Parameters
    ----------
    rng : numpy.random.Generator
        The only source of randomness.
    length_m : (float, float) or float
        Range to draw the length from, or a fixed length (m), within 50..5000 m.
    max_grade_deg : float
        Steepest grade drawn, in (0, 45).
    vehicle, load_kg, running_resistance, adhesion :
        When ``feasible`` and ``load_kg`` is given, up-grades are capped at ``feasibility_margin`` times
        :func:`uuom_core.limits.max_climbable_grade_rad` for that loaded vehicle, so the train can climb them, and
        down-grades at the same fraction of :func:`uuom_core.limits.max_descendable_grade_rad`, so its service brake
        can hold it on them.
    feasible : bool
        False leaves the grades uncapped (a track that may stall the train).
    """
    if not isinstance(rng, np.random.Generator):
        raise TrackError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    if np.ndim(length_m) == 0:
        lo = hi = float(length_m)  # type: ignore[arg-type]
    else:
        lo, hi = (float(v) for v in length_m)  # type: ignore[union-attr]
    if not (50.0 <= lo <= hi <= 5000.0):
        raise TrackError(f"length_m must lie within 50..5000 m with low <= high, got {length_m!r}")
    if not (0.0 < max_grade_deg < 45.0):
        raise TrackError(f"max_grade_deg must be in (0, 45), got {max_grade_deg!r}")
    total = float(rng.uniform(lo, hi)) if hi > lo else lo
    up_cap = max_grade_deg
    if feasible and load_kg is not None:
        veh = vehicle or DEFAULT_VEHICLE
        climb = max_climbable_grade_rad(veh, veh.empty_mass_kg + load_kg, running_resistance, adhesion)
        up_cap = min(up_cap, feasibility_margin * math.degrees(climb))
    down_cap = max_grade_deg
    if feasible and load_kg is not None:
        # nor down-grades its service brake cannot hold (a vehicle file with weak brakes or a heavy train: even the
        # oracle tripped on them; no cap for the project's vehicle, whose brake holds 21 deg at rated load)
        veh = vehicle or DEFAULT_VEHICLE
        descend = max_descendable_grade_rad(veh, veh.empty_mass_kg + load_kg, running_resistance)
        down_cap = min(down_cap, feasibility_margin * math.degrees(descend))

    s = np.arange(0.0, total + grid_m / 2, grid_m)
    slope = np.zeros_like(s)
    pos = float(rng.uniform(25.0, 50.0))  # level run-in
    grade = 0.0
    while pos < total:
        kind = rng.choice(["level", "grade", "grade", "varying"])
        if kind == "level":
            target = 0.0
        else:
            target = float(rng.uniform(-down_cap, up_cap)) if up_cap > 0 else float(rng.uniform(-down_cap, 0.0))
        t_len = _transition_length(math.radians(target - grade), rng)
        seg_len = float(rng.uniform(30.0, 200.0))
        # transition: slope ramps linearly (a vertical curve)
        m = (s >= pos) & (s < pos + t_len)
        slope[m] = grade + (target - grade) * (s[m] - pos) / t_len
        pos += t_len
        m = (s >= pos) & (s < pos + seg_len)
        if kind == "varying":
            amp = float(rng.uniform(1.0, 4.0))
            wl1, wl2 = float(rng.uniform(30.0, 90.0)), float(rng.uniform(12.0, 30.0))
            ph = rng.uniform(0.0, 2 * math.pi, size=2)
            x = s[m] - pos
            # the undulation starts and ends at zero so the joins stay continuous
            env = np.sin(np.pi * np.clip(x / seg_len, 0, 1))
            wav = amp * env * (0.7 * np.sin(2 * np.pi * x / wl1 + ph[0]) + 0.3 * np.sin(2 * np.pi * x / wl2 + ph[1]))
            slope[m] = np.clip(target + wav, -down_cap, up_cap)
        else:
            slope[m] = target
        pos += seg_len
        grade = target
    slope[s >= pos] = grade
    return TrackProfile(s, np.radians(slope), name=name)


def _section1(grid_m: float) -> TrackProfile:
    return profile_from_knots([(0, 0.0), (45, 0.0), (65, 8.0), (250, 8.0)], "section1", grid_m)


def _section2(grid_m: float) -> TrackProfile:
    s = np.arange(0.0, 200.0 + grid_m / 2, grid_m)
    ramp = np.clip(s / 20.0, 0.0, 1.0)
    deg = ramp * (3.5 + 3.0 * np.sin(2 * np.pi * s / 70.0 - np.pi / 2) + 1.2 * np.sin(2 * np.pi * s / 23.0))
    deg = np.where(s < 5.0, 0.0, deg)
    return TrackProfile(s, np.radians(deg), name="section2")


def _roadtest(grid_m: float) -> TrackProfile:
    return profile_from_knots(
        [
            (0, 0.0), (10, 0.0), (16, 0.6), (24, 0.6), (30, -0.5), (36, -0.5), (41, 0.3), (44, 0.3),
            (51, 11.0), (54, 11.0), (57, 7.0), (58, 7.0), (63, 0.8), (160, 0.8),
        ],
        "roadtest",
        grid_m,
    )


# The one list of the named scenarios (the paper's track sections): everything else takes the names from here.
_SCENARIO_TRACKS = {"section1": _section1, "section2": _section2, "roadtest": _roadtest}
SCENARIO_NAMES: tuple[str, ...] = tuple(_SCENARIO_TRACKS)


def scenario_track(name: str, grid_m: float = GRID_M) -> TrackProfile:
    """The paper's fixed track sections (paper 000 §4.2, §4.3, §5.2; see :mod:`uuom_gym.sim.scenarios`).

    ``section1``: level, transition, 8 deg up-grade. ``section2``: continuously varying grade.
    ``roadtest``: near-level stretch with small grade changes, transition, up-grade (max 11 deg, < 15),
    high level stretch. Transitions are vertical curves of radius >= 40 m; sharper ones make the wheels knock at
    the 0.5 m rail-polyline vertices (visible as accelerometer spikes).
    """
    build = _SCENARIO_TRACKS.get(name) if isinstance(name, str) else None
    if build is None:
        raise TrackError(f"unknown scenario track {name!r}; known: {', '.join(SCENARIO_NAMES)}")
    return build(grid_m)


__all__ = [
    "GRID_M",
    "MIN_CURVE_RADIUS_M",
    "SCENARIO_NAMES",
    "TrackError",
    "TrackProfile",
    "profile_from_knots",
    "random_track",
    "scenario_track",
]
