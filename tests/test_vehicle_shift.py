"""The vehicle-shift study (:mod:`agents.vehicle_shift`, ``scripts/vehicle_shift.py``): the tasks it runs, the
tables it writes, and its bad input."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from agents.evaluation import trained_env_kwargs
from agents.vehicle_shift import ShiftConfig, report_vehicle_shift, run_vehicle_shift, shift_tasks, track_id

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
    # the report rebuilt from the files alone is the same (the command comes from run.json)
    again = report_vehicle_shift(ShiftConfig(controllers=("rule-based",), vehicles=1, out=tmp_path), progress=False)
    assert again == res and (tmp_path / "summary.md").read_text() == md


@pytest.mark.parametrize("args, word", [
    (["--controllers", "rule-based", "--spread", "0.5"], "spread"),
    (["--controllers", "no-such-controller"], "no-such-controller"),
    (["--controllers", "rule-based", "--episodes", "0"], "episodes"),
    (["--controllers", "rule-based", "--pool", "x"], "LABEL=CTRL"),
    (["--controllers", "rule-based", "--report-only"], "no finished run"),
])
def test_bad_input_is_named(args: list[str], word: str, tmp_path: Path) -> None:
    p = subprocess.run([sys.executable, str(ROOT / "scripts/vehicle_shift.py"), *args, "--out", str(tmp_path)],
                       capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert p.returncode == 2 and word in p.stderr, p.stderr
    assert not (tmp_path / "episodes.csv").exists()
