"""Estimators by name, so the environment, ``uuom-estimate`` and the benchmarks pick them by string.

Entries are ``"module:Class"`` strings imported on first use, so importing :mod:`estimators` stays cheap and one
broken method cannot stop the others from loading.
"""

from __future__ import annotations

import importlib
import re
from typing import Any, Iterable

from uuom_core.vehicle import VehicleParams

from .base import Estimator
from .option_ranges import check_option_values

_REGISTRY: dict[str, str] = {
    # paper 000 (Liu et al. 2023) and its baselines, spec §5.1-5.5
    "rls": "estimators.rls:RLSMassEstimator",
    "ffrls": "estimators.rls:FFRLSMassEstimator",
    "dffrls": "estimators.rls:DFFRLSMassEstimator",
    "ekf": "estimators.ekf:JointEKF",
    "rls-ekf": "estimators.two_layer:RLSEKF",
    # the project's variant, env default: a bank over the slope geometry (one member: estimators.dffrls_aekf)
    "dffrls-aekf": "estimators.geometry_bank:GeometryBank",
    "dffrls-aekf-paper": "estimators.dffrls_aekf_paper:DFFRLSAEKFPaper",
    # issue 10: mass, gravity slope and resistance offset from all on-board signals, learned gravity blend
    "fused": "estimators.fused:FusedObserver",
    # improvement on paper 000: uses the accelerometer's specific force (issue 3)
    "sf-kf": "estimators.specific_force:SpecificForceKF",
    # other source methods, spec §5.6-5.8
    "mmae": "estimators.mmae:MMAEEstimator",
    "imu-ukf": "estimators.imu.estimator:IMUUKFEstimator",
    "aupf": "estimators.aupf:AUPFEstimator",
}


class UnknownEstimatorError(KeyError):
    """An estimator name that is not registered."""

    def __str__(self) -> str:  # KeyError quotes its argument; keep the message readable
        return str(self.args[0])


def register(name: str, target: str, *, overwrite: bool = False) -> None:
    """Register ``target`` (``"package.module:Class"``) under ``name``."""
    if name in _REGISTRY and not overwrite:
        raise ValueError(f"estimator {name!r} is already registered")
    _REGISTRY[name] = target


def available() -> list[str]:
    """Names of all registered estimators, sorted."""
    return sorted(_REGISTRY)


def _unknown(name: str, extra: list[str] | None = None) -> UnknownEstimatorError:
    return UnknownEstimatorError(f"unknown estimator {name!r}; available: {', '.join(available() + (extra or []))}")


def get_class(name: str) -> type[Estimator]:
    """The estimator class registered under ``name``."""
    try:
        target = _REGISTRY[name]
    except KeyError:
        raise _unknown(name) from None
    module_name, _, class_name = target.partition(":")
    module = importlib.import_module(module_name)
    return getattr(module, class_name)


def parse_names(given: str | Iterable[str], *, also: Iterable[str] = ()) -> list[str]:
    """Estimator names from a command line: comma- or space-separated, in one string or several.

    Every name must be registered (or be one of ``also``, e.g. ``"none"`` where a script knows it); the check does
    not import the estimator, so a benchmark can still skip a method whose optional dependency is missing.

    Raises
    ------
    ValueError
        No name given.
    UnknownEstimatorError
        A name that is neither registered nor in ``also``; the message names it and lists the registered ones.
    """
    items = [given] if isinstance(given, str) else list(given)
    names = [n for item in items for n in re.split(r"[,\s]+", item) if n]
    if not names:
        raise ValueError("no estimator name given")
    known = set(_REGISTRY) | set(also)
    for name in names:
        if name not in known:
            raise _unknown(name, sorted(set(also) - set(_REGISTRY)))
    return names


def make(name: str, vehicle: VehicleParams | None = None, **options: Any) -> Estimator:
    """Construct the estimator registered under ``name``; every real-valued option is first checked against its
    plausible range (:data:`estimators.option_ranges.OPTION_RANGES`: a ``ValueError`` naming it)."""
    cls = get_class(name)
    check_option_values(name, options)
    return cls(vehicle, **options)


__all__ = ["UnknownEstimatorError", "available", "get_class", "make", "parse_names", "register"]
