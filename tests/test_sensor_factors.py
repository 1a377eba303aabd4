"""uuom_gym.sim.sensor_factors: the point-mass sensors' imperfections scaled one by one."""

from __future__ import annotations

import math

import pytest

from uuom_gym.sim.point_mass import PointMassSensors
from uuom_gym.sim.sensor_factors import scale_sensor_fields


def test_only_the_named_fields_change():
    base = PointMassSensors()
    out = scale_sensor_fields(base, {"speed_noise_std_mps": 3.0, "accel_noise_std_mps2": 0.0})
    assert out.speed_noise_std_mps == 3.0 * base.speed_noise_std_mps
    assert out.accel_noise_std_mps2 == 0.0
    assert out.torque_noise_std_nm == base.torque_noise_std_nm and out.speed_resolution_mps == base.speed_resolution_mps
    assert scale_sensor_fields(base, {}) == base


@pytest.mark.parametrize("factors, match", [
    ({"no_such": 2.0}, "unknown sensor field"),
    ({"speed_noise_std_mps": -1.0}, "finite number >= 0"),
    ({"speed_noise_std_mps": math.nan}, "finite number >= 0"),
    ({"speed_noise_std_mps": math.inf}, "finite number >= 0"),
    ({"speed_noise_std_mps": True}, "finite number >= 0"),
    ({"speed_noise_std_mps": "3"}, "finite number >= 0"),
])
def test_bad_names_and_factors_are_refused(factors, match):
    with pytest.raises(ValueError, match=match):
        scale_sensor_fields(PointMassSensors(), factors)
