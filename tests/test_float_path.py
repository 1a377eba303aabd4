"""The float32 fingerprint that tells where a trained policy's episode is reproducible bit for bit."""

from __future__ import annotations

import re
from pathlib import Path

from agents.evaluation import Task, run_episode
from agents.float_path import float_path_fingerprint

POLICY = Path(__file__).resolve().parents[1] / "results" / "rl" / "policies" / "ppo_bare_span_08_13_300k_s0"


def test_fingerprint_names_torch_and_is_stable() -> None:
    fp = float_path_fingerprint()
    assert re.fullmatch(r"torch-\S+-[0-9a-f]{12}", fp)
    float_path_fingerprint.cache_clear()
    assert float_path_fingerprint() == fp


def test_a_policy_episode_records_the_fingerprint_and_a_rule_based_one_does_not() -> None:
    import json

    cfg = json.loads((POLICY / "config.json").read_text())
    env_kwargs = json.dumps({**cfg["env_kwargs"], "track_length_m": [60.0, 80.0]})
    assert run_episode(Task(str(POLICY), "oracle", 3, env_kwargs))["float_path"] == float_path_fingerprint()
    assert "float_path" not in run_episode(Task("rule-based", "oracle", 3, env_kwargs))
