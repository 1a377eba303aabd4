"""The vehicle-shift study (:mod:`agents.vehicle_shift`, ``scripts/vehicle_shift.py``): the tasks it runs, the
tables it writes, and its bad input."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from agents.evaluation import trained_env_kwargs
from agents.evaluation import Task, read_episodes, run_episode
from agents.float_path import float_path_fingerprint
from agents.vehicle_shift import (ShiftConfig, load_config, report_vehicle_shift, run_vehicle_shift, shift_tasks,
                                  track_id)

ROOT = Path(__file__).resolve().parents[1]
POLICY = ROOT / "results/rl/policies/ppo_bare_span_08_13_300k_s0"


def test_tasks_cover_every_controller_vehicle_and_track() -> None:
    cfg = ShiftConfig(controllers=("rule-based", str(POLICY)), vehicles=2, episodes=3)
    tasks = shift_tasks(cfg)
    assert len(tasks) == 3 * 3 * 3  # (project + 2 sisters) x (oracle added + 2) x 3 tracks
    for k, t in tasks:
        kw = json.loads(t.env_kwargs_json)
        assert ("vehicle" in kw) == (k > 0)  # the project's vehicle is the env's default
        assert t.observer == ("oracle" if t.controller == "oracle" else "dffrls-aekf")
        if t.controller == str(POLICY):  # a policy keeps its own training env; the vehicle is the only shift
            assert {key: v for key, v in kw.items() if key != "vehicle"} == trained_env_kwargs(POLICY)
    sisters = {t.env_kwargs_json for k, t in tasks if k > 0 and t.controller == "oracle"}
    assert len(sisters) == 2
    ids = {track_id(k, t.seed) for k, t in tasks}
    assert len(ids) == 3 * 3


def test_a_small_study_writes_its_tables(tmp_path: Path) -> None:
    cfg = ShiftConfig(controllers=("rule-based",), vehicles=1, episodes=1, workers=1, out=tmp_path)
    res = run_vehicle_shift(cfg, progress=False)
    md = (tmp_path / "summary.md").read_text()
    for part in ("## The project's vehicle", "## The sister vehicles, pooled", "## Per vehicle", "0: the project's"):
        assert part in md
    rows = [r for r in res["sisters"] if r["controller"] == "rule-based"]
    assert len(rows) == 1 and rows[0]["episodes"] == 1
    vehicles = json.loads((tmp_path / "vehicles.json").read_text())
    assert [v["index"] for v in vehicles] == [0, 1] and vehicles[0]["vehicle"] == {} and vehicles[1]["vehicle"]
    header = (tmp_path / "episodes.csv").read_text().splitlines()[0].split(",")
    assert {"vehicle", "track_seed", "seed"} <= set(header)
    assert (tmp_path / "vehicle_shift.png").stat().st_size > 0
    # the report rebuilt from the files alone is the same (the configuration and command come from run.json)
    assert load_config(tmp_path).controllers == ("rule-based",)
    report_vehicle_shift(tmp_path, progress=False)
    assert (tmp_path / "summary.md").read_text() == md


@pytest.mark.parametrize("args, word", [
    (["--controllers", "rule-based", "--spread", "0.5"], "spread"),
    (["--controllers", "no-such-controller"], "no-such-controller"),
    (["--controllers", "rule-based", "--episodes", "0"], "episodes"),
    (["--controllers", "rule-based", "--pool", "x"], "LABEL=CTRL"),
    (["--report-only"], "no finished run"),
    ([], "--controllers is required"),
])
def test_bad_input_is_named(args: list[str], word: str, tmp_path: Path) -> None:
    p = subprocess.run([sys.executable, str(ROOT / "scripts/vehicle_shift.py"), *args, "--out", str(tmp_path)],
                       capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert p.returncode == 2 and word in p.stderr, p.stderr
    assert not (tmp_path / "episodes.csv").exists()


STUDIES = sorted(p.parent for p in (ROOT / "results" / "agents").glob("vehicle_shift*/run.json"))


def test_the_committed_studies_are_there() -> None:
    assert {p.name for p in STUDIES} >= {"vehicle_shift", "vehicle_shift_15", "vehicle_shift_15_gentle_brake"}


@pytest.mark.parametrize("study", STUDIES, ids=[p.name for p in STUDIES])
def test_committed_tables_are_their_episodes_reported_by_this_tree(study: Path, tmp_path: Path) -> None:
    for name in ("episodes.csv", "vehicles.json", "run.json"):
        shutil.copy(study / name, tmp_path / name)
    report_vehicle_shift(tmp_path, progress=False)
    for name in ("summary.md", "summary_vehicles.csv"):
        assert (tmp_path / name).read_text() == (study / name).read_text(), f"{study.name}/{name} is stale"


def _committed_episode(study: str, controller: str, vehicle: int, seed: int) -> dict:
    rows = [r for r in read_episodes(ROOT / "results/agents" / study / "episodes.csv")
            if r["controller"] == controller and r["vehicle"] == vehicle and r["track_seed"] == seed]
    assert len(rows) == 1
    return rows[0]


def _rerun(study: str, spec: str, vehicle: int, seed: int) -> dict:
    cfg = load_config(ROOT / "results/agents" / study)
    cfg = ShiftConfig(**{**cfg.__dict__, "controllers": (spec,)})
    task = [t for k, t in shift_tasks(cfg) if k == vehicle and t.controller == spec and t.seed == seed][0]
    return run_episode(Task(task.controller, task.observer, task.seed, task.env_kwargs_json))


def _same(got: dict, want: dict) -> None:
    assert str(got["termination"]) == want["termination"]
    assert got["trip_time_s"] == pytest.approx(want["trip_time_s"], abs=1e-6)
    assert got["cost"] == pytest.approx(want["cost"], rel=1e-6, abs=1e-9)


def test_the_default_brake_trips_a_rated_load_train_of_a_sister_vehicle_and_the_gentle_one_does_not() -> None:
    """docs/rl.md §53: vehicle 9 of the x/÷1.5 study, a 98 % load on held-out track 100008."""
    want = _committed_episode("vehicle_shift_15", "rule-based", 9, 100008)
    got = _rerun("vehicle_shift_15", "rule-based", 9, 100008)
    assert want["termination"] == "overspeed_trip"
    _same(got, want)
    want = _committed_episode("vehicle_shift_15_gentle_brake", "rule-based@overspeed_gain_per_s=2.5", 9, 100008)
    got = _rerun("vehicle_shift_15_gentle_brake", "rule-based@overspeed_gain_per_s=2.5", 9, 100008)
    assert want["termination"] == "arrived" and not want["overspeed_trip"]
    _same(got, want)


@pytest.mark.parametrize("policy, ending", [("ppo_bare_span_08_13_300k_s0", "arrived"),
                                            ("ppo_bc_ceiling_traction_s0", "overspeed_trip")])
def test_a_shipped_policy_on_a_sister_vehicle(policy: str, ending: str) -> None:
    """Vehicle 6 of the x/÷1.5 study (14.1 t carrying 29.9 t), track 100002: the speed-target policy arrives, the
    traction policy trips. A policy's episode is reproducible only on the float32 path that wrote it."""
    want = _committed_episode("vehicle_shift_15", policy, 6, 100002)
    assert want["termination"] == ending
    if want.get("float_path") != float_path_fingerprint():
        pytest.skip(f"the committed row was written with float32 path {want.get('float_path')}, this machine has "
                    f"{float_path_fingerprint()}")
    _same(_rerun("vehicle_shift_15", str(ROOT / "results/rl/policies" / policy), 6, 100002), want)


def test_a_study_on_a_vehicle_file(tmp_path: Path) -> None:
    f = tmp_path / "mine.toml"
    f.write_text("[vehicle]\nempty_mass_kg = 18000\nrated_load_kg = 22000\n")
    cfg = ShiftConfig(controllers=("rule-based",), vehicle_files=(str(f),), episodes=1, workers=1, out=tmp_path / "o")
    run_vehicle_shift(cfg, progress=False)
    md = (tmp_path / "o" / "summary.md").read_text()
    assert "mine.toml" in md and "| 1: 18.0 t + 22.0 t" in md
    assert load_config(tmp_path / "o").vehicle_files == (str(f),)


def test_a_missing_vehicle_file_is_named(tmp_path: Path) -> None:
    p = subprocess.run([sys.executable, str(ROOT / "scripts/vehicle_shift.py"), "--controllers", "rule-based",
                        "--vehicle-files", str(tmp_path / "nope.toml"), "--out", str(tmp_path)],
                       capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert p.returncode == 2 and "nope.toml" in p.stderr, p.stderr


def test_a_policy_trained_on_drawn_vehicles_is_judged_on_the_studys_fixed_ones(tmp_path: Path) -> None:
    """A run trained with ``vehicle_spread`` keeps its other env settings (here the vehicle entries) and drops the
    draw: each task's env is the study's vehicle."""
    run = tmp_path / "dr_run"
    run.mkdir()
    (run / "config.json").write_text(json.dumps({"algo": "ppo", "env_kwargs": {"vehicle_spread": 1.5,
                                                                               "vehicle_observation": True}}))
    cfg = ShiftConfig(controllers=(str(run),), vehicles=2, spread=1.5, episodes=1, workers=1, out=tmp_path / "o")
    tasks = [(k, t) for k, t in shift_tasks(cfg) if t.controller == str(run)]
    assert [k for k, _ in tasks] == [0, 1, 2]
    for k, t in tasks:
        kw = json.loads(t.env_kwargs_json)
        assert "vehicle_spread" not in kw and kw["vehicle_observation"] is True
        assert ("vehicle" in kw) == (k > 0)


def test_a_policy_trained_on_drawn_vehicles_trips_the_rated_load_train_of_a_sister_vehicle() -> None:
    """docs/rl.md §54: the traction recipe trained on drawn vehicles with the vehicle entries still trips a
    rated-load train (track 100010, 95 % load) on vehicle 6 of the x/÷1.5 study; re-run from the shipped policy."""
    policy = "ppo_bc_ceiling_dr15_vehobs_traction_s0"
    want = _committed_episode("vehicle_shift_15_dr", policy, 6, 100010)
    assert want["termination"] == "overspeed_trip"
    if want.get("float_path") != float_path_fingerprint():
        pytest.skip(f"the committed row was written with float32 path {want.get('float_path')}, this machine has "
                    f"{float_path_fingerprint()}")
    _same(_rerun("vehicle_shift_15_dr", str(ROOT / "results/rl/policies" / policy), 6, 100010), want)
