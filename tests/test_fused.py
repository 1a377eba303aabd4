"""``fused`` (issue 10 item 1): the learned gravity blend makes one observer good on both simulators, the pymunk
plant (an 18 m train, gravity spread behind the sensors) and the point-mass world (gravity at one point). Loose
accuracy bounds on a few seeded runs, not timings. Kernel robustness and the compiled-vs-reference check are in
``tests/test_dffrls_aekf.py`` (parametrised over ``fused``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import estimators


def _errors(tr, s) -> tuple[float, float]:
    k = tr["t_s"] >= tr["t_s"][0] + 10.0
    m = tr["mass_kg"][k]
    ref = tr.columns.get("effective_slope_deg", tr["slope_deg"])[k]
    return (float(np.max(np.abs(s.mass_kg[k] - m) / m)) * 100.0,
            float(np.sqrt(np.mean((s.slope_deg[k] - ref) ** 2))))


def test_registered_with_its_extras() -> None:
    est = estimators.make("fused")
    assert "fused" in estimators.available() and est.config.fused
    e = est.update(3000.0, 0.5, 0.1, 0.005)
    assert set(e.extras) == {"mu", "mu_std", "gravity_weight_sensor", "nis"}
    assert 0.0 <= e.extras["gravity_weight_sensor"] <= 1.0
    with pytest.raises(ValueError, match="fused"):
        estimators.make("fused", offset_forgetting_ratio=0.0)


@pytest.mark.slow
@pytest.mark.parametrize("scenario", ["pm-section1", "pm-resistance-mismatch"])
def test_point_mass_world_learns_gravity_at_the_sensors(scenario: str) -> None:
    from uuom_gym.sim.point_mass import simulate_point_mass

    tr = simulate_point_mass(scenario, seed=2)
    fused = estimators.make("fused").run(tr)
    # the fixed 14 m window (the registered dffrls-aekf has learnt where gravity acts since session 8, so it is no
    # longer the comparison this test makes; against it the test had failed since)
    window = estimators.make("dffrls-aekf", train_length_m=14.0).run(tr)
    mass, slope = _errors(tr, fused)
    # measured (session 58, seed 2): pm-section1 0.7 % / 0.09 deg, pm-resistance-mismatch 7.4 % / 0.10 deg; the
    # fixed 14 m window 1.30 / 1.32 deg
    assert mass < 20.0 and slope < 0.4
    assert slope < 0.5 * _errors(tr, window)[1]
    assert fused.extras["gravity_weight_sensor"][-1] > 0.7


@pytest.mark.slow
def test_plant_section1() -> None:
    from uuom_gym.sim.recording import simulate_run

    tr = simulate_run("section1", seed=2)
    s = estimators.make("fused").run(tr)
    mass, slope = _errors(tr, s)
    assert mass < 6.0 and slope < 1.0
    assert np.all(np.isfinite(s.slope_std_rad)) and np.all(s.slope_std_rad >= math.radians(0.1))


def test_env_and_cli_accept_fused(tmp_path) -> None:
    gym = pytest.importorskip("gymnasium")
    import uuom_gym  # noqa: F401  (registers the env)

    env = gym.make("UUOM-Track-v0", observer="fused")
    env.reset(seed=0)
    for _ in range(3):
        env.step(env.action_space.sample())
    env.close()


def test_blend_gate_holds_the_mass_while_the_blend_is_uncertain() -> None:
    # the fault-recovery trace with a 3 s dropout (tests/test_estimators_faults.py): after the restart the blend's
    # variance is wide again and the grades differ, so without the gate the mass re-learns from the restart's
    # transient (measured: 3.4 t off the clean run 12-27 s later; with the gate 410 kg). Shown with one pendulum on
    # the vehicle file's chains, the model of session 10's measurement; this trace's load is rigid, and with the
    # chain-length bank (session 19) both runs sit 3-6 t low, a baseline the gate cannot be judged against
    from estimators.fault_injection import inject, run_outputs, seven_channel_rows

    assert estimators.make("fused").config.max_geometry_ambiguity_rad == 0.002
    rows = seven_channel_rows(26_000.0, 40.0, 0.005, seed=3)
    bad = inject(rows, "dropout", 2000, 2600)
    scored = slice(5000, None)

    def drift(**options: float) -> float:
        options = {"chain_length_factors": (), **options}
        clean = run_outputs("fused", rows, **options)["mass"][scored]
        return float(np.mean(np.abs(run_outputs("fused", bad, **options)["mass"][scored] - clean)))

    # measured with the mass learning on grade changes, as in session 10; since session 24 the spread gate on the
    # mass (fused_spread_gate) holds it there too, so either gate alone keeps the restart's transient out. Shown on the
    # two-state slope layer of those sessions: since session 62 fused's curvature state follows the grade without
    # that lag, and the transient without either gate stays under the bound too (412 kg), so it cannot show the gates.
    # Those sessions' fused also counted no grade variance in its mass noise (slope_var_weight 0, session 63; with it
    # on the two-state layer the default drifts 677 kg, a combination no default or env setting uses)
    assert drift() < 520.0
    two_state = {"grade_curvature_std": 0.0, "slope_var_weight": 0.0}
    assert drift(**two_state) < 520.0 < drift(max_geometry_ambiguity_rad=math.inf, fused_spread_gate=False, **two_state)
    assert drift(max_geometry_ambiguity_rad=math.inf, **two_state) < 520.0


def test_blend_learns_from_the_first_metre() -> None:
    """pm-section2, sensor seed 0: the grade changes from the start. Waiting for a slope window of measured slopes
    only (sessions 1-24) left alpha at its prior for the first 12 m and the slope output half the window's lagging
    average (measured: alpha 0.49 at 10 s, slope RMSE 1.11 deg over 5-20 s; learning from the first metre: 0.97,
    0.15 deg)."""
    from uuom_gym.sim.point_mass import simulate_point_mass

    tr = simulate_point_mass("pm-section2", seed=0)
    t = tr["t_s"]
    early = (t >= 5.0) & (t < 20.0)
    i10 = int(np.searchsorted(t, 10.0))

    def blend_and_slope(**options: bool) -> tuple[float, float]:
        s = estimators.make("fused", **options).run(tr)
        rmse = float(np.sqrt(np.mean((s.slope_deg[early] - tr["slope_deg"][early]) ** 2)))
        return float(s.extras["gravity_weight_sensor"][i10]), rmse

    assert estimators.make("fused").config.blend_from_start
    alpha, slope = blend_and_slope()
    alpha_late, slope_late = blend_and_slope(blend_from_start=False)
    assert alpha > 0.8 > 0.6 > alpha_late
    assert slope < 0.3 < 0.8 < slope_late


def test_early_blend_only_leans() -> None:
    """Plant tuning run 1057 starts across a crest: in the first 14 m the window's start-up guess is wrong and alpha
    learns 0.3 -> 1.0 in 3 s at the head of a descent, after which no sample with a measured drive force comes. Once
    the window holds measured slopes, alpha keeps half of that early move (measured: alpha at the end 0.75 and slope
    RMSE 2.31 deg; the whole move kept: 1.00 and 2.73 deg)."""
    from estimators.metrics import train_slope_deg
    from uuom_gym.sim.protocol_runs import RunSpec, make_run

    tr = make_run(RunSpec("plant", "plant-1057", 1057, 1057, "plant"))
    k = tr["t_s"] >= 10.0
    ref = train_slope_deg(tr)

    def blend_and_slope(**options: float) -> tuple[float, float]:
        s = estimators.make("fused", **options).run(tr)
        return (float(s.extras["gravity_weight_sensor"][-1]),
                float(np.sqrt(np.mean((s.slope_deg[k] - ref[k]) ** 2))))

    assert estimators.make("fused").config.early_blend_kept == 0.5
    assert blend_and_slope()[0] < 0.8
    # shown with the mass noise of session 25 (since session 63 the grade's variance in it keeps alpha's early move
    # smaller: 0.90 with the whole move kept)
    s25 = {"slope_var_weight": 0.0, "min_accel_mps2": 0.05}
    (alpha, slope), (alpha_all, slope_all) = blend_and_slope(**s25), blend_and_slope(early_blend_kept=1.0, **s25)
    assert alpha < 0.8 < 0.95 < alpha_all
    assert slope < slope_all - 0.2
    with pytest.raises(ValueError, match="early_blend_kept"):
        estimators.make("fused", early_blend_kept=1.5)


def test_blend_learns_only_where_the_two_slopes_differ() -> None:
    """pm-resistance-mismatch, sensor seed 3, every sensor imperfection x2: 48 s of level track, then a grade. On the
    level the blend's regressor (the slope under the sensors minus the window's) is the slope layer's noise alone;
    fitting it pulls the blend towards the window and shrinks its variance, so at the grade's onset the mass took the
    window's lag (measured: max error 16.8 %, blend 0.19 at 50.5 s). Learning only where the slopes differ by
    ``evidence_min_disagreement_rad`` (0.002 rad): 6.0 %, blend 0.29. Measured with the two-state slope layer of that
    session; with the curvature state (session 62) the gate still halves the mass error (10.7 against 18.7 %), the
    blend 0.20 against 0.16."""
    from uuom_gym.sim.point_mass import simulate_point_mass, with_sensor_scale

    tr = simulate_point_mass(with_sensor_scale("pm-resistance-mismatch", 2.0), seed=3)
    i = int(np.searchsorted(tr["t_s"], 50.5))
    k = tr["t_s"] >= 10.0
    est = estimators.make("fused")
    assert est.config.evidence_min_disagreement_rad == pytest.approx(0.002)

    def max_error(s) -> float:
        return float(np.max(np.abs(s.mass_kg[k] / tr["mass_kg"][k] - 1.0)))

    assert max_error(est.run(tr)) < 0.13
    # shown with the mass noise and gate of session 27 (session 63's grade variance in the noise and 0.03 m/s² gate:
    # the blend's lag at the onset teaches the mass little either way)
    s27 = {"slope_var_weight": 0.0, "min_accel_mps2": 0.05}
    gated = estimators.make("fused", **s27).run(tr)
    every = estimators.make("fused", evidence_min_disagreement_rad=0.0, **s27).run(tr)
    assert max_error(gated) < 0.13 and max_error(every) > 0.16
    two_state = {"grade_curvature_std": 0.0, **s27}
    gated = estimators.make("fused", **two_state).run(tr)
    every = estimators.make("fused", evidence_min_disagreement_rad=0.0, **two_state).run(tr)
    assert gated.extras["gravity_weight_sensor"][i] > every.extras["gravity_weight_sensor"][i] + 0.05
    assert max_error(gated) < 0.09 and max_error(every) > 0.14


def test_env_keeps_the_blend_learning_on_every_sample() -> None:
    import gymnasium as gym

    import uuom_gym  # noqa: F401  (registers the env ids)

    env = gym.make("UUOM-Track-v0", observer="fused")
    assert env.unwrapped.observer.estimator.config.evidence_min_disagreement_rad == 0.0
    stated = gym.make("UUOM-Track-v0", observer="fused", observer_options={"evidence_min_disagreement_rad": 0.002})
    assert stated.unwrapped.observer.estimator.config.evidence_min_disagreement_rad == pytest.approx(0.002)
    # stating one blend option keeps the other's env value
    blend = gym.make("UUOM-Track-v0", observer="fused", observer_options={"blend_from_start": True})
    assert blend.unwrapped.observer.estimator.config.blend_from_start
    assert blend.unwrapped.observer.estimator.config.evidence_min_disagreement_rad == 0.0


def test_offline_fused_carries_the_curvature_state_and_the_env_keeps_it_off() -> None:
    """Session 62: ``fused``'s slope layer has ``dffrls-aekf``'s curvature state offline (chosen on the plant's tuning
    runs, docs/estimation.md); the env's observer keeps the two-state layer its episodes were made with, unless the
    observer options say otherwise."""
    import gymnasium as gym

    import uuom_gym  # noqa: F401  (registers the env ids)

    assert estimators.make("fused").config.grade_curvature_std == pytest.approx(0.01)
    env = gym.make("UUOM-Track-v0", observer="fused")
    assert env.unwrapped.observer.estimator.config.grade_curvature_std == 0.0
    stated = gym.make("UUOM-Track-v0", observer="fused", observer_options={"grade_curvature_std": 0.01})
    assert stated.unwrapped.observer.estimator.config.grade_curvature_std == pytest.approx(0.01)


def test_slope_variance_weights_the_mass_samples() -> None:
    """Session 63: ``fused`` adds the slope layer's grade variance to its mass regression's per-sample noise,
    ``k c² g² P22`` with ``k = slope_var_weight = 30`` (chosen on plant tuning runs 1000-1399), so a sample read while
    the slope layer is unsure of the grade teaches the mass less. Two seeded point-mass evaluation runs (12 and 17:
    measured 17.9 -> 8.3 % and 13.1 -> 6.6 % max mass error after 10 s at the 0.05 m/s² gate; with the 0.03 m/s² gate
    of the same session 11.6 and 7.0 %) lose more than a third of their error; the
    option is validated; ``dffrls-aekf`` and the env's ``fused`` keep it at 0."""
    from estimators import dffrls_aekf_kernel as kern
    from estimators.metrics import error_after_settling
    from uuom_core.vehicle import VehicleParams
    from uuom_gym.envs.observers import make_observer
    from uuom_gym.sim.protocol_runs import RunSpec, make_run

    assert estimators.make("fused").C[kern.SLOPE_VAR_W] == 30.0
    assert all(m.C[kern.SLOPE_VAR_W] == 0.0 for m in estimators.make("dffrls-aekf").members)
    assert make_observer("fused", VehicleParams()).estimator.C[kern.SLOPE_VAR_W] == 0.0
    for bad in (-1.0, math.nan, math.inf, True):
        with pytest.raises(ValueError, match="slope_var_weight"):
            estimators.make("fused", slope_var_weight=bad)
    # at the 0.05 m/s² mass gate it was chosen with (since the same session fused's gate is 0.03: "now")
    variants = {"session 62": {"slope_var_weight": 0.0, "min_accel_mps2": 0.05},
                "weight": {"slope_var_weight": 30.0, "min_accel_mps2": 0.05}, "now": {}}
    for i in (12, 17):
        tr = make_run(RunSpec("point", f"point-{i:03d}", i, i, "point"))
        runs = {label: estimators.make("fused", **o).run(tr) for label, o in variants.items()}
        err = {label: error_after_settling(tr["t_s"], s.mass_kg, tr["mass_kg"], 10.0, relative=True).max_abs
               for label, s in runs.items()}
        assert err["weight"] < 0.67 * err["session 62"] and err["now"] < 0.7 * err["session 62"], (i, err)
        # the reported σ inflates only the white share of the noise for correlation (the grade's share is counted
        # already): its median after 10 s stays well under the prior's 12 t (measured 5.7 / 5.5 t at k = 30; counted
        # twice it sat at the prior's cap)
        assert np.median(runs["weight"].mass_std_kg[tr["t_s"] >= 10.0]) < 0.6 * 12_000.0
