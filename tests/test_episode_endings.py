"""How evaluation episodes end (agents.episode_endings, scripts/episode_endings.py)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from agents.episode_endings import ending, ending_counts, endings_markdown, mass_band, mass_band_markdown

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


@pytest.mark.parametrize("mass_kg, want", [
    (19_999.0, "< 20 t"), (20_000.0, "20-25 t"), (27_999.0, "25-28 t"), (32_999.0, "31-33 t"), (33_000.0, ">= 33 t"),
])
def test_a_train_falls_in_the_band_whose_lower_edge_it_reaches(mass_kg, want):
    assert mass_band(mass_kg) == want


def test_the_mass_band_table_counts_arrivals_and_pairs_trip_times_with_the_oracle_by_track():
    def row(controller, seed, mass_t, term="arrived", time_s=100.0, run=""):
        return dict(controller=controller, seed=seed, mass_kg=mass_t * 1000.0, termination=term, trip_time_s=time_s,
                    training_run=run)

    rows = [row("oracle", 1, 18, time_s=100.0), row("oracle", 2, 34, time_s=200.0), row("oracle", 3, 34, time_s=50.0),
            row("pool", 1, 18, time_s=120.0, run="s0"), row("pool", 2, 34, time_s=300.0, run="s0"),
            row("pool", 3, 34, "stopped_short", time_s=400.0, run="s0"),   # a failure: counted, no ratio
            row("rule-based", 2, 34, time_s=260.0)]
    lines = mass_band_markdown(rows).splitlines()
    assert lines[0] == "| controller | < 20 t | 20-25 t | 25-28 t | 28-31 t | 31-33 t | >= 33 t |"
    assert lines[3] == "| s0 | 1/1, 1.20x | - | - | - | - | 1/2, 1.50x |"
    assert lines[4] == "| rule-based | - | - | - | - | - | 1/1, 1.30x |"
    no_oracle = mass_band_markdown([r for r in rows if r["controller"] != "oracle"]).splitlines()
    assert no_oracle[2] == "| s0 | 1/1 | - | - | - | - | 1/2 |"
    with pytest.raises(ValueError, match="increasing"):
        mass_band_markdown(rows, (25.0, 20.0))


def test_the_script_splits_the_committed_tanh_seeds_by_train_mass():
    csv_path = ROOT / "results" / "rl" / "near_tanh" / "eval" / "pooled_6seeds" / "episodes.csv"
    script = [sys.executable, str(ROOT / "scripts" / "episode_endings.py"), str(csv_path), "--by-mass"]
    out = subprocess.run([*script, "--controllers", "sac_bare_accel_tanh_s4_selected"], capture_output=True,
                         text=True, check=True, cwd=ROOT).stdout.splitlines()
    band_rows = [line for line in out if line.startswith("| sac_bare_accel_tanh_s4_selected |")]
    assert len(band_rows) == 2 and band_rows[1].endswith("| 7/13, 2.00x | 9/14, 1.98x |")
    assert not any(line.startswith("| oracle |") for line in out)  # the oracle only pairs the trip times
    bad = subprocess.run([*script, "--mass-edges-t", "30", "20"], capture_output=True, text=True, cwd=ROOT)
    assert bad.returncode == 2 and "increasing" in bad.stderr
