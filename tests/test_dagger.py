"""The DAgger warm start (:mod:`agents.dagger`): a run directory the evaluation drives and PPO continues, the
demonstrator's actions fitted, deterministic for a seed, bad input named."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from agents.dagger import DEFAULT_DEMONSTRATOR_OPTIONS, DaggerConfig, DaggerError, _rollout, dagger

TINY = dict(demo_episodes=2, iterations=1, episodes_per_iteration=1, validation_episodes=1, value_episodes=1,
            epochs=40, env_kwargs={"track_length_m": [60.0, 80.0]})


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory) -> Path:
    return dagger(DaggerConfig(run_dir=str(tmp_path_factory.mktemp("dg") / "run"), **TINY), log=lambda _: None)


def test_run_directory_is_a_policy(tiny_run: Path) -> None:
    from agents.evaluation import ModelPolicy

    for name in ("model.zip", "vecnormalize.pkl", "config.json", "dagger.json"):
        assert (tiny_run / name).is_file(), name
    cfg = json.loads((tiny_run / "config.json").read_text())
    assert cfg["algo"] == "ppo" and cfg["residual"] == 0.0 and cfg["shield"] is False and cfg["timesteps"] == 0
    assert cfg["dagger"]["iterations"] == 1 and cfg["dagger"]["demonstrator_options"] == {"speed_margin": 0.2}
    log = json.loads((tiny_run / "dagger.json").read_text())
    assert [h["iteration"] for h in log["iterations"]] == [0, 1]
    assert log["kept_iteration"] in (0, 1)
    pol = ModelPolicy(tiny_run)
    a = pol.act(np.zeros(16, dtype=np.float32), {})
    assert a.shape == (1,) and np.isfinite(a).all()
    assert np.isclose(float(pol.model.policy.log_std.detach()[0]), np.log(0.1))


def test_actor_imitates_the_demonstrator(tiny_run: Path) -> None:
    """On its first demonstration track the fitted mean action follows the demonstrator's, far closer than a constant
    does (how well it generalises to new tracks is the study's question, docs/rl.md §46, not a unit test's)."""
    import gymnasium as gym

    from agents.demonstrations import DEMO_SEED_OFFSET, demonstrator_for
    from agents.evaluation import ModelPolicy

    env = gym.make("UUOM-Track-v0", observer="dffrls-aekf", **TINY["env_kwargs"])
    x, y, _, info = _rollout(env, demonstrator_for(env, **DEFAULT_DEMONSTRATOR_OPTIONS), DEMO_SEED_OFFSET)
    env.close()
    assert info["is_success"]
    pol = ModelPolicy(tiny_run)
    pred = np.array([pol.act(o, {})[0] for o in x[::10]])
    target = np.clip(y[::10, 0], -1, 1)
    err = np.mean((pred - target) ** 2)
    assert err < 0.1 * np.var(target), (err, np.var(target))


def test_same_seed_same_policy(tiny_run: Path, tmp_path: Path) -> None:
    import torch

    again = dagger(DaggerConfig(run_dir=str(tmp_path / "again"), **TINY), log=lambda _: None)
    from stable_baselines3 import PPO

    a = PPO.load(tiny_run / "model.zip", device="cpu").policy.state_dict()
    b = PPO.load(again / "model.zip", device="cpu").policy.state_dict()
    assert all(torch.equal(a[k], b[k]) for k in a)


def test_ppo_continues_from_it(tiny_run: Path, tmp_path: Path) -> None:
    from agents.training import TrainConfig, train

    out = train(TrainConfig(algo="ppo", residual=0.0, shield=False, timesteps=2048, eval_freq=0,
                            checkpoint_freq=0, progress=False, init_from=str(tiny_run),
                            env_kwargs=TINY["env_kwargs"], run_dir=str(tmp_path / "ft")))
    assert (out / "model.zip").is_file()
    assert json.loads((out / "config.json").read_text())["init_from"] == str(tiny_run)


@pytest.mark.parametrize("bad, msg", [
    ({"iterations": -1}, "iterations"),
    ({"demo_episodes": 0}, "demo_episodes"),
    ({"epochs": 2.5}, "epochs"),
    ({"learning_rate": float("nan")}, "learning_rate"),
    ({"seed": -3}, "seed"),
    ({"demo_episodes": 900, "iterations": 6, "episodes_per_iteration": 20}, "1000"),
    ({"env_kwargs": {"action_mode": "speed_target"}}, "traction command"),
    ({"observer": "no-such-observer"}, "no-such-observer"),
    ({"keep": "best"}, "keep"),
    ({"demonstrator_options": {"no_such_gain": 1.0}}, "no_such_gain"),
])
def test_bad_input_is_named(bad: dict, msg: str, tmp_path: Path) -> None:
    with pytest.raises(DaggerError, match=msg):
        dagger(DaggerConfig(run_dir=str(tmp_path / "x"), **{**TINY, **bad}), log=lambda _: None)
    assert not (tmp_path / "x").exists()


def test_script_names_bad_input(tmp_path: Path) -> None:
    import subprocess
    import sys

    root = Path(__file__).resolve().parents[1]
    out = subprocess.run([sys.executable, str(root / "scripts" / "dagger.py"), "--run-dir", str(tmp_path / "x"),
                          "--demonstrator-options", '{"no_such_gain": 1}'], capture_output=True, text=True, cwd=root)
    assert out.returncode == 2 and "demonstrator_options" in out.stderr and "no_such_gain" in out.stderr, out.stderr
    assert not (tmp_path / "x").exists()
