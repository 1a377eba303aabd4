"""Harris-hawks optimisation as a generic tuner (paper 001, §3.1), plus plain HHO and random search.

``tune(objective, bounds, budget, seed, method=...)`` minimises ``objective(x)`` over the box ``bounds`` with
exactly ``budget`` objective evaluations (so methods compare at equal cost). It tunes any estimator's noise
settings against simulated truth (``scripts/tune_imu_ukf.py`` does it for ``imu-ukf``).

Plain HHO (Heidari et al. 2019): escape energy ``E = E1 · E0``, ``E0 ~ U(-1, 1)``, ``E1 = 2 (1 - d/d_max)``;
``|E| >= 1`` explores (perch on a random hawk or relative to the flock mean), ``|E| < 1`` exploits (soft/hard
besiege, with progressive rapid dives using Lévy flights, accepted greedily).

Improved HHO (the paper's two changes):

1. non-linear escape-energy factor from the chi-square inverse CDF. The paper's eq. (11) did not survive text
   extraction; the project uses the form that reproduces its Fig. 5 description (slow decrease early and in the
   middle, fast at the end, ``|E| > 1`` possible almost to the end)::

       E1 = 2 (1 - chi2inv(p_max · d/d_max, N) / chi2inv(p_max, N)),   N = 2, p_max = 0.999

2. dynamic inertia weight on the prey (rabbit) position, eqs. (12)–(13)::

       w_d = w_max - (w_max - w_min) (s - s_min) / (s_avg - s_min)
       L_rabbit' = L_rabbit + w_d · L_rabbit ⊙ u,   u ~ U(-1, 1)^dim    (in the normalised box [-1, 1]^dim)

   with ``s`` the rabbit's fitness, ``s_min``/``s_avg`` over the last 10 rabbit fitnesses; the candidate replaces
   the rabbit only if it is better (greedy, one evaluation per iteration). When the rabbit has not improved for
   more than 3 iterations the large weight ``w_max`` is used to jump out of the neighbourhood. The paper lists
   ``w_min, w_max = 0.95, 0.45`` (swapped); the project uses ``w_min = 0.45, w_max = 0.95``.

Progress ``d/d_max`` is measured in evaluations used / budget, so the schedule ends with the budget.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.special import gamma as _gamma_fn
from scipy.stats import chi2

__all__ = ["METHODS", "TuneError", "TuneResult", "chi2_escape_factor", "linear_escape_factor", "tune"]

METHODS = ("ihho", "hho", "random")


class TuneError(ValueError):
    """Bad arguments to :func:`tune`; the message names them."""


@dataclass
class TuneResult:
    """Outcome of :func:`tune`.

    Attributes
    ----------
    x : ndarray
        Best point found (inside the bounds).
    fun : float
        Its objective value.
    n_evals : int
        Objective evaluations used (== budget).
    history : ndarray
        Best objective value after each evaluation.
    method : str
    """

    x: np.ndarray
    fun: float
    n_evals: int
    history: np.ndarray
    method: str
    evals_x: list[np.ndarray] = field(default_factory=list, repr=False)


def linear_escape_factor(progress: float) -> float:
    """Plain HHO: ``E1 = 2 (1 - d/d_max)``."""
    return 2.0 * (1.0 - min(max(progress, 0.0), 1.0))


def chi2_escape_factor(progress: float, dof: float = 2.0, p_max: float = 0.999) -> float:
    """Improved HHO: ``E1 = 2 (1 - chi2inv(p_max d/d_max, N) / chi2inv(p_max, N))`` (non-linear, slow then fast)."""
    p = min(max(progress, 0.0), 1.0)
    return 2.0 * (1.0 - float(chi2.ppf(p_max * p, dof)) / float(chi2.ppf(p_max, dof)))


class _BudgetExhausted(Exception):
    pass


class _Counter:
    """Wraps the objective: counts evaluations, tracks the best, maps normalised [-1, 1] points to bounds."""

    def __init__(self, objective: Callable[[np.ndarray], float], lo: np.ndarray, hi: np.ndarray, budget: int):
        self.objective, self.lo, self.hi, self.budget = objective, lo, hi, budget
        self.n = 0
        self.best_f = math.inf
        self.best_z: np.ndarray | None = None
        self.history: list[float] = []

    def to_x(self, z: np.ndarray) -> np.ndarray:
        return self.lo + (np.clip(z, -1.0, 1.0) + 1.0) * 0.5 * (self.hi - self.lo)

    def __call__(self, z: np.ndarray) -> float:
        if self.n >= self.budget:
            raise _BudgetExhausted
        z = np.clip(z, -1.0, 1.0)
        f = float(self.objective(self.to_x(z)))
        if math.isnan(f):
            f = math.inf  # a setting that breaks the estimator is the worst setting
        self.n += 1
        if f < self.best_f:
            self.best_f, self.best_z = f, z.copy()
        self.history.append(self.best_f)
        return f

    @property
    def progress(self) -> float:
        return self.n / self.budget


def _levy(rng: np.random.Generator, dim: int, beta: float = 1.5) -> np.ndarray:
    sigma = (_gamma_fn(1 + beta) * math.sin(math.pi * beta / 2)
             / (_gamma_fn((1 + beta) / 2) * beta * 2 ** ((beta - 1) / 2))) ** (1 / beta)
    u = rng.normal(0.0, sigma, dim)
    v = rng.normal(0.0, 1.0, dim)
    return 0.01 * u / np.abs(v) ** (1 / beta)


def _random_search(f: _Counter, rng: np.random.Generator, dim: int) -> None:
    while True:
        f(rng.uniform(-1.0, 1.0, dim))


def _hho(f: _Counter, rng: np.random.Generator, dim: int, pop: int, improved: bool,
         w_min: float, w_max: float) -> None:
    X = rng.uniform(-1.0, 1.0, (pop, dim))
    fit = np.array([f(x) for x in X])
    best = int(np.argmin(fit))
    rabbit, rabbit_f = X[best].copy(), float(fit[best])
    recent: list[float] = [rabbit_f]
    stall = 0
    escape = chi2_escape_factor if improved else linear_escape_factor
    while True:
        E1 = escape(f.progress)
        prev_rabbit_f = rabbit_f
        for i in range(pop):
            E0 = rng.uniform(-1.0, 1.0)
            E = E1 * E0
            if abs(E) >= 1.0:  # exploration
                if rng.random() >= 0.5:
                    Xr = X[rng.integers(pop)]
                    new = Xr - rng.random() * np.abs(Xr - 2.0 * rng.random() * X[i])
                else:
                    new = (rabbit - X.mean(axis=0)) - rng.random() * (-1.0 + rng.random() * 2.0)
                X[i] = np.clip(new, -1.0, 1.0)
                fit[i] = f(X[i])
            else:  # exploitation
                r = rng.random()
                J = 2.0 * (1.0 - rng.random())
                if r >= 0.5 and abs(E) >= 0.5:  # soft besiege
                    new = (rabbit - X[i]) - E * np.abs(J * rabbit - X[i])
                    X[i] = np.clip(new, -1.0, 1.0)
                    fit[i] = f(X[i])
                elif r >= 0.5:  # hard besiege
                    new = rabbit - E * np.abs(rabbit - X[i])
                    X[i] = np.clip(new, -1.0, 1.0)
                    fit[i] = f(X[i])
                else:  # progressive rapid dives (Lévy flights), greedy
                    base = X[i] if abs(E) >= 0.5 else X.mean(axis=0)
                    Y = np.clip(rabbit - E * np.abs(J * rabbit - base), -1.0, 1.0)
                    fy = f(Y)
                    if fy < fit[i]:
                        X[i], fit[i] = Y, fy
                    else:
                        Z = np.clip(Y + rng.random(dim) * _levy(rng, dim), -1.0, 1.0)
                        fz = f(Z)
                        if fz < fit[i]:
                            X[i], fit[i] = Z, fz
            if fit[i] < rabbit_f:
                rabbit, rabbit_f = X[i].copy(), float(fit[i])
        if improved:
            stall = 0 if rabbit_f < prev_rabbit_f else stall + 1
            recent = (recent + [rabbit_f])[-10:]
            s_min, s_avg = min(recent), float(np.mean(recent))
            if stall > 3:
                w = w_max
            elif s_avg - s_min > 1e-300 and math.isfinite(s_avg):
                w = w_max - (w_max - w_min) * (rabbit_f - s_min) / (s_avg - s_min)
                w = min(max(w, w_min), w_max)
            else:
                w = w_min
            cand = np.clip(rabbit + w * rabbit * rng.uniform(-1.0, 1.0, dim), -1.0, 1.0)
            fc = f(cand)
            if fc < rabbit_f:
                rabbit, rabbit_f = cand, fc


def tune(objective: Callable[[np.ndarray], float], bounds: Sequence[tuple[float, float]], budget: int,
         seed: int, method: str = "ihho", *, population: int = 10, w_min: float = 0.45,
         w_max: float = 0.95) -> TuneResult:
    """Minimise ``objective`` over a box with exactly ``budget`` evaluations.

    Parameters
    ----------
    objective : callable
        ``objective(x) -> float`` with ``x`` an ndarray inside ``bounds``; NaN counts as +inf.
    bounds : sequence of (low, high)
        One pair per dimension, ``low < high``, finite. Tune noise levels in log10 units.
    budget : int
        Number of objective evaluations (>= population + 1 for the hawks).
    seed : int
        Seed of the ``np.random.Generator``.
    method : {"ihho", "hho", "random"}
    population : int
        Hawks in the flock (HHO variants).
    w_min, w_max : float
        Inertia-weight range of the improved HHO.

    Returns
    -------
    TuneResult
    """
    if method not in METHODS:
        raise TuneError(f"method must be one of {METHODS}, got {method!r}")
    b = np.asarray(bounds, dtype=np.float64)
    if b.ndim != 2 or b.shape[1] != 2 or b.shape[0] == 0:
        raise TuneError(f"bounds must be a sequence of (low, high) pairs, got shape {b.shape}")
    if not np.all(np.isfinite(b)) or np.any(b[:, 0] >= b[:, 1]):
        raise TuneError(f"bounds must be finite with low < high, got {b.tolist()}")
    if not isinstance(budget, (int, np.integer)) or budget < 1:
        raise TuneError(f"budget must be a positive integer, got {budget!r}")
    if not isinstance(population, (int, np.integer)) or population < 2:
        raise TuneError(f"population must be an integer >= 2, got {population!r}")
    if method != "random" and budget < population + 1:
        raise TuneError(f"budget {budget} is too small for a flock of {population} hawks")
    if not 0.0 <= w_min <= w_max:
        raise TuneError(f"need 0 <= w_min <= w_max, got {w_min}, {w_max}")
    rng = np.random.default_rng(seed)
    dim = b.shape[0]
    f = _Counter(objective, b[:, 0], b[:, 1], int(budget))
    try:
        if method == "random":
            _random_search(f, rng, dim)
        else:
            _hho(f, rng, dim, int(population), method == "ihho", w_min, w_max)
    except _BudgetExhausted:
        pass
    assert f.best_z is not None
    return TuneResult(f.to_x(f.best_z), f.best_f, f.n, np.asarray(f.history), method)
