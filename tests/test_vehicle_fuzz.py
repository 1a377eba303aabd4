"""Any vehicle the validator accepts works: the env resets and steps, and every estimator stays finite.

Why: ``uuom_core.vehicle.PLAUSIBLE_RANGES`` is the contract of the vehicle file, and nothing checked that the parts
above it hold over the whole of it. A random draw over the ranges (session 59) found two holes, both closed by
narrowing the range: a wheel of moment 0 (``wheel_inertia_kgm2 = 0``) crashed the pymunk plant at reset on 35 of 150
vehicles, and a rated load of 0 left the RLS estimators without a mass prior and ``fused`` with a singular
covariance. Each field is drawn at its lower bound, its upper bound, its default or log-uniformly between; the
relations between fields are then repaired (a draw is always a valid vehicle, so no example is wasted).
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import estimators
import uuom_gym  # noqa: F401  (registers the env ids)
from uuom_core.limits import max_descendable_grade_rad
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2, PLAUSIBLE_RANGES, VehicleParams
from uuom_core.vehicle_variants import consistent_vehicle
from uuom_gym.sim.track import random_track
from uuom_gym.sim.train_body import solver_iterations_for

from test_estimators_fuzz import _check_covariances, _check_estimate, clean_stream

FUZZ = settings(derandomize=True, deadline=None, database=None, suppress_health_check=[HealthCheck.too_slow])


@st.composite
def vehicles(draw: st.DrawFn) -> VehicleParams:
    kw: dict[str, float] = {}
    for name, (lo, hi, _) in PLAUSIBLE_RANGES.items():
        default = getattr(DEFAULT_VEHICLE, name)
        how = draw(st.sampled_from(("lo", "hi", "default", "between")))
        if how == "lo":
            x = lo
        elif how == "hi":
            x = hi
        elif how == "default":
            x = default
        else:
            u = draw(st.floats(0.0, 1.0))
            a = math.log(max(lo, 1e-3))
            x = min(max(math.exp(a + u * (math.log(hi) - a)), lo), hi)
        kw[name] = int(round(x)) if isinstance(default, int) else float(x)
    return consistent_vehicle(kw)


def test_the_repair_gives_valid_vehicles_at_every_corner() -> None:
    for pick in (0, 1):
        kw = {k: float(r[pick]) for k, r in PLAUSIBLE_RANGES.items()}
        for k in ("inertia_wheel_count", "drive_unit_count"):
            kw[k] = int(kw[k])
        assert isinstance(consistent_vehicle(kw), VehicleParams)


@settings(FUZZ, max_examples=8)
@given(v=vehicles(), seed=st.integers(0, 2**16))
def test_env_resets_and_steps_with_any_valid_vehicle(v: VehicleParams, seed: int) -> None:
    env = gym.make("UUOM-Track-v0", vehicle=v)
    try:
        obs, _ = env.reset(seed=seed)
        assert np.all(np.isfinite(obs))
        env.action_space.seed(seed)
        for i in range(120):
            action = env.action_space.sample() if i % 3 else np.ones(env.action_space.shape, np.float32)
            obs, reward, terminated, truncated, info = env.step(action)
            assert np.all(np.isfinite(obs)) and math.isfinite(reward) and math.isfinite(info["cost"])
            if terminated or truncated:
                obs, _ = env.reset(seed=seed + 1)
    finally:
        env.close()


@settings(FUZZ, max_examples=6)
@given(v=vehicles(), seed=st.integers(0, 2**16))
def test_every_estimator_stays_finite_with_any_valid_vehicle(v: VehicleParams, seed: int) -> None:
    data = clean_stream(1500, seed)
    # the default vehicle's torque, scaled to this vehicle's wheel and mass (the signal need not fit it: a vehicle
    # file that does not match the train is a model error, and the output must still be finite)
    data[:, 0] *= (v.drive_wheel_radius_m / DEFAULT_VEHICLE.drive_wheel_radius_m
                   * v.empty_mass_kg / DEFAULT_VEHICLE.empty_mass_kg)
    for name in estimators.available():
        est = estimators.make(name, vehicle=v)
        for i, row in enumerate(data.tolist()):
            _check_estimate(name, est.update(*row), f"sample {i}, vehicle {v}")
        _check_covariances(name, est, f"at the end, vehicle {v}")


@pytest.mark.parametrize("field, value", [("wheel_inertia_kgm2", 0.0), ("rated_load_kg", 0.0)])
def test_the_ranges_the_fuzz_narrowed(field: str, value: float) -> None:
    with pytest.raises(ValueError, match=field):
        DEFAULT_VEHICLE.with_changes(**{field: value})


def test_the_service_brake_holds_the_train_on_the_steepest_descent_it_allows() -> None:
    v = DEFAULT_VEHICLE
    mass = v.rated_mass_kg
    t = max_descendable_grade_rad(v, mass)
    downhill = mass * G_MPS2 * (math.sin(t) - v.running_resistance * math.cos(t))
    assert downhill == pytest.approx(v.service_brake_n, rel=1e-9)
    assert 20.0 < math.degrees(t) < 22.0  # the project's vehicle: above the env's 15 deg, so no track of it changes


def test_random_tracks_stay_within_what_the_brake_holds() -> None:
    weak = DEFAULT_VEHICLE.with_changes(service_brake_n=40_000.0, emergency_brake_n=60_000.0)
    cap = 0.85 * math.degrees(max_descendable_grade_rad(weak, weak.rated_mass_kg, 0.02))
    assert cap < 10.0
    for seed in range(5):
        track = random_track(np.random.default_rng(seed), max_grade_deg=15.0, vehicle=weak,
                             load_kg=weak.rated_load_kg, running_resistance=0.02)
        assert math.degrees(track.slope_rad.min()) >= -cap - 1e-9


def test_a_drive_that_cannot_haul_the_rated_train_is_refused() -> None:
    with pytest.raises(ValueError, match="cannot haul the rated train"):
        DEFAULT_VEHICLE.with_changes(max_traction_n=5_000.0)


def test_the_solver_iterations_grow_with_a_load_heavy_against_the_sections() -> None:
    v = DEFAULT_VEHICLE
    body = v.empty_mass_kg - 4 * v.carrying_wheel_mass_kg - v.hook_mass_kg
    lighter = min(v.drive_section_mass_share, 1.0 - v.drive_section_mass_share) * body
    # the project's vehicle keeps the configured iterations up to the plant's largest load (1.5x rated)
    assert solver_iterations_for(20, v.hook_mass_kg + 1.5 * v.rated_load_kg, lighter) == 20
    assert solver_iterations_for(20, 34_800.0, 4_180.0) == 34  # the 16 t train with 34 t of session 59


def test_random_tracks_are_never_steeper_than_the_vehicle_is_specified_for() -> None:
    v = DEFAULT_VEHICLE.with_changes(max_grade_deg=8.0)
    env = gym.make("UUOM-Track-v0", vehicle=v, observer="oracle", allow_infeasible=True)
    try:
        for seed in range(4):
            env.reset(seed=seed)
            assert np.degrees(np.abs(env.unwrapped.track.slope_rad)).max() <= 8.0 + 1e-9
    finally:
        env.close()


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_oracle_arrives_with_a_vehicle_near_the_projects(seed: int) -> None:
    """Every field within x/÷ 1.5 of the project's vehicle (16 of 16 arrived in session 59's scan; at x/÷ 3 the
    oracle trips on 4 of 16, docs/robustness.md)."""
    from agents.controllers import OracleController

    rng = np.random.default_rng(seed)
    kw: dict[str, float] = {}
    for name, (lo, hi, _) in PLAUSIBLE_RANGES.items():
        d = getattr(DEFAULT_VEHICLE, name)
        x = min(max(d * math.exp(rng.uniform(-math.log(1.5), math.log(1.5))), lo), hi) if d else d
        kw[name] = int(round(x)) if isinstance(d, int) else float(x)
    v = consistent_vehicle(kw)
    env = gym.make("UUOM-Track-v0", vehicle=v, observer="oracle")
    try:
        obs, info = env.reset(seed=seed)
        ctrl = OracleController(v)
        ctrl.reset(env, info)
        for _ in range(20_000):
            obs, _, terminated, truncated, info = env.step(ctrl.act(obs, info))
            if terminated or truncated:
                break
        assert info["termination"] == "arrived", (info["termination"], v)
    finally:
        env.close()
