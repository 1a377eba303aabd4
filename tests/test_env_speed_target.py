"""``action_mode="speed_target"``: the mapping, the tracker, the config, and that the action's zero drives."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import uuom_gym  # noqa: F401 - registers the env
from uuom_core.vehicle import DEFAULT_VEHICLE
from uuom_gym.envs.config import ConfigError, make_config
from uuom_gym.envs.speed_target import SpeedTracker, target_speed_mps


@pytest.mark.parametrize(
    "action, expected", [(-1.0, 0.0), (0.0, 0.25), (0.5, 0.375), (1.0, 0.5), (-3.0, 0.0), (3.0, 0.5)]
)
def test_target_is_a_fraction_of_the_cautious_limit(action, expected):
    assert target_speed_mps(action, 0.5) == pytest.approx(expected)


def test_target_is_never_negative():
    assert target_speed_mps(0.3, -1.0) == 0.0


def test_tracker_drives_from_rest_and_brakes_above_the_target():
    tr = SpeedTracker(DEFAULT_VEHICLE, 0.1)
    m = DEFAULT_VEHICLE.rated_mass_kg
    assert tr.command(0.3, 0.0, m, 0.0) > 0.0
    tr.reset()
    assert tr.command(0.3, 0.8, m, 0.0) < 0.0
    tr.reset()
    # On a down-grade the feed-forward brakes even at the target speed.
    assert tr.command(0.3, 0.3, m, -0.15) < 0.0
    tr.reset()
    # Stop asked and reached: hold on the service brake.
    assert tr.command(0.0, 0.01, m, 0.1) == -1.0


def test_tracker_integral_is_clamped():
    tr = SpeedTracker(DEFAULT_VEHICLE, 0.1)
    for _ in range(1000):
        tr.command(1.0, 0.0, DEFAULT_VEHICLE.empty_mass_kg, 0.0)
    assert tr.integral_m == pytest.approx(tr.integral_clamp_m)
    for _ in range(1000):
        tr.command(0.0, 2.0, DEFAULT_VEHICLE.empty_mass_kg, 0.0)
    assert tr.integral_m == pytest.approx(-tr.integral_clamp_m)


def test_config_default_and_bad_value():
    assert make_config()["action_mode"] == "command"
    with pytest.raises(ConfigError, match="action_mode"):
        make_config(action_mode="speed")


def test_check_env_passes_in_speed_target_mode():
    env = gym.make("UUOM-Track-v0", action_mode="speed_target")
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def _advance_with_zero_action(mode: str, seconds: float = 20.0) -> tuple[float, dict]:
    env = gym.make("UUOM-Track-v0", action_mode=mode)
    _, info = env.reset(seed=100000)
    for _ in range(int(seconds * 10)):
        _, _, term, trunc, info = env.step(np.zeros(1, np.float32))
        if term or trunc:
            break
    env.close()
    return info["position_m"], info


def test_zero_action_drives_gently_in_speed_target_mode_and_coasts_by_default():
    # The point of the mode (docs/rl.md): a policy whose mean action is 0 must move the train, without tripping.
    pos, info = _advance_with_zero_action("speed_target")
    assert pos > 2.0
    assert info["termination"] != "overspeed_trip"
    assert 0.0 < info["target_speed_mps"] <= info["true_speed_limit_mps"]
    pos_default, info_default = _advance_with_zero_action("command")
    assert pos_default < 1.0
    assert "target_speed_mps" not in info_default


# --- rev. 4 options: speed_target_cap="station", speed_tracker (docs/rl.md §7) ---------------------------------
def test_station_envelope():
    from uuom_gym.envs.speed_target import ENVELOPE_DECEL_MPS2, ENVELOPE_STOP_OFFSET_M, station_envelope_mps

    assert station_envelope_mps(ENVELOPE_STOP_OFFSET_M) == 0.0
    assert station_envelope_mps(-5.0) == 0.0
    d = 10.0
    assert station_envelope_mps(d) == pytest.approx(np.sqrt(2.0 * ENVELOPE_DECEL_MPS2 * (d - ENVELOPE_STOP_OFFSET_M)))


def test_new_config_defaults_and_bad_values():
    cfg = make_config()
    assert cfg["speed_target_cap"] == "cautious" and cfg["speed_tracker"] == {}
    with pytest.raises(ConfigError, match="speed_target_cap"):
        make_config(speed_target_cap="envelope")
    with pytest.raises(ConfigError, match="unknown key"):
        make_config(speed_tracker={"kp": 1.0})
    with pytest.raises(ConfigError, match="speed_tracker"):
        make_config(speed_tracker={"integral_clamp_m": -1.0})
    assert make_config(speed_tracker={"integral_clamp_m": 2})["speed_tracker"] == {"integral_clamp_m": 2.0}


def test_speed_tracker_overrides_reach_the_tracker():
    env = gym.make("UUOM-Track-v0", action_mode="speed_target", speed_tracker={"integral_clamp_m": 2.0})
    assert env.unwrapped._tracker.integral_clamp_m == 2.0
    assert env.unwrapped._tracker.gain_per_s == SpeedTracker(DEFAULT_VEHICLE, 0.1).gain_per_s
    env.close()


def test_check_env_passes_with_station_cap():
    env = gym.make("UUOM-Track-v0", action_mode="speed_target", speed_target_cap="station",
                   speed_tracker={"integral_clamp_m": 2.0})
    check_env(env.unwrapped, skip_render_check=True)
    env.close()


def test_station_cap_stops_a_full_speed_action_at_the_station():
    # The point of the cap: a = +1 all the way arrives (the cautious cap alone overruns the station).
    kw = dict(action_mode="speed_target", track_length_m=(50.0, 50.0), load_kg=0.0)
    ends = {}
    for cap in ("station", "cautious"):
        env = gym.make("UUOM-Track-v0", speed_target_cap=cap, **kw)
        _, info = env.reset(seed=3)
        for _ in range(3000):
            _, _, term, trunc, info = env.step(np.ones(1, np.float32))
            if term or trunc:
                break
        env.close()
        ends[cap] = info
    assert ends["station"]["termination"] == "arrived", ends["station"]["termination"]
    assert abs(ends["station"]["distance_to_go_m"]) <= 3.0
    assert ends["cautious"]["termination"] == "overrun"
    assert ends["station"]["target_speed_mps"] == 0.0


@pytest.mark.parametrize("action, expected", [(-1.0, 0.35), (0.0, 0.475), (1.0, 0.6)])
def test_target_span_maps_actions_around_the_cautious_limit(action, expected):
    assert target_speed_mps(action, 0.5, (0.7, 1.2)) == pytest.approx(expected)
    assert target_speed_mps(action, 0.5, (0.0, 1.0)) == target_speed_mps(action, 0.5)


def test_target_span_config():
    assert make_config()["speed_target_range"] == (0.0, 1.0)
    with pytest.raises(ConfigError, match="speed_target_range"):
        make_config(speed_target_range=(1.2, 0.7))
    with pytest.raises(ConfigError, match="speed_target_range"):
        make_config(speed_target_range=(0.5, 3.0))


def test_span_above_one_never_asks_for_more_than_the_station_envelope():
    from uuom_gym.envs.speed_target import station_envelope_mps

    env = gym.make("UUOM-Track-v0", action_mode="speed_target", speed_target_cap="station",
                   speed_target_range=(0.7, 1.2), track_length_m=(50.0, 50.0), load_kg=0.0)
    _, info = env.reset(seed=3)
    for _ in range(3000):  # a = 0: 0.95 x the cautious limit, then the envelope
        u = env.unwrapped
        envelope = station_envelope_mps(u.station_m - u.obs_builder.odometry_m)  # where the target is set
        _, _, term, trunc, info = env.step(np.zeros(1, np.float32))
        assert info["target_speed_mps"] <= envelope + 1e-12
        if term or trunc:
            break
    env.close()
    assert info["termination"] == "arrived", info["termination"]
