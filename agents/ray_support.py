"""Optional Ray back end of evaluation and sweeps: one place that imports Ray and says how to install it."""

from __future__ import annotations

import os
from typing import Any

RAY_INSTALL_HINT = 'pip install -e ".[ray]"'
"""What to install for ``--ray`` (from a checkout): the ``[ray]`` extra of pyproject.toml."""


class RayUnavailableError(RuntimeError):
    """``--ray`` was asked for but Ray is not installed."""


def init_ray() -> Any:
    """Import Ray and connect (``RAY_ADDRESS`` for a cluster, else a local instance); return the module.

    Raises
    ------
    RayUnavailableError
        If Ray is not installed; the message says how to install it.
    """
    try:
        import ray
    except ImportError:
        raise RayUnavailableError(f"--ray needs Ray, which is not installed: {RAY_INSTALL_HINT}") from None
    ray.init(address=os.environ.get("RAY_ADDRESS"), ignore_reinit_error=True)
    return ray


__all__ = ["RAY_INSTALL_HINT", "RayUnavailableError", "init_ray"]
