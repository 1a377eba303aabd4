"""How evaluation episodes end (agents.episode_endings, scripts/episode_endings.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from agents.episode_endings import ending, ending_counts, endings_markdown

ROOT = Path(__file__).resolve().parents[1]


def _row(term: str, distance_m: float = 100.0, length_m: float = 200.0, controller: str = "c", run: str = "") -> dict:
    return dict(termination=term, distance_m=distance_m, track_length_m=length_m, controller=controller,
                training_run=run)


@pytest.mark.parametrize("row, want", [
    (_row("arrived"), "arrived"),
    (_row("overspeed_trip", 1.0), "overspeed_trip"),  # only stopped_short is split by place
    (_row("stopped_short", 0.3), "stopped_short_at_start"),
    (_row("stopped_short", 4.99), "stopped_short_at_start"),
    (_row("stopped_short", 193.0, 200.0), "stopped_short_at_station"),
    (_row("stopped_short", 150.0, 200.0), "stopped_short_elsewhere"),
])
def test_a_stopped_short_ending_is_split_by_where_the_train_stood(row, want):
    assert ending(row) == want


def test_pooled_rows_count_per_training_run_and_the_table_keeps_the_columns_in_order():
    rows = [_row("arrived", controller="pool", run="s0"), _row("stopped_short", 1.0, controller="pool", run="s0"),
            _row("overrun", controller="pool", run="s1"), _row("arrived", controller="rule-based"),
            _row("weird_end", controller="rule-based")]
    counts = ending_counts(rows)
    assert list(counts) == ["s0", "s1", "rule-based"]
    assert counts["s0"] == {"arrived": 1, "stopped_short_at_start": 1}
    lines = endings_markdown(counts).splitlines()
    assert lines[0] == ("| controller | episodes | arrived | overrun | stopped short at start | weird end |")
    assert lines[2] == "| s0 | 2 | 1 | 0 | 1 | 0 |" and lines[4] == "| rule-based | 2 | 1 | 0 | 0 | 1 |"


def test_the_script_counts_the_committed_five_seed_table_and_names_a_missing_controller():
    csv_path = ROOT / "results" / "rl" / "traction_exploration" / "eval" / "ppo_ceiling_5seeds" / "episodes.csv"
    script = [sys.executable, str(ROOT / "scripts" / "episode_endings.py"), str(csv_path)]
    big3 = "ppo_bare_traction_ceiling_big_1150k_s3"
    out = subprocess.run([*script, "--controllers", "rule-based", big3], capture_output=True, text=True, check=True,
                         cwd=ROOT).stdout.splitlines()
    assert out[2].startswith("| rule-based | 100 | 100 | ")
    assert out[3].startswith(f"| {big3} | 100 | 0 | ") and out[3].endswith("| 100 |")  # never left the start
    bad = subprocess.run([*script, "--controllers", "nobody"], capture_output=True, text=True, cwd=ROOT)
    assert bad.returncode == 2 and "no episodes of nobody" in bad.stderr
