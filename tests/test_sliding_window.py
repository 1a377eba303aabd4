"""``agents.sliding_window.WindowMax`` (the pessimistic memories of the shield and the rule-based controller) and
``uuom_core.units.clamp``: the same numbers as the plain scans they replace."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from agents.sliding_window import WindowMax
from uuom_core.units import clamp


def _scan(history: list[tuple[float, float]], span_s: float, sign: float) -> float:
    """The replaced code: keep (t, x) of the last span_s seconds in a list, then max / min over it."""
    t_now = history[-1][0]
    kept = [x for t, x in history if not t < t_now - span_s]
    return max(kept) if sign > 0 else min(kept)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.floats(0.0, 2.0), st.floats(-1e6, 1e6)), min_size=1, max_size=80),
       st.floats(0.0, 5.0), st.sampled_from([1.0, -1.0]), st.floats(0.0, 1.0))
def test_window_extreme_equals_a_scan_of_the_window(steps, span_s, sign, part):
    # value_within: the extreme of the most recent part of the window (the rule-based controller's light_memory_s)
    w = WindowMax(span_s, sign)
    t, history = 0.0, []
    for dt, x in steps:
        t += dt
        history.append((t, x))
        w.push(t, x)
        assert w.value == _scan(history, span_s, sign) == w.value_within(t, span_s)
        assert w.value_within(t, part * span_s) == _scan(history, part * span_s, sign)


def test_window_is_empty_until_the_first_push():
    w = WindowMax(1.0)
    assert w.value is None
    w.push(0.0, 3.0)
    assert w.value == 3.0


def test_a_value_leaves_the_window_after_span():
    w = WindowMax(1.0)
    w.push(0.0, 10.0)
    w.push(0.5, 1.0)
    assert w.value == 10.0
    w.push(1.0, 2.0)  # 0.0 is not older than 1.0 - 1.0: still in
    assert w.value == 10.0
    w.push(1.01, 0.0)
    assert w.value == 2.0


@given(st.floats(allow_nan=True, allow_infinity=True), st.floats(-10, 0), st.floats(0, 10))
def test_clamp_is_np_clip_for_one_number(x, lo, hi):
    a, b = clamp(x, lo, hi), float(np.clip(x, lo, hi))
    assert (math.isnan(a) and math.isnan(b)) or (a == b and math.copysign(1, a) == math.copysign(1, b))

