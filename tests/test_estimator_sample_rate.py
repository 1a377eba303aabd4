"""With ``rate_from_trace`` (opt-in, session 48) ``dffrls-aekf`` and ``fused`` are the same filter per second at any
sample rate.

Their per-sample settings were tuned at 200 Hz. With perfect sensors (no noise to differ between rates) the point-mass
section 2 (a continuously varying grade) recorded at 100 / 200 / 400 Hz must give nearly the same errors; with the
200 Hz settings kept (``rate_from_trace=False``, the default) the mass max error of ``dffrls-aekf`` was
3.57 / 2.62 / 1.9 %. A 200 Hz trace keeps exactly the configured settings (every 200 Hz table unchanged).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pytest

from estimators import dffrls_aekf_kernel as kern
from estimators.dffrls_aekf import DFFRLSAEKF, median_step_s
from estimators.registry import make
from uuom_gym.sim.point_mass import PointMassSensors, simulate_point_mass, with_options

RATES_HZ = (100.0, 200.0, 400.0)


@lru_cache(maxsize=None)
def perfect_trace(rate_hz: float):
    return simulate_point_mass(with_options("pm-section2", sensors=PointMassSensors.perfect()), seed=0,
                               sample_hz=rate_hz)


def errors(name: str, rate_hz: float, **options) -> tuple[float, float]:
    tr = perfect_trace(rate_hz)
    s = make(name, **options).run(tr)
    after = tr["t_s"] >= 10.0
    m = tr["mass_kg"][after]
    mass = float(np.max(np.abs(s.mass_kg[after] - m) / m) * 100.0)
    slope = float(np.sqrt(np.mean((np.degrees(s.slope_rad[after]) - tr["slope_deg"][after]) ** 2)))
    return mass, slope


@pytest.mark.parametrize("name", ["dffrls-aekf", "fused"])
def test_same_filter_per_second_at_any_rate(name: str) -> None:
    ref_mass, ref_slope = errors(name, 200.0, rate_from_trace=True)
    for hz in (100.0, 400.0):
        mass, slope = errors(name, hz, rate_from_trace=True)
        assert abs(mass - ref_mass) < 0.25, f"{name} at {hz:g} Hz: mass max error {mass:.2f} % vs {ref_mass:.2f} %"
        assert abs(slope - ref_slope) < 0.1 * ref_slope + 0.002, f"{name} at {hz:g} Hz: slope RMSE {slope:.3f}"


def test_the_200hz_settings_depend_on_the_rate() -> None:
    """Guard against a vacuous test: with the 200 Hz settings kept, the rates do differ."""
    ref_mass, _ = errors("dffrls-aekf", 200.0, rate_from_trace=False)
    mass_100, _ = errors("dffrls-aekf", 100.0, rate_from_trace=False)
    assert abs(mass_100 - ref_mass) > 0.5


def test_a_200hz_trace_keeps_the_configured_settings() -> None:
    tr = perfect_trace(200.0)
    est = DFFRLSAEKF(rate_from_trace=True)
    configured = est.C.copy()
    np.testing.assert_array_equal(est.settings_for(tr["t_s"]), configured)
    assert configured[kern.RATE_R] == 1.0
    est.run(tr)
    np.testing.assert_array_equal(est.C, configured)


def test_rate_from_trace_rescales_per_sample_settings() -> None:
    est = DFFRLSAEKF(rate_from_trace=True)
    C = est.settings_for(perfect_trace(100.0)["t_s"])
    base = est.config.settings(est.vehicle)
    assert C[kern.RATE_R] == pytest.approx(2.0)
    assert C[kern.DT_NOM] == pytest.approx(0.01)
    assert C[kern.CORR_N] == pytest.approx(base[kern.CORR_N] / 2.0)
    assert C[kern.R0] == pytest.approx(base[kern.R0] / 2.0)  # a white noise's variance per sample goes as 1 / dt
    assert C[kern.FADING] == pytest.approx(base[kern.FADING] ** 2)
    assert C[kern.RELOCK] == round(base[kern.RELOCK] / 2.0)
    off = DFFRLSAEKF()  # the default keeps the 200 Hz settings
    np.testing.assert_array_equal(off.settings_for(perfect_trace(100.0)["t_s"]), base)


def test_the_bank_adopts_the_rate_in_place() -> None:
    """The geometry bank's members' settings are rows of one stacked array: run() must rewrite them there."""
    bank = make("dffrls-aekf", rate_from_trace=True)
    bank.run(perfect_trace(400.0))
    assert all(m.C[kern.RATE_R] == pytest.approx(0.5) for m in bank.members)
    assert np.all(bank._CC[:, kern.RATE_R] == pytest.approx(0.5))
    bank.run(perfect_trace(200.0))
    assert np.all(bank._CC[:, kern.RATE_R] == 1.0)


def test_median_step() -> None:
    assert median_step_s(np.arange(100) * 0.01) == pytest.approx(0.01)
    assert median_step_s(np.arange(5) * 0.01) is None  # too few steps to tell
    t = np.arange(200) * 0.005
    t[50:60] = np.nan  # dropouts of the clock and a repeated stamp do not move it
    t[100] = t[99]
    assert median_step_s(t) == pytest.approx(0.005)
