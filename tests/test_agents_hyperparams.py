"""The rl-zoo hyperparameter files train the same set-up as ``uuom-train`` (their ``env_wrapper``), and bad
entries are named."""

from __future__ import annotations

import importlib
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import pytest

import uuom_gym  # noqa: F401 - registers the env
from agents.algos import ALGOS
from agents.hyperparameters import (
    RESIDUAL_WRAPPER,
    SHIELD_WRAPPER,
    TrainConfigError,
    load_hyperparams,
    wrappers_from_env_wrapper,
)
from agents.training import make_env_fn

ROOT = Path(__file__).resolve().parents[1]


def _zoo_style_wrap(env: gym.Env, spec: list) -> gym.Env:
    """What rl_zoo3.utils.get_wrapper_class does: import each dotted name, apply in list order with its kwargs."""
    for item in spec:
        name, kwargs = next(iter(item.items())) if isinstance(item, dict) else (item, {})
        module, cls = name.rsplit(".", 1)
        env = getattr(importlib.import_module(module), cls)(env, **(kwargs or {}))
    return env


def _stack(env: gym.Env) -> list[tuple[str, float | None]]:
    out = []
    while isinstance(env, gym.Wrapper):
        out.append((type(env).__name__, getattr(env, "scale", None)))
        env = env.env
    return out


@pytest.mark.parametrize("algo", ALGOS)
def test_yaml_env_wrapper_is_the_training_default(algo):
    hp = load_hyperparams(algo)
    assert wrappers_from_env_wrapper(hp["env_wrapper"]) == (True, 0.5)
    zoo = _zoo_style_wrap(gym.make("UUOM-Track-v0", observer="oracle"), hp["env_wrapper"])
    ours = make_env_fn("oracle", 0, True, {}, 0.5)()
    ours_stack = [w for w in _stack(ours) if w[0] != "Monitor"]
    assert [w for w in _stack(zoo)][:2] == ours_stack[:2] == [("ResidualWrapper", 0.5), ("ShieldWrapper", None)]


@pytest.mark.parametrize(
    "spec, fragment",
    [
        (["agents.shield.Nope"], "not supported"),
        ([{RESIDUAL_WRAPPER: {"gain": 1}}], "not supported"),
        ([{RESIDUAL_WRAPPER: {"scale": 0.5}}, SHIELD_WRAPPER], "outside"),
    ],
)
def test_bad_env_wrapper_is_named(spec, fragment):
    with pytest.raises(TrainConfigError, match=fragment):
        wrappers_from_env_wrapper(spec)


def test_bare_policy_without_env_wrapper():
    assert wrappers_from_env_wrapper(None) == (False, 0.0)
    assert wrappers_from_env_wrapper([{RESIDUAL_WRAPPER: {"scale": 1.0}}]) == (False, 1.0)


def test_missing_or_broken_files_are_named(tmp_path):
    with pytest.raises(TrainConfigError, match="not found"):
        load_hyperparams("ppo", tmp_path / "none.yml")
    bad = tmp_path / "bad.yml"
    bad.write_text("Other-v0:\n  n_envs: 1\n")
    with pytest.raises(TrainConfigError, match="no 'UUOM-Track-v0' entry"):
        load_hyperparams("ppo", bad)


@pytest.mark.slow
def test_rl_zoo_trains_the_same_set_up(tmp_path):
    """With the ``[zoo]`` extra: rl_zoo3 builds the same wrappers and trains a few steps."""
    pytest.importorskip("rl_zoo3", reason="the optional [zoo] extra is not installed")
    from rl_zoo3.utils import get_wrapper_class

    hp = load_hyperparams("ppo")
    wrapper = get_wrapper_class({"env_wrapper": hp["env_wrapper"]})
    env = wrapper(gym.make("UUOM-Track-v0", observer="oracle"))
    assert _stack(env)[:2] == [("ResidualWrapper", 0.5), ("ShieldWrapper", None)]
    cmd = [sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", "UUOM-Track-v0", "--gym-packages",
           "uuom_gym", "--conf-file", str(ROOT / "agents/hyperparams/ppo.yml"), "-n", "1024", "--eval-freq", "-1",
           "--log-folder", str(tmp_path), "--env-kwargs", "track_length_m:[50.0,60.0]", "-params", "n_steps:256",
           "batch_size:64", "n_epochs:2", "--vec-env", "dummy"]
    out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert list(tmp_path.rglob("UUOM-Track-v0.zip"))


def test_speed_target_entry_is_the_bare_set_up_on_its_env_id():
    from agents.training import TrainConfig, plan
    from uuom_gym.registration import SPEED_TARGET_KWARGS

    hp = load_hyperparams("ppo", env_id="UUOM-Track-SpeedTarget-v0")
    base = load_hyperparams("ppo")
    assert wrappers_from_env_wrapper(hp["env_wrapper"]) == (False, 0.0) and hp["n_timesteps"] == 3e5
    assert {k: v for k, v in hp.items() if k not in ("env_wrapper", "n_timesteps")} == {
        k: v for k, v in base.items() if k not in ("env_wrapper", "n_timesteps")}
    p = plan(TrainConfig(env_id="UUOM-Track-SpeedTarget-v0", env_kwargs={"track_length_m": [50.0, 60.0]}))
    assert (p.shield, p.residual, p.total) == (False, 0.0, 300_000)
    assert p.env_kwargs == {**SPEED_TARGET_KWARGS, "track_length_m": [50.0, 60.0]}
    env = gym.make("UUOM-Track-SpeedTarget-v0", observer="oracle")
    assert env.unwrapped.config["action_mode"] == "speed_target"
    assert list(env.unwrapped.config["speed_target_range"]) == [0.8, 1.3]
    env.close()


def test_unknown_env_id_is_named():
    from agents.training import TrainConfig, plan

    with pytest.raises(TrainConfigError, match="unknown env id 'UUOM-Nope-v0'"):
        plan(TrainConfig(env_id="UUOM-Nope-v0"))


@pytest.mark.slow
def test_rl_zoo_trains_the_speed_target_set_up(tmp_path):
    """rl_zoo3 on the registered speed-target id: no wrappers, the speed-target action."""
    pytest.importorskip("rl_zoo3", reason="the optional [zoo] extra is not installed")
    cmd = [sys.executable, "-m", "rl_zoo3.train", "--algo", "ppo", "--env", "UUOM-Track-SpeedTarget-v0",
           "--gym-packages", "uuom_gym", "--conf-file", str(ROOT / "agents/hyperparams/ppo.yml"), "-n", "1024",
           "--eval-freq", "-1", "--log-folder", str(tmp_path), "--env-kwargs", "track_length_m:[50.0,60.0]",
           "-params", "n_steps:256", "batch_size:64", "n_epochs:2", "--vec-env", "dummy"]
    out = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    assert list(tmp_path.rglob("UUOM-Track-SpeedTarget-v0.zip"))
