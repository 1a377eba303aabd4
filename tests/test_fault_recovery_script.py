"""``scripts/fault_recovery.py``: its seed list parser, and that its two criteria measure what they say."""

from __future__ import annotations

import argparse
import importlib.util
import math
from pathlib import Path

import pytest

_SPEC = importlib.util.spec_from_file_location(
    "fault_recovery", Path(__file__).parents[1] / "scripts" / "fault_recovery.py")
fault_recovery = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(fault_recovery)


def test_seed_lists() -> None:
    assert fault_recovery._seeds("3") == [3]
    assert fault_recovery._seeds("0-3") == [0, 1, 2, 3]
    assert fault_recovery._seeds("1,4-5") == [1, 4, 5]
    for bad in ("", "-1", "a", "3-1"):
        with pytest.raises((argparse.ArgumentTypeError, ValueError)):
            fault_recovery._seeds(bad)


def test_both_criteria_on_one_estimator() -> None:
    """Against the clean run the test's seed-3 values (``tests/test_estimators_faults.py`` bounds them); against the
    truth a dropout, after which ``rls`` holds its estimate, costs accuracy of the same order; an output without a
    truth on this trace is None, not NaN (a NaN would mean a non-finite output)."""
    vs_clean = fault_recovery.recovery("rls", 3, against_truth=False)
    vs_truth = fault_recovery.recovery("rls", 3, against_truth=True)
    assert set(vs_clean) == {"mass", "slope"} == set(vs_truth)
    for values in (vs_clean["mass"], vs_clean["slope"]):
        assert len(values) == len(fault_recovery.FAULTS) and all(v >= 0.0 for v in values)
    assert all(v is not None and math.isfinite(v) for v in vs_truth["mass"] + vs_truth["slope"])
    # an accuracy difference is at most the distance between the runs (triangle inequality, per sample)
    for k in ("mass", "slope"):
        for d_truth, d_clean in zip(vs_truth[k], vs_clean[k]):
            assert d_truth <= d_clean + 1e-9
    aupf = fault_recovery.recovery("aupf", 3, against_truth=True)
    assert all(v is None for v in aupf["slip_ratio"])
