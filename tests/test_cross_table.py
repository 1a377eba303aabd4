"""scripts/cross_table.py: rows = the observer a policy was trained with (from its config.json), columns = the
observer it drove with, on a made-up merged summary."""

from __future__ import annotations

import csv
import importlib.util
import json
from pathlib import Path

_SPEC = importlib.util.spec_from_file_location("cross_table", Path(__file__).parents[1] / "scripts" / "cross_table.py")
cross = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(cross)  # type: ignore[union-attr]


def test_cells_mark_the_training_observer_and_the_note_is_said(tmp_path: Path):
    runs = []
    for name, obs in (("pol_a", "dffrls-aekf"), ("pol_b", "oracle")):
        (tmp_path / name).mkdir()
        (tmp_path / name / "config.json").write_text(json.dumps({"observer": obs}))
        runs.append(tmp_path / name)
    rows = [("oracle", "oracle", 0, 100, "1.0"), ("pol_a", "dffrls-aekf", 0, 100, "1.096"),
            ("pol_a", "oracle", 0, 30, "1.078"), ("pol_b", "oracle", 0, 100, "1.023"),
            ("pol_b", "dffrls-aekf", 3, 30, "nan")]
    summary = tmp_path / "summary.csv"
    with open(summary, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["controller", "observer", "overspeed_trips", "episodes", "trip_time_iqm"])
        w.writerows(rows)
    out = tmp_path / "cross.md"
    assert cross.main([str(summary), "--runs", *map(str, runs), "--out", str(out), "--note", "shipped as X"]) == 0
    text = out.read_text()
    assert text.startswith(f"Cross table from `{summary}` (shipped as X): rows")
    lines = [ln for ln in text.splitlines() if ln.startswith("| `")]
    # columns in first-seen order of the policies' rows: dffrls-aekf, oracle
    assert lines[0] == "| `dffrls-aekf` (pol_a) | **0/100, 1.096** | 0/30, 1.078 |"
    assert lines[1] == "| `oracle` (pol_b) | 3/30, n/a | **0/100, 1.023** |"
