"""scripts/regressor_noise.py: a sensor's noise in the mass regression, from twin runs with the same draws."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

_SPEC = importlib.util.spec_from_file_location(
    "regressor_noise", Path(__file__).parents[1] / "scripts" / "regressor_noise.py")
rn = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(rn)  # type: ignore[union-attr]

_ENCODER_X3 = {"speed_noise_std_mps": 3.0, "speed_resolution_mps": 3.0}


def test_twin_runs_differ_only_by_the_named_noise():
    # factor 0: the "noisy" run has no encoder noise either, so the twins are the same run and carry no difference
    same = rn.compare(("pm-steep-empty-climb", 0, {"speed_noise_std_mps": 0.0, "speed_resolution_mps": 0.0}, 0.0, {}))
    assert same[:4] == [0.0, 0.0, 0.0, 0.0] and same[4] == same[5]
    noisy = rn.compare(("pm-steep-empty-climb", 0, _ENCODER_X3, 0.0, {}))
    dh2, dal2, da2, _, err_noisy, err_quiet = noisy
    assert dh2 > 0.0 and dal2 > 0.0 and da2 > 0.0
    assert err_noisy != err_quiet and all(np.isfinite(noisy))


def test_the_signals_are_the_mass_layers_inputs():
    from uuom_gym.sim.point_mass import POINT_MASS_SCENARIOS, simulate_point_mass

    tr = simulate_point_mass(POINT_MASS_SCENARIOS["pm-steep-empty-climb"], seed=0)
    sig, mass = rn.regression_signals(tr, 0.0, {})
    ran = np.isfinite(sig[:, 0])
    assert 0 < ran.sum() < len(tr["t_s"])  # not before the train moves, then on most samples of the climb
    assert np.all(np.isfinite(mass))
    # the same filter run as a batch gives the same mass: the twin runs step the real estimator, not a copy of it
    import estimators

    batch = estimators.make("dffrls-aekf", train_length_m=0.0).run(tr).mass_kg
    np.testing.assert_allclose(mass, batch, rtol=1e-12)


@pytest.mark.parametrize("argv, match", [
    (["--scale-fields", '{"no_such": 2}'], "unknown sensor field"),
    (["--scale-fields", "{}"], "non-empty"),
    (["--scale-fields", '{"speed_noise_std_mps": -1}'], "finite number >= 0"),
    (["--scenarios", "pm-nowhere"], "unknown scenario"),
    (["--seeds", "0"], "--seeds"),
    (["--options", '{"accel_regressor": true}'], "regression's form"),
    (["--options", '{"estimate_mu": false}'], "regression's form"),
])
def test_bad_arguments_are_refused(argv, match, capsys):
    with pytest.raises(SystemExit):
        rn.main(argv)
    assert match in capsys.readouterr().err
