"""The NIS consistency test (no truth needed) and the speed innovations of the compiled two-layer estimators."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.metrics import nis_consistency
from estimators.protocol import score_trace
from estimators.registry import make
from uuom_gym.sim.protocol_runs import RunSpec, make_run


def test_nis_band_accepts_chi2_and_rejects_a_filter_four_times_too_sure():
    rng = np.random.default_rng(0)
    t = np.arange(0.0, 200.0, 0.005)
    good = rng.standard_normal(t.size) ** 2
    good[::7] = np.nan  # samples without a correction are skipped
    mean, lo, hi, inside, n = nis_consistency(t, good, 10.0)
    assert inside and lo < 1.0 < hi and n == 190 and abs(mean - 1.0) < 0.3
    assert not nis_consistency(t, 4.0 * good, 10.0)[3]
    assert not nis_consistency(t, 0.25 * good, 10.0)[3]
    assert nis_consistency(t, np.full(t.size, np.nan), 10.0) is None


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_speed_nis_reported_and_scored(name):
    tr = make_run(RunSpec("point", "point-002", 2, 2, "point", duration_s=40.0))
    s = make(name).run(tr)
    nis = s.extras["nis"]
    assert nis.shape == s.mass_kg.shape and np.mean(np.isfinite(nis)) > 0.9 and np.nanmin(nis) >= 0.0
    row = score_trace(tr, name)
    assert 0.3 < row["speed_nis"] < 3.0 and isinstance(row["speed_nis_in_band"], bool)
    # an estimator without innovations gets no NIS
    assert np.isnan(score_trace(tr, "rls")["speed_nis"])
