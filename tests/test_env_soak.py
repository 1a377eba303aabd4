"""Random-action soak of UUOM-Track-v0 (default observer): no NaN anywhere, bounded observations, flat memory.

The default run does a short soak; the full 10^5-step soak is marked slow (``pytest -m slow``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from uuom_gym.envs.track_env import UUOMTrackEnv


def _rss_mb() -> float:
    with open("/proc/self/statm") as fh:
        pages = int(fh.read().split()[1])
    import resource

    return pages * resource.getpagesize() / 2**20


def soak(n_steps: int, seed: int = 0, check_memory_after: int | None = None) -> dict:
    env = UUOMTrackEnv()
    rng = np.random.default_rng(seed)
    obs, info = env.reset(seed=seed)
    bias = 0.0
    episodes = 0
    terminations: dict[str, int] = {}
    rss0 = None
    for i in range(n_steps):
        # uniform random actions with a per-episode bias, so episodes also reach trips, overruns and arrivals
        a = np.array([bias + rng.uniform(-1.0, 1.0)], np.float32)
        obs, reward, term, trunc, info = env.step(a)
        assert env.observation_space.contains(obs), obs
        assert math.isfinite(reward) and math.isfinite(info["cost"]) and info["cost"] >= 0.0
        for k in ("est_mass_kg", "est_slope_rad", "est_mass_std_kg", "est_slope_std_rad", "est_speed_limit_mps",
                  "true_speed_limit_mps", "speed_mps", "position_m"):
            assert math.isfinite(info[k]), (k, info[k])
        if term or trunc:
            episodes += 1
            terminations[info["termination"]] = terminations.get(info["termination"], 0) + 1
            obs, info = env.reset()
            bias = float(rng.uniform(-0.3, 0.8))
        if check_memory_after is not None and i == check_memory_after:
            rss0 = _rss_mb()
    env.close()
    return {"episodes": episodes, "terminations": terminations, "rss0": rss0,
            "rss1": _rss_mb() if rss0 is not None else None}


def test_short_soak():
    out = soak(3000, seed=1)
    assert out["episodes"] >= 1


@pytest.mark.slow
def test_soak_1e5_steps_flat_memory():
    out = soak(100_000, seed=2, check_memory_after=20_000)
    assert out["episodes"] >= 10
    assert out["rss1"] - out["rss0"] < 30.0, out
