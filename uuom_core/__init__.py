"""The dependency-free core of UUOM-Gym: vehicle parameters, the trace format, the safety speed limits and units.

Every other package (``uuom_gym``, ``estimators``, ``agents``) depends on this one; it depends on nothing of the
project and importing it has no side effects (no Gymnasium registration, no pymunk, no torch).
"""

from uuom_core.trace import Trace, TraceFormatError, read_trace_csv, write_trace_csv
from uuom_core.units import G_MPS2
from uuom_core.vehicle import DEFAULT_VEHICLE, VehicleFileError, VehicleParams

__all__ = [
    "DEFAULT_VEHICLE",
    "G_MPS2",
    "Trace",
    "TraceFormatError",
    "VehicleFileError",
    "VehicleParams",
    "read_trace_csv",
    "write_trace_csv",
]
