"""``action_mode="acceleration"``: the demand's mapping, the ramped target, the config, and what the env does with it."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import uuom_gym  # noqa: F401 - registers the env
from uuom_gym.envs.actions import ACTION_MODES, accel_demand_mps2
from uuom_gym.envs.config import ConfigError, make_config
from uuom_gym.envs.speed_target import RAMP_WINDOW_MPS, ramp_target_mps

HELD_OUT = range(100_000, 100_005)


@pytest.mark.parametrize(
    "action, expected", [(-1.0, -0.8), (-0.5, -0.4), (0.0, 0.0), (0.5, 0.25), (1.0, 0.5), (3.0, 0.5), (-3.0, -0.8)]
)
def test_demand_is_piecewise_linear_with_zero_at_zero(action, expected):
    assert accel_demand_mps2(action, (-0.8, 0.5)) == pytest.approx(expected)


def test_ramp_moves_the_target_and_stays_near_the_measured_speed():
    assert ramp_target_mps(0.4, 0.5, 0.1, 0.4) == pytest.approx(0.45)
    # A train that does not follow: the target waits for it.
    assert ramp_target_mps(1.0, 0.5, 0.1, 0.2) == pytest.approx(0.2 + RAMP_WINDOW_MPS)
    assert ramp_target_mps(0.0, -0.5, 0.1, 1.0) == pytest.approx(1.0 - RAMP_WINDOW_MPS)
    assert ramp_target_mps(0.01, -0.5, 0.1, 0.0) == 0.0


def test_config_names_every_mode_and_checks_the_span():
    assert "acceleration" in ACTION_MODES
    assert make_config()["accel_demand_mps2"] == (-0.5, 0.5)
    with pytest.raises(ConfigError, match="'command', 'speed_target', 'acceleration'"):
        make_config(action_mode="accel")
    with pytest.raises(ConfigError, match="lo < 0 < hi"):
        make_config(action_mode="acceleration", accel_demand_mps2=(0.1, 0.5))
    with pytest.raises(ConfigError, match="accel_demand_mps2"):
        make_config(action_mode="acceleration", accel_demand_mps2=(-0.5, float("nan")))


def test_check_env_passes_in_acceleration_mode():
    env = gym.make("UUOM-Track-v0", action_mode="acceleration")
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped, warn=False)
    env.close()


def _run(seed: int, actions: list[float]):
    env = gym.make("UUOM-Track-v0", action_mode="acceleration")
    env.reset(seed=seed)
    infos = []
    for a in actions:
        *_, terminated, truncated, info = env.step(np.array([a], dtype=np.float32))
        infos.append(info)
        if terminated or truncated:
            break
    env.close()
    return infos


@pytest.mark.parametrize("seed", HELD_OUT)
def test_a_small_demand_starts_every_train(seed):
    # The feed-forward alone cannot: at rest the estimate is the prior (26 t) and a 33 t train on seed 100001 stays
    # put under it; the tracker's loop gets it past the breakaway force.
    infos = _run(seed, [0.1] * 200)
    assert infos[-1]["termination"] != "stopped_short"
    assert infos[0]["accel_demand_mps2"] == pytest.approx(0.05)
    assert infos[-1]["position_m"] > 2.0


@pytest.mark.parametrize("seed", HELD_OUT[:2])
def test_no_demand_at_rest_holds_the_brake_and_no_demand_at_speed_holds_the_speed(seed):
    infos = _run(seed, [0.0] * 30)
    assert all(i["command"] == -1.0 for i in infos)
    assert abs(infos[-1]["position_m"]) < 0.05
    infos = _run(seed, [0.6] * 20 + [0.0] * 50)
    target = infos[-1]["target_speed_mps"]
    assert target == pytest.approx(0.6, abs=0.01)
    assert all(abs(i["speed_mps"] - target) < 0.08 for i in infos[30:])


def test_default_mode_has_no_demand_in_info():
    env = gym.make("UUOM-Track-v0")
    _, info = env.reset(seed=0)
    assert "accel_demand_mps2" not in info and "target_speed_mps" not in info
    env.close()


@pytest.mark.parametrize("name, episodes", [
    ("ppo_bare_accel_mix_s1_selected", "acceleration_action/eval/pooled_5seeds"),
    ("sac_bare_accel_mix_s0_selected", "sac_acceleration/eval/pooled_4seeds"),
    ("sac_bare_accel_clock_s0_selected", "idle_clock/eval/pooled_4seeds"),
    ("sac_bare_accel_caution_s3_selected", "caution/eval/pooled_4seeds"),
    ("sac_bare_accel_buffer_s3_selected", "replay_buffer/eval/pooled_6seeds"),
    ("sac_bare_accel_tanh_s2_selected", "near_tanh/eval/pooled_4seeds"),
    ("sac_bare_accel_heavy_s1_selected", "heavy_loads/eval/pooled_2seeds"),
    ("sac_bare_accel_mixed_s1_selected", "mixed_loads/eval/pooled_2seeds"),
    ("sac_bare_accel_demo_s0_selected", "demonstrations/eval/pooled_4seeds"),
    ("sac_bare_accel_demo_s4_selected", "demonstrations/eval/pooled_6seeds"),
    ("sac_bare_accel_demo_bc_s2_selected", "demo_bc/eval/pooled"),
    ("sac_bare_accel_demo_bc_s3_selected", "demo_bc/eval/pooled_4seeds"),
    # Not acceleration policies: bare SAC and PPO on UUOM-Track-SpeedTarget-v0 (docs/rl.md §42-§45), the same check.
    ("sac_bare_speed_target_s1_selected", "sac_speed_target/eval/pooled"),
    ("sac_bare_speed_target_s3_selected", "sac_speed_target/eval/pooled_5seeds"),
    ("sac_bare_speed_target_s5_selected", "sac_speed_target/eval/pooled_7seeds"),
    ("ppo_bare_span_08_13_300k_s4", "ppo_speed_target/eval/pooled_5seeds"),
])
def test_a_shipped_acceleration_policy_reproduces_its_committed_held_out_episode(name, episodes):
    import json
    from pathlib import Path

    from agents.evaluation import Task, read_episodes, run_episode, trained_env_kwargs
    from agents.float_path import float_path_fingerprint

    root = Path(__file__).resolve().parents[1]
    rows = read_episodes(root / "results" / "rl" / episodes / "episodes.csv")
    want = [r for r in rows if r.get("training_run") == name and r["seed"] == 100_000]
    assert len(want) == 1
    want = want[0]
    if want["float_path"] != float_path_fingerprint():
        pytest.skip(f"the committed row was written with float32 path {want['float_path']}; this machine has "
                    f"{float_path_fingerprint()}: a policy's episode is reproducible only on the same path")
    # Judged on the default tracks, loads and reward: its training configuration (action mode, idle clock) without
    # its 50-300 m tracks, its load curriculum and its reward weights (a training-only term such as `caution` does
    # not change the episode).
    run = root / "results" / "rl" / "policies" / name
    training_only = ("track_length_m", "load_fraction_beta", "load_fraction_uniform_share", "reward_weights")
    judged = {k: v for k, v in trained_env_kwargs(run).items() if k not in training_only}
    got = run_episode(Task(str(run), "dffrls-aekf", 100_000, json.dumps(judged)))
    assert (got["termination"], got["steps"]) == (want["termination"], want["steps"])
    assert got["trip_time_s"] == pytest.approx(want["trip_time_s"], abs=1e-9)
