"""Plain PPO from scripts/train.py defaults (bare: no residual, no shield) trains, saves and reloads; the shipped
policies under results/rl/policies load and drive an episode (no performance asserts: see docs/rl.md)."""

from __future__ import annotations

import importlib.util
import json
import math
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
POLICIES = ROOT / "results" / "rl" / "policies"
SHORT = {"track_length_m": [50.0, 60.0]}


def _load(name: str):
    spec = importlib.util.spec_from_file_location(f"_uuom_rl_{name}", ROOT / "scripts" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


train = _load("train")
evaluate = _load("evaluate")


def test_bare_ppo_smoke_with_default_hyperparameters(tmp_path):
    # agents/hyperparams/ppo.yml as it is (n_steps 1024 x 2 envs = one 2 048-step rollout and one update)
    args = train.parse_args(
        ["--algo", "ppo", "--residual", "0", "--no-shield", "--observer", "oracle", "--timesteps", "2048",
         "--seed", "5", "--run-dir", str(tmp_path / "run"), "--eval-freq", "0", "--no-subproc", "--no-progress",
         "--env-kwargs", json.dumps(SHORT)]
    )
    run = train.train(args)
    cfg = json.loads((run / "config.json").read_text())
    assert cfg["residual"] == 0.0 and cfg["shield"] is False
    policy = evaluate._ModelPolicy(run)
    assert not policy.shield and policy.residual == 0.0
    assert policy.model.num_timesteps >= 2048
    assert policy.vecnorm is not None and policy.vecnorm.obs_rms.count > 2048  # statistics were collected
    obs = np.zeros(16, dtype=np.float32)
    a = policy.act(obs, {})
    assert a.shape == (1,) and np.all(np.isfinite(a))


def test_shipped_policies_load_and_drive_one_episode():
    runs = sorted(p.parent for p in POLICIES.glob("*/model.zip"))
    assert runs, f"no shipped policy under {POLICIES}"
    for run in runs:
        for f in ("config.json", "vecnormalize.pkl"):
            assert (run / f).exists(), f"{run.name}: {f} missing"
        row = evaluate.run_episode(evaluate.Task(str(run), "oracle", 100_000, json.dumps(SHORT)))
        assert row["steps"] > 0 and row["termination"], row
        for key in ("cost", "trip_time_s", "distance_m"):
            assert math.isfinite(float(row[key])), (run.name, key, row[key])
