"""Fixtures shared by the test files."""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
import pytest

from uuom_core.trace import Trace


def _drop_samples(trace: Trace, names: Iterable[str], seed: int, fraction: float = 0.2) -> Trace:
    """Make a seeded random ``fraction`` of each named column missing (NaN), in place; returns ``trace``."""
    rng = np.random.default_rng(seed)
    for name in names:
        col = trace[name].copy()
        col[rng.random(len(col)) < fraction] = np.nan
        trace.columns[name] = col
    return trace


@pytest.fixture
def drop_samples():
    """``drop_samples(trace, names, seed, fraction=0.2)``: dropouts in the named columns of a trace, in place."""
    return _drop_samples
