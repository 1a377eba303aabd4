"""UUOM-Track-v0 end to end: registration, API checkers, determinism, observers, errors, safety in the loop."""

from __future__ import annotations

import math
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import estimators
import uuom_gym
from uuom_gym.envs.config import ConfigError
from uuom_gym.envs.observation import OBS_NAMES, UnknownObserverError
from uuom_gym.envs.track_env import InvalidActionError, UUOMTrackEnv
from uuom_gym.registration import ENV_IDS, register_envs
from uuom_gym.sim.track import profile_from_knots

ID = "UUOM-Track-v0"


def drive(env, obs, info, n, speed_frac=0.7):
    """A plain proportional speed controller on the observation (used to make situations, not a benchmark)."""
    for _ in range(n):
        o = dict(zip(OBS_NAMES, obs.tolist()))
        to_go = max(info["distance_to_go_m"], 0.0)
        target = min(speed_frac * o["est_speed_limit"] * 2.0, math.sqrt(2 * 0.25 * to_go))
        # ramped like a driver: a sudden full command swings the load beyond the sway limit
        a = np.clip(3.0 * (target - o["speed"] * 2.0), o["last_command"] - 0.03, o["last_command"] + 0.03)
        obs, r, term, trunc, info = env.step(np.array([a], np.float32))
        if term or trunc:
            return obs, info, True
    return obs, info, False


# --- registration and API ----------------------------------------------------------------------------------------
def test_make_both_ids_and_idempotent_registration():
    register_envs()
    register_envs()
    env = gym.make(ID, observer="oracle")
    assert isinstance(env.unwrapped, UUOMTrackEnv)
    assert env.spec.max_episode_steps is not None
    env.close()
    env = gym.make("uuom_gym:" + ID, observer="oracle")
    env.close()


def test_string_id_works_without_prior_import():
    code = "import gymnasium as gym; e = gym.make('uuom_gym:UUOM-Track-v0', observer='oracle'); e.reset(seed=1); print('ok')"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().endswith("ok")


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_gymnasium_env_checker(env_id):
    from gymnasium.utils.env_checker import check_env

    env = gym.make(env_id).unwrapped
    check_env(env, skip_render_check=False)
    env.close()


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_sb3_env_checker(env_id):
    from stable_baselines3.common.env_checker import check_env

    env = gym.make(env_id)
    check_env(env, warn=True)
    env.close()


def test_default_config_exposed_and_docstring_sections():
    cfg = UUOMTrackEnv.default_config()
    assert cfg["observer"] == "dffrls-aekf" and cfg["policy_hz"] == 10.0 and cfg["physics_hz"] == 200.0
    doc = UUOMTrackEnv.__doc__
    for section in ("## Description", "## Action Space", "## Observation Space", "## Rewards", "## Starting State",
                    "## Episode End", "## Arguments", "## Version History"):
        assert section in doc


# --- config and action errors --------------------------------------------------------------------------------------
def test_unknown_config_keys_error_through_make():
    with pytest.raises(ConfigError, match="polcy_hz"):
        gym.make(ID, polcy_hz=5)


def test_unknown_observer_lists_choices():
    with pytest.raises(UnknownObserverError, match="oracle"):
        gym.make(ID, observer="nonsense")


@pytest.mark.parametrize(
    "action, fragment",
    [
        (np.array([np.nan], np.float32), "finite"),
        (np.array([np.inf], np.float32), "finite"),
        (np.zeros(2, np.float32), "shape"),
        (np.zeros((1, 1), np.float32), "shape"),
        ("full", "str"),
    ],
)
def test_bad_actions_raise(action, fragment):
    env = UUOMTrackEnv(observer="oracle")
    env.reset(seed=0)
    with pytest.raises(InvalidActionError, match=fragment):
        env.step(action)


def test_step_before_reset_is_an_error():
    with pytest.raises(RuntimeError, match="reset"):
        UUOMTrackEnv(observer="oracle").step(np.zeros(1, np.float32))


def test_out_of_range_actions_are_clipped():
    a, b = UUOMTrackEnv(observer="oracle"), UUOMTrackEnv(observer="oracle")
    a.reset(seed=3)
    b.reset(seed=3)
    for _ in range(20):
        oa, ra, ta, *_ = a.step(np.array([7.5], np.float32))
        ob, rb, tb, *_ = b.step(np.array([1.0], np.float32))
        assert ta == tb
        if ta:  # full traction trips on this track; stepping on would be refused (ResetNeeded)
            break
    np.testing.assert_array_equal(oa, ob)
    assert ra == rb


# --- determinism -----------------------------------------------------------------------------------------------------
def rollout(seed, n=60, **cfg):
    env = UUOMTrackEnv(**cfg)
    obs, info = env.reset(seed=seed)
    rng = np.random.default_rng(123)
    out = [(obs, 0.0, info)]
    for _ in range(n):
        obs, r, term, trunc, info = env.step(rng.uniform(-0.3, 1.0, size=1).astype(np.float32))
        out.append((obs, r, info))
        if term or trunc:
            break
    return out


def _same(x, y):
    if isinstance(x, dict):
        return x.keys() == y.keys() and all(_same(x[k], y[k]) for k in x)
    if isinstance(x, np.ndarray):
        return np.array_equal(x, y)
    return x == y


def test_same_seed_same_episode_default_observer():
    a, b = rollout(7), rollout(7)
    assert len(a) == len(b)
    for (oa, ra, ia), (ob, rb, ib) in zip(a, b):
        assert np.array_equal(oa, ob) and ra == rb and _same(ia, ib)


def test_different_seeds_draw_different_conditions():
    env = UUOMTrackEnv(observer="oracle")
    infos = [env.reset(seed=s)[1] for s in range(6)]
    assert len({round(i["track_length_m"], 3) for i in infos}) > 1
    assert len({round(i["load_kg"], 3) for i in infos}) > 1
    for i in infos:
        assert 100.0 <= i["track_length_m"] <= 300.5
        assert 0.0 <= i["load_kg"] <= 20_000.0


# --- observers -----------------------------------------------------------------------------------------------------
def test_oracle_reports_truth():
    env = UUOMTrackEnv(observer="oracle")
    obs, info = env.reset(seed=2)
    obs, info, _ = drive(env, obs, info, 30)
    assert info["est_mass_kg"] == info["true_mass_kg"] and info["est_slope_rad"] == info["true_slope_rad"]
    assert info["est_mass_std_kg"] == 0.0
    assert info["est_speed_limit_2sigma_mps"] == info["est_speed_limit_mps"] == info["true_speed_limit_mps"]
    named = dict(zip(OBS_NAMES, obs.tolist()))
    assert named["est_load"] == pytest.approx(info["load_kg"] / 20_000.0, abs=1e-6)


def test_none_observer_reports_prior_and_worst_case_limit():
    env = UUOMTrackEnv(observer="none")
    obs, info = env.reset(seed=2)
    obs, r, term, trunc, info = env.step(np.array([0.6], np.float32))
    assert info["est_mass_kg"] == 26_000.0 and info["est_slope_rad"] == 0.0
    assert info["est_speed_limit_mps"] == pytest.approx(0.5)


class _CountingEstimator(estimators.Estimator):
    """A real (trivially simple) estimator that counts its samples: the env must call it at every tick."""

    name = "count-test"
    calls = 0

    def reset(self):
        type(self).calls = 0

    def update(self, torque_nm, speed_mps, accel_mps2, dt_s, motor_speed_radps=math.nan, gyro_radps=math.nan,
               accel_normal_mps2=math.nan):
        type(self).calls += 1
        assert dt_s == pytest.approx(0.005)
        return self.estimate

    @property
    def estimate(self):
        return estimators.Estimate(self.vehicle.empty_mass_kg, 0.0, 1000.0, 0.01)


def test_estimator_updates_on_every_sensor_sample():
    if "count-test" not in estimators.available():
        estimators.register("count-test", f"{__name__}:_CountingEstimator")
    env = UUOMTrackEnv(observer="count-test")
    env.reset(seed=0)
    for _ in range(7):
        env.step(np.array([0.5], np.float32))
    assert _CountingEstimator.calls == 7 * 20


@pytest.mark.parametrize("name", ["dffrls-aekf", "rls-ekf"])
def test_estimator_observers_run_and_stay_finite(name):
    env = UUOMTrackEnv(observer=name, scenario="section1")
    obs, info = env.reset(seed=0)
    for _ in range(100):
        obs, info, done = drive(env, obs, info, 1)
        assert np.all(np.isfinite(obs)) and env.observation_space.contains(obs)
        assert not done, info["termination"]
    assert info["observer"] == name
    assert info["est_speed_limit_2sigma_mps"] <= info["est_speed_limit_mps"]
    assert math.isfinite(info["est_mass_kg"]) and math.isfinite(info["est_slope_rad"])


# --- safety rules in the loop --------------------------------------------------------------------------------------
def test_safe_drive_costs_nothing_and_arrives():
    env = UUOMTrackEnv(observer="oracle", scenario="section1")
    obs, info = env.reset(seed=0)
    obs, info, done = drive(env, obs, info, 6000, speed_frac=0.6)
    assert done and info["is_success"], info["termination"]
    assert info["episode_cost"] == 0.0, info["violation_counts"]
    assert abs(info["distance_to_go_m"]) <= 3.0


def test_overspeed_trip_ends_the_episode_as_failure():
    down = profile_from_knots([(0, 0.0), (30, 0.0), (60, -8.0), (300, -8.0)], "down")
    env = UUOMTrackEnv(observer="oracle", track=down, load_kg=10_000.0)
    env.reset(seed=0)
    for _ in range(3000):
        obs, r, term, trunc, info = env.step(np.array([1.0], np.float32))
        if term or trunc:
            break
    assert term and info["termination"] == "overspeed_trip" and not info["is_success"]
    assert info["violations"]["overspeed_trip"] and info["violations"]["speed_limit"]
    assert info["rewards"]["failure"] < 0 and info["cost"] > 0
    assert env.plant.emergency


def test_stall_on_an_infeasible_grade():
    steep = profile_from_knots([(0, 0.0), (20, 0.0), (40, 14.0), (200, 14.0)], "steep")
    env = UUOMTrackEnv(observer="oracle", track=steep, load_kg=20_000.0)
    env.reset(seed=0)
    seen = set()
    info = {"speed_mps": 0.0}
    for _ in range(1500):
        # full traction, but kept below the speed limit on the level run-in
        a = 1.0 if info["speed_mps"] < 0.3 else 0.0
        obs, r, term, trunc, info = env.step(np.array([a], np.float32))
        seen |= {k for k, v in info["violations"].items() if v}
        if term or trunc:
            break
    assert "stall" in seen and info["costs"]["stall"] > 0.0
    assert info["max_climbable_grade_rad"] < math.radians(14.0)


def test_rollback_when_coasting_on_a_grade():
    grade = profile_from_knots([(0, 6.0), (300, 6.0)], "grade")
    env = UUOMTrackEnv(observer="oracle", track=grade, load_kg=5_000.0)
    env.reset(seed=0)
    rolled = False
    for _ in range(30):
        obs, r, term, trunc, info = env.step(np.array([0.0], np.float32))  # neither traction nor brake
        rolled |= info["violations"]["rollback"]
        if term or trunc:  # rolling back 2 m ends the episode (rolled_back); the env refuses steps after it
            break
    assert rolled and info["speed_mps"] < 0.0 and info["costs"]["rollback"] > 0.0
    env.reset(seed=0)
    for _ in range(30):  # holding the brake: no rollback
        obs, r, term, trunc, info = env.step(np.array([-1.0], np.float32))
        assert not info["violations"]["rollback"]


def test_slip_on_wet_rail_under_full_traction():
    env = UUOMTrackEnv(observer="oracle", scenario=None, track=profile_from_knots([(0, 0.0), (300, 0.0)]),
                       load_kg=0.0, wet_probability=1.0, adhesion_wet_range=(0.1, 0.1))
    env.reset(seed=0)
    hit = False
    for _ in range(30):
        obs, r, term, trunc, info = env.step(np.array([1.0], np.float32))
        hit |= info["violations"]["adhesion"]
        if term or trunc:  # full traction ends in an overspeed trip; the env refuses steps after it
            break
    assert hit
    assert dict(zip(OBS_NAMES, obs.tolist()))["wheel_slip"] > 0.1


def test_random_tracks_are_feasible_unless_asked():
    for seed in range(5):
        env = UUOMTrackEnv(observer="oracle")
        _, info = env.reset(seed=seed)
        assert float(np.max(env.track.slope_rad)) < info["max_climbable_grade_rad"]
    hard = UUOMTrackEnv(observer="oracle", allow_infeasible=True, load_fraction_range=(1.0, 1.0),
                        wet_probability=1.0, track_length_m=(600.0, 600.0))
    steeper = 0
    for seed in range(5):
        _, info = hard.reset(seed=seed)
        steeper += float(np.max(hard.track.slope_rad)) > info["max_climbable_grade_rad"]
    assert steeper > 0


@pytest.mark.parametrize("scenario", ["section1", "section2", "roadtest"])
def test_scenarios_are_fixed(scenario):
    env = UUOMTrackEnv(observer="oracle", scenario=scenario)
    _, i1 = env.reset(seed=0)
    _, i2 = env.reset(seed=99)
    assert i1["track_length_m"] == i2["track_length_m"] and i1["load_kg"] == i2["load_kg"]


def test_hard_brake_swings_the_load_beyond_the_limit():
    flat = profile_from_knots([(0, 0.0), (400, 0.0)], "flat")
    env = UUOMTrackEnv(observer="oracle", track=flat, load_kg=2_000.0)
    env.reset(seed=0)
    info = {"speed_mps": 0.0}
    for _ in range(200):  # gentle run-up to ~1.2 m/s: no breach
        a = 0.15 if info["speed_mps"] < 1.2 else 0.0
        obs, r, term, trunc, info = env.step(np.array([a], np.float32))
        assert not info["violations"]["sway"]
    seen = False
    for _ in range(40):  # then the full service brake
        obs, r, term, trunc, info = env.step(np.array([-1.0], np.float32))
        seen |= info["violations"]["sway"]
    assert seen and info["costs"]["sway"] >= 0.0


def test_config_dict_and_scalar_action():
    env = gym.make(ID, config={"observer": "oracle", "policy_hz": 5})
    assert env.unwrapped.ticks_per_step == 40 and env.unwrapped.config["observer"] == "oracle"
    env.reset(seed=0)
    obs, *_ = env.unwrapped.step(0.4)  # a plain number is one action
    assert env.unwrapped.last_command == pytest.approx(0.4)
    env.close()
