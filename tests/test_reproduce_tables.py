"""The committed result tables are recomputed by this tree: one held-out episode per row of the per-observer study
(``results/agents/observer_study_ppo``, README and docs/rl.md §9), re-run from the *shipped* policy with its
observer, and of the rule-based controller under every observer (``results/agents/observer_study_rule_based``),
must give the episode the committed ``episodes.csv`` holds.

Why: the tables are the project's RL evidence, and the estimators under them keep changing. An estimator change that
alters an observer's episodes leaves its row stale without any other test noticing (it happened: ``fused``'s blend
gate in round 2, session 10, changed its rows until they were re-run). Each check is one full-length episode (about
a second), so the suite keeps its budget; ``scripts/observer_study.sh`` re-runs a stale row.

A trained policy's episode is reproducible bit for bit only on a CPU whose float32 arithmetic is the table's
(:mod:`agents.float_path`): elsewhere the PPO rows are skipped, saying so, unless the committed row records this
machine's fingerprint. What holds on every machine: the rule-based rows (no torch; they see every observer's
estimator, so an estimator change that makes a row stale fails there), and each shipped policy's actions on
observations of its first held-out episode (``tests/data/policy_actions_pinned.npz``, open loop, to 1e-5: a change
of the policy files, their normalisation or the observation layout fails there). To rewrite that file after an
intended change: ``UUOM_REWRITE_PINNED=1 python -m pytest tests/test_reproduce_tables.py`` and say why in the commit.
"""

from __future__ import annotations

import functools
import json
import math
import os
from pathlib import Path
from typing import Any

import pytest

import numpy as np

from agents.evaluation import ModelPolicy, Task, read_episodes, run_episode
from agents.float_path import float_path_fingerprint

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "results" / "agents" / "observer_study_ppo"
SPAN_POLICIES = ROOT / "results" / "rl" / "policies"
SEED = 100_000  # the first held-out track

# (observer, training seed): one policy per observer, the seeds spread over the three
CASES = [("oracle", 0), ("dffrls-aekf", 1), ("fused", 2), ("sf-kf", 0), ("dffrls-aekf-paper", 1), ("none", 2),
         ("rls-ekf", 0), ("ffrls", 1), ("ekf", 2), ("mmae", 0)]


@functools.lru_cache(maxsize=None)
def _first_track_rows(study: Path) -> list[dict[str, Any]]:
    """The committed episodes of ``study`` on the first held-out track (the file is read once per process)."""
    return [r for r in read_episodes(study / "episodes.csv") if r["seed"] == SEED]


def _committed(study: Path, **match: str) -> dict[str, Any]:
    rows = [r for r in _first_track_rows(study) if all(r.get(k) == v for k, v in match.items())]
    assert len(rows) == 1, f"{study.name} {match}: expected one committed episode on seed {SEED}, got {len(rows)}"
    return rows[0]


def _policy(observer: str, seed: int) -> tuple[Path, str]:
    """The shipped policy folder and the training run name the committed table records for it."""
    if observer == "dffrls-aekf":  # the §8 policies, shipped under results/rl/policies
        name = f"ppo_bare_span_08_13_300k_s{seed}"
        return SPAN_POLICIES / name, name
    return STUDY / "policies" / f"{observer}_s{seed}", f"span13_{observer}_s{seed}"


@pytest.mark.parametrize("observer,seed", CASES, ids=[f"{o}_s{s}" for o, s in CASES])
def test_study_row_episode_is_reproduced_by_its_shipped_policy(observer, seed):
    run, training_run = _policy(observer, seed)
    cfg = json.loads((run / "config.json").read_text())
    assert cfg["observer"] == observer
    want = _committed(STUDY, observer=observer, training_run=training_run)
    here = float_path_fingerprint()
    if want.get("float_path") != here:
        pytest.skip(f"the committed row was written with float32 path {want.get('float_path') or '(not recorded)'}, "
                    f"this machine has {here}: a policy's episode is reproducible only on the same path")
    got = run_episode(Task(str(run), observer, SEED, json.dumps(cfg["env_kwargs"])))
    _same_episode(got, want, "stale row: re-run it (scripts/observer_study.sh) and re-merge the study")


PINNED_ACTIONS = ROOT / "tests" / "data" / "policy_actions_pinned.npz"
PINNED_EVERY, PINNED_STEPS = 20, 400
"""Every 20th observation of the first 400 policy steps of each shipped policy's first held-out episode."""


def _actions(policy: ModelPolicy, obs: np.ndarray) -> np.ndarray:
    return np.stack([policy.act(o, {}) for o in obs])


def _observations(policy: ModelPolicy, observer: str, env_kwargs: dict[str, Any]) -> np.ndarray:
    """Raw observations of the policy's own episode on the first held-out track (this machine's closed loop)."""
    import gymnasium as gym

    from agents.evaluation import ENV_ID
    from agents.training import wrap_env

    env = wrap_env(gym.make(ENV_ID, observer=observer, **env_kwargs), policy.shield, policy.residual,
                   policy.margin_schedule)
    obs, info = env.reset(seed=SEED)
    out = []
    for step in range(PINNED_STEPS):
        if step % PINNED_EVERY == 0:
            out.append(np.array(obs, dtype=np.float32))
        obs, _, term, trunc, info = env.step(policy.act(obs, info))
        if term or trunc:
            break
    env.close()
    return np.stack(out)


def _rewrite_pinned_actions() -> None:
    arrays = {}
    for observer, seed in CASES:
        run, _ = _policy(observer, seed)
        env_kwargs = json.loads((run / "config.json").read_text())["env_kwargs"]
        policy = ModelPolicy(run)
        obs = _observations(policy, observer, env_kwargs)
        arrays[f"{observer}_s{seed}/obs"] = obs
        arrays[f"{observer}_s{seed}/action"] = _actions(policy, obs)
    np.savez_compressed(PINNED_ACTIONS, **arrays)


if os.environ.get("UUOM_REWRITE_PINNED") == "1":  # pragma: no cover - maintenance path
    _rewrite_pinned_actions()


@pytest.mark.parametrize("observer,seed", CASES, ids=[f"{o}_s{s}" for o, s in CASES])
def test_shipped_policy_acts_as_pinned(observer, seed):
    run, _ = _policy(observer, seed)
    with np.load(PINNED_ACTIONS) as data:
        obs, want = data[f"{observer}_s{seed}/obs"], data[f"{observer}_s{seed}/action"]
    got = _actions(ModelPolicy(run), obs)
    # float32 products of another CPU's code path differ in the last bits (~1e-7); a changed policy by far more
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-5, err_msg=f"{run.name}: the shipped policy acts differently")


RB_STUDY = ROOT / "results" / "agents" / "observer_study_rule_based"
RB_OBSERVERS = ["oracle", "dffrls-aekf-paper", "dffrls-aekf", "fused", "sf-kf", "rls-ekf", "ekf", "ffrls", "mmae",
                "none"]


@pytest.mark.parametrize("observer", RB_OBSERVERS)
def test_rule_based_study_row_episode_is_reproduced(observer):
    """The README's "how much the estimator decides safety" table: the rule-based controller with every observer."""
    want = _committed(RB_STUDY, controller="rule-based", observer=observer)
    got = run_episode(Task("rule-based", observer, SEED))
    _same_episode(got, want, "stale row: re-run the README's command for results/agents/observer_study_rule_based")


def test_rule_based_reference_of_the_ppo_study_is_reproduced():
    want = _committed(STUDY, controller="rule-based")
    _same_episode(run_episode(Task("rule-based", want["observer"], SEED)), want, "stale reference row")


def _same_episode(got: dict[str, Any], want: dict[str, Any], stale: str) -> None:
    assert str(got["termination"]) == want["termination"], (stale, got["termination"], want["termination"])
    assert bool(got["overspeed_trip"]) == want["overspeed_trip"], stale
    assert math.isclose(float(got["trip_time_s"]), want["trip_time_s"], rel_tol=0, abs_tol=1e-6), (
        stale, got["trip_time_s"], want["trip_time_s"])
    assert math.isclose(float(got["cost"]), want["cost"], rel_tol=1e-6, abs_tol=1e-9), (
        stale, got["cost"], want["cost"])


def _studies_with_committed_episodes() -> list[str]:
    """Every results folder whose ``episodes.csv`` is committed (an exception ``!results/...`` in ``.gitignore``, which
    ignores the rest) and has a ``summary.csv``: read from ``.gitignore``, not listed here, so a new study is covered
    without editing this file, and a machine's local, uncommitted evaluations are not."""
    lines = (ROOT / ".gitignore").read_text().splitlines()
    files = [ROOT / line[1:] for line in lines if line.startswith("!results/") and line.endswith("/episodes.csv")]
    return sorted(str(f.parent.relative_to(ROOT / "results")) for f in files
                  if f.is_file() and (f.parent / "summary.csv").is_file())


def test_the_committed_studies_are_found():
    # the .gitignore exceptions up to round 2, session 41: at least these are found
    found = set(_studies_with_committed_episodes())
    assert {"agents/observer_study_ppo", "agents/observer_study_rule_based", "agents/light_memory_observers",
            "rl/traction_exploration/eval/ppo_ceiling_5seeds", "rl/caution/eval/pooled_4seeds",
            "rl/replay_buffer/eval/pooled_6seeds"} <= found


@pytest.mark.parametrize("study", _studies_with_committed_episodes())
def test_committed_summary_is_its_episodes_summarised_by_this_tree(study):
    """Each committed ``summary.csv`` beside a committed ``episodes.csv`` is what this tree's statistics make of those
    episodes: a change to the table's statistics (it happened: the pooled rates' intervals, round 2, session 33)
    leaves no summary printed with the old ones."""
    import csv

    from agents.evaluation_table import summarise

    folder = ROOT / "results" / study
    fresh = {(r["controller"], r["observer"]): r for r in summarise(read_episodes(folder / "episodes.csv"))}
    with open(folder / "summary.csv", newline="") as fh:
        committed = list(csv.DictReader(fh))
    assert {(r["controller"], r["observer"]) for r in committed} == set(fresh)
    for row in committed:
        new = fresh[(row["controller"], row["observer"])]
        for key, text in row.items():
            if key in ("controller", "observer"):
                continue
            assert math.isclose(float(text), float(new[key]), rel_tol=1e-9, abs_tol=1e-12) or (
                math.isnan(float(text)) and math.isnan(float(new[key]))), f"{study} {row['controller']} {key}: {text} vs {new[key]}"
