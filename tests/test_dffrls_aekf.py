"""``dffrls-aekf`` (the project's two-layer estimator, compiled kernel) and ``dffrls-aekf-paper`` (paper 000 as
printed): registry, the compiled path against the pure-Python reference, online against batch, faulty data, and
loose accuracy bounds on seeded runs of both simulators (accuracy, not timings)."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import numpy as np
import pytest

import estimators
from estimators import dffrls_aekf_kernel as kern
from uuom_core.synthetic import synthetic_trace
from uuom_core.trace import Trace

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _series_array(s) -> np.ndarray:
    return np.c_[s.mass_kg, s.slope_rad, s.mass_std_kg, s.slope_std_rad, s.extras["mu"], s.extras["mu_std"]]


@pytest.fixture(scope="module")
def faulty() -> Trace:
    """40 s synthetic run with dropouts, spikes, out-of-order and repeated stamps, a 3 s gap and huge values."""
    tr = synthetic_trace("section1", seed=5, mass_kg=30_000.0, duration_s=40.0)
    rng = np.random.default_rng(5)
    cols = {k: v.copy() for k, v in tr.columns.items()}
    n = len(tr)
    for k in ("torque_nm", "speed_mps", "accel_mps2"):
        cols[k][rng.random(n) < 0.05] = np.nan
        cols[k][rng.random(n) < 0.002] = rng.choice([np.inf, -np.inf, 1e300, -1e300])
    t = cols["t_s"]
    t[3000] = t[2999]  # repeated stamp
    t[4000] = t[3990]  # out of order
    t[5000:] += 3.0  # a 3 s gap
    return Trace(cols, source="faulty")


def test_registered_and_selectable() -> None:
    names = estimators.available()
    assert "dffrls-aekf" in names and "dffrls-aekf-paper" in names
    assert type(estimators.make("dffrls-aekf")).__name__ == "GeometryBank"  # geometry bank of DFFRLSAEKF members
    assert type(estimators.make("dffrls-aekf-paper")).__name__ == "DFFRLSAEKFPaper"
    with pytest.raises(TypeError, match="no_such_option"):
        estimators.make("dffrls-aekf", no_such_option=1)
    with pytest.raises(ValueError, match="delta"):
        estimators.make("dffrls-aekf", delta=1.5)
    with pytest.raises(ValueError, match="fading"):
        estimators.make("dffrls-aekf-paper", fading=1.0)


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_online_update_equals_batch_run(name: str, faulty: Trace) -> None:
    est = estimators.make(name)
    batch = _series_array(est.run(faulty))
    est.reset()
    t = faulty["t_s"]
    dts = np.diff(t, prepend=t[0] - (t[1] - t[0]))
    rows = []
    for i in range(len(t)):
        e = est.update(faulty["torque_nm"][i], faulty["speed_mps"][i], faulty["accel_mps2"][i], dts[i])
        rows.append((e.mass_kg, e.slope_rad, e.mass_std_kg, e.slope_std_rad, e.extras["mu"], e.extras["mu_std"]))
    np.testing.assert_array_equal(np.array(rows), batch)


@pytest.mark.skipif(not kern.HAVE_NUMBA, reason="the reference comparison needs the compiled kernel")
@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_compiled_kernel_matches_the_pure_python_reference(name: str, faulty: Trace, tmp_path) -> None:
    """The same kernel source run by the Python interpreter (``NUMBA_DISABLE_JIT=1``) is the reference."""
    compiled = _series_array(estimators.make(name).run(faulty))
    short = 6000  # the interpreter runs the kernel ~100x slower
    path = tmp_path / "ref.npy"
    code = (
        "import sys, numpy as np; sys.path.insert(0, %r)\n"
        "import estimators\n"
        "from uuom_core.trace import Trace\n"
        "d = np.load(%r)\n"
        "tr = Trace({k: d[k] for k in d.files})\n"
        "s = estimators.make(%r).run(tr)\n"
        "np.save(%r, np.c_[s.mass_kg, s.slope_rad, s.mass_std_kg, s.slope_std_rad,\n"
        "                  s.extras['mu'], s.extras['mu_std']])\n"
    ) % (ROOT, str(tmp_path / "in.npz"), name, str(path))
    np.savez(tmp_path / "in.npz", **{k: v[:short] for k, v in faulty.columns.items()})
    env = dict(os.environ, NUMBA_DISABLE_JIT="1")
    subprocess.run([sys.executable, "-c", code], check=True, env=env, cwd=ROOT, timeout=600)
    reference = np.load(path)
    np.testing.assert_allclose(compiled[:short], reference, rtol=1e-9, atol=1e-12)


@pytest.mark.parametrize("name", ["dffrls-aekf", "dffrls-aekf-paper", "fused"])
def test_faulty_data_never_gives_nan(name: str, faulty: Trace) -> None:
    est = estimators.make(name)
    s = est.run(faulty)
    for col in (s.mass_kg, s.slope_rad, s.mass_std_kg, s.slope_std_rad):
        assert np.all(np.isfinite(col))
    assert np.all(s.mass_std_kg >= 0) and np.all(s.slope_std_rad > 0)
    v = est.vehicle
    assert np.all((s.mass_kg >= v.empty_mass_kg) & (s.mass_kg <= v.max_mass_kg))


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_covariances_stay_spd_per_sample(name: str, faulty: Trace) -> None:
    est = estimators.make(name)
    t = faulty["t_s"]
    dts = np.diff(t, prepend=t[0] - 0.005)
    for i in range(0, len(t)):
        est.update(faulty["torque_nm"][i], faulty["speed_mps"][i], faulty["accel_mps2"][i], dts[i])
        if i % 7 == 0:
            for m in getattr(est, "members", [est]):  # dffrls-aekf: every member of the geometry bank
                for P in (m.slope_P, m.mass_P, m.regression_P):
                    assert np.all(np.isfinite(P)) and P[0, 1] == P[1, 0]
                    assert np.linalg.eigvalsh(P).min() > 0.0


@pytest.mark.parametrize("name", ["dffrls-aekf", "dffrls-aekf-paper", "fused"])
def test_huge_dt_and_stamps_do_not_hang_or_break(name: str) -> None:
    est = estimators.make(name)
    for dt in (0.005, 1e300, math.inf, math.nan, -1.0, 0.0, 0.005, 50.0):
        e = est.update(3000.0, 0.5, 0.05, dt)
        assert math.isfinite(e.mass_kg) and math.isfinite(e.slope_rad)


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_recovers_after_a_fault_burst(name: str) -> None:
    """Clean accuracy comes back within 10 s after 10 s of garbage on every channel (issue 10 item 4)."""
    tr = synthetic_trace("section1", seed=9, mass_kg=26_000.0, duration_s=80.0)
    clean = estimators.make(name, train_length_m=0.0).run(tr)
    cols = {k: v.copy() for k, v in tr.columns.items()}
    rng = np.random.default_rng(9)
    burst = (tr["t_s"] > 20.0) & (tr["t_s"] < 30.0)
    for k in ("torque_nm", "speed_mps", "accel_mps2"):
        cols[k][burst] = rng.choice([np.nan, np.inf, -1e300, 1e6], burst.sum())
    hit = estimators.make(name, train_length_m=0.0).run(Trace(cols))
    late = tr["t_s"] > 40.0
    slope_err = np.degrees(np.abs(hit.slope_rad[late] - clean.slope_rad[late]))
    assert slope_err.max() < 0.3
    assert np.max(np.abs(hit.mass_kg[late] / clean.mass_kg[late] - 1.0)) < 0.05


def _errors(tr: Trace, s) -> tuple[float, float]:
    k = tr["t_s"] >= tr["t_s"][0] + 10.0
    m = tr["mass_kg"][k]
    ref = tr.columns.get("effective_slope_deg", tr["slope_deg"])[k]
    return (float(np.max(np.abs(s.mass_kg[k] - m) / m)) * 100.0,
            float(np.sqrt(np.mean((s.slope_deg[k] - ref) ** 2))))


@pytest.mark.slow
def test_accuracy_on_the_plant_section1() -> None:
    from uuom_gym.sim.recording import simulate_run

    tr = simulate_run("section1", seed=1)
    mass, slope = _errors(tr, estimators.make("dffrls-aekf").run(tr))
    paper_mass, paper_slope = _errors(tr, estimators.make("dffrls-aekf-paper").run(tr))
    # measured (seed 1): 2.8 % / 0.27 deg for dffrls-aekf; the paper as printed sits at the mass clamp, 11 deg
    assert mass < 6.0 and slope < 0.6
    assert paper_slope > 3.0 * slope


@pytest.mark.slow
def test_accuracy_on_the_point_mass_world() -> None:
    from uuom_gym.sim.point_mass import simulate_point_mass

    tr = simulate_point_mass("pm-section1", seed=1)
    mass, slope = _errors(tr, estimators.make("dffrls-aekf").run(tr))
    assert mass < 15.0 and slope < 1.5


def test_paper_variant_as_printed_settles_its_noise_mean_against_the_slope() -> None:
    """The printed Sage-Husa estimates the speed-noise mean q̂_v, which is collinear with the slope: on a level run
    with the true mass fixed, the means-off filter stays near level and the as-printed one does not."""
    tr = synthetic_trace("level", seed=2, mass_kg=26_000.0, duration_s=40.0)
    k = tr["t_s"] > 10.0
    printed = estimators.make("dffrls-aekf-paper").run(tr)
    no_means = estimators.make("dffrls-aekf-paper", adapt_means=False).run(tr)
    assert np.all(np.isfinite(printed.slope_rad)) and np.all(np.isfinite(no_means.slope_rad))
    assert np.mean(np.abs(printed.slope_deg[k])) > np.mean(np.abs(no_means.slope_deg[k]))


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_mass_clamped_at_the_empty_train_moves_the_offset_with_it(name: str) -> None:
    """An empty train's mass is the lower bound of the mass range; start-up noise drives the estimate through it.
    Clamping the mass alone left the correlated resistance offset where the unclamped mass had put it, and the
    two then walked apart to a wrong pair that constant-speed running never corrects (point-mass steep empty climb,
    sensor seed 6, measured: max mass error after 10 s 47.7 % (``dffrls-aekf``) and 68.5 % (``fused``) without the
    projection, 0.4 % and 0.6 % with it)."""
    from uuom_gym.sim.point_mass import simulate_point_mass

    tr = simulate_point_mass("pm-steep-empty-climb", seed=6)
    k = tr["t_s"] >= 10.0

    def worst_pct(**options: bool) -> float:
        s = estimators.make(name, **options).run(tr)
        return float(np.max(np.abs(s.mass_kg[k] / tr["mass_kg"][k] - 1.0))) * 100.0

    assert worst_pct() < 3.0
    # the failure this guards against (shown with fused's mass noise of session 18: since session 63 the grade's
    # variance in it keeps the start-up noise from driving its mass through the bound here, 0.7 % without projection)
    before_63 = {"slope_var_weight": 0.0} if name == "fused" else {}
    assert worst_pct(clamp_projection=False, **before_63) > 20.0


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_chain_bank_finds_the_chains_and_keeps_the_mass(name: str) -> None:
    """The point-mass world's load on chains shorter and longer than the vehicle file's 2 m: the bank's evidence
    lands on the true length, and the mass holds where one 2 m pendulum loses it (pm-section1, sensor seed 0,
    measured: chains 1.7 / 2.8 m, estimated 1.73-1.81 / 2.71-2.74 m; max mass error after 10 s at 2.8 m 3.9 % and
    4.3 % with the bank, 11.3 % and 19.0 % with one pendulum)."""
    from dataclasses import replace

    from uuom_gym.sim.point_mass import point_mass_scenario, simulate_point_mass

    for chain_m in (1.7, 2.8):
        tr = simulate_point_mass(replace(point_mass_scenario("pm-section1"), chain_length_m=chain_m), seed=0)
        k = tr["t_s"] >= 10.0
        errors = {}
        # the one pendulum as measured then, before session 63's window_weak_spread_rad (with it: 7.6 % at 2.8 m)
        before_63 = {"window_weak_spread_rad": 0.0} if name == "dffrls-aekf" else {}
        for label, options in (("bank", {}), ("one", {"chain_length_factors": (), **before_63})):
            est = estimators.make(name, **options)
            s = est.run(tr)
            errors[label] = float(np.max(np.abs(s.mass_kg[k] / tr["mass_kg"][k] - 1.0))) * 100.0
            if label == "bank":
                for member in getattr(est, "members", [est]):
                    assert member.chain_length_estimate_m == pytest.approx(chain_m, abs=0.2)
                    w = member.chain_weights
                    assert w.shape == (5,) and w.sum() == pytest.approx(1.0) and np.all(w >= 0.0)
            else:
                assert getattr(est, "members", [est])[0].chain_weights.tolist() == [1.0]
        if chain_m > 2.5:
            # the one pendulum's failure the bank removes (`dffrls-aekf`'s one pendulum: 11.1 % before session 27's
            # evidence threshold of the geometry bank, 8.4 % with it; the bank's 0.9 -> 1.0 %)
            assert errors["bank"] < 6.0 and errors["one"] > 8.0 and errors["one"] > 2.0 * errors["bank"]
        else:
            # fused 5.7 % since session 63's slope_var_weight (2.5 % before; its one pendulum 5.9 %): on this climb the
            # samples it learns from are the ones read while the grade is uncertain (docs/estimation.md, session 63)
            assert errors["bank"] < (4.0 if name == "dffrls-aekf" else 6.5)


@pytest.mark.parametrize("options, what", [
    ({"chain_length_factors": (1.0, math.nan)}, "chain_length_factors"),
    ({"chain_length_factors": (1.0, -0.5)}, "chain_length_factors"),
    ({"chain_length_factors": tuple(0.5 + 0.1 * k for k in range(kern.MAX_CHAINS + 1))}, "chain_length_factors"),
    ({"chain_length_factors": 2.0}, "chain_length_factors"),
    ({"chain_prior_std": 0.0}, "chain_prior_std"),
    ({"chain_prior_std": math.nan}, "chain_prior_std"),
])
def test_chain_bank_options_are_checked(options: dict, what: str) -> None:
    with pytest.raises(ValueError, match=what):
        estimators.make("dffrls-aekf", **options)


@pytest.mark.parametrize("name, options, what", [
    ("dffrls-aekf", {"weak_offset_random_walk": "false"}, "weak_offset_random_walk must be True or False"),
    ("dffrls-aekf", {"gates": 1}, "gates must be True or False"),
    ("fused", {"fused_spread_gate": None}, "fused_spread_gate must be True or False"),
    ("dffrls-aekf-paper", {"adapt_means": "no"}, "adapt_means must be True or False"),
    ("dffrls", {"vector_forgetting": 0}, "vector_forgetting must be True or False"),
])
def test_switches_take_only_true_or_false(name: str, options: dict, what: str) -> None:
    """A switch given anything but a bool is refused, naming it: the string "false" is truthy in Python, and
    ``uuom-estimate --option gates=false`` had silently meant True."""
    with pytest.raises(ValueError, match=what):
        estimators.make(name, **options)
    assert estimators.make(name, **{k: np.bool_(False) for k in options}) is not None  # NumPy's bool is a bool


def test_env_observer_is_told_the_plants_chains() -> None:
    """The env's plant hangs its load on the vehicle file's chains: its observers run one pendulum of that length
    (the bank is for data whose chains are unknown), unless the options state the swing themselves."""
    from uuom_core.vehicle import VehicleParams
    from uuom_gym.envs.observers import make_observer

    v = VehicleParams()
    for name in ("dffrls-aekf", "fused"):
        est = make_observer(name, v).estimator
        for member in getattr(est, "members", [est]):
            assert member.C[kern.N_CHAIN] == 0.0 and member.C[kern.CHAIN_L] == v.chain_length_m
    est = make_observer("fused", v, {"chain_prior_std": 1.0}).estimator
    assert est.C[kern.N_CHAIN] == 5.0
    one = estimators.make("fused", chain_length_factors=(1.25,))  # one factor: one pendulum on 1.25 x the file's
    assert one.C[kern.N_CHAIN] == 0.0 and one.C[kern.CHAIN_L] == pytest.approx(1.25 * v.chain_length_m)


def test_env_observer_keeps_the_two_state_slope_layer() -> None:
    """Offline ``dffrls-aekf`` carries the grade's curvature; the env's plant, where it was neutral to worse on the
    tuning runs, keeps the two-state slope layer unless the options ask for it; so does ``fused`` (offline it has
    carried the curvature state since session 62, the env's episodes were made without it)."""
    from uuom_core.vehicle import VehicleParams
    from uuom_gym.envs.observers import make_observer

    v = VehicleParams()
    assert all(m.C[kern.CURV_VAR_M] > 0.0 for m in estimators.make("dffrls-aekf").members)
    assert estimators.make("fused").C[kern.CURV_VAR_M] == pytest.approx(0.01**2)
    assert make_observer("fused", v).estimator.C[kern.CURV_VAR_M] == 0.0
    in_env = make_observer("dffrls-aekf", v).estimator
    assert all(m.C[kern.CURV_VAR_M] == 0.0 for m in getattr(in_env, "members", [in_env]))
    asked = make_observer("dffrls-aekf", v, {"grade_curvature_std": 0.02}).estimator
    assert all(m.C[kern.CURV_VAR_M] == pytest.approx(0.02**2) for m in getattr(asked, "members", [asked]))
    # the mass gate the RL tables were computed with (session 22 lowered the offline default to 0.03 m/s²)
    assert all(m.C[kern.MIN_ACC] == 0.05 for m in getattr(in_env, "members", [in_env]))
    asked = make_observer("dffrls-aekf", v, {"min_accel_mps2": 0.03}).estimator
    assert all(m.C[kern.MIN_ACC] == 0.03 for m in getattr(asked, "members", [asked]))


@pytest.mark.parametrize("scenario", ["pm-section1", "pm-roadtest"])
def test_accel_regressor_and_curvature_remove_the_slope_lag_on_clean_data(scenario: str) -> None:
    """On a point-mass trace without sensor noise or bias, the two-state slope layer (a random walk on θ) lags the
    grade changes and the regression reads the lag as mass: 4.3-4.6 % off after 10 s. Either cure removes most of it:
    ``accel_regressor`` (the gravity term from the accelerometer; off by default: with the sensors' noise it loses,
    docs/estimation.md session 20) < 2.5 %, the curvature state (``grade_curvature_std``, session 21) < 3 %."""
    from estimators.metrics import error_after_settling
    from uuom_gym.sim.point_mass import PointMassSensors, point_mass_scenario, simulate_point_mass, with_options

    assert estimators.make("dffrls-aekf").members[0].C[kern.ACC_REG] == 0.0
    assert estimators.make("dffrls-aekf", accel_regressor=True, use_accel=False).members[0].C[kern.ACC_REG] == 0.0

    tr = simulate_point_mass(with_options(point_mass_scenario(scenario), sensors=PointMassSensors.perfect()), seed=0)
    variants = {"two-state": {"grade_curvature_std": 0.0},
                "accel_regressor": {"grade_curvature_std": 0.0, "accel_regressor": True},
                "curvature": {"grade_curvature_std": 0.01}}
    # the mass gate of sessions 19-21 (0.05 m/s² in both members): the point member then learns only in the
    # accelerations, where the lag shows (session 22's gate also learns at constant speed: next test)
    gate = {"min_accel_mps2": 0.05, "point_min_accel_mps2": None}
    errs, slope = {}, {}
    for label, options in variants.items():
        s = estimators.make("dffrls-aekf", **options, **gate).run(tr)
        errs[label] = error_after_settling(tr["t_s"], s.mass_kg, tr["mass_kg"], 10.0, relative=True).max_abs
        slope[label] = error_after_settling(tr["t_s"], s.slope_deg, tr["slope_deg"], 10.0).rmse
    assert errs["accel_regressor"] < 2.5 < 3.5 < errs["two-state"], errs
    assert errs["curvature"] < 3.0, errs
    assert slope["curvature"] < 0.6 * slope["two-state"], slope  # the lag gone from the slope too


@pytest.mark.parametrize("scenario", ["pm-section1", "pm-roadtest", "pm-resistance-mismatch"])
def test_mass_gate_of_session_22(scenario: str) -> None:
    """Session 22's mass gate: 0.03 m/s² (was 0.05), and the point-mass member (slope for gravity = the one measured
    under the sensors) corrects its mass also below it, at constant speed, where a grade change excites the
    regression -- those samples counted 10x noisier (``weak_accel_noise_factor``: they are correlated over ~100
    samples and carry the grade's level and the offset's prior more than new information). On clean point-mass
    traces the max mass error after 10 s falls from 2.4-3.9 % (the old gate) to 1.2-2.6 %."""
    from estimators.metrics import error_after_settling
    from uuom_gym.sim.point_mass import PointMassSensors, point_mass_scenario, simulate_point_mass, with_options

    bank = estimators.make("dffrls-aekf")
    assert [(m.C[kern.MIN_ACC], m.C[kern.WEAK_ACC], m.C[kern.WEAK_R]) for m in bank.members] == [
        (0.0, 0.03, 10.0), (0.03, 0.03, 10.0)]  # the window member's band is its uniform grades (next test)
    assert estimators.make("dffrls-aekf", train_length_m=12.0).single.C[kern.MIN_ACC] == 0.03
    assert estimators.make("dffrls-aekf", train_length_m=0.0, point_min_accel_mps2=None).single.C[kern.MIN_ACC] == 0.03
    assert estimators.make("fused").C[kern.MIN_ACC] == 0.03  # since session 63 (0.05 before; the env keeps 0.05)
    for bad in (-0.1, math.nan, math.inf, True, "0"):
        with pytest.raises(ValueError, match="point_min_accel_mps2"):
            estimators.make("dffrls-aekf", point_min_accel_mps2=bad)
    for bad in (0.5, math.nan, -1.0):
        with pytest.raises(ValueError, match="weak_accel_noise_factor"):
            estimators.make("dffrls-aekf", weak_accel_noise_factor=bad)

    tr = simulate_point_mass(with_options(point_mass_scenario(scenario), sensors=PointMassSensors.perfect()), seed=0)
    errs = {}
    for label, options in {"now": {}, "before": {"min_accel_mps2": 0.05, "point_min_accel_mps2": None}}.items():
        s = estimators.make("dffrls-aekf", **options).run(tr)
        errs[label] = error_after_settling(tr["t_s"], s.mass_kg, tr["mass_kg"], 10.0, relative=True).max_abs
    assert errs["now"] < 3.0 and errs["now"] < 0.8 * errs["before"], errs


def test_curvature_state_follows_a_vertical_curve_and_keeps_its_covariance_pd(faulty: Trace) -> None:
    """The third state of the slope layer: on a noise-free ramp of the grade (1 deg per 10 m, a vertical curve) the
    two-state layer trails the grade (0.02 deg), the curvature state does not (< 1e-5 deg); on faulty data its 3x3
    covariance stays SPD."""
    from estimators.dffrls_aekf import DFFRLSAEKF
    from uuom_gym.sim.point_mass import (GradeProfile, PointMassScenario, PointMassSensors, SpeedPlan,
                                         simulate_point_mass)

    sc = PointMassScenario("ramp", GradeProfile(((0, 0.0), (10, 0.0), (60, 5.0), (400, 5.0))),
                           SpeedPlan(((0.0, 1.0),)), 10_000.0, duration_s=70.0, sensors=PointMassSensors.perfect())
    tr = simulate_point_mass(sc, seed=0)
    on_ramp = (tr["position_m"] > 20.0) & (tr["position_m"] < 55.0)
    lag = {}
    for k in (0.0, 0.01):
        est = DFFRLSAEKF(train_length_m=0.0, grade_curvature_std=k)
        s = est.run(tr)
        lag[k] = float(np.mean(tr["slope_deg"][on_ramp] - s.slope_deg[on_ramp]))
        assert est.slope_P.shape == ((3, 3) if k else (2, 2))
    assert lag[0.0] > 0.01 and abs(lag[0.01]) < 0.1 * lag[0.0], lag

    est = DFFRLSAEKF(train_length_m=0.0, grade_curvature_std=0.01)
    t = faulty["t_s"]
    dts = np.diff(t, prepend=t[0] - 0.005)
    for i in range(len(t)):
        est.update(faulty["torque_nm"][i], faulty["speed_mps"][i], faulty["accel_mps2"][i], dts[i])
        if i % 11 == 0:
            P = est.slope_P
            assert np.all(np.isfinite(P)) and np.array_equal(P, P.T) and np.linalg.eigvalsh(P).min() > 0.0
    assert abs(est.S[kern.KAP]) <= est.config.max_curvature_per_m


def _worst_mass_error(tr, name: str = "dffrls-aekf", **options) -> float:
    """Max |relative mass error| after 10 s of estimator ``name`` with ``options`` on ``tr``."""
    k = tr["t_s"] >= 10.0
    s = estimators.make(name, **options).run(tr)
    return float(np.max(np.abs(s.mass_kg[k] / tr["mass_kg"][k] - 1.0)))


def test_a_frozen_accelerometer_is_dropped() -> None:
    """pm-sensor-faults, sensor seed 1: the accelerometer freezes for 3 s at 30 s; without the detector the geometry
    bank's weights turn to the 12 m window and its mass takes the next deceleration (measured 17.8 % max error after
    10 s, 3.2 % with the detector); the detector's rule is ``estimators.input_faults.StuckDetector``'s."""
    from uuom_gym.sim.point_mass import simulate_point_mass

    tr = simulate_point_mass("pm-sensor-faults", seed=1)
    worst = {n: _worst_mass_error(tr, stuck_repeats=n) for n in (0, 20)}
    assert worst[20] < 0.06 < 0.10 < worst[0]
    with pytest.raises(ValueError, match="stuck_repeats"):
        estimators.make("dffrls-aekf", stuck_repeats=-1)


def test_accelerometer_spikes_are_held_back_by_the_jump_gate() -> None:
    """The point-mass road test with +-4 m/s^2 accelerometer spikes (0.2 % of the samples, inside the plausibility
    gate): sensor seed 4 measured 6.7 % max mass error without the jump gate and 2.2 % with it, as without spikes."""
    from uuom_gym.sim.point_mass import PointMassFaults, simulate_point_mass, with_options

    clean = simulate_point_mass("pm-roadtest", seed=4)
    faults = PointMassFaults(spike_prob=0.002, spike_scale={"torque_nm": 0.0, "speed_mps": 0.0, "accel_mps2": 4.0})
    spiky = simulate_point_mass(with_options("pm-roadtest", faults=faults), seed=4)
    gated = _worst_mass_error(spiky)
    assert gated < _worst_mass_error(clean) + 0.01
    assert gated + 0.02 < _worst_mass_error(spiky, accel_jump_mps2=0.0)
    with pytest.raises(ValueError, match="accel_jump_mps2"):
        estimators.make("dffrls-aekf", accel_jump_mps2=-1.0)
    with pytest.raises(ValueError, match="torque_jump_fraction"):
        estimators.make("dffrls-aekf", torque_jump_fraction=math.inf)


def test_torque_spikes_on_the_plant_give_back_the_clean_run() -> None:
    """The protocol's plant road test with +-6000 N m spikes (0.5 % of the samples): with the torque's jump gate the
    mass follows the clean run's (measured RMSE after 10 s 7.2 % clean, 7.6 % gated, 4.1 % with the spikes: random
    force noise happens to soften the road test's brake-release error; docs/estimation.md, session 24)."""
    from dataclasses import replace

    from uuom_gym.sim.protocol_runs import make_run, protocol_runs

    spec = next(s for s in protocol_runs(0, 0, paper_seeds=0, fault_seeds=1) if s.name == "fault-spikes-plant-s0")
    clean, spiky = make_run(replace(spec, fault="")), make_run(spec)
    k = clean["t_s"] >= 10.0
    ref = estimators.make("dffrls-aekf").run(clean).mass_kg[k]
    for tr, options, near in ((spiky, {}, True), (spiky, {"torque_jump_fraction": 0.0}, False)):
        m = estimators.make("dffrls-aekf", **options).run(tr).mass_kg[k]
        assert bool(np.sqrt(np.mean((m - ref) ** 2)) / ref.mean() < 0.01) is near


def test_a_missing_speed_sample_does_not_pause_the_regression_filters() -> None:
    """2 % speed dropouts on the point-mass road test, sensor seed 5: a paused speed low-pass reads a too large dv/dt
    after each dropout and the mass too small (measured -2.4 % max error; +0.7 % without dropouts, -0.9 % with the
    missing samples filled by the slope layer's predicted speed)."""
    from uuom_gym.sim.point_mass import PointMassFaults, simulate_point_mass, with_options

    clean = simulate_point_mass("pm-roadtest", seed=5)
    drop = simulate_point_mass(with_options("pm-roadtest", faults=PointMassFaults(dropout_prob=0.02)), seed=5)
    cols = dict(clean.columns)
    cols["speed_mps"] = drop["speed_mps"]  # the speed's dropouts alone
    tr = Trace(cols, source="speed dropouts", meta=dict(clean.meta))
    filled, paused = _worst_mass_error(tr), _worst_mass_error(tr, fill_missing_speed=False)
    assert filled < _worst_mass_error(clean) + 0.005 < paused


def test_fused_holds_its_mass_on_a_grade_change() -> None:
    """The point-mass road test, sensor seed 0: without the spread gate on its mass ``fused`` read the slope layer's
    lag at the top of the 11 deg climb as mass (measured 8.0 % max error after 10 s; 4.2 % with the gate). Shown on
    the two-state slope layer it was measured with: since session 62 ``fused``'s curvature state follows that climb
    without the lag, and the gate changes nothing on this trace (4.5 % either way)."""
    from uuom_gym.sim.point_mass import simulate_point_mass

    tr = simulate_point_mass("pm-roadtest", seed=0)
    assert _worst_mass_error(tr, "fused") < 0.05
    worst = {gate: _worst_mass_error(tr, "fused", fused_spread_gate=gate, grade_curvature_std=0.0)
             for gate in (False, True)}
    assert worst[True] < 0.05 < 0.07 < worst[False]


def test_env_tells_its_observers_their_sensors_have_no_faults() -> None:
    import gymnasium as gym

    import uuom_gym  # noqa: F401
    from uuom_gym.sim.sensors import FaultConfig

    for name in ("dffrls-aekf", "fused"):
        assert estimators.make(name).config.stuck_repeats == 20
        env = gym.make("UUOM-Track-v0", observer=name)
        cfg = env.unwrapped.observer.estimator.config
        assert cfg.stuck_repeats == 0 and cfg.accel_jump_mps2 == cfg.torque_jump_fraction == 0.0  # nothing to detect
        faulty = gym.make("UUOM-Track-v0", observer=name, sensor_faults=FaultConfig(spike_prob=0.01))
        cfg = faulty.unwrapped.observer.estimator.config
        assert cfg.stuck_repeats == 20 and cfg.accel_jump_mps2 == 0.5 and cfg.torque_jump_fraction == 0.15
    assert estimators.make("fused").config.fused_spread_gate  # offline; the env keeps the mass it was trained with
    assert not gym.make("UUOM-Track-v0", observer="fused").unwrapped.observer.estimator.config.fused_spread_gate
    other_gate = gym.make("UUOM-Track-v0", observer="fused", observer_options={"min_accel_mps2": 0.04})
    assert not other_gate.unwrapped.observer.estimator.config.fused_spread_gate  # a mass-gate option of its own
    # the blend as the RL tables' fused rows had it (PLANT_BLEND_OPTIONS), unless the observer options say otherwise
    assert not gym.make("UUOM-Track-v0", observer="fused").unwrapped.observer.estimator.config.blend_from_start
    stated = gym.make("UUOM-Track-v0", observer="fused", observer_options={"blend_from_start": True})
    assert stated.unwrapped.observer.estimator.config.blend_from_start


def test_window_member_learns_at_constant_speed_on_a_uniform_grade() -> None:
    """Session 63: a window member counts a constant-speed sample as a weak one (10x noisier) while its window's grade
    spread is under ``window_weak_spread_rad`` (0.001 rad): on a uniform grade its slope for gravity is the point
    member's. Off, a 12 m filter holds its mass through 50 s of level track at 0.5 m/s (point-mass heavy downhill,
    protocol sensors, seed 7); on, it keeps learning. Where the bank's evidence cannot choose between its members
    (uniform grades) it had mixed a learning point member with a frozen window member: on two clean point-mass
    scenarios (sensor seed 4) the bank's max mass error after 10 s falls by more than half a point. The env's 12 m
    filter keeps it off."""
    from estimators.metrics import error_after_settling
    from uuom_core.vehicle import VehicleParams
    from uuom_gym.envs.observers import make_observer
    from uuom_gym.sim.protocol_runs import make_run, protocol_runs

    assert estimators.make("dffrls-aekf").members[1].C[kern.WIN_WEAK] == 0.001
    assert estimators.make("dffrls-aekf").members[0].C[kern.WIN_WEAK] == 0.0  # the point member has its own band
    for bad in (-0.1, math.nan, math.inf, True):
        with pytest.raises(ValueError, match="window_weak_spread_rad"):
            estimators.make("dffrls-aekf", window_weak_spread_rad=bad)
    env_est = make_observer("dffrls-aekf", VehicleParams()).estimator
    assert all(f.C[kern.WIN_WEAK] == 0.0 for f in ([env_est.single] if env_est.single is not None else env_est.members))

    specs = {s.scenario: s for s in protocol_runs(0, 0, paper_seeds=1, fault_seeds=0) if s.world == "point"}
    tr = make_run(specs["pm-heavy-downhill"].with_sensor_seed(7))
    level = (tr["t_s"] > 10.0) & (tr["t_s"] < 60.0)
    off = estimators.make("dffrls-aekf", train_length_m=12.0, window_weak_spread_rad=0.0).run(tr).mass_kg[level]
    on = estimators.make("dffrls-aekf", train_length_m=12.0).run(tr).mass_kg[level]
    assert np.ptp(off) < 1e-6 * off[0] and np.ptp(on) > 1e-4 * on[0]  # frozen, and learning (slowly: 10x noisier)
    for scenario in ("pm-section1", "pm-roadtest"):
        tr = make_run(specs[scenario].with_sensor_seed(4))
        mass = {w: estimators.make("dffrls-aekf", window_weak_spread_rad=w).run(tr).mass_kg for w in (0.0, 0.001)}
        err = {w: error_after_settling(tr["t_s"], m, tr["mass_kg"], 10.0, relative=True).max_abs for w, m in mass.items()}
        assert err[0.001] < err[0.0] - 0.5, (scenario, err)
