"""The estimators' load-swing model takes the chain length and hook mass from the vehicle file unless the estimator's
options say otherwise (before session 10 they were fixed at 2 m / 300 kg whatever the file said)."""

from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

import estimators
from estimators import dffrls_aekf_kernel as kern
from estimators.cli import main as estimate_main
from uuom_core.vehicle import DEFAULT_VEHICLE
from uuom_gym.sim.point_mass import simulate_point_mass

LONG_CHAIN = dataclasses.replace(DEFAULT_VEHICLE, chain_length_m=2.5, hook_mass_kg=500.0)


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_kernel_settings_follow_the_vehicle(name: str) -> None:
    est = estimators.make(name, vehicle=LONG_CHAIN, train_length_m=12.0) if name == "dffrls-aekf" else \
        estimators.make(name, vehicle=LONG_CHAIN)
    C = est.single.C if name == "dffrls-aekf" else est.C
    assert C[kern.CHAIN_L] == 2.5
    assert C[kern.M_RIGID] == LONG_CHAIN.empty_mass_kg - 500.0
    told = estimators.make(name, vehicle=LONG_CHAIN, chain_length_m=1.5, hook_mass_kg=0.0,
                           **({"train_length_m": 12.0} if name == "dffrls-aekf" else {}))
    C2 = told.single.C if name == "dffrls-aekf" else told.C
    assert C2[kern.CHAIN_L] == 1.5 and C2[kern.M_RIGID] == LONG_CHAIN.empty_mass_kg  # the options win


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused", "dffrls", "sf-kf"])
def test_a_file_that_states_the_chain_equals_the_option(name: str) -> None:
    tr = simulate_point_mass("pm-section1", seed=0)  # its load hangs on 2.5 m
    from_file = estimators.make(name, vehicle=LONG_CHAIN).run(tr)
    from_option = estimators.make(name, vehicle=dataclasses.replace(LONG_CHAIN, chain_length_m=2.0),
                                  chain_length_m=2.5).run(tr)
    np.testing.assert_array_equal(from_file.mass_kg, from_option.mass_kg)
    default = estimators.make(name, vehicle=dataclasses.replace(LONG_CHAIN, chain_length_m=2.0)).run(tr)
    assert not np.array_equal(from_file.mass_kg, default.mass_kg)


def test_uuom_estimate_reads_the_chain_from_the_vehicle_file(tmp_path, capsys) -> None:
    tr = simulate_point_mass("pm-section1", seed=0)
    csv = tmp_path / "t.csv"
    cols = ["t_s", "torque_nm", "speed_mps", "accel_mps2", "mass_kg", "slope_deg"]
    np.savetxt(csv, np.column_stack([tr[c] for c in cols]), delimiter=",", header=",".join(cols), comments="")
    toml = tmp_path / "v.toml"
    results = {}
    for chain in (2.0, 2.5):
        toml.write_text(f"[vehicle]\nchain_length_m = {chain}\n")
        assert estimate_main([str(csv), "--vehicle", str(toml), "--estimator", "dffrls-aekf",
                              "--out", str(tmp_path / "o.csv"), "--json"]) == 0
        results[chain] = json.loads(capsys.readouterr().out)
    assert results[2.0] != results[2.5]


@pytest.mark.parametrize("options, match", [
    ({"chain_length_m": -1.0}, "chain_length_m"),
    ({"chain_length_m": float("nan")}, "chain_length_m"),
    ({"hook_mass_kg": -5.0}, "hook_mass_kg"),
    ({"hook_mass_kg": 1e9}, "hook_mass_kg"),
])
@pytest.mark.parametrize("name", ["dffrls-aekf", "dffrls", "sf-kf"])
def test_bad_swing_options_are_named(name: str, options: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        estimators.make(name, **options)
