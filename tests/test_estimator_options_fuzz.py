"""Every option of every estimator, given a bad or extreme value through ``estimators.make``: a ``ValueError`` or
``TypeError`` that names the option, or an estimator whose outputs stay finite with symmetric positive definite
covariances.

Why: the options had no common check. Session 59 gave these values to every option of every registered estimator:
116 of the 244 (estimator, option) pairs broke the contract with at least one of them (this test with the range
check taken out of ``estimators.make``): a string or ``None`` raised comparisons' own ``TypeError`` without the option's
name, a standard deviation of 1e300 raised ``OverflowError`` (not a ``ValueError``: ``uuom-estimate`` printed a
traceback), 1e-300 divided by zero or hung, a sway damping ratio of 5e4 and an offset forgetting 1000x the mass's
gave NaN, an infinite prior gave an infinite standard deviation. :data:`estimators.option_ranges.OPTION_RANGES` now
bounds every real-valued option.
"""

from __future__ import annotations

import dataclasses
import inspect
import math
from typing import Any

import pytest

import estimators
from estimators.option_ranges import OPTION_RANGES

from test_estimators_fuzz import _check_covariances, _check_estimate, clean_stream, watchdog

STREAM = clean_stream(300, 3)


def option_defaults(name: str) -> dict[str, Any]:
    """The options ``estimators.make(name, ...)`` takes, with their defaults: the constructor's keyword arguments
    and, for estimators configured by a dataclass, its fields."""
    cls = estimators.get_class(name)
    out: dict[str, Any] = {}
    params = inspect.signature(cls.__init__).parameters.values()
    for p in params:
        if p.name not in ("self", "vehicle", "config") and p.kind not in (p.VAR_KEYWORD, p.VAR_POSITIONAL):
            out[p.name] = p.default
    if any(p.name == "config" or p.kind == p.VAR_KEYWORD for p in params):
        est = estimators.make(name)
        for attr in ("config", "cfg", "_cfg", "_config"):
            cfg = getattr(est, attr, None)
            if cfg is not None and dataclasses.is_dataclass(cfg):
                for f in dataclasses.fields(cfg):
                    out.setdefault(f.name, getattr(cfg, f.name))
    return out


def bad_values(default: Any) -> list[Any]:
    values: list[Any] = ["abc", [], math.nan, math.inf, -math.inf, 1e300, 1e-300, -1.0, 0.0]
    if default is not None:
        values.append(None)
    if isinstance(default, (int, float)) and not isinstance(default, bool) and default:
        values.append(default * 1e3)
    return values


CASES = [(name, option, default) for name in estimators.available()
         for option, default in option_defaults(name).items()]


def test_every_real_option_of_every_estimator_has_a_range() -> None:
    """A new real-valued option must be given its plausible range (or a check of its own, listed here)."""
    own_checks = {"n_models", "n_particles", "seed", "relock_after", "stuck_repeats"}  # integers, checked as such
    missing = sorted({option for name in estimators.available() for option, d in option_defaults(name).items()
                      if isinstance(d, (int, float)) and not isinstance(d, bool) and option not in OPTION_RANGES
                      and option not in own_checks})
    assert missing == [], f"options without a range in estimators/option_ranges.py: {missing}"


@pytest.mark.parametrize("name, option, default", CASES, ids=[f"{n}-{o}" for n, o, _ in CASES])
def test_a_bad_option_is_refused_by_name_or_harmless(name: str, option: str, default: Any) -> None:
    for value in bad_values(default):
        try:
            est = estimators.make(name, **{option: value})
        except (TypeError, ValueError) as exc:
            assert option in str(exc), f"{name}: the error for {option}={value!r} does not name it: {exc}"
            continue
        with watchdog(15):  # a step of 1e-300 m had hung the slope history: fail, do not hang
            for i, row in enumerate(STREAM.tolist()):
                _check_estimate(name, est.update(*row), f"sample {i}, {option}={value!r}")
        _check_covariances(name, est, f"after {len(STREAM)} samples, {option}={value!r}")
