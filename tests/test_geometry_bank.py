"""``dffrls-aekf`` as a geometry bank (:mod:`estimators.geometry_bank`): it learns where gravity acts from the data.

Accuracy is checked on one seeded run of each simulator, with loose bounds (the protocol's tables have the
statistics); the rest checks the mechanics: one window is the member exactly, per-sample updates equal the batch
run, bad options are refused, the env keeps the plant's known geometry.
"""

from __future__ import annotations

import math
from functools import lru_cache

import numpy as np
import pytest

import estimators
from estimators import dffrls_aekf_kernel as kern
from estimators.dffrls_aekf import DFFRLSAEKF
from estimators.geometry_bank import DEFAULT_WINDOWS_M, GeometryBank
from estimators.geometry_bank_kernel import N_OUT_FIXED, ambiguity, member_score, mix
from uuom_core.trace import Trace
from uuom_gym.sim.protocol_runs import RunSpec, make_run


@lru_cache(maxsize=None)
def protocol_run(world: str, index: int) -> Trace:
    return make_run(RunSpec(world, f"{world}-{index:03d}", index, index, world))


def _errors(tr: Trace, s) -> tuple[float, float]:
    k = tr["t_s"] >= tr["t_s"][0] + 10.0
    m = tr["mass_kg"][k]
    mass = float(np.max(np.abs(s.mass_kg[k] - m) / m))
    slope = float(np.sqrt(np.mean((s.slope_deg[k] - tr["effective_slope_deg"][k]) ** 2)))
    return mass, slope


@pytest.mark.parametrize("world, index, member", [("point", 1, 0), ("plant", 0, 1)])
def test_learns_the_geometry_of_each_world(world: str, index: int, member: int) -> None:
    # protocol run point-001 (a point mass: gravity at the sensors) and plant-000 (the 18 m train), both with
    # traction at grade changes, where the geometry shows; the same estimator, no options
    tr = protocol_run(world, index)
    bank = estimators.make("dffrls-aekf")
    s = bank.run(tr)
    w = bank.weights
    assert w[member] > 0.99, f"{world}: weights {w} (windows {bank.windows_m})"
    key = f"weight_window_{DEFAULT_WINDOWS_M[member]:g}m"
    assert s.extras[key][-1] == pytest.approx(w[member])
    mass, slope = _errors(tr, s)
    # the wrong fixed geometry on the same run, for contrast: what the bank avoids
    wrong = DFFRLSAEKF(train_length_m=DEFAULT_WINDOWS_M[1 - member]).run(tr)
    assert slope < 0.5 * _errors(tr, wrong)[1]
    assert slope < 0.6 and mass < 0.15


def test_one_window_is_that_member_exactly() -> None:
    tr = protocol_run("point", 1)
    a = estimators.make("dffrls-aekf", train_length_m=12.0).run(tr)
    b = DFFRLSAEKF(train_length_m=12.0).run(tr)
    for x, y in ((a.mass_kg, b.mass_kg), (a.slope_rad, b.slope_rad), (a.mass_std_kg, b.mass_std_kg),
                 (a.slope_std_rad, b.slope_std_rad), (a.extras["mu"], b.extras["mu"])):
        np.testing.assert_array_equal(x, y)


def test_update_per_sample_equals_run() -> None:
    tr = protocol_run("point", 1)
    n = 4000
    t = tr["t_s"][:n]
    bank = GeometryBank()
    ref = bank.run(Trace({k: v[:n] for k, v in tr.columns.items()}))
    bank.reset()
    dts = np.diff(t, prepend=t[0] - (t[1] - t[0]))
    for i in range(n):
        e = bank.update(tr["torque_nm"][i], tr["speed_mps"][i], tr["accel_mps2"][i], dts[i])
    assert e.mass_kg == pytest.approx(ref.mass_kg[-1], rel=1e-12)
    assert e.slope_rad == pytest.approx(ref.slope_rad[-1], rel=1e-9, abs=1e-12)
    assert e.extras["weight_window_0m"] == pytest.approx(ref.extras["weight_window_0m"][-1], rel=1e-9)


def test_update_block_equals_update() -> None:
    # the ambiguity gate couples the members sample by sample: a block must step them together, not one by one
    from uuom_gym.sim.point_mass import simulate_point_mass

    tr = simulate_point_mass("pm-stop-and-go", seed=0)
    n, blk = 6000, 20  # the first 30 s: the gate closes from ~8 s
    a, b = GeometryBank(), GeometryBank()
    for i0 in range(0, n, blk):
        sl = slice(i0, i0 + blk)
        a.update_block(tr["torque_nm"][sl], tr["speed_mps"][sl], tr["accel_mps2"][sl], 0.005)
        for i in range(i0, i0 + blk):
            b.update(tr["torque_nm"][i], tr["speed_mps"][i], tr["accel_mps2"][i], 0.005)
    np.testing.assert_array_equal(a._SS, b._SS)
    assert a.estimate.mass_kg == b.estimate.mass_kg


def test_mixture_mean_and_spread() -> None:
    rows = np.zeros((2, 9))
    rows[:, 8] = [0.0, math.log(3.0)]  # scores
    rows[:, 0] = [1.0, 5.0]  # mass means
    rows[:, 2] = [1.0, 1.0]  # mass standard deviations
    out = np.zeros(N_OUT_FIXED + 2)
    mix(rows, out)
    w, m, s = out[N_OUT_FIXED:], out[0], out[2]
    np.testing.assert_allclose(w, [0.75, 0.25])
    assert m == pytest.approx(2.0)
    assert s == pytest.approx(math.sqrt(1.0 + 0.75 * 1.0 + 0.25 * 9.0))


def test_ambiguity_is_the_evidence_weighted_spread_of_the_slopes() -> None:
    SS = np.zeros((2, kern.N_S))
    SS[:, kern.TH_TRAIN] = [0.01, 0.03]
    SS[:, kern.SCORE] = [0.0, math.log(3.0)]  # weights 0.75 / 0.25
    mean = 0.75 * 0.01 + 0.25 * 0.03
    spread = math.sqrt(0.75 * (0.01 - mean) ** 2 + 0.25 * (0.03 - mean) ** 2)
    CC = np.zeros((2, kern.N_C))
    assert ambiguity(SS, CC, np.empty(2)) == pytest.approx(spread)
    SS[1, kern.SCORE] = 800.0  # the evidence has chosen: no ambiguity, however far apart the members are
    assert ambiguity(SS, CC, np.empty(2)) == pytest.approx(0.0, abs=1e-12)


def test_early_evidence_leans_the_bank_only_as_far_as_its_cap() -> None:
    SS = np.zeros((2, kern.N_S))
    CC = np.zeros((2, kern.N_C))
    CC[:, kern.EARLY_CAP] = 1.0
    SS[:, kern.SCORE_EARLY] = [3.0, 10.0]  # early evidence 7 nats for member 0: capped at 1
    SS[:, kern.SCORE] = [5.0, 5.5]  # later evidence counts whole
    assert member_score(SS, CC, 0) == pytest.approx(5.0)
    assert member_score(SS, CC, 1) == pytest.approx(6.5)
    CC[:, kern.EARLY_CAP] = 0.0  # not counted at all
    assert member_score(SS, CC, 1) == pytest.approx(5.5)
    CC[:, kern.EARLY_CAP] = math.inf  # counted whole
    assert member_score(SS, CC, 1) == pytest.approx(12.5)


def test_early_evidence_picks_the_point_mass_sooner() -> None:
    # point-mass section 2 (grades vary from the start): with no early evidence the bank stays 50/50 until the
    # train has travelled the 12 m window (~20 s) and reports the mean of a right and a lagging slope meanwhile
    from uuom_gym.sim.point_mass import simulate_point_mass

    tr = simulate_point_mass("pm-section2", seed=0)
    t = tr["t_s"]
    early = (t > 10.0) & (t < 18.0)
    w_none = GeometryBank(max_early_evidence=0.0).run(tr).extras["weight_window_0m"]
    w_cap = GeometryBank().run(tr).extras["weight_window_0m"]
    w_all = GeometryBank(max_early_evidence=math.inf).run(tr).extras["weight_window_0m"]
    assert np.all(np.abs(w_none[early] - 0.5) < 0.05)
    cap = GeometryBank().config.max_early_evidence
    assert np.max(w_cap[early]) > 0.7
    assert np.all(w_cap[early] <= 1.0 / (1.0 + math.exp(-cap)) + 1e-9)  # leaning, not deciding
    assert np.median(w_all[early]) > 0.99
    _, slope_none = _errors(tr, GeometryBank(max_early_evidence=0.0).run(tr))
    _, slope_cap = _errors(tr, GeometryBank().run(tr))
    assert slope_cap < 0.8 * slope_none


def test_no_mass_learnt_while_the_geometry_is_ambiguous() -> None:
    # point-mass stop-and-go: the train pulls away onto a grade ramp before 12 m of history exist, so the members
    # disagree and no evidence has chosen; the gate holds every member's mass, which it lets learn again later
    from uuom_gym.sim.point_mass import simulate_point_mass

    tr = simulate_point_mass("pm-stop-and-go", seed=0)
    bank = GeometryBank()
    limit = bank.config.max_geometry_ambiguity_rad
    dts = np.diff(tr["t_s"], prepend=tr["t_s"][0] - 0.005)
    held = changed = 0
    for i in range(len(dts)):
        before = [m.S[kern.MC] for m in bank.members]
        bank.update(tr["torque_nm"][i], tr["speed_mps"][i], tr["accel_mps2"][i], dts[i])
        moved = [m.S[kern.MC] != b for m, b in zip(bank.members, before)]
        if bank.members[0].S[kern.AMBIG] > limit:
            assert not any(moved), f"mass learnt at t={tr['t_s'][i]:.2f} s with ambiguity above the gate"
            held += 1
        changed += any(moved)
    assert held > 1000 and changed > 1000  # the gate closed for seconds, and the masses learnt elsewhere
    # without the gate (and without the early evidence that leans the bank to the point mass before the window
    # is measured) the window member learns the ramp's slope lag as mass. Shown with one pendulum on the vehicle
    # file's chains: with the chain-length bank (the default since session 19) this trace's worst error is set by
    # the swing, 13.1 % gated against 11.4 % open; what the gate is worth over many runs is in the ablation table
    one = {"max_early_evidence": 0.0, "chain_length_factors": ()}
    mass_gated, _ = _errors(tr, GeometryBank(**one).run(tr))
    mass_open, _ = _errors(tr, GeometryBank(**one, max_geometry_ambiguity_rad=math.inf).run(tr))
    assert mass_gated < mass_open


@pytest.mark.parametrize("options, match", [
    ({"windows_m": ()}, "windows_m"),
    ({"windows_m": (0.0, -1.0)}, "windows_m"),
    ({"windows_m": (0.0, math.nan)}, "windows_m"),
    ({"windows_m": (0.0, math.inf)}, "windows_m"),
    ({"windows_m": (0.0, 12.0), "train_length_m": 12.0}, "not both"),
    ({"fused": True}, "fused"),
    ({"max_geometry_ambiguity_rad": -0.1}, "max_geometry_ambiguity_rad"),
    ({"max_geometry_ambiguity_rad": math.nan}, "max_geometry_ambiguity_rad"),
    ({"max_early_evidence": -1.0}, "max_early_evidence"),
    ({"max_early_evidence": math.nan}, "max_early_evidence"),
    ({"evidence_min_disagreement_rad": -0.001}, "evidence_min_disagreement_rad"),
    ({"evidence_min_disagreement_rad": math.nan}, "evidence_min_disagreement_rad"),
    ({"no_such_option": 1}, "unknown option"),
])
def test_bad_options_are_named(options: dict, match: str) -> None:
    with pytest.raises((ValueError, TypeError), match=match):
        estimators.make("dffrls-aekf", **options)


def test_env_tells_its_observer_the_plants_geometry() -> None:
    from uuom_core.vehicle import DEFAULT_VEHICLE
    from uuom_gym.envs.observers import make_observer

    est = make_observer("dffrls-aekf", DEFAULT_VEHICLE).estimator
    assert est.windows_m == (12.0,)
    assert make_observer("dffrls-aekf", DEFAULT_VEHICLE, {"windows_m": (0.0, 12.0)}).estimator.windows_m == (0.0, 12.0)
    assert make_observer("dffrls-aekf", DEFAULT_VEHICLE, {"train_length_m": 0.0}).estimator.windows_m == (0.0,)


def test_electric_braking_is_a_measured_force() -> None:
    # point-mass run 1023 (a tuning seed, not one of the protocol's evaluation runs) brakes with its motors through
    # grade changes: those samples now score the geometries and teach the mass (session 23)
    tr = make_run(RunSpec("point", "point-1023", 1023, 1023, "point"))
    assert np.mean(tr["torque_nm"] < -1000.0) > 0.1
    mass, slope = _errors(tr, estimators.make("dffrls-aekf").run(tr))
    mass_t, slope_t = _errors(tr, estimators.make("dffrls-aekf", braking_samples=False).run(tr))
    assert slope < 0.6 * slope_t and mass < 0.5 * mass_t
    assert mass < 0.04 and slope < 0.5


def test_braking_samples_change_nothing_where_the_motors_never_brake() -> None:
    # the plant brakes with its brake cars, the motors at ~0 N m: its runs (and every env episode) are unchanged
    tr = protocol_run("plant", 0)
    a = estimators.make("dffrls-aekf").run(tr)
    b = estimators.make("dffrls-aekf", braking_samples=False).run(tr)
    for x, y in ((a.mass_kg, b.mass_kg), (a.slope_rad, b.slope_rad), (a.mass_std_kg, b.mass_std_kg)):
        np.testing.assert_array_equal(x, y)
    assert estimators.make("dffrls-aekf").config.braking_samples
    assert not estimators.make("fused").config.braking_samples  # measured worse at the median (estimators/fused.py)


def test_the_mass_waits_for_the_geometry() -> None:
    # session 23's gate (2.5e-4 rad): on point-mass stop-and-go the train pulls away onto a ramp and the 12 m member,
    # whose window lags the ramp, learned that lag as mass under the old gate (0.004 rad) before the evidence had
    # chosen; measured 7.6 % max error after 10 s with the old gate, 6.2 % with the new one
    from uuom_gym.sim.point_mass import simulate_point_mass

    tr = simulate_point_mass("pm-stop-and-go", seed=0)
    assert GeometryBank().config.max_geometry_ambiguity_rad == 2.5e-4
    mass_new, _ = _errors(tr, GeometryBank().run(tr))
    mass_old, _ = _errors(tr, GeometryBank(max_geometry_ambiguity_rad=0.004).run(tr))
    assert mass_new < 0.07 and mass_new < mass_old - 0.01


def test_evidence_counts_only_where_the_geometries_disagree() -> None:
    # point-mass resistance-mismatch scenario, sensor seed 3, twice the sensor noise: 48 s of level track, then a
    # grade. On the level the point member reads the slope layer's noisy grade and the window member its average, so
    # counting those samples as evidence handed the window member (the wrong geometry here) the whole weight, and its
    # mass then learnt the grade's onset as mass (+25.8 %); counted only where the members' slopes differ, the bank
    # keeps an open mind on the level and the mass stays within a few per cent
    from uuom_gym.sim.point_mass import simulate_point_mass, with_sensor_scale

    tr = simulate_point_mass(with_sensor_scale("pm-resistance-mismatch", 2.0), seed=3)
    t = tr["t_s"]
    gated = GeometryBank()
    assert gated.config.evidence_min_disagreement_rad == pytest.approx(0.002)
    s_gated = gated.run(tr)
    # the open bank as measured then, before session 63's window_weak_spread_rad (with it: 19.6 %)
    s_open = GeometryBank(evidence_min_disagreement_rad=0.0, window_weak_spread_rad=0.0).run(tr)
    i = np.searchsorted(t, 45.0)
    assert s_open.extras["weight_window_12m"][i] > 0.99
    assert s_gated.extras["weight_window_12m"][i] < s_open.extras["weight_window_12m"][i] - 0.02
    mass_gated, _ = _errors(tr, s_gated)
    mass_open, _ = _errors(tr, s_open)
    assert mass_open > 0.2 and mass_gated < 0.12
    # both end on the true geometry once the grade has shown it
    assert s_gated.extras["weight_window_0m"][-1] > 0.99 and s_open.extras["weight_window_0m"][-1] > 0.99


def test_a_lone_filter_counts_every_sample_as_evidence() -> None:
    # the disagreement is written by the bank; a filter on its own keeps DISAGREE_ALONE, so its reported score is
    # the same whatever the threshold
    tr = protocol_run("point", 1)
    a = DFFRLSAEKF(train_length_m=12.0)
    b = DFFRLSAEKF(train_length_m=12.0, evidence_min_disagreement_rad=0.0)
    a.run(tr)
    b.run(tr)
    assert a.S[kern.DISAGREE] == kern.DISAGREE_ALONE
    assert a.S[kern.SCORE] == b.S[kern.SCORE] != 0.0


def test_bank_members_are_told_how_far_apart_their_slopes_are() -> None:
    tr = protocol_run("point", 1)
    bank = GeometryBank()
    dts = np.diff(tr["t_s"], prepend=tr["t_s"][0] - 0.005)
    for i in range(4000):
        th = [m.S[kern.TH_TRAIN] for m in bank.members]
        bank.update(tr["torque_nm"][i], tr["speed_mps"][i], tr["accel_mps2"][i], dts[i])
        for m in bank.members:
            assert m.S[kern.DISAGREE] == max(th) - min(th)
