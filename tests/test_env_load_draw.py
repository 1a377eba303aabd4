"""``load_fraction_beta``: a training curriculum that draws heavy trains more often (docs/rl.md §38)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from stable_baselines3.common.env_checker import check_env as sb3_check_env

import uuom_gym  # noqa: F401 - registers the env
from uuom_gym.envs._plant_adapter import draw_conditions
from uuom_gym.envs.config import ConfigError, make_config
from uuom_core.vehicle import VehicleParams


def _fractions(beta, n: int = 400, load_range=(0.0, 1.0), share: float = 0.0) -> np.ndarray:
    """Load fractions of ``n`` condition draws, one generator per seed (as ``reset(seed=s)`` makes)."""
    cfg = make_config({"load_fraction_beta": beta, "load_fraction_range": load_range,
                       "load_fraction_uniform_share": share})
    vehicle = VehicleParams()
    return np.array([
        draw_conditions(cfg, vehicle, np.random.default_rng(s)).load_kg / vehicle.rated_load_kg for s in range(n)
    ])


def test_default_keeps_the_uniform_draw_of_earlier_revisions():
    """None is one uniform draw from the generator, the draw every earlier revision made (shipped seeds unchanged)."""
    cfg = make_config({})
    vehicle = VehicleParams()
    for seed in range(5):
        want = np.random.default_rng(seed).uniform(*cfg["load_fraction_range"]) * vehicle.rated_load_kg
        got = draw_conditions(cfg, vehicle, np.random.default_rng(seed)).load_kg
        assert got == pytest.approx(want, rel=0, abs=1e-9)


def test_beta_weights_heavy_trains_within_the_range():
    uniform, heavy = _fractions(None), _fractions((2.0, 1.0))
    # Beta(2, 1) has mean 2/3 and P(x > 0.86) = 1 - 0.86^2 = 0.26, against 0.5 and 0.14 uniform.
    assert heavy.mean() == pytest.approx(2 / 3, abs=0.04)
    assert uniform.mean() == pytest.approx(0.5, abs=0.04)
    assert (heavy > 0.86).mean() > 1.5 * (uniform > 0.86).mean()
    narrow = _fractions((2.0, 1.0), n=100, load_range=(0.5, 0.8))
    assert narrow.min() >= 0.5 and narrow.max() <= 0.8


def test_same_seed_same_heavy_episode():
    loads = []
    for _ in range(2):
        env = gym.make("UUOM-Track-v0", load_fraction_beta=(2.0, 1.0))
        env.reset(seed=11)
        loads.append(env.unwrapped.conditions.load_kg)
        env.close()
    assert loads[0] == loads[1]


@pytest.mark.parametrize("bad", [(0.0, 1.0), (2.0,), "heavy", (2.0, float("nan")), (1.0, -1.0)])
def test_bad_values_are_named(bad):
    with pytest.raises(ConfigError, match="load_fraction_beta"):
        make_config({"load_fraction_beta": bad})


def test_env_checkers_pass():
    env = gym.make("UUOM-Track-v0", load_fraction_beta=(2.0, 1.0), track_length_m=(50.0, 80.0))
    check_env(env.unwrapped, skip_render_check=True)
    sb3_check_env(env.unwrapped, warn=False)
    env.close()


def test_uniform_share_mixes_the_two_draws():
    """``load_fraction_uniform_share``: a mixture that keeps light trains (docs/rl.md §39)."""
    mixed = _fractions((2.0, 1.0), n=2000, share=0.5)
    pure, uniform = _fractions((2.0, 1.0), n=2000), _fractions(None, n=2000)
    # Density 0.5 + x: mean 7/12, P(x < 0.2) = 0.12 (Beta(2, 1): 0.04, uniform: 0.2).
    assert mixed.mean() == pytest.approx(7 / 12, abs=0.03)
    assert (pure < 0.2).mean() < (mixed < 0.2).mean() < (uniform < 0.2).mean()
    assert (mixed < 0.2).mean() == pytest.approx(0.12, abs=0.025)
    assert (mixed > 0.85).mean() > (uniform > 0.85).mean()


def test_zero_share_is_the_pure_beta_draw():
    """The default share 0 draws what rev. 19 drew (the shipped heavy-load policies' training episodes)."""
    a = _fractions((2.0, 1.0), n=20, share=0.0)
    want = [np.random.default_rng(s).beta(2.0, 1.0) for s in range(20)]
    np.testing.assert_allclose(a, want, rtol=0, atol=1e-12)


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"load_fraction_beta": (2.0, 1.0), "load_fraction_uniform_share": 1.5}, "load_fraction_uniform_share"),
        ({"load_fraction_beta": (2.0, 1.0), "load_fraction_uniform_share": float("nan")},
         "load_fraction_uniform_share"),
        ({"load_fraction_uniform_share": 0.5}, "needs load_fraction_beta"),
    ],
)
def test_bad_shares_are_named(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        make_config(kwargs)
