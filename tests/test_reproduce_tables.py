"""The committed result tables are recomputed by this tree: one held-out episode per row of the per-observer study
(``results/agents/observer_study_ppo``, README and docs/rl.md §9), re-run from the *shipped* policy with its
observer, and of the rule-based controller under every observer (``results/agents/observer_study_rule_based``),
must give the episode the committed ``episodes.csv`` holds.

Why: the tables are the project's RL evidence, and the estimators under them keep changing. An estimator change that
alters an observer's episodes leaves its row stale without any other test noticing (it happened: ``fused``'s blend
gate in round 2, session 10, changed its rows until they were re-run). Each check is one full-length episode (about
a second), so the suite keeps its budget; ``scripts/observer_study.sh`` re-runs a stale row.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import pytest

from agents.evaluation import Task, run_episode

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "results" / "agents" / "observer_study_ppo"
SPAN_POLICIES = ROOT / "results" / "rl" / "policies"
SEED = 100_000  # the first held-out track

# (observer, training seed): one policy per observer, the seeds spread over the three
CASES = [("oracle", 0), ("dffrls-aekf", 1), ("fused", 2), ("sf-kf", 0), ("dffrls-aekf-paper", 1), ("none", 2),
         ("rls-ekf", 0), ("ffrls", 1), ("ekf", 2), ("mmae", 0)]


def _committed(observer: str, training_run: str) -> dict[str, str]:
    with open(STUDY / "episodes.csv") as fh:
        rows = [r for r in csv.DictReader(fh) if r["observer"] == observer and r.get("training_run") == training_run
                and int(r["seed"]) == SEED]
    assert len(rows) == 1, f"{observer}/{training_run}: expected one committed episode on seed {SEED}, got {len(rows)}"
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
    want = _committed(observer, training_run)
    got = run_episode(Task(str(run), observer, SEED, json.dumps(cfg["env_kwargs"])))
    _same_episode(got, want, "stale row: re-run it (scripts/observer_study.sh) and re-merge the study")


RB_STUDY = ROOT / "results" / "agents" / "observer_study_rule_based"
RB_OBSERVERS = ["oracle", "dffrls-aekf-paper", "dffrls-aekf", "fused", "sf-kf", "rls-ekf", "ekf", "ffrls", "mmae",
                "none"]


@pytest.mark.parametrize("observer", RB_OBSERVERS)
def test_rule_based_study_row_episode_is_reproduced(observer):
    """The README's "how much the estimator decides safety" table: the rule-based controller with every observer."""
    with open(RB_STUDY / "episodes.csv") as fh:
        want = next(r for r in csv.DictReader(fh)
                    if r["controller"] == "rule-based" and r["observer"] == observer and int(r["seed"]) == SEED)
    got = run_episode(Task("rule-based", observer, SEED))
    _same_episode(got, want, "stale row: re-run the README's command for results/agents/observer_study_rule_based")


def test_rule_based_reference_of_the_ppo_study_is_reproduced():
    with open(STUDY / "episodes.csv") as fh:
        want = next(r for r in csv.DictReader(fh) if r["controller"] == "rule-based" and int(r["seed"]) == SEED)
    _same_episode(run_episode(Task("rule-based", want["observer"], SEED)), want, "stale reference row")


def _same_episode(got: dict, want: dict[str, str], stale: str) -> None:
    assert str(got["termination"]) == want["termination"], (stale, got["termination"], want["termination"])
    assert str(got["overspeed_trip"]) == want["overspeed_trip"], stale
    assert math.isclose(float(got["trip_time_s"]), float(want["trip_time_s"]), rel_tol=0, abs_tol=1e-6), (
        stale, got["trip_time_s"], want["trip_time_s"])
    assert math.isclose(float(got["cost"]), float(want["cost"]), rel_tol=1e-6, abs_tol=1e-9), (
        stale, got["cost"], want["cost"])
