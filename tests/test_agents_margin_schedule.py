"""agents.margin_schedule: the action sets the rule-based controller's speed margin (docs/rl.md §14)."""

from __future__ import annotations

import json

import gymnasium as gym
import numpy as np
import pytest

import uuom_gym  # noqa: F401 - registers the env
from agents.controllers import RuleBasedController
from agents.margin_schedule import ABS_PER_REL_MARGIN_MPS, MarginScheduleWrapper, check_span, margin_of_action
from agents.training import TrainConfig, TrainConfigError, plan

SHORT = {"track_length_m": [60.0, 80.0]}


def test_action_maps_linearly_onto_the_span_and_is_clipped():
    assert margin_of_action(-1.0, (0.0, 0.12)) == 0.0
    assert margin_of_action(0.0, (0.0, 0.12)) == pytest.approx(0.06)
    assert margin_of_action(1.0, (0.02, 0.1)) == pytest.approx(0.1)
    assert margin_of_action(7.0, (0.0, 0.12)) == pytest.approx(0.12)


@pytest.mark.parametrize("span", [(0.1, 0.05), (-0.01, 0.1), (0.0, 0.9), ("a", 1), (0.1,), (0.0, float("nan"))])
def test_bad_spans_are_named(span):
    with pytest.raises(ValueError, match="margin schedule"):
        check_span(span)


def test_a_constant_action_drives_exactly_like_the_controller_with_that_margin():
    """The fixed-margin family is the constant actions: same commands, step for step."""
    m = margin_of_action(0.5, (0.0, 0.12))
    wrapped = MarginScheduleWrapper(gym.make("UUOM-Track-v0", observer="dffrls-aekf", **SHORT), span=(0.0, 0.12))
    plain = gym.make("UUOM-Track-v0", observer="dffrls-aekf", **SHORT)
    ctrl = RuleBasedController(plain.unwrapped.vehicle, speed_margin=m, speed_margin_mps=m * ABS_PER_REL_MARGIN_MPS)
    _, info_w = wrapped.reset(seed=3)
    obs_p, info_p = plain.reset(seed=3)
    ctrl.reset(plain, info_p)
    for _ in range(200):
        _, _, tw, trw, info_w = wrapped.step(np.array([0.5], dtype=np.float32))
        obs_p, _, tp, trp, info_p = plain.step(ctrl.act(obs_p, info_p))
        assert info_w["command"] == info_p["command"] and info_w["speed_margin"] == pytest.approx(m)
        assert (tw, trw) == (tp, trp)
        if tw or trw:
            break


def test_bad_actions_and_step_before_reset_are_refused():
    env = MarginScheduleWrapper(gym.make("UUOM-Track-v0", observer="oracle", **SHORT))
    with pytest.raises(gym.error.ResetNeeded):
        env.step(np.zeros(1))
    env.reset(seed=0)
    for bad in (np.array([np.nan]), np.zeros(2)):
        with pytest.raises(ValueError, match="one finite number"):
            env.step(bad)


def test_training_config_records_the_span_and_refuses_it_with_a_residual(tmp_path):
    p = plan(TrainConfig(observer="oracle", residual=0.0, shield=False, margin_schedule=(0.0, 0.12), env_kwargs=SHORT,
                         log_dir=tmp_path))
    assert p.margin_schedule == (0.0, 0.12) and p.run_dir.name == "ppo_oracle_margin_s0"
    with pytest.raises(TrainConfigError, match="--residual 0"):
        plan(TrainConfig(observer="oracle", residual=0.5, margin_schedule=(0.0, 0.12), log_dir=tmp_path))
    with pytest.raises(TrainConfigError, match="0 <= lo < hi"):
        plan(TrainConfig(observer="oracle", residual=0.0, margin_schedule=(0.2, 0.1), log_dir=tmp_path))


def test_a_short_training_is_evaluated_through_the_same_wrapper(tmp_path):
    from agents.evaluation import ModelPolicy, Task, run_episode
    from agents.training import train

    run = train(TrainConfig(observer="oracle", residual=0.0, shield=False, margin_schedule=(0.0, 0.12), timesteps=256,
                            n_envs=1, eval_freq=0, checkpoint_freq=0, progress=False, subproc=False,
                            hyperparams=["n_steps=128", "batch_size=64"], env_kwargs=SHORT, run_dir=tmp_path / "r"))
    assert json.loads((run / "config.json").read_text())["margin_schedule"] == [0.0, 0.12]
    assert ModelPolicy(run).margin_schedule == (0.0, 0.12)
    row = run_episode(Task(str(run), "oracle", 100_000, json.dumps(SHORT)))
    assert row["steps"] > 0 and row["termination"] and np.isfinite(row["cost"])
