"""Any config ``gym.make`` accepts runs: random overrides either raise :class:`ConfigError` naming a key they set, or
the env resets and steps with finite observations, rewards and costs.

Why: the config's checks and the parts below it (plant, track, tracker) had their own ranges, and a value between
them passed ``make()`` to fail later. A random draw of 3 000 configs (session 59) found three: ``physics_hz`` below
100 or above 5000 (the plant's range) and ``max_grade_deg = 0`` (the track's) failed at ``reset()``, and a
``policy_hz`` of 1e-9 asked for 2e11 physics ticks per step (``MemoryError``; 0.001 Hz: a minute per step).
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import uuom_gym  # noqa: F401  (registers the env ids)
from uuom_gym.envs.config import ConfigError, default_config

NUMBERS = (0.0, 1e-9, 1e-3, 0.05, 0.5, 1.0, 2.0, 5.0, 15.0, 50.0, 1e3, 1e9, -1.0, math.nan, math.inf)
CHOICES = {
    "action_mode": ("command", "speed_target", "acceleration", "torque"),
    "speed_target_cap": ("cautious", "station", "none"),
    "slip_observation": ("sensors", "estimator", "truth"),
    "near_distance_observation": ("clip", "tanh", "log"),
    "observer": ("dffrls-aekf", "oracle", "none", "ekf", "sf-kf", "no-such-observer"),
}
# keys whose values are objects or whose cost is rendering, not the task
SKIPPED = {"vehicle", "track", "scenario", "observer_options", "sensor_faults", "render_fps", "render_size",
           "render_window_m"}
KEYS = sorted(k for k in default_config() if k not in SKIPPED)


@st.composite
def overrides(draw: st.DrawFn) -> dict[str, object]:
    defaults = default_config()
    out: dict[str, object] = {}
    for key in draw(st.lists(st.sampled_from(KEYS), min_size=1, max_size=3, unique=True)):
        d = defaults[key]
        number = st.sampled_from(NUMBERS)
        near = st.sampled_from((0.5, 1.0, 2.0))  # a factor on the default: most draws should reach the run
        if key in CHOICES:
            out[key] = draw(st.sampled_from(CHOICES[key]))
        elif isinstance(d, bool):
            out[key] = draw(st.booleans())
        elif isinstance(d, tuple):
            if draw(st.booleans()):
                out[key] = tuple(sorted(x * draw(near) for x in d))
            else:
                out[key] = tuple(sorted(draw(st.tuples(number, number))))
        elif isinstance(d, dict):
            out[key] = {k: (draw(number) if draw(st.booleans()) else v * draw(near)) for k, v in d.items()}
        elif d is None:
            out[key] = draw(st.one_of(number, st.tuples(number, number)))
        else:
            out[key] = d * draw(near) if draw(st.booleans()) else draw(number)
    return out


# no shrinking: the failing config is printed as drawn (shrinking rebuilt hundreds of plants for little gain)
@settings(derandomize=True, max_examples=80, deadline=None, database=None, phases=(Phase.explicit, Phase.generate),
          suppress_health_check=[HealthCheck.too_slow])
@given(config=overrides(), seed=st.integers(0, 2**16))
def test_a_config_is_refused_naming_its_key_or_runs(config: dict[str, object], seed: int) -> None:
    try:
        env = gym.make("UUOM-Track-v0", **config)
    except ConfigError as exc:
        assert any(f"'{k}'" in str(exc) or k in str(exc) for k in config), (config, str(exc))
        return
    try:
        obs, _ = env.reset(seed=seed)
        assert np.all(np.isfinite(obs))
        env.action_space.seed(seed)
        for _ in range(100):
            obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
            assert np.all(np.isfinite(obs)) and math.isfinite(reward) and math.isfinite(info["cost"]), config
            if terminated or truncated:
                env.reset()
    finally:
        env.close()


@pytest.mark.parametrize("config, key", [
    ({"physics_hz": 50.0, "policy_hz": 10.0}, "physics_hz"),
    ({"physics_hz": 10_000.0}, "physics_hz"),
    ({"policy_hz": 1e-9}, "policy_hz"),
    ({"max_grade_deg": 0.0}, "max_grade_deg"),
])
def test_what_the_fuzz_found_is_refused_by_make(config: dict[str, float], key: str) -> None:
    with pytest.raises(ConfigError, match=key):
        gym.make("UUOM-Track-v0", **config)
