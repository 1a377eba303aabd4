"""Causal detectors of two sensor faults that plausibility limits cannot see: a one-sample spike on an input and a
channel stuck at one value.

Both faults stay within :class:`~estimators.input_limits.InputLimits`, so they reach a filter as data. Where a filter
weighs models by every sample's likelihood (``mmae``), a single wrong torque sample or three seconds of a frozen
accelerometer move the model probabilities by tens of per cent (measured on ``pm-sensor-faults``, docs/estimation.md
"Sensor faults that reach the likelihood"). Each detector turns such samples into missing ones (``NaN``), which the
filters already handle: predict without correcting.

* :class:`JumpGate`: a sample that differs from the last accepted one by more than ``max_jump`` is held back; when
  the next sample is near it (within ``max_jump``) the new level is real (a step of the drive command) and is
  accepted; when the next sample is back near the old level, the held one was a spike. A real step thus costs one
  sample; a one-sample spike is never used. With ``noise_factor`` the threshold grows to that many times the
  channel's recent mean sample-to-sample change, so a sensor noisier than expected is not cut to pieces. Its older
  relative :class:`~estimators.filters.SpikeGate` (the regression front end, ``sf-kf``) bounds the rate of change
  instead and re-locks after a count of rejections whatever the value; the torque of the env and of a PI driver
  steps within one sample, so ``mmae`` and ``dffrls-aekf`` need the confirmation by the next sample, not a rate.
* :class:`StuckDetector`: a channel whose noise makes consecutive samples differ (the accelerometer: noise,
  vibration of the load, quantisation finer than the noise) and that repeats one value ``min_repeats`` times in a
  row is frozen; its samples count as missing until the value changes. Only a channel that has shown its noise is
  judged: white noise reverses the direction of the previous change on two samples of three, a smooth signal
  (noise-free simulated data) almost never; while fewer than one in three of the recent samples did, a run of equal
  values is data (a level stretch of a simulation, quantisation coarser than the noise).
"""

from __future__ import annotations

import math

from .filters import check_int_option, check_number_options
from .numba_shim import njit

_RATE_GAIN = 0.01  # memory of the noise rate: ~100 samples (0.5 s at 200 Hz)
_NOISY = 1.0 / 3.0  # half of white noise's rate of direction reversals

STUCK_STATE = 4
"""Length of :func:`stuck_step`'s state: the last value, the last change, the run length, the noise rate."""


@njit(cache=True)
def stuck_reset(st):
    """:func:`stuck_step`'s state at the start: no value seen, no change, no run, no noise seen."""
    st[0] = math.nan
    st[1] = 0.0
    st[2] = 0.0
    st[3] = 0.0


@njit(cache=True)
def stuck_step(st, min_repeats, value):
    """One sample through the stuck rule of :class:`StuckDetector`, its state in ``st`` (:data:`STUCK_STATE`
    entries, the first NaN at the start): ``value``, or NaN while the channel is stuck. Compiled, so the
    ``dffrls-aekf`` kernel runs the same rule on its accelerometer."""
    if not (value == value) or abs(value) == math.inf or min_repeats <= 0.0:
        return value
    last = st[0]
    change = value - last if last == last else 0.0
    st[2] = st[2] + 1.0 if change == 0.0 else 1.0
    st[0] = value
    if st[2] < min_repeats:  # a stuck run must not teach the channel that it has no noise
        st[3] += _RATE_GAIN * ((1.0 if change * st[1] < 0.0 else 0.0) - st[3])
        st[1] = change
    elif st[3] > _NOISY:
        return math.nan
    return value


# the plain functions (where numba is missing, the functions themselves): the classes below run them on a list
_stuck_step_py = getattr(stuck_step, "py_func", stuck_step)
_stuck_reset_py = getattr(stuck_reset, "py_func", stuck_reset)

JUMP_STATE = 3
"""Length of :func:`jump_step`'s state: the last accepted value, the held-back one, the mean |change|."""


@njit(cache=True)
def jump_reset(st):
    """:func:`jump_step`'s state at the start: nothing accepted, nothing held back, no noise seen."""
    st[0] = math.nan
    st[1] = math.nan
    st[2] = 0.0


@njit(cache=True)
def jump_step(st, max_jump, noise_factor, value):
    """One sample through the rule of :class:`JumpGate`, its state in ``st`` (:data:`JUMP_STATE` entries, the first
    two NaN at the start): ``value``, or NaN while it is held back. Compiled, so the ``dffrls-aekf`` kernel runs the
    same rule on its torque and accelerometer."""
    if not (value == value) or abs(value) == math.inf or max_jump <= 0.0:
        return value
    last = st[0]
    thr = max(max_jump, noise_factor * st[2])
    # a NaN last (nothing accepted yet) compares False, so the first finite sample is taken as it is
    if not abs(value - last) > thr or abs(value - st[1]) <= thr:
        if last == last:  # a step enters the noise level bounded, so one real step cannot open the gate
            st[2] += _RATE_GAIN * (min(abs(value - last), thr) - st[2])
        st[0] = value
        st[1] = math.nan
        return value
    st[1] = value
    return math.nan


_jump_step_py = getattr(jump_step, "py_func", jump_step)
_jump_reset_py = getattr(jump_reset, "py_func", jump_reset)


class JumpGate:
    """Hold back a sample that jumps by more than ``max_jump`` from the last accepted one until the next confirms it.

    Parameters
    ----------
    max_jump : float
        Largest change between consecutive accepted samples that is taken at once (channel units); 0 = gate off.
    noise_factor : float, default 0
        The threshold is ``max(max_jump, noise_factor * mean |change|)``, the mean over about the last 100 accepted
        samples (each change counted at most at the threshold); 0: ``max_jump`` alone.

    Attributes
    ----------
    n_held : int
        Samples held back (spikes, and the first sample of every real step).
    """

    def __init__(self, max_jump: float, noise_factor: float = 0.0) -> None:
        check_number_options({"max_jump": max_jump, "noise_factor": noise_factor}, ValueError,
                             non_negative=("max_jump", "noise_factor"), reject_bool=True)
        self.max_jump = float(max_jump)
        self.noise_factor = float(noise_factor)
        self.reset()

    def reset(self) -> None:
        self._st = [0.0] * JUMP_STATE
        _jump_reset_py(self._st)
        self.n_held = 0

    def __call__(self, value: float) -> float:
        """``value`` if it is accepted, else ``NaN``; a ``NaN`` in gives ``NaN`` out and changes nothing."""
        value = float(value)
        # the rule's Python source on a list (a compiled call's dispatch from Python costs more than the rule)
        out = _jump_step_py(self._st, self.max_jump, self.noise_factor, value)
        if out != out and value == value:
            self.n_held += 1
        return out


class StuckDetector:
    """Treat a channel as stuck while it repeats one value at least ``min_repeats`` times in a row.

    Parameters
    ----------
    min_repeats : int
        Consecutive identical samples (the first one counted) from which on the value is taken as frozen; 0 = off.
        Missing samples in between neither count nor break the run.

    Attributes
    ----------
    n_stuck : int
        Samples dropped as stuck.
    noise_rate : float
        Recent share of samples whose change reversed the sign of the previous change (about the last 100 samples,
        outside stuck runs); ~2/3 for white noise, 0 for a smooth signal; starts at 0 (no noise seen yet).
    """

    def __init__(self, min_repeats: int) -> None:
        check_int_option("min_repeats", min_repeats, ValueError, minimum=0)
        self.min_repeats = int(min_repeats)
        self.reset()

    def reset(self) -> None:
        self._st = [0.0] * STUCK_STATE
        _stuck_reset_py(self._st)
        self.n_stuck = 0

    @property
    def noise_rate(self) -> float:
        return float(self._st[3])

    def __call__(self, value: float) -> float:
        """``value``, or ``NaN`` while the channel is stuck; a ``NaN`` in gives ``NaN`` out."""
        value = float(value)
        # the rule's Python source on a list: called per sample from Python, a compiled call's dispatch costs more
        # than the rule (measured 1.04 against 0.28 µs)
        out = _stuck_step_py(self._st, float(self.min_repeats), value)
        if out != out and value == value:
            self.n_stuck += 1
        return out


__all__ = ["JUMP_STATE", "JumpGate", "STUCK_STATE", "StuckDetector", "jump_reset", "jump_step", "stuck_reset",
           "stuck_step"]
