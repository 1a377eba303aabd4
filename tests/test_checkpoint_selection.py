"""Choosing a run's checkpoint on validation tracks (agents.checkpoint_selection, scripts/select_checkpoint.py)."""

from __future__ import annotations

import json
import math
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from agents.checkpoint_selection import candidates, rank, ranking_markdown, step_of
from agents.evaluation import controller_label, run_config_path, trained_env_kwargs

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / "results" / "rl" / "policies" / "ppo_bare_traction_ceiling_big_1150k_s0"


def _fake_run(tmp_path: Path, steps=(100, 200, 300), final=True) -> Path:
    run = tmp_path / "run_s0"
    for n in steps:
        d = run / "checkpoints" / f"step_{n:010d}"
        d.mkdir(parents=True)
        (d / "model.zip").write_bytes(b"")
    (run / "config.json").write_text(json.dumps({"observer": "oracle", "env_kwargs": {"action_mode": "acceleration"}}))
    if final:
        (run / "model.zip").write_bytes(b"")
    return run


def test_candidates_filter_by_step_and_end_with_the_final_model(tmp_path):
    run = _fake_run(tmp_path)
    assert [step_of(c) for c in candidates(run)] == [100, 200, 300, None]
    assert [step_of(c) for c in candidates(run, min_step=200)] == [200, 300, None]
    assert [step_of(c) for c in candidates(run, every=200)] == [200, None]
    with pytest.raises(FileNotFoundError, match="no model.zip"):
        candidates(tmp_path / "empty")


def test_an_every_that_matches_no_checkpoint_is_an_error_naming_their_steps(tmp_path):
    """A run continued with ``--init-from`` from step 56 saves at 156, 256, ...: ``every=100`` must not quietly leave
    the final model as the only candidate."""
    run = _fake_run(tmp_path, steps=(156, 256, 356))
    with pytest.raises(ValueError, match=r"--every 100 matches none of its checkpoints \(steps 156, 256, 356\)"):
        candidates(run, every=100)
    assert [step_of(c) for c in candidates(run)] == [156, 256, 356, None]


def test_a_checkpoint_folder_is_described_by_its_runs_config_and_labelled_by_it(tmp_path):
    run = _fake_run(tmp_path)
    ck = run / "checkpoints" / "step_0000000200"
    assert run_config_path(ck) == run / "config.json"
    assert trained_env_kwargs(ck) == {"action_mode": "acceleration"}
    assert controller_label(str(ck)) == "run_s0_step_0000000200"
    assert controller_label(str(run)) == "run_s0"


def _rows(label: str, arrived: int, trips: int, n: int = 10, time_s: float = 100.0) -> list[dict]:
    rows = [dict(controller=label, success=True, termination="arrived", trip_time_s=time_s)] * arrived
    rows += [dict(controller=label, success=False, termination="overspeed_trip", trip_time_s=math.nan)] * trips
    return rows + [dict(controller=label, success=False, termination="overrun", trip_time_s=math.nan)] * (
        n - arrived - trips)


def test_rank_weighs_a_trip_as_ten_misses_then_prefers_faster_then_later(tmp_path):
    run = _fake_run(tmp_path)
    c = {controller_label(str(p)): p for p in candidates(run)}
    a, b, d, final = list(c)
    rows = _rows(a, 10, 1) + _rows(b, 9, 0, time_s=120.0) + _rows(d, 9, 0, time_s=110.0) + _rows(final, 9, 0,
                                                                                                  time_s=110.0)
    table = rank(rows, c)
    assert [t["candidate"] for t in table] == [final, d, b, a]
    assert table[-1]["score"] == 10 - 10
    assert ranking_markdown(table).splitlines()[2].startswith(f"| **{final}** | final | 10 | 9 | 0 |")
    with pytest.raises(ValueError, match="no episodes"):
        rank(rows[:10], c)


def test_the_script_validates_off_the_held_out_tracks_and_copies_the_choice(tmp_path):
    run = tmp_path / "traction_s0"
    for n in (100, 200):
        d = run / "checkpoints" / f"step_{n:010d}"
        d.mkdir(parents=True)
        for name in ("model.zip", "vecnormalize.pkl"):
            shutil.copy(SHIPPED / name, d / name)
    shutil.copy(SHIPPED / "config.json", run / "config.json")
    cmd = [sys.executable, str(ROOT / "scripts" / "select_checkpoint.py"), str(run), "--episodes", "1",
           "--env-kwargs", '{"track_length_m": [50, 50]}', "--allow-env-shift", "--out", str(tmp_path / "sel"),
           "--copy-to", str(tmp_path / "ship")]
    out = subprocess.run(cmd, capture_output=True, text=True, check=True, cwd=ROOT).stdout
    assert out.startswith(f"{run}: traction_s0_step_")
    md = (tmp_path / "sel" / "traction_s0" / "selection.md").read_text()
    assert md.startswith("Validation seeds 200000..200000")
    cfg = json.loads((tmp_path / "ship" / "traction_s0_selected" / "config.json").read_text())
    assert cfg["selected_checkpoint"]["step"] in (100, 200) and cfg["algo"] == "ppo"
    bad = subprocess.run([*cmd[:3], "--seed-base", "99990", "--episodes", "20", "--out", str(tmp_path / "x")],
                         capture_output=True, text=True, cwd=ROOT)
    assert bad.returncode == 2 and "overlaps the held-out tracks" in bad.stderr


def test_a_policy_trained_on_normalized_observations_is_not_run_without_its_statistics(tmp_path):
    from agents.evaluation import ModelPolicy

    for name in ("model.zip", "config.json"):
        shutil.copy(SHIPPED / name, tmp_path / name)
    with pytest.raises(FileNotFoundError, match="no vecnormalize.pkl"):
        ModelPolicy(tmp_path)
    shutil.copy(SHIPPED / "vecnormalize.pkl", tmp_path / "vecnormalize.pkl")
    assert ModelPolicy(tmp_path).vecnorm is not None
