"""Online mass and slope estimators for overhead monorails, usable in the environment and on recorded traces."""

from .base import Estimate, EstimateSeries, Estimator
from .registry import UnknownEstimatorError, available, get_class, make, parse_names, register

__all__ = [
    "Estimate",
    "EstimateSeries",
    "Estimator",
    "UnknownEstimatorError",
    "available",
    "get_class",
    "make",
    "parse_names",
    "register",
]
