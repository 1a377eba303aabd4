"""Property-based fuzzing of every registered estimator's ``update()`` (issue 12).

Hypothesis draws a clean, physically plausible sample stream and injects faults into it: any input (torque, ground
speed, specific force, motor speed, gyro, normal accelerometer) set to NaN, +-inf, +-1e300, 0 or a large finite
value, single samples or bursts, and any sample interval set to 0, negative, NaN, +-inf, 1e9 or 1e300. Every
estimator in :func:`estimators.available` is covered, so a new registry entry is fuzzed without editing this file.

Properties checked after every call:

* no exception, except ``ValueError`` naming ``dt`` for an invalid interval (NaN, +-inf, negative, and for the
  estimators that document it, 0); the estimator stays usable after it;
* every field of the returned :class:`~estimators.base.Estimate` (extras included) is finite and the standard
  deviations are >= 0;
* every covariance the estimator exposes (``P`` arrays, ``P11/P12/P22`` triples, also in ``mass_layer`` /
  ``slope_layer`` / ``ukf``) is finite, symmetric and positive definite (checked after each fault segment);
* no call takes longer than :data:`CALL_LIMIT_S` wall time, and a ``SIGALRM`` watchdog turns a real hang into a
  test failure instead of a stuck suite (a hang detector, not a timing test).

The default suite tries ``MAX_EXAMPLES`` fault plans per estimator; ``-m slow`` adds a 10^6-update soak per
estimator. Failures found in estimators owned elsewhere are marked ``xfail(strict=False)`` with the reason in
:data:`KNOWN_FAILURES`, so they turn into passes as soon as they are fixed; estimators in :data:`KNOWN_HANGS`
(huge ``dt`` hangs) get no huge ``dt`` in their plans and an ``xfail(run=False)`` for it in
:func:`test_extreme_but_valid_dt_then_clean` (running a hang costs a watchdog period).
"""

from __future__ import annotations

import math
import signal
import time
from collections.abc import Iterator
from contextlib import contextmanager

import numpy as np
import pytest
from hypothesis import HealthCheck, Phase, given, settings
from hypothesis import strategies as st

import estimators
from uuom_core.vehicle import DEFAULT_VEHICLE, G_MPS2

CALL_LIMIT_S = 5.0
"""Wall-time bound of one ``update()`` call: a hang detector, not a timing test (updates take microseconds; a
sub-step loop of ``ceil(dt / h)`` iterations for ``dt = 1e9`` takes hours). Generous for a loaded CI machine."""
WATCHDOG_S = 15
"""Alarm that aborts a whole example that hangs inside C code or a loop that never returns."""
MAX_EXAMPLES = 30
N_CLEAN = 120  # samples of the clean stream (0.6 s at 200 Hz) around the faults

# Failures found in estimators this suite's author does not own (reported; docs/robustness.md). They turn into
# passes (xfail is not strict) as soon as they are fixed; then delete the entry.
# (Empty now: the huge-dt hangs of rls/ffrls/dffrls/rls-ekf/sf-kf and the NaN slope of rls-ekf after +-inf speed,
# found by this suite, were fixed in 05c16dc and 7727f2b.)
KNOWN_HANGS: dict[str, str] = {}
"""Estimators that hang on a huge finite ``dt``: the fuzz plans leave 1e9 / 1e300 out for them (a hang costs a
watchdog period), and :func:`test_extreme_but_valid_dt_then_clean` records the hang as an expected failure."""
KNOWN_FAILURES: dict[str, str] = {}
HUGE_DT = (1e9, 1e300)

SPECIAL = [math.nan, math.inf, -math.inf, 1e300, -1e300, 0.0, 1e9, -1e9, 5e5, -5e5]
BAD_DT = [0.0, -0.005, -1.0, math.nan, math.inf, -math.inf, 1e9, 1e300, 1e-300, 3.0, 60.0]
FIELDS = ("torque_nm", "speed_mps", "accel_mps2", "dt_s", "motor_speed_radps", "gyro_radps", "accel_normal_mps2")

STATS = {"examples": 0, "updates": 0, "value_errors": 0}


def _names() -> list[object]:
    out: list[object] = []
    for name in estimators.available():
        reason = KNOWN_FAILURES.get(name)
        marks = [pytest.mark.xfail(strict=False, reason=reason)] if reason else []
        out.append(pytest.param(name, marks=marks, id=name))
    return out


def clean_stream(n: int, seed: int) -> np.ndarray:
    """A train pulling a part load up a mild grade at ~1 m/s, 200 Hz, with sensor noise: rows of the 7 inputs."""
    rng = np.random.default_rng(seed)
    veh = DEFAULT_VEHICLE
    mass = veh.empty_mass_kg + 0.4 * veh.rated_load_kg
    th = math.radians(2.0)
    t = np.arange(n) * 0.005
    speed = 1.0 + 0.1 * np.sin(0.5 * t)
    acc = 0.05 * np.cos(0.5 * t)
    force = mass * (G_MPS2 * (math.sin(th) + veh.running_resistance * math.cos(th)) + acc)
    r = veh.drive_wheel_radius_m
    out = np.empty((n, 7))
    out[:, 0] = force * r + 20.0 * rng.standard_normal(n)
    out[:, 1] = speed + 0.01 * rng.standard_normal(n)
    out[:, 2] = acc + G_MPS2 * math.sin(th) + 0.1 * rng.standard_normal(n)
    out[:, 3] = 0.005
    out[:, 4] = speed / r * 1.003 + 0.02 * rng.standard_normal(n)
    out[:, 5] = 1e-3 * rng.standard_normal(n)
    out[:, 6] = G_MPS2 * math.cos(th) + 0.1 * rng.standard_normal(n)
    return out


@st.composite
def fault_plans(draw: st.DrawFn, huge_dt: bool = True) -> tuple[int, list[tuple[int, int, int, float]]]:
    """A seed for the clean stream and a list of (start, length, field, value) faults."""
    seed = draw(st.integers(0, 2**16))
    bad_dt = BAD_DT if huge_dt else [v for v in BAD_DT if v not in HUGE_DT]
    faults = []
    for _ in range(draw(st.integers(1, 6))):
        field = draw(st.integers(0, 6))
        value = draw(st.sampled_from(bad_dt if field == 3 else SPECIAL))
        length = draw(st.sampled_from([1, 1, 2, 5, 40, 200]))  # single spikes and bursts
        start = draw(st.integers(0, N_CLEAN - 1))
        faults.append((start, length, field, value))
    return seed, faults


def _dt_invalid(dt: float) -> bool:
    return not (dt > 0.0 and math.isfinite(dt))


@contextmanager
def watchdog(seconds: int) -> Iterator[None]:
    def _raise(signum: int, frame: object) -> None:
        raise TimeoutError(f"estimator hung: no return within {seconds} s")

    old = signal.signal(signal.SIGALRM, _raise)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)


def _check_estimate(name: str, e: estimators.Estimate, where: str) -> None:
    values = {"mass_kg": e.mass_kg, "slope_rad": e.slope_rad, "mass_std_kg": e.mass_std_kg,
              "slope_std_rad": e.slope_std_rad, **e.extras}
    for key, v in values.items():
        assert isinstance(v, float) or isinstance(v, (int, np.floating)), f"{name}: {key} is {type(v).__name__}"
        assert math.isfinite(v), f"{name}: {key} = {v!r} {where}"
        if key.endswith("_std") or key.endswith("_std_kg") or key.endswith("_std_rad"):
            assert v >= 0.0, f"{name}: {key} = {v!r} < 0 {where}"


def covariances(est: object, depth: int = 0) -> Iterator[tuple[str, np.ndarray]]:
    """Every covariance matrix an estimator exposes, as (label, array of shape (..., n, n)).

    ``P``/``Q``/``mass_P``/``slope_P`` as square arrays (or stacks of them), as flat lists of n*n floats (the scalar-Python UKF), as
    ``P11/P12/P22`` float triples; per-particle variances (``radius_var_m2``) as stacks of 1x1 matrices; and the
    same one level down in ``mass_layer`` / ``slope_layer`` / ``ukf``.
    """
    for attr in ("P", "Q", "mass_P", "slope_P"):
        m = getattr(est, attr, None)
        if isinstance(m, (list, tuple)) and m and all(isinstance(v, float) for v in m):
            k = math.isqrt(len(m))
            if k * k == len(m):
                m = np.array(m, dtype=float).reshape(k, k)
        if isinstance(m, np.ndarray) and m.ndim >= 2 and m.shape[-1] == m.shape[-2]:
            yield attr, m
    for attr in ("radius_var_m2",):
        v = getattr(est, attr, None)
        if isinstance(v, np.ndarray) and v.ndim == 1:
            yield attr, v[:, None, None]
    for prefix in ("P", "Q"):
        trip = [getattr(est, f"{prefix}{a}", None) for a in ("11", "12", "22")]
        if all(isinstance(v, (int, float)) for v in trip):
            yield f"{prefix}11/12/22", np.array([[trip[0], trip[1]], [trip[1], trip[2]]])
    if depth < 1:
        for sub in ("mass_layer", "slope_layer", "ukf"):
            obj = getattr(est, sub, None)
            if obj is not None:
                for label, m in covariances(obj, depth + 1):
                    yield f"{sub}.{label}", m


def _check_covariances(name: str, est: object, where: str) -> None:
    for label, m in covariances(est):
        assert np.all(np.isfinite(m)), f"{name}: {label} not finite {where}"
        np.testing.assert_allclose(m, np.swapaxes(m, -1, -2), rtol=1e-9, atol=1e-300,
                                   err_msg=f"{name}: {label} not symmetric {where}")
        mats = m.reshape(-1, m.shape[-1], m.shape[-1])
        sym = 0.5 * (mats + np.swapaxes(mats, -1, -2))
        # positive definite: Cholesky succeeds on every matrix of the stack
        for k, a in enumerate(sym):
            try:
                np.linalg.cholesky(a)
            except np.linalg.LinAlgError:
                pytest.fail(f"{name}: {label}[{k}] not positive definite {where}: {a.tolist()}")


def run_plan(name: str, seed: int, faults: list[tuple[int, int, int, float]]) -> None:
    # a throwaway clean update first: loading compiled code (numba cache) must not count as a slow call
    estimators.make(name).update(*clean_stream(1, 0)[0].tolist())
    est = estimators.make(name)
    data = clean_stream(N_CLEAN + 400, seed)
    bad = data.copy()
    for start, length, field, value in faults:
        bad[start:start + length, field] = value
    where_cov = {min(s + n, len(bad)) for s, n, _, _ in faults} | {len(bad)}
    STATS["examples"] += 1
    with watchdog(WATCHDOG_S):
        for i, row in enumerate(bad.tolist()):
            where = f"at sample {i}, inputs {dict(zip(FIELDS, row))}"
            t0 = time.perf_counter()
            try:
                e = est.update(*row)
            except ValueError as exc:
                assert _dt_invalid(row[3]), f"{name}: ValueError for a valid dt {where}: {exc}"
                assert "dt" in str(exc), f"{name}: ValueError without naming dt {where}: {exc}"
                STATS["value_errors"] += 1
                e = est.estimate
            elapsed = time.perf_counter() - t0
            STATS["updates"] += 1
            assert elapsed < CALL_LIMIT_S, f"{name}: one update took {elapsed:.2f} s {where}"
            _check_estimate(name, e, where)
            if i + 1 in where_cov:
                _check_covariances(name, est, where)


@pytest.fixture(scope="module", autouse=True)
def _report_counts() -> Iterator[None]:
    yield
    print(f"\nfuzz: {STATS['examples']} fault plans, {STATS['updates']} update() calls, "
          f"{STATS['value_errors']} documented dt ValueErrors")


@pytest.mark.parametrize("name", _names())
def test_update_survives_faults(name: str) -> None:
    estimators.make(name).update(*clean_stream(1, 0)[0].tolist())  # compile/warm outside the watchdog

    # derandomized (the same plans on every run: CI is deterministic); no shrinking, because a hang costs a
    # watchdog period per shrink step and the failing plan is printed as drawn
    @settings(max_examples=MAX_EXAMPLES, deadline=None, derandomize=True, database=None,
              phases=(Phase.explicit, Phase.generate),
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
    @given(plan=fault_plans(huge_dt=name not in KNOWN_HANGS))
    def check(plan: tuple[int, list[tuple[int, int, int, float]]]) -> None:
        run_plan(name, *plan)

    check()


# Plans that a wider, randomised run of the fuzz above found (MAX_EXAMPLES = 400, derandomize=False), kept for every
# estimator: 200 samples of dt = 60 s in a row had multiplied mmae's speed-slope-curvature covariance to ~1e36, where
# its round-off was no longer symmetric (round 2, session 59; its predict now bounds each variance)
FOUND_PLANS: list[tuple[int, list[tuple[int, int, int, float]]]] = [
    (19535, [(29, 2, 5, 0.0), (57, 200, 0, 500000.0), (81, 200, 3, 60.0)]),
]


@pytest.mark.parametrize("name", _names())
@pytest.mark.parametrize("plan", FOUND_PLANS, ids=[f"plan{k}" for k in range(len(FOUND_PLANS))])
def test_plans_found_by_wider_fuzzing(name: str, plan: tuple[int, list[tuple[int, int, int, float]]]) -> None:
    if name in KNOWN_HANGS:
        pytest.skip(KNOWN_HANGS[name])
    run_plan(name, *plan)


@pytest.mark.parametrize("name", _names())
@pytest.mark.parametrize("value", [math.inf, -math.inf, 1e300, math.nan], ids=["+inf", "-inf", "1e300", "nan"])
def test_bad_value_on_each_input_then_clean(name: str, value: float) -> None:
    """Deterministic companion of the fuzz: each input in turn bad for the first 60 samples (0.3 s) and again
    for 60 samples mid-stream; a +inf must not produce NaN (issue 12)."""
    for field in (0, 1, 2, 4, 5, 6):
        run_plan(name, 5, [(0, 60, field, value), (200, 60, field, value)])


def _dt_cases() -> list[object]:
    out: list[object] = []
    for name in estimators.available():
        for dt in (0.0, 1e-300, *HUGE_DT):
            hang = KNOWN_HANGS.get(name) if dt in HUGE_DT else None
            marks = [pytest.mark.xfail(run=False, reason=hang)] if hang else []
            out.append(pytest.param(name, dt, marks=marks, id=f"{name}-{dt:g}"))
    return out


@pytest.mark.parametrize("name, dt", _dt_cases())
def test_extreme_but_valid_dt_then_clean(name: str, dt: float) -> None:
    """A finite dt >= 0, however absurd, gives an estimate (0 may be refused as documented), then clean data works."""
    run_plan(name, 1, [(50, 1, 3, dt)])


def _soak_inputs(rng: np.random.Generator, n: int, huge_dt: bool = True) -> np.ndarray:
    x = clean_stream(n, int(rng.integers(2**16)))
    x[:, :3] *= rng.uniform(0.0, 3.0, (n, 3))
    x[:, 4:] *= rng.uniform(0.0, 3.0, (n, 3))
    hit = rng.random((n, 7)) < 0.01
    x[hit] = rng.choice(SPECIAL, hit.sum())
    dt_hit = rng.random(n) < 0.001
    x[dt_hit, 3] = rng.choice([1e9, 1e300, 3.0, 1e-300] if huge_dt else [3.0, 1e-300], dt_hit.sum())
    return x


@pytest.mark.slow
@pytest.mark.parametrize("name", _names())
def test_soak_1e6_updates(name: str) -> None:
    rng = np.random.default_rng(12)
    est = estimators.make(name)
    chunk = 10_000
    for c in range(100):
        x = _soak_inputs(rng, chunk, huge_dt=name not in KNOWN_HANGS).tolist()
        with watchdog(600):
            for row in x:
                try:
                    e = est.update(*row)
                except ValueError as exc:  # the documented refusal of an invalid interval, nothing else
                    assert _dt_invalid(row[3]) and "dt" in str(exc), f"{name}: {exc} for inputs {row}"
                    e = est.estimate
        _check_estimate(name, e, f"after chunk {c}")
        _check_covariances(name, est, f"after chunk {c}")
