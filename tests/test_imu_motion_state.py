"""Motion-state recognition (paper 001 §2.2-2.3): labels, features, temporal constraint, trained forest.

The forest is trained in a module fixture on the synthetic unit-test signal (no pickled model in the repo).
"""

import math

import numpy as np
import pytest

import estimators
from estimators.imu.motion_state import (ACCELERATING, CRUISING, DECELERATING, STANDSTILL, STATE_NAMES,
                                         TRANSITIONS, MotionStateError, MotionStateRecognizer,
                                         apply_temporal_constraint, label_motion_states, per_state_accuracy,
                                         window_features)
from uuom_core.synthetic import synthetic_imu_run


def test_labels_follow_the_speed_profile():
    dt = 0.005
    v = np.concatenate([np.zeros(400), np.linspace(0, 1, 1000), np.ones(1000), np.linspace(1, 0, 500),
                        np.zeros(400)])
    lab = label_motion_states(v, dt)
    assert lab[200] == STANDSTILL
    assert lab[900] == ACCELERATING
    assert lab[1900] == CRUISING
    assert lab[2650] == DECELERATING
    assert lab[-100] == STANDSTILL
    with pytest.raises(MotionStateError, match="NaN"):
        label_motion_states(np.array([0.0, np.nan]), dt)
    with pytest.raises(MotionStateError, match="dt_s"):
        label_motion_states(v, 0.0)


def test_window_features_known_values():
    fs = 200.0
    const = np.full((1, 100), 0.3)
    imp, skew, energy, rmsf = window_features(const, fs)[0]
    assert imp == pytest.approx(1.0) and skew == 0.0 and energy == pytest.approx(0.09) and rmsf == pytest.approx(0)
    t = np.arange(200) / fs
    sine = np.sin(2 * np.pi * 10.0 * t)[None, :]
    imp, skew, energy, rmsf = window_features(sine, fs)[0]
    assert rmsf == pytest.approx(10.0, rel=1e-6)
    assert energy == pytest.approx(0.5, rel=1e-3)
    assert imp == pytest.approx(math.pi / 2, rel=1e-2)
    skewed = np.r_[np.zeros(95), np.full(5, 3.0)][None, :]
    assert window_features(skewed, fs)[0, 1] > 2.0
    v = np.linspace(0.0, 0.5, 100)[None, :]
    feats = window_features(np.zeros((1, 100)), fs, v, "paper+speed")[0]
    assert feats[5] == pytest.approx(0.5 / (99 / fs))  # fitted dv/dt
    with pytest.raises(MotionStateError, match="speed_windows"):
        window_features(np.zeros((1, 100)), fs, None, "paper+speed")
    with pytest.raises(MotionStateError, match="feature_set"):
        window_features(np.zeros((1, 100)), fs, None, "magic")


@pytest.mark.parametrize("transitions", ["paper", "monorail"])
def test_constraint_takes_a_forbidden_transition_only_on_overwhelming_evidence(transitions):
    rng = np.random.default_rng(0)
    proba = rng.dirichlet(np.ones(4) * 0.3, size=500)
    allowed = TRANSITIONS[transitions]
    strict = apply_temporal_constraint(proba, transitions, override_ratio=0.0)
    for a, b in zip(strict[:-1], strict[1:]):
        assert allowed[a, b], f"forbidden transition {STATE_NAMES[a]} -> {STATE_NAMES[b]}"
    states = apply_temporal_constraint(proba, transitions, override_ratio=0.1)
    for k in range(1, states.size):
        a, b = states[k - 1], states[k]
        if not allowed[a, b]:
            assert np.max(proba[k][allowed[a]]) <= 0.1 * proba[k].max()
            assert b == int(np.argmax(proba[k]))


def test_constraint_fixes_an_isolated_misclassification():
    # standstill, then a single window that looks like cruising, then standstill again
    p = np.tile([0.7, 0.1, 0.1, 0.1], (10, 1))
    p[5] = [0.2, 0.1, 0.6, 0.1]
    assert apply_temporal_constraint(p, "paper").tolist() == [0] * 10
    assert apply_temporal_constraint(p, "none")[5] == CRUISING


@pytest.fixture(scope="module")
def trained():
    runs = [synthetic_imu_run(100 + k, duration_s=90.0) for k in range(5)]
    pitches = [estimators.make("imu-ukf").run(tr).slope_rad for tr in runs]
    rec = MotionStateRecognizer(feature_set="paper+speed", transitions="monorail", n_estimators=25, seed=0)
    rec.fit(runs[:4], pitches[:4])
    return rec, runs[4], pitches[4]


def test_trained_recognizer_per_state_accuracy(trained):
    rec, tr, pitch = trained
    truth = label_motion_states(tr["true_speed_mps"], 0.005)
    pred = rec.predict_trace(tr["accel_mps2"], tr["speed_mps"], pitch)
    acc = per_state_accuracy(truth, pred)
    for name in STATE_NAMES:
        if not math.isnan(acc[name]):
            assert acc[name] > 0.8, (name, acc)
    assert acc["overall"] > 0.9


def test_online_update_matches_offline(trained):
    rec, tr, pitch = trained
    rec.reset()
    n = 6000
    online = np.array([rec.update(a, v, p) for a, v, p in zip(tr["accel_mps2"][:n], tr["speed_mps"][:n],
                                                               pitch[:n])])
    offline = rec.predict_trace(tr["accel_mps2"][:n], tr["speed_mps"][:n], pitch[:n])
    np.testing.assert_array_equal(online, offline)
    assert rec.is_standstill == (rec.state == STANDSTILL)


def test_nan_samples_do_not_break_it(trained):
    rec, tr, pitch = trained
    a = tr["accel_mps2"][:3000].copy()
    a[1000:1100] = np.nan
    states = rec.predict_trace(a, tr["speed_mps"][:3000], pitch[:3000])
    assert set(np.unique(states)) <= {0, 1, 2, 3}


def test_untrained_and_bad_settings():
    rec = MotionStateRecognizer()
    with pytest.raises(MotionStateError, match="not trained"):
        rec.update(0.0, 0.0)
    with pytest.raises(MotionStateError, match="transitions"):
        MotionStateRecognizer(transitions="random")
    with pytest.raises(MotionStateError, match="hop"):
        MotionStateRecognizer(window=50, hop=60)
    with pytest.raises(MotionStateError, match="labels"):
        MotionStateRecognizer().fit_arrays(np.zeros((3, 4)), np.array([0, 1, 7]))
