"""The protocol's random runs on another vehicle (``make_run(spec, vehicle)``, ``score_trace(..., vehicle=)``), the
ground of ``scripts/estimator_vehicle_shift.py``."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.protocol import score_trace
from uuom_core.vehicle import DEFAULT_VEHICLE
from uuom_core.vehicle_variants import sister_vehicles
from uuom_gym.sim.protocol_runs import make_run, protocol_runs

SPECS = {s.world: s for s in protocol_runs(1, 1, paper_seeds=0, fault_seeds=0)}
SISTER = sister_vehicles(0, 1, 1.5)[0]


@pytest.mark.parametrize("world", ["plant", "point"])
def test_the_project_vehicle_given_explicitly_is_the_same_run(world: str) -> None:
    a, b = make_run(SPECS[world]), make_run(SPECS[world], DEFAULT_VEHICLE)
    assert a.columns.keys() == b.columns.keys()
    for c in a.columns:
        assert np.array_equal(a[c], b[c], equal_nan=True), c


@pytest.mark.parametrize("world", ["plant", "point"])
def test_a_sister_vehicle_changes_the_run_within_its_own_limits(world: str) -> None:
    base, other = make_run(SPECS[world]), make_run(SPECS[world], SISTER)
    load = float(other["mass_kg"][0]) - SISTER.empty_mass_kg
    assert 0.0 <= load <= SISTER.rated_load_kg + 1.0
    assert not np.array_equal(base["mass_kg"], other["mass_kg"])
    # the same draws: the load is the same fraction of the rated load
    frac = (float(base["mass_kg"][0]) - DEFAULT_VEHICLE.empty_mass_kg) / DEFAULT_VEHICLE.rated_load_kg
    assert load / SISTER.rated_load_kg == pytest.approx(frac, rel=1e-9)
    assert float(other.meta["chain_m"]) / float(base.meta["chain_m"]) == pytest.approx(
        SISTER.chain_length_m / DEFAULT_VEHICLE.chain_length_m, rel=1e-3)
    row = score_trace(other, "dffrls-aekf", vehicle=SISTER)
    assert row["finite"] and np.isfinite(row["mass_max_pct"])


def test_a_fixed_scenario_refuses_another_vehicle() -> None:
    spec = [s for s in protocol_runs(0, 0, paper_seeds=1, fault_seeds=0) if s.world == "point"][0]
    with pytest.raises(ValueError, match="random runs"):
        make_run(spec, SISTER)


def _script(*args: str, tmp_path) -> "subprocess.CompletedProcess[str]":
    import subprocess
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    return subprocess.run([sys.executable, str(root / "scripts/estimator_vehicle_shift.py"), *args],
                          capture_output=True, text=True, cwd=root, timeout=300)


def test_the_script_writes_its_table(tmp_path) -> None:
    out = tmp_path / "t.md"
    p = _script("--vehicles", "1", "--runs", "1", "--workers", "1", "--estimators", "rls", "--out", str(out),
                tmp_path=tmp_path)
    assert p.returncode == 0, p.stderr
    text = out.read_text()
    assert "| plant | `rls` | the project's | 1 |" in text and "| point | `rls` | sisters, pooled | 1 |" in text


@pytest.mark.parametrize("args, word", [(["--estimators", "nope"], "nope"), (["--spread", "0.5"], "spread"),
                                        (["--runs", "0"], "--runs")])
def test_the_script_names_bad_input(args: list[str], word: str, tmp_path) -> None:
    p = _script(*args, tmp_path=tmp_path)
    assert p.returncode == 2 and word in p.stderr, p.stderr
