"""Tests of the running-resistance calibration (spec §5.2)."""

from __future__ import annotations

import numpy as np
import pytest

from estimators.mu_identification import MuIdentificationError, identify_running_resistance
from uuom_core.synthetic import synthetic_trace
from uuom_core.trace import Trace


@pytest.mark.parametrize("mu", [0.01, 0.02, 0.04])
def test_recovers_mu_on_unit_signal(mu: float) -> None:
    tr = synthetic_trace("section1", seed=4, running_resistance=mu, mass_kg=28_000.0, duration_s=40.0)
    r = identify_running_resistance(tr)
    assert abs(r.mu - mu) < 1e-3
    assert abs(r.mu_final - mu) < 2e-3
    assert r.n_used > 1000
    assert np.all(np.isfinite(r.history[~np.isnan(r.history)]))


def test_known_values_override_columns() -> None:
    tr = synthetic_trace("level", seed=4, running_resistance=0.03, mass_kg=20_000.0, duration_s=30.0)
    cols = {k: v for k, v in tr.columns.items() if k not in ("mass_kg", "slope_deg")}
    bare = Trace(cols, source="bare")
    with pytest.raises(MuIdentificationError, match="mass_kg"):
        identify_running_resistance(bare)
    r = identify_running_resistance(bare, mass_kg=20_000.0, slope_rad=0.0)
    assert abs(r.mu - 0.03) < 1e-3


def test_too_few_samples_and_bad_options() -> None:
    tr = synthetic_trace("level", seed=4, duration_s=1.0)
    with pytest.raises(MuIdentificationError, match="usable samples"):
        identify_running_resistance(tr)
    with pytest.raises(ValueError, match="delta"):
        identify_running_resistance(tr, delta=1.0)
    with pytest.raises(ValueError, match="sigma"):
        identify_running_resistance(tr, sigma=0.0)


def test_recovers_plant_running_resistance() -> None:
    """On the pymunk plant (model mismatch: swinging load, couplers, wheel inertia), on a surveyed constant grade."""
    from uuom_gym.sim import recording
    from uuom_gym.sim.plant import PlantConfig
    from uuom_gym.sim.track import profile_from_knots

    for mu, grade_deg in ((0.015, 0.0), (0.03, 4.0)):
        track = profile_from_knots([(0.0, grade_deg), (400.0, grade_deg)])
        tr = recording.simulate_run(track, seed=1, load_kg=10_000.0, duration_s=40.0,
                                    plant_config=PlantConfig(running_resistance=mu))
        r = identify_running_resistance(tr)
        assert abs(r.mu - mu) < 0.15 * mu, (mu, r.mu)
