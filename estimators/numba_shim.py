"""``njit`` for the compiled kernels: numba's when it is installed, else a no-op decorator.

numba is a dependency (``pyproject.toml``); the fallback keeps the package importable without it, and the kernels
then run as plain Python (same results, much slower). :data:`HAVE_NUMBA` says which one is in use.
"""

from __future__ import annotations

try:
    from numba import njit
except ImportError:  # pragma: no cover
    def njit(*args, **kwargs):  # type: ignore[no-redef]
        if args and callable(args[0]):
            return args[0]
        return lambda f: f

HAVE_NUMBA = njit.__module__.startswith("numba")

__all__ = ["HAVE_NUMBA", "njit"]
