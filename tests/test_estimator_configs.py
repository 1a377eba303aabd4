"""The frozen, validated tuning dataclasses of ``mmae`` and ``aupf`` (issue 9) and how options reach them."""

from __future__ import annotations

import dataclasses
import math

import pytest

import estimators
from estimators.aupf import AUPFConfig, AUPFConfigError, AUPFEstimator
from estimators.mmae import MMAEConfig, MMAEConfigError, MMAEEstimator


@pytest.mark.parametrize("config_type", [MMAEConfig, AUPFConfig])
def test_configs_are_frozen_and_documented(config_type: type) -> None:
    cfg = config_type()
    first = dataclasses.fields(config_type)[0].name
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(cfg, first, 3)
    doc = config_type.__doc__ or ""
    for field in dataclasses.fields(config_type):
        assert field.name in doc, f"{config_type.__name__}.{field.name} is not documented"


@pytest.mark.parametrize("config_type, error, field, value", [
    (MMAEConfig, MMAEConfigError, "n_models", 1),
    (MMAEConfig, MMAEConfigError, "gate_nis", math.inf),
    (MMAEConfig, MMAEConfigError, "front_mass_fraction", 1.5),
    (MMAEConfig, MMAEConfigError, "running_resistance", 1.0),
    (AUPFConfig, AUPFConfigError, "n_particles", True),
    (AUPFConfig, AUPFConfigError, "radius_model_std_m", -1.0),
    (AUPFConfig, AUPFConfigError, "resample_ess_fraction", 1.5),
])
def test_config_rejects_bad_values_naming_the_field(config_type: type, error: type, field: str, value: object) -> None:
    with pytest.raises(error, match=field):
        config_type(**{field: value})


def test_options_override_a_config_and_unknown_names_are_rejected() -> None:
    base = MMAEConfig(n_models=12, rear_offset_m=0.0)
    est = MMAEEstimator(config=base, n_models=20)
    assert est.config.n_models == 20 and est.config.rear_offset_m == 0.0 and base.n_models == 12
    assert len(est.payloads_kg) == 20
    assert estimators.make("aupf", config=AUPFConfig(n_particles=8)).n_particles == 8
    with pytest.raises(TypeError, match="bogus"):
        AUPFEstimator(config=AUPFConfig(), bogus=1)
    with pytest.raises(TypeError, match="MMAEConfig"):
        MMAEEstimator(config=AUPFConfig())  # type: ignore[arg-type]


def test_same_config_same_results() -> None:
    rows = [(8000.0, 1.0, 0.5, 0.005)] * 50
    a = MMAEEstimator(n_models=10)
    b = MMAEEstimator(config=MMAEConfig(n_models=10))
    for row in rows:
        ea, eb = a.update(*row), b.update(*row)
    assert ea == eb
