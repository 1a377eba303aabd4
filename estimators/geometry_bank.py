"""A bank of ``dffrls-aekf`` filters that differ only in where along the train gravity acts, weighted by how well
each explains the force balance: the slope geometry learned from the data instead of assumed.

Why: the sensors measure the slope at one point; gravity acts on the whole train. On the project's plant (an 18 m
train, sensors at the front, the payload 9 m behind) the slope gravity acts on is the mean over ~12 m behind the
sensors; on a point mass it is the slope under the sensors. A fixed choice is right in one world and wrong in the
other (``docs/estimators.md``, ablation: 0.24° vs 1.85° median slope RMSE), and a trace file does not say which
vehicle it comes from. Both hypotheses agree on constant grades; at a grade change the wrong one predicts the
drive force late or early, and its force-balance residual grows.

Each member accumulates the Gaussian negative log-likelihood of its one-step force-balance prediction
(``S[SCORE]`` of :mod:`estimators.dffrls_aekf_kernel`: counted once per correlated stretch of the low-passed
signals, capped per sample so a sensor fault cannot decide). The weights are ``w_k ∝ exp(−score_k)`` with no
forgetting (a train does not change its geometry on the way); the output is the weighted mixture (mean, and
variance including the spread between members). Evidence gathered while a window member's history still holds the
start-up guess (the first window length travelled) is kept apart (``S[SCORE_EARLY]``) and may set the members
apart by at most ``max_early_evidence`` nats (default 1.5: weights up to 82 / 18): on a point mass it leans the
bank the right way within the first metres, but a long train that starts across a grade change fits its start-up
guess badly, so only the later evidence may decide (:func:`estimators.geometry_bank_kernel.member_score`).
"""

from __future__ import annotations

import math
from typing import Any, ClassVar, Sequence

import numpy as np

from uuom_core.trace import Trace
from uuom_core.vehicle import VehicleParams

from . import dffrls_aekf_kernel as kern
from . import geometry_bank_kernel as bk
from .base import Estimate, EstimateSeries, Estimator
from .dffrls_aekf import DFFRLSAEKF, DFFRLSAEKFConfig, batch_arrays, block_columns, gyro_column

__all__ = ["DEFAULT_WINDOWS_M", "GeometryBank"]

DEFAULT_WINDOWS_M: tuple[float, ...] = (0.0, 12.0)
"""A point mass, and the window that fits the project's plant (``estimators.dffrls_aekf``: chosen on plant runs)."""


class GeometryBank(Estimator):
    """``dffrls-aekf``: members that differ only in their slope window, mixed by their force-balance evidence
    (module docstring). With one window (``train_length_m=X`` or ``windows_m=(X,)``) it is that one member exactly.

    Parameters
    ----------
    vehicle : VehicleParams, optional
    config : DFFRLSAEKFConfig, optional
        Settings shared by every member (``train_length_m`` is replaced by each hypothesis).
    windows_m : sequence of float, optional
        The hypotheses: lengths behind the sensors over which the slope gravity acts on is averaged (0: a point
        mass). Default :data:`DEFAULT_WINDOWS_M`; ``train_length_m`` given as an option means that one window.
    **options
        Any field of :class:`~estimators.dffrls_aekf.DFFRLSAEKFConfig`.

    Extras: ``mu``, ``mu_std`` and ``nis`` (mixed over the members) and, with several members,
    ``weight_window_<X>m``: each member's weight.
    """

    name: ClassVar[str] = "dffrls-aekf"
    provides: ClassVar[frozenset[str]] = frozenset({"mass", "slope", "mu"})
    inputs: ClassVar[tuple[str, ...]] = ("gyro_radps",)  # the witness of grade changes (gyro_witness_deg)

    def __init__(self, vehicle: VehicleParams | None = None, config: DFFRLSAEKFConfig | None = None,
                 windows_m: Sequence[float] | None = None, **options: Any) -> None:
        super().__init__(vehicle)
        if windows_m is None:
            windows_m = (options.pop("train_length_m"),) if "train_length_m" in options else DEFAULT_WINDOWS_M
        elif "train_length_m" in options:
            raise ValueError(f"{self.name}: give windows_m or train_length_m, not both")
        # None: the vehicle's length, as for a single filter
        if isinstance(windows_m, (str, bytes)) or not isinstance(windows_m, Sequence | np.ndarray) or any(
                w is not None and (isinstance(w, bool) or not isinstance(w, (int, float, np.integer, np.floating)))
                for w in windows_m):
            raise ValueError(f"{self.name}: windows_m must be a sequence of lengths (m), got {windows_m!r}")
        windows = [self.vehicle.length_m if w is None else float(w) for w in windows_m]
        if not windows or any(not (math.isfinite(w) and w >= 0.0) for w in windows):
            raise ValueError(f"{self.name}: windows_m must be finite lengths >= 0, got {windows_m!r}")
        base = config or DFFRLSAEKFConfig()
        if base.fused or options.get("fused"):
            raise ValueError(f"{self.name}: the members are dffrls-aekf filters (fused=False); use 'fused'")
        self.windows_m = tuple(windows)
        if len(windows) > 1 and options.get("spread_length_m", base.spread_length_m) is None:
            # one spread gate for all: every member stops updating at the same grade changes and is scored there
            # with the parameters it had before them, so only the geometry tells the members apart
            options = {**options, "spread_length_m": max(windows)}
        self.members = [DFFRLSAEKF(self.vehicle, base, **options, train_length_m=w) for w in windows]
        self.config = self.members[0].config
        k = len(self.members)
        # the members' arrays are rows of three stacked arrays, so the compiled bank step sees them all at once
        self._SS = np.zeros((k, kern.N_S))
        self._HH = np.zeros((k, kern.N_H))
        self._CC = np.ascontiguousarray(np.stack([m.C for m in self.members]))
        for i, m in enumerate(self.members):
            m.S, m.H, m.C = self._SS[i], self._HH[i], self._CC[i]
        self._rows = np.zeros((k, kern.N_EST))
        self._out = np.zeros(bk.N_OUT_FIXED + k)
        self._w = np.zeros(k)
        self._weight_keys = [f"weight_window_{w:g}m" for w in self.windows_m]
        self.reset()

    @property
    def single(self) -> DFFRLSAEKF | None:
        """The member, when there is only one."""
        return self.members[0] if len(self.members) == 1 else None

    def reset(self) -> None:
        for m in self.members:
            m.reset()

    def update(self, torque_nm: float, speed_mps: float, accel_mps2: float, dt_s: float,
               motor_speed_radps: float = math.nan, gyro_radps: float = math.nan,
               accel_normal_mps2: float = math.nan) -> Estimate:
        bk.bank_step(self._SS, self._HH, self._CC, float(torque_nm), float(speed_mps), float(accel_mps2),
                     float(gyro_radps), float(dt_s), self._w)
        return self.estimate

    def update_block(self, torque_nm, speed_mps, accel_mps2, dt_s, motor_speed_radps=None, gyro_radps=None,
                     accel_normal_mps2=None) -> Estimate:
        """The samples of a block through the compiled bank step in one call; the same state as :meth:`update` each
        (sample by sample across the members: each sample's ambiguity gate needs all of them)."""
        cols = block_columns(self.name, torque_nm, speed_mps, accel_mps2)
        bk.bank_steps(self._SS, self._HH, self._CC, *cols, gyro_column(gyro_radps, len(cols[0])), float(dt_s),
                      self._w)
        return self.estimate

    @property
    def weights(self) -> np.ndarray:
        """The members' current weights (sum 1)."""
        bk.bank_estimate(self._SS, self._CC, self._rows, self._out)
        return self._out[bk.N_OUT_FIXED:].copy()

    @property
    def estimate(self) -> Estimate:
        if self.single is not None:
            return self.single.estimate
        o = self._out
        bk.bank_estimate(self._SS, self._CC, self._rows, o)
        extras = {"mu": float(o[4]), "mu_std": float(o[5]), "nis": float(o[6])}
        for i, key in enumerate(self._weight_keys):
            extras[key] = float(o[bk.N_OUT_FIXED + i])
        return Estimate(float(o[0]), float(o[1]), float(o[2]), float(o[3]), extras)

    def run(self, trace: Trace, reset: bool = True, *, t_prev_s: float | None = None) -> EstimateSeries:
        """The whole trace in one compiled loop over all members; the same results as :meth:`update` per sample."""
        if self.single is not None:
            return self.single.run(trace, reset, t_prev_s=t_prev_s)
        if reset:
            for m in self.members:
                m.adopt_rate(trace["t_s"])
            self.reset()
        t, dts, cols, out = batch_arrays(trace, t_prev_s, len(self._out))
        gyro = gyro_column(trace.get("gyro_radps"), len(t))
        bk.bank_run(self._SS, self._HH, self._CC, *cols, gyro, dts, out)
        r = out.T
        extras = {"mu": r[4], "mu_std": r[5], "nis": r[6]}
        for i, key in enumerate(self._weight_keys):
            extras[key] = r[bk.N_OUT_FIXED + i]
        return EstimateSeries(t if t is not trace["t_s"] else t.copy(), r[0], r[1], r[2], r[3], extras)
