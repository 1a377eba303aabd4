"""Each safety rule of spec §6 triggers in a constructed situation and stays silent when safe."""

from __future__ import annotations

import math

import numpy as np
import pytest

from uuom_gym.envs.config import RULES, make_config
from uuom_gym.envs.safety import SafetyMonitor, SafetyParams
from uuom_core.limits import max_climbable_grade_rad, speed_limit_mps, speed_limit_mps_array
from uuom_core.vehicle import DEFAULT_VEHICLE as V

DT = 0.005
N = 20


def monitor(load_kg: float = 10_000.0, mu: float = 0.02, adhesion: float = 0.35, **over) -> SafetyMonitor:
    m = SafetyMonitor(V, SafetyParams.from_config(make_config(**over)))
    m.reset(V.empty_mass_kg + load_kg, mu, adhesion)
    return m


def ticks(speed=0.5, slope=0.0, slipping=False, sway=0.0, n=N):
    f = lambda x, dt=float: np.full(n, x, dtype=dt) if np.ndim(x) == 0 else np.asarray(x, dtype=dt)  # noqa: E731
    return dict(speed_mps=f(speed), slope_rad=f(slope), slipping=f(slipping, bool), sway_rad=f(sway))


def test_safe_step_is_silent_and_costs_zero():
    m = monitor()
    for slope in (-0.2, 0.0, 0.1):
        rep = m.evaluate(DT, **ticks(speed=0.5, slope=slope, sway=0.05))
        assert not any(rep.violations.values()), rep.violations
        assert rep.cost == 0.0 and all(c == 0.0 for c in rep.costs.values())
        assert set(rep.violations) == set(RULES) == set(rep.costs)


def test_speed_limit_breach_and_cost():
    m = monitor(load_kg=20_000.0)  # v_lim 0.5 m/s on the level
    rep = m.evaluate(DT, **ticks(speed=0.6))
    assert rep.violations["speed_limit"] and not rep.violations["overspeed_trip"]
    assert rep.costs["speed_limit"] == pytest.approx(0.1 * N * DT)
    assert rep.cost == pytest.approx(10.0 * 0.1 * N * DT)
    assert rep.speed_limit_mps == pytest.approx(0.5)


def test_speed_limit_depends_on_grade_true_state():
    m = monitor(load_kg=0.0)  # empty: 2.0 m/s on the level, less where the brake must beat the down-grade
    steep_down = -math.radians(14.0)
    lim = speed_limit_mps(V, V.empty_mass_kg, steep_down)
    assert lim < 1.95
    rep = m.evaluate(DT, **ticks(speed=lim + 0.05, slope=steep_down))
    assert rep.violations["speed_limit"]
    rep = m.evaluate(DT, **ticks(speed=lim - 0.01, slope=steep_down))
    assert not rep.violations["speed_limit"]


def test_overspeed_trip_beyond_margin():
    m = monitor(load_kg=0.0)  # 2.0 m/s limit
    rep = m.evaluate(DT, **ticks(speed=np.r_[np.full(N - 1, 2.1), 2.25]))
    assert rep.tripped and rep.violations["overspeed_trip"] and rep.costs["overspeed_trip"] == 1.0
    rep = m.evaluate(DT, **ticks(speed=2.15))
    assert not rep.tripped and rep.violations["speed_limit"]


def test_adhesion_needs_slip_beyond_grace_across_steps():
    m = monitor(slip_grace_s=0.15)  # 30 ticks
    rep1 = m.evaluate(DT, **ticks(slipping=True))  # 0.1 s of slip: within grace
    assert not rep1.violations["adhesion"]
    rep2 = m.evaluate(DT, **ticks(slipping=True))  # 0.2 s continuous: 10 ticks beyond grace
    assert rep2.violations["adhesion"]
    assert rep2.costs["adhesion"] == pytest.approx(10 * DT)
    # a slip interrupted by grip starts over
    m2 = monitor(slip_grace_s=0.15)
    m2.evaluate(DT, **ticks(slipping=True))
    m2.evaluate(DT, **ticks(slipping=np.r_[np.zeros(1, bool), np.ones(N - 1, bool)]))
    rep = m2.evaluate(DT, **ticks(slipping=False))
    assert not rep.violations["adhesion"]


def test_rollback_triggers_on_backward_motion_only():
    m = monitor(rollback_speed_mps=0.02)
    rep = m.evaluate(DT, **ticks(speed=-0.1, slope=0.1))
    assert rep.violations["rollback"]
    assert rep.costs["rollback"] == pytest.approx(0.1 * N * DT)
    rep = m.evaluate(DT, **ticks(speed=-0.01, slope=0.1))  # creep within tolerance
    assert not rep.violations["rollback"]


def test_sway_beyond_limit():
    m = monitor(sway_limit_deg=5.0)
    rep = m.evaluate(DT, **ticks(sway=-math.radians(7.0)))
    assert rep.violations["sway"]
    assert rep.costs["sway"] == pytest.approx(math.radians(2.0) * N * DT)
    assert not m.evaluate(DT, **ticks(sway=math.radians(4.9))).violations["sway"]


def test_stall_on_grade_the_load_cannot_climb():
    m = monitor(load_kg=20_000.0, adhesion=0.35)
    climb = max_climbable_grade_rad(V, V.rated_mass_kg, 0.02, 0.35)
    assert math.degrees(climb) < 13.0  # spec §1: ~12 deg at rated load
    rep = m.evaluate(DT, **ticks(speed=0.0, slope=climb + 0.02))
    assert rep.violations["stall"] and rep.costs["stall"] == pytest.approx(N * DT)
    # the same grade empty is climbable: no stall
    empty = monitor(load_kg=0.0)
    assert not empty.evaluate(DT, **ticks(speed=0.0, slope=climb + 0.02)).violations["stall"]
    # moving on a climbable grade: no stall
    assert not m.evaluate(DT, **ticks(speed=0.3, slope=climb - 0.02)).violations["stall"]


def test_bad_inputs_are_rejected():
    m = monitor()
    with pytest.raises(ValueError, match="equal length"):
        m.evaluate(DT, speed_mps=np.zeros(3), slope_rad=np.zeros(2), slipping=np.zeros(3, bool), sway_rad=np.zeros(3))
    with pytest.raises(ValueError, match="mass_kg"):
        m.reset(float("nan"), 0.02, 0.35)


def test_vectorised_limit_matches_scalar():
    slopes = np.radians(np.linspace(-20, 20, 41))
    for mass in (16_000.0, 27_500.0, 36_000.0, 45_000.0):
        ref = [speed_limit_mps(V, mass, s) for s in slopes]
        np.testing.assert_allclose(speed_limit_mps_array(V, mass, slopes), ref, rtol=0, atol=1e-12)


def test_fast_path_limit_equals_formula_everywhere():
    rng = np.random.default_rng(0)
    for load in (0.0, 7_000.0, 20_000.0, 24_000.0):
        m = monitor(load_kg=load)
        for _ in range(50):
            slope = rng.uniform(-0.45, 0.3, size=N)
            speed = rng.uniform(0.0, 2.5, size=N)
            rep = m.evaluate(DT, **ticks(speed=speed, slope=slope))
            ref = speed_limit_mps_array(V, V.empty_mass_kg + load, slope)
            assert rep.speed_limit_mps == pytest.approx(ref[-1], abs=1e-9)
            assert rep.costs["speed_limit"] == pytest.approx(float(np.maximum(speed - ref, 0).sum()) * DT, abs=1e-9)
