"""The committed estimation results are this tree's: every estimator's cells of the point-mass scenarios in
``results/estimation/summary.md`` (the table the README's scenario figures come from) are recomputed with the
protocol's own scoring and must print the same.

Why: the protocol caches rows by source fingerprint and its summary names the fingerprints, but nothing failed when
an estimator changed and the tables were not re-run. Comparing values, not fingerprints, lets a comment edit pass
and any change of behaviour fail; the fix is ``python scripts/estimator_protocol.py --workers 2`` (cached rows of
unchanged estimators are reused). Eight 100-120 s traces, about 30 s of CPU for all estimators.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from estimators.protocol import score_trace
from uuom_gym.sim.protocol_runs import make_run, protocol_runs

SUMMARY = Path(__file__).resolve().parents[1] / "results" / "estimation" / "summary.md"
_CELL = re.compile(r"^(–|[-\d.]+) % / ([-\d.]+)°$")


def _scenario_table() -> tuple[list[str], dict[str, list[str]]]:
    """Scenario names and, per estimator, the printed cells of the fixed-scenario table."""
    lines = SUMMARY.read_text(encoding="utf-8").splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith("## Fixed scenarios"))
    header = next(ln for ln in lines[start:] if ln.startswith("| estimator |"))
    scenarios = [c.strip().strip("`") for c in header.strip("|").split("|")[1:]]
    rows: dict[str, list[str]] = {}
    for ln in lines[lines.index(header) + 2:]:
        if not ln.startswith("| `"):
            break
        cells = [c.strip() for c in ln.strip("|").split("|")]
        rows[cells[0].strip("`")] = cells[1:]
    return scenarios, rows


SCENARIOS, ROWS = _scenario_table()


@pytest.fixture(scope="module")
def point_mass_traces():
    specs = [s for s in protocol_runs(0, 0) if s.group == "paper" and s.world == "point"]
    return {s.scenario: make_run(s) for s in specs}


def test_the_table_holds_every_point_mass_scenario(point_mass_traces):
    assert set(point_mass_traces) <= set(SCENARIOS), "summary.md lacks a point-mass scenario: re-run the protocol"
    assert {"dffrls-aekf", "fused", "sf-kf", "dffrls-aekf-paper"} <= set(ROWS)


@pytest.mark.parametrize("name", sorted(ROWS))
def test_point_mass_scenario_cells_are_reproduced(name, point_mass_traces):
    stale = f"results/estimation/summary.md is stale for {name}: run python scripts/estimator_protocol.py --workers 2"
    for scenario, trace in point_mass_traces.items():
        printed = ROWS[name][SCENARIOS.index(scenario)]
        m = _CELL.match(printed)
        assert m, (name, scenario, printed)
        row = score_trace(trace, name)
        mass = "–" if not row["provides_mass"] else f"{row['mass_max_pct']:.1f}"
        slope = f"{row['slope_train_rmse_deg']:.2f}"
        assert (mass, slope) == (m.group(1), m.group(2)), (stale, scenario, (mass, slope), printed)
