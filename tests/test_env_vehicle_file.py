"""The env's ``vehicle`` config key takes the path of a TOML vehicle file (the trace format's ``[vehicle]`` table)."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import pytest

import uuom_gym  # noqa: F401  (registers the env ids)
from uuom_core.vehicle import DEFAULT_VEHICLE, VehicleParams
from uuom_gym.envs.config import ConfigError


def _file(tmp_path: Path, text: str) -> Path:
    p = tmp_path / "vehicle.toml"
    p.write_text(text)
    return p


@pytest.mark.parametrize("as_str", [True, False])
def test_a_vehicle_file_is_the_env_vehicle(tmp_path: Path, as_str: bool) -> None:
    p = _file(tmp_path, "[vehicle]\nempty_mass_kg = 18000\nrated_load_kg = 22000\n")
    env = gym.make("UUOM-Track-v0", vehicle=str(p) if as_str else p)
    v = env.unwrapped.vehicle
    assert v == VehicleParams.from_toml(p) and v.empty_mass_kg == 18000.0
    assert v.length_m == DEFAULT_VEHICLE.length_m  # the keys a file leaves out keep their defaults
    obs, info = env.reset(seed=0)
    assert info["true_mass_kg"] >= 18000.0
    env.close()


@pytest.mark.parametrize("text, word", [(None, "no such vehicle file"), ("[vehicle\n", "not valid TOML"),
                                        ("[vehicle]\nempty_mass_kg = -1\n", "empty_mass_kg"),
                                        ("[vehicle]\nwheels = 4\n", "wheels")])
def test_a_bad_vehicle_file_is_a_config_error_naming_it(tmp_path: Path, text: str | None, word: str) -> None:
    p = tmp_path / "missing.toml" if text is None else _file(tmp_path, text)
    with pytest.raises(ConfigError, match=word) as exc:
        gym.make("UUOM-Track-v0", vehicle=str(p))
    assert "vehicle" in str(exc.value) and p.name in str(exc.value)
