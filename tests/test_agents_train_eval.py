"""scripts/train.py and scripts/evaluate.py end to end on tiny runs (short tracks, few steps)."""

from __future__ import annotations

import csv
import importlib.util
import json
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _load(name: str):
    spec = importlib.util.spec_from_file_location(f"_uuom_{name}", ROOT / "scripts" / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


train = _load("train")
evaluate = _load("evaluate")

TINY_ENV = json.dumps({"track_length_m": [50.0, 60.0]})
TINY_HP = ["n_steps=256", "batch_size=64", "n_epochs=2"]


def _train(run_dir: Path, steps: int, algo: str = "ppo", extra: list[str] | None = None):
    args = train.parse_args(
        [
            "--algo", algo, "--observer", "oracle", "--timesteps", str(steps), "--seed", "3", "--n-envs", "2",
            "--run-dir", str(run_dir), "--eval-freq", "0", "--checkpoint-freq", "512", "--no-subproc",
            "--no-progress", "--env-kwargs", TINY_ENV, "--hyperparams", *TINY_HP, *(extra or []),
        ]
    )
    return train.train(args)


def test_training_smoke_saves_reloads_and_evaluates(tmp_path):
    run = _train(tmp_path / "run", 1024)
    assert (run / "model.zip").exists() and (run / "vecnormalize.pkl").exists()
    assert list((run / "checkpoints").glob("model_*_steps.zip"))
    events = list((run / "tb").rglob("events.out.tfevents*"))
    assert events
    from tensorboard.backend.event_processing.event_accumulator import EventAccumulator

    acc = EventAccumulator(str(events[0].parent))
    acc.Reload()
    tags = acc.Tags()["scalars"]
    for tag in ("uuom/cost_rate", "uuom/success_rate", "uuom/trip_time_s", "uuom/violations_per_km/speed_limit"):
        assert tag in tags, f"{tag} not logged; have {tags}"
    out = tmp_path / "eval"
    summary = evaluate.evaluate(
        evaluate.parse_args(
            ["--controllers", "oracle", str(run), "--observers", "oracle", "--episodes", "1", "--workers", "1",
             "--env-kwargs", TINY_ENV, "--out", str(out), "--quiet"]
        )
    )
    labels = {r["controller"] for r in summary}
    assert labels == {"oracle", "run"}
    model_row = next(r for r in summary if r["controller"] == "run")
    assert model_row["episodes"] == 1 and 0.0 <= model_row["success_rate"] <= 1.0


def test_resume_from_checkpoint(tmp_path):
    run = tmp_path / "run"
    _train(run, 1024, algo="ppo-lag")
    steps = sorted(int(p.stem.split("_")[1]) for p in (run / "checkpoints").glob("model_*_steps.zip"))
    assert steps[-1] >= 1024
    # an interrupted run: only the older checkpoint left; rerunning the command continues from it
    for p in (run / "checkpoints").glob(f"model*_{steps[-1]}_steps.*"):
        p.unlink()
    (run / "model.zip").unlink()
    _train(run, 2048, algo="ppo-lag")
    from agents.ppo_lagrangian import PPOLagrangian

    model = PPOLagrangian.load(run / "model.zip", device="cpu")
    assert model.num_timesteps >= 2048
    assert max(int(p.stem.split("_")[1]) for p in (run / "checkpoints").glob("model_*_steps.zip")) >= 2048


def test_evaluate_table_on_two_tiny_runs_is_deterministic(tmp_path):
    rows = []
    for name in ("a", "b"):
        out = tmp_path / name
        evaluate.evaluate(
            evaluate.parse_args(
                ["--controllers", "oracle", "rule-based", "full-throttle+shield", "--observers", "oracle", "none",
                 "--episodes", "2", "--workers", "2", "--env-kwargs", TINY_ENV, "--out", str(out), "--quiet"]
            )
        )
        with (out / "summary.csv").open() as fh:
            rows.append(list(csv.DictReader(fh)))
        md = (out / "summary.md").read_text()
        assert "| controller | observer | success |" in md
        assert (out / "bars.png").stat().st_size > 10_000 and (out / "episode.png").stat().st_size > 10_000
    a, b = rows
    assert [(r["controller"], r["observer"]) for r in a] == [
        ("oracle", "oracle"),
        ("full-throttle+shield", "oracle"),
        ("full-throttle+shield", "none"),
        ("rule-based", "oracle"),
        ("rule-based", "none"),
    ]
    for ra, rb in zip(a, b):
        assert ra["success_rate"] == rb["success_rate"] and ra["cost_rate"] == rb["cost_rate"]
        assert ra["trip_time_vs_oracle"] == rb["trip_time_vs_oracle"]
    oracle = a[0]
    assert float(oracle["trip_time_vs_oracle"]) == pytest.approx(1.0)
    rule_oracle = next(r for r in a if r["controller"] == "rule-based" and r["observer"] == "oracle")
    assert float(rule_oracle["success_rate"]) == 1.0 and int(rule_oracle["overspeed_trips"]) == 0
