"""Track profiles: random roadways and the paper's fixed sections."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uuom_core.limits import max_climbable_grade_rad
from uuom_gym.sim.track import (
    MIN_CURVE_RADIUS_M,
    TrackError,
    TrackProfile,
    profile_from_knots,
    random_track,
    scenario_track,
)
from uuom_core.vehicle import DEFAULT_VEHICLE as V


@pytest.mark.parametrize("seed", range(12))
def test_random_track_is_plausible(seed):
    tr = random_track(np.random.default_rng(seed))
    assert 200.0 <= tr.length_m <= 1500.0
    deg = np.degrees(tr.slope_rad)
    assert np.max(np.abs(deg)) <= 15.0 + 1e-9
    assert np.all(deg[tr.s_m < 25.0] == 0.0)  # level run-in where the train starts
    # vertical curves: no grade jumps; transitions change the slope by at most 1/R_min per metre, the
    # undulations of varying sections (<= 4 deg over >= 12 m wavelengths) by about as much
    rate = np.abs(np.diff(tr.slope_rad)) / np.diff(tr.s_m)
    assert rate.max() <= 1.25 / MIN_CURVE_RADIUS_M
    # the geometry integrates the slope
    assert tr.elevation_at(tr.length_m) == pytest.approx(np.trapezoid(np.sin(tr.slope_rad), tr.s_m), abs=1e-6)


def test_random_tracks_have_variety_and_are_deterministic():
    a = random_track(np.random.default_rng(3))
    b = random_track(np.random.default_rng(3))
    c = random_track(np.random.default_rng(4))
    assert np.array_equal(a.slope_rad, b.slope_rad)
    assert a.length_m != c.length_m
    grades = np.concatenate([np.degrees(random_track(np.random.default_rng(s)).slope_rad) for s in range(20)])
    assert grades.max() > 10.0 and grades.min() < -10.0  # up and down grades
    assert np.mean(np.abs(grades) < 0.01) > 0.05  # level stretches


@pytest.mark.parametrize("load", [0.0, 10_000.0, 20_000.0])
def test_feasible_tracks_respect_the_loaded_train(load):
    cap = 0.85 * math.degrees(max_climbable_grade_rad(V, V.empty_mass_kg + load))
    for seed in range(10):
        tr = random_track(np.random.default_rng(seed), vehicle=V, load_kg=load)
        assert np.degrees(tr.slope_rad).max() <= min(15.0, cap) + 1e-9


def test_infeasible_tracks_on_request():
    steep = [
        np.degrees(random_track(np.random.default_rng(s), load_kg=20_000, feasible=False).slope_rad).max()
        for s in range(20)
    ]
    cap = math.degrees(max_climbable_grade_rad(V, V.rated_mass_kg))
    assert max(steep) > cap


def test_scenarios():
    s1 = scenario_track("section1")
    assert s1.slope_at(10.0) == 0.0
    assert math.degrees(s1.slope_at(150.0)) == pytest.approx(8.0)
    assert 0.0 < math.degrees(s1.slope_at(55.0)) < 8.0  # the transition
    s2 = scenario_track("section2")
    d2 = np.degrees(s2.slope_rad)
    assert np.count_nonzero(np.diff(np.sign(np.diff(d2[s2.s_m > 20])))) >= 4  # continuously varying
    rt = scenario_track("roadtest")
    drt = np.degrees(rt.slope_rad)
    assert drt.max() < 15.0 and drt.max() > 8.0
    assert np.all(np.abs(drt[rt.s_m < 40]) < 1.0)  # near-level stretch with small changes
    assert np.all(np.abs(drt[rt.s_m > 70] - 0.8) < 1e-9)  # high level stretch
    assert rt.elevation_at(100.0) > 2.0
    with pytest.raises(TrackError, match="unknown scenario"):
        scenario_track("section9")


def test_geometry_helpers_are_consistent():
    tr = profile_from_knots([(0, 0.0), (50, 0.0), (80, 10.0), (200, 10.0)])
    s = np.linspace(-20.0, 230.0, 101)
    assert np.allclose(tr.s_at_x(tr.x_at(s)), s, atol=1e-6)
    assert tr.slope_at(1e4) == pytest.approx(math.radians(10.0))
    pts = tr.polyline()
    assert len(pts) < len(tr.s_m)  # straight pieces merged
    assert np.all(np.diff(pts[:, 0]) > 0)
    # polyline vertices lie on the rail
    inside = (pts[:, 0] >= 0) & (pts[:, 0] <= tr.x_m[-1])
    assert np.allclose(np.interp(pts[inside, 0], tr.x_m, tr.z_m), pts[inside, 1], atol=1e-9)


@pytest.mark.parametrize(
    "make, word",
    [
        (lambda: TrackProfile(np.array([0.0, 1.0, 1.0]), np.zeros(3)), "increasing"),
        (lambda: TrackProfile(np.array([1.0, 2.0]), np.zeros(2)), "start at 0"),
        (lambda: TrackProfile(np.array([0.0, 1.0]), np.array([0.0, 1.0])), "45 deg"),
        (lambda: TrackProfile(np.array([0.0, np.nan]), np.zeros(2)), "finite"),
        (lambda: random_track(np.random.default_rng(0), length_m=(10.0, 20.0)), "length_m"),
        (lambda: random_track(np.random.default_rng(0), max_grade_deg=50.0), "max_grade_deg"),
        (lambda: random_track(0), "Generator"),
    ],
)
def test_bad_input_is_named(make, word):
    with pytest.raises(TrackError, match=word):
        make()


def test_every_scenario_name_has_its_track_and_driver():
    from uuom_gym.envs.config import SCENARIOS
    from uuom_gym.sim import SCENARIO_NAMES, scenario, scenario_track

    assert SCENARIOS is SCENARIO_NAMES  # one list of names
    for name in SCENARIO_NAMES:
        sc = scenario(name)
        assert sc.name == name and sc.track.name == name == scenario_track(name).name and sc.load_kg == 10_000.0
    for bad in ("section3", None, 1):
        with pytest.raises(TrackError, match="unknown scenario"):
            scenario(bad)
        with pytest.raises(TrackError, match="unknown scenario"):
            scenario_track(bad)
