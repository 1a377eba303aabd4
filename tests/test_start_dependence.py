"""``scripts/start_dependence.py``: logs that begin in motion, the measured-force share, and that the two
estimators the issue names keep their σ honest on a log without the start from rest."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from uuom_gym.sim.protocol_runs import make_run

_SPEC = importlib.util.spec_from_file_location(
    "start_dependence", Path(__file__).parents[1] / "scripts" / "start_dependence.py")
start_dependence = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(start_dependence)


def _scenario(name: str):
    return next(s for g, s in start_dependence.run_specs(0, 1) if s.scenario == name)


def test_run_set_is_the_protocols() -> None:
    specs = start_dependence.run_specs(3, 2)
    groups = [g for g, _ in specs]
    assert groups.count("plant") == groups.count("point") == 3
    assert groups.count("pm-scenarios") == 2 * 8  # eight point-mass scenarios, two sensor seeds
    assert len({s.name for _, s in specs}) == len(specs)


def test_measured_force_share_counts_traction_only() -> None:
    tr = make_run(_scenario("pm-heavy-downhill"))  # level at 0.5 m/s, then electric braking down 10 degrees
    share = start_dependence.measured_force_share(tr)
    t = tr["t_s"]
    braking = (tr["torque_nm"] < 0) & (t >= t[0] + 10.0)
    assert 0.0 < share < 1.0 - 0.9 * braking.mean()  # braking samples are not traction
    assert start_dependence.measured_force_share(make_run(_scenario("pm-steep-empty-climb"))) > 0.9


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_sigma_stays_honest_on_logs_begun_in_motion(name: str) -> None:
    """Without the pull-away a log at constant speed holds little about the mass; the estimate may be far off, but
    its σ must say so: on the eight point-mass scenarios begun 15 s in, the truth lies within ±2σ on at least 95 %
    of the samples and within 3σ throughout (measured: 100 % and max |z| < 3 for both)."""
    rows = [start_dependence.score(start_dependence.log_begun_at(make_run(s), 15.0), name)
            for g, s in start_dependence.run_specs(0, 1) if g == "pm-scenarios"]
    assert np.mean([r["within_2sd"] for r in rows]) >= 0.95
    assert max(r["max_z"] for r in rows) <= 3.0
    assert all(np.isfinite(r["mass_max"]) and np.isfinite(r["slope_rmse"]) for r in rows)


def test_report_and_command_line(tmp_path, capsys) -> None:
    out = tmp_path / "r.md"
    assert start_dependence.main(["--runs", "1", "--scenario-seeds", "0", "--starts", "0", "20",
                                  "--estimators", "dffrls-aekf", "--workers", "1", "--out", str(out)]) == 0
    text = out.read_text()
    assert "| `dffrls-aekf` | plant | rest (t = 0) | 1 |" in text and "| `dffrls-aekf` | point | 20 s | 1 |" in text
    assert "Measured drive force" in text and capsys.readouterr().out.startswith(text)
    for bad in (["--starts", "55"], ["--estimators", "nope"], ["--runs", "-1"]):
        with pytest.raises(SystemExit):
            start_dependence.main(bad)
