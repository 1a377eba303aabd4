"""scripts/fault_breakdown.py: the point-mass fault trace taken apart, one fault kind and channel at a time."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

_SPEC = importlib.util.spec_from_file_location(
    "fault_breakdown", Path(__file__).parents[1] / "scripts" / "fault_breakdown.py")
fb = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(fb)  # type: ignore[union-attr]


def test_each_variant_keeps_the_road_test_and_adds_only_its_fault() -> None:
    none = fb.variant_trace("none", 2)
    speed_drops = fb.variant_trace("drop:speed_mps", 2)
    accel_spikes = fb.variant_trace("spike:accel_mps2", 2)
    for c in ("torque_nm", "accel_mps2"):  # the other channels are the fault-free ones, sample for sample
        np.testing.assert_array_equal(speed_drops[c], none[c])
    missing = np.isnan(speed_drops["speed_mps"])
    assert 0.01 < missing.mean() < 0.03 and not np.isnan(none["speed_mps"]).any()
    np.testing.assert_array_equal(speed_drops["speed_mps"][~missing], none["speed_mps"][~missing])
    jumps = np.abs(accel_spikes["accel_mps2"] - none["accel_mps2"])
    assert 0 < np.count_nonzero(jumps) < 0.005 * len(jumps) and np.allclose(jumps[jumps > 0], 4.0)
    np.testing.assert_array_equal(accel_spikes["torque_nm"], none["torque_nm"])
    assert set(fb.variants()) >= {"none", "stuck", "all"}


def test_bad_arguments_are_refused_before_any_run(capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        fb.main(["--seeds", "0"])
    assert exc.value.code == 2 and "--seeds must be >= 1" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        fb.main(["--protocol-fault", "lightning"])
