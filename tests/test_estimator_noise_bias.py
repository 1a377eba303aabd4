"""scripts/estimator_noise_bias.py: the signed mass error on the point-mass scenarios with scaled sensors."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

_SPEC = importlib.util.spec_from_file_location(
    "estimator_noise_bias", Path(__file__).parents[1] / "scripts" / "estimator_noise_bias.py")
nb = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(nb)  # type: ignore[union-attr]


def test_one_run_gives_signed_errors_and_the_max():
    row = nb.signed_errors(("pm-steep-empty-climb", 0, 1.0, {}, "dffrls-aekf", {}))
    assert len(row) == len(nb.TIMES_S) + 1
    assert row[-1] >= max(abs(x) for x in row[:-1] if x == x) - 1e-9  # the max |error| bounds every signed one
    assert row[-1] < 5.0  # the empty climb: the estimator's best scenario (1 % on the protocol's seed)


def test_a_field_factor_changes_that_sensor_only():
    # perfect sensors but speed noise: the run differs from perfect sensors alone
    clean = nb.signed_errors(("pm-section1", 1, 0.0, {}, "dffrls-aekf", {}))
    same = nb.signed_errors(("pm-section1", 1, 0.0, {"speed_noise_std_mps": 3.0}, "dffrls-aekf", {}))
    assert clean == same  # 3 x 0 is still perfect
    noisy = nb.signed_errors(("pm-section1", 1, 1.0, {"speed_noise_std_mps": 3.0}, "dffrls-aekf", {}))
    assert noisy != nb.signed_errors(("pm-section1", 1, 1.0, {}, "dffrls-aekf", {}))


def test_main_prints_one_summary_line(capsys):
    assert nb.main(["--scenarios", "pm-steep-empty-climb", "--seeds", "1", "--workers", "1"]) == 0
    out = capsys.readouterr().out
    assert "1 runs: signed mass error % at 10 / 30 / 59 s mean" in out and "below the truth at 30 s" in out


@pytest.mark.parametrize("argv, match", [
    (["--scale-fields", '{"no_such": 2}'], "unknown sensor field"),
    (["--scale-fields", '{"speed_noise_std_mps": -1}'], "finite number >= 0"),
    (["--scale-fields", "[1]"], "JSON objects"),
    (["--options", "{bad"], "JSON objects"),
    (["--scenarios", "pm-nowhere"], "unknown scenario"),
    (["--sensor-scale", "nan"], "sensor-scale"),
    (["--seeds", "0"], "--seeds"),
])
def test_bad_arguments_are_named_before_any_run(argv, match, capsys):
    with pytest.raises(SystemExit) as exc:
        nb.main(argv + ["--workers", "1"])
    assert exc.value.code == 2 and match in capsys.readouterr().err


def test_unknown_estimator_is_refused_before_any_run():
    with pytest.raises(Exception, match="no-such"):
        nb.main(["--estimator", "no-such", "--workers", "1"])


def test_encoder_noise_is_read_from_the_differences():
    import numpy as np

    rng = np.random.default_rng(0)
    v = np.linspace(0.0, 1.0, 20000) + rng.normal(0.0, 0.01, 20000)
    v[::97] = np.nan  # dropouts do not spoil it
    assert nb.encoder_noise_mps(v) == pytest.approx(0.01, rel=0.05)


def test_tuning_runs_report(capsys):
    assert nb.main(["--tuning-runs", "2", "--world", "point", "--workers", "1"]) == 0
    out = capsys.readouterr().out
    assert "point runs 1000-1001: signed mass error % at 30 s mean" in out and "below / above its median" in out
