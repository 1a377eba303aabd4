"""``njit`` for the compiled kernels: numba's when it is installed, else a no-op decorator.

numba is a dependency (``pyproject.toml``); the fallback keeps the package importable without it, and the kernels
then run as plain Python (same results, much slower). :data:`HAVE_NUMBA` says which one is in use.

**Stale caches.** numba's on-disk cache (``cache=True``) checks only the time stamp of the file that *defines* a
function. The kernels call each other across files (the geometry bank's step inlines ``dffrls_aekf_kernel.step``)
and read the array layout of ``dffrls_aekf_layout`` as compile-time constants, so an edit of one file (or a
``git pull``) left the others' cached machine code running the old code, silently (seen: a changed kernel gave
bit-identical results through the bank). On import, :func:`drop_stale_caches` therefore compares a hash of all
kernel sources with the one stored beside each cache folder numba may use (:func:`numba_cache_dirs`) and, when it
differs, removes the kernels' cache files there, so numba compiles them again.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Iterable

try:
    from numba import njit
except ImportError:  # pragma: no cover
    def njit(*args, **kwargs):  # type: ignore[no-redef]
        if args and callable(args[0]):
            return args[0]
        return lambda f: f

HAVE_NUMBA = njit.__module__.startswith("numba")

KERNEL_SOURCES: tuple[str, ...] = ("numba_shim.py", "dffrls_aekf_layout.py", "dffrls_aekf_kernel.py",
                                   "fused_kernel.py", "fixed_lag_kernel.py", "geometry_bank_kernel.py", "mmae_kernel.py",
                                   "input_faults.py")
"""The files whose compiled functions depend on one another (every file that uses :func:`njit`, and the layout)."""

STAMP_NAME = "kernels.sha256"

__all__ = ["HAVE_NUMBA", "KERNEL_SOURCES", "drop_stale_caches", "njit", "numba_cache_dirs"]


def drop_stale_caches(source_dir: Path, cache_dir: Path, sources: Iterable[str] = KERNEL_SOURCES) -> bool:
    """Remove the kernels' numba cache files (``<module>.*.nbi`` / ``.nbc`` in ``cache_dir``) when the hash of
    ``sources`` differs from the one stored there; store the new hash. Returns whether caches were dropped.
    Never raises on a read-only or missing cache folder (numba then caches elsewhere or not at all)."""
    names = list(sources)
    digest = hashlib.sha256()
    for name in names:
        path = source_dir / name
        digest.update(name.encode())
        digest.update(path.read_bytes() if path.is_file() else b"")
    new = digest.hexdigest()
    stamp = cache_dir / STAMP_NAME
    try:
        if stamp.is_file() and stamp.read_text().strip() == new:
            return False
        cache_dir.mkdir(exist_ok=True)
        for name in names:
            for pattern in (f"{Path(name).stem}.*.nbi", f"{Path(name).stem}.*.nbc"):
                for f in cache_dir.glob(pattern):
                    f.unlink(missing_ok=True)
        stamp.write_text(new + "\n")
    except OSError:
        return False
    return True


def numba_cache_dirs(source_dir: Path) -> list[Path]:
    """Where numba may keep the caches of functions defined in ``source_dir``: beside the sources (``__pycache__``),
    under ``NUMBA_CACHE_DIR`` when set, and numba's user-wide folder (its fallback when the sources' folder is not
    writable, e.g. a read-only install). The last two use numba's own path rule, read from numba's (internal)
    locator; if that ever moves, only ``__pycache__`` is checked."""
    dirs = [source_dir / "__pycache__"]
    try:
        from numba.core import caching, config
        from numba.misc.appdirs import AppDirs

        sub = caching._CacheLocator.get_suitable_cache_subpath(str(source_dir / KERNEL_SOURCES[0]))
        if config.CACHE_DIR:
            dirs.append(Path(config.CACHE_DIR) / sub)
        dirs.append(Path(AppDirs(appname="numba", appauthor=False).user_cache_dir) / sub)
    except Exception:  # pragma: no cover - numba internals moved: the in-tree folder is still guarded
        pass
    return dirs


if HAVE_NUMBA:
    _here = Path(__file__).resolve().parent
    for _d in numba_cache_dirs(_here):
        if _d.name == "__pycache__" or _d.is_dir():  # never create numba's other folders just to stamp them
            drop_stale_caches(_here, _d)
