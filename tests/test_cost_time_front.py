"""scripts/cost_time_front.py: the learned-vs-rule-based comparison at no higher cost rate, on made-up episodes."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from agents.evaluation_table import write_csv

_SPEC = importlib.util.spec_from_file_location("cost_time_front", Path(__file__).parents[1] / "scripts" / "cost_time_front.py")
front = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(front)  # type: ignore[union-attr]


def _episodes(controller: str, time_factor: float, cost_per_step: float, tracks: int = 20) -> list[dict]:
    return [
        {"controller": controller, "observer": "dffrls-aekf", "seed": 100 + k, "success": True, "overspeed_trip": False,
         "trip_time_s": 100.0 * time_factor * (1 + 0.01 * (k % 3)), "steps": 1000, "cost": cost_per_step * 1000}
        for k in range(tracks)
    ]


@pytest.fixture()
def folder(tmp_path: Path) -> Path:
    rows = (_episodes("oracle", 1.0, 0.0) + _episodes("rule-based", 1.2, 1e-7)
            + _episodes("rule-based@speed_margin=0.04", 1.15, 1e-4) + _episodes("rule-based@speed_margin=0", 1.05, 1e-2)
            + _episodes("fast_s0", 1.10, 5e-5) + _episodes("fast_s1", 1.11, 6e-5) + _episodes("reckless", 1.0, 1e-1))
    write_csv(tmp_path / "episodes.csv", rows)
    return tmp_path


def test_each_learned_point_meets_the_fastest_rule_based_setting_that_is_no_costlier(folder: Path, tmp_path: Path):
    out = tmp_path / "front"
    assert front.main([str(folder), "--pool", "fast=fast_s0,fast_s1", "--out", str(out)]) == 0
    md = (out / "front.md").read_text()
    # 5.5e-05 per step: the 1e-04 setting is costlier, so the default (1e-07, 1.2x) is the comparison
    assert "- fast: IQM 1.105 at 5.50e-05 vs `rule-based` 1.200 at 1.00e-07: **faster**." in md
    assert "- reckless: IQM 1.000 at 1.00e-01 vs `rule-based@speed_margin=0` 1.050 at 1.00e-02: **faster**." in md
    assert "| R0 | rule-based | 1 | 20 |" in md and "| R2 | rule-based@speed_margin=0 |" in md
    assert (out / "front.png").stat().st_size > 10_000


def test_a_learned_point_safer_than_every_setting_is_said_so(folder: Path, tmp_path: Path):
    write_csv(folder / "episodes.csv", _episodes("oracle", 1.0, 0.0) + _episodes("rule-based", 1.2, 1e-3)
              + _episodes("careful", 1.3, 0.0))
    assert front.main([str(folder), "--out", str(tmp_path / "o")]) == 0
    assert "careful: no rule-based setting here is as safe" in (tmp_path / "o" / "front.md").read_text()


def test_prefix_keeps_same_named_controllers_of_two_folders_apart(folder: Path, tmp_path: Path):
    other = tmp_path / "other"
    other.mkdir()
    write_csv(other / "episodes.csv", _episodes("fast_s0", 1.3, 0.0))
    out = tmp_path / "o"
    assert front.main([str(folder), str(other), "--prefix", f"{other}=slow ", "--out", str(out)]) == 0
    md = (out / "front.md").read_text()
    assert "| slow fast_s0 | 1 | 20 |" in md and "| fast_s0 | 1 | 20 |" in md
    with pytest.raises(SystemExit, match="--prefix"):
        front.main([str(folder), "--prefix", "elsewhere=x", "--out", str(out)])


def test_missing_oracle_or_folder_is_named(folder: Path, tmp_path: Path):
    with pytest.raises(SystemExit, match="no episodes.csv"):
        front.main([str(tmp_path / "nowhere"), "--out", str(tmp_path / "o")])
    write_csv(folder / "episodes.csv", _episodes("rule-based", 1.2, 1e-7))
    with pytest.raises(SystemExit, match="no oracle episodes"):
        front.main([str(folder), "--out", str(tmp_path / "o")])
