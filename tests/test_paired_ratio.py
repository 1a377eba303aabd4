"""scripts/paired_ratio.py: trip times paired per track against a reference, in one file or with the reference read
from another (the same controller under two env configurations carries the same name in both)."""

from __future__ import annotations

import csv
import importlib.util
from pathlib import Path

import pytest

_SPEC = importlib.util.spec_from_file_location("paired_ratio", Path(__file__).parents[1] / "scripts" / "paired_ratio.py")
pr = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(pr)  # type: ignore[union-attr]

_FIELDS = ["success", "trip_time_s", "mass_kg", "controller", "observer", "seed"]


def _write(path: Path, rows: list[tuple[str, int, float, bool]]) -> Path:
    with path.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(_FIELDS)
        for controller, seed, trip_s, ok in rows:
            w.writerow([ok, trip_s, 30_000.0 if seed == 0 else 10_000.0, controller, "dffrls-aekf", seed])
    return path


def _mean_ratio(out: str) -> float:
    return float(out.split("mean ratio ")[1].split()[0])


def test_reference_from_another_file_pairs_the_same_controller_name(tmp_path, capsys):
    ref = _write(tmp_path / "ref.csv", [("rule-based", 0, 100.0, True), ("rule-based", 1, 200.0, True),
                                        ("rule-based", 2, 50.0, True)])
    other = _write(tmp_path / "other.csv", [("rule-based", 0, 110.0, True), ("rule-based", 1, 220.0, True),
                                            ("rule-based", 2, 1.0, False)])  # did not arrive: not paired
    assert pr.main([str(other), "--reference-from", str(ref), "--controllers", "rule-based"]) == 0
    out = capsys.readouterr().out
    assert "on 2 tracks both arrived" in out and "faster on 0/2" in out
    assert _mean_ratio(out) == pytest.approx(1.1)
    assert "trains above 28 t (1 tracks): mean ratio 1.100" in out


def test_without_reference_from_the_files_are_concatenated(tmp_path, capsys):
    a = _write(tmp_path / "a.csv", [("rule-based", 0, 100.0, True), ("rule-based", 1, 100.0, True)])
    b = _write(tmp_path / "b.csv", [("ppo", 0, 90.0, True), ("ppo", 1, 80.0, True)])
    assert pr.main([str(a), str(b), "--controllers", "ppo"]) == 0
    out = capsys.readouterr().out
    assert "faster on 2/2" in out and _mean_ratio(out) == pytest.approx(0.85)


def test_an_unknown_controller_is_named(tmp_path):
    a = _write(tmp_path / "a.csv", [("rule-based", 0, 100.0, True)])
    with pytest.raises(SystemExit, match="no episodes of controller 'ppo'"):
        pr.main([str(a), "--controllers", "ppo"])


def test_a_missing_episodes_file_is_named_before_anything_is_read(tmp_path, capsys):
    a = _write(tmp_path / "a.csv", [("rule-based", 0, 100.0, True)])
    with pytest.raises(SystemExit):
        pr.main([str(a), "--reference-from", str(tmp_path / "nope.csv"), "--controllers", "rule-based"])
    err = capsys.readouterr().err
    assert "no such episodes file" in err and "nope.csv" in err
