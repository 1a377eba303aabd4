"""scripts/trip_anatomy.py: the state at each overspeed trip, replayed on the evaluation's tracks (docs/rl.md §28)."""

from __future__ import annotations

import csv
import importlib.util
from pathlib import Path

import pytest

_SPEC = importlib.util.spec_from_file_location("trip_anatomy", Path(__file__).parents[1] / "scripts" / "trip_anatomy.py")
ta = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(ta)  # type: ignore[union-attr]


def test_full_throttle_trips_on_the_prior_and_writes_its_rows(tmp_path, capsys):
    out_csv = tmp_path / "trips.csv"
    assert ta.main(["--controller", "full-throttle", "--episodes", "2", "--csv", str(out_csv)]) == 0
    out = capsys.readouterr().out
    assert "2 overspeed trips in 2 episodes" in out
    # full traction from rest passes the limit within a second, long before the estimator has seen enough motion
    assert "on the prior (mass std still >= 90% of its start value): 2" in out
    with open(out_csv, newline="") as fh:
        rows = list(csv.DictReader(fh))
    assert [int(r["seed"]) for r in sorted(rows, key=lambda r: r["seed"])] == [100000, 100001]
    for r in rows:
        assert float(r["speed_mps"]) > float(r["true_limit_mps"]) + 0.19  # the trip margin, 0.2 m/s
        assert float(r["t_s"]) < 2.0
        assert float(r["first_over_cautious_s"]) <= float(r["t_s"])


def test_episodes_csv_replays_only_the_trips_it_lists(tmp_path, capsys):
    episodes = tmp_path / "episodes.csv"
    with open(episodes, "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["controller", "observer", "seed", "termination"])
        w.writerow(["full-throttle", "dffrls-aekf", 100001, "overspeed_trip"])
        w.writerow(["full-throttle", "dffrls-aekf", 100002, "arrived"])  # not replayed
        w.writerow(["full-throttle", "oracle", 100003, "overspeed_trip"])  # another observer: not replayed
    assert ta.main(["--controller", "full-throttle", "--episodes-csv", str(episodes)]) == 0
    out = capsys.readouterr().out
    assert "1 overspeed trips in 1 episodes" in out and "| 100001 |" in out and "| 100003 |" not in out


def test_episodes_csv_without_the_controller_is_named(tmp_path):
    episodes = tmp_path / "episodes.csv"
    episodes.write_text("controller,observer,seed,termination\nrule-based,dffrls-aekf,100000,arrived\n")
    with pytest.raises(SystemExit, match="no rows of controller 'full-throttle'"):
        ta.main(["--controller", "full-throttle", "--episodes-csv", str(episodes)])


@pytest.mark.parametrize("argv", [["--env-kwargs", "[1]"], ["--env-kwargs", "{oops"], ["--episodes", "0"]])
def test_bad_arguments_are_usage_errors(argv, capsys):
    with pytest.raises(SystemExit) as exc:
        ta.main(["--controller", "full-throttle", *argv])
    assert exc.value.code == 2
    assert "--env-kwargs" in capsys.readouterr().err or "--episodes" in " ".join(argv)


def test_summary_without_trips():
    assert ta.summary_lines([{"tripped": False}], 1) == ["1 episodes, no overspeed trip"]


def test_unknown_controller_is_a_usage_error(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        ta.main(["--controller", str(tmp_path / "no_such_run")])
    assert exc.value.code == 2 and "neither one of" in capsys.readouterr().err


def test_summary_says_when_the_observer_has_no_prior():
    trip = {"tripped": True, "t_s": 1.0, "std_share_of_prior": float("nan"), "first_over_cautious_s": 0.5,
            "true_mass_t": 35.0, "speed_mps": 0.75, "est_limit_mps": 0.8}
    lines = ta.summary_lines([trip], 1)
    assert "no mass uncertainty at the start" in lines[1]
    assert lines[3].endswith("drove past what it was told): 0; at or below it (the estimate's limit was too high): 1")
