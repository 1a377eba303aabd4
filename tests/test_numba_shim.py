"""The guard against stale numba caches across kernel files (estimators.numba_shim.drop_stale_caches)."""

from __future__ import annotations

from pathlib import Path

from estimators.numba_shim import KERNEL_SOURCES, STAMP_NAME, drop_stale_caches


def _setup(tmp_path: Path) -> tuple[Path, Path]:
    src, cache = tmp_path / "src", tmp_path / "src" / "__pycache__"
    cache.mkdir(parents=True)
    (src / "a_kernel.py").write_text("x = 1\n")
    (src / "layout.py").write_text("N = 3\n")
    return src, cache


def _cache_files(cache: Path) -> list[str]:
    for stem in ("a_kernel.step-10.py311", "a_kernel.run-40.py311", "layout.f-1.py311"):
        (cache / f"{stem}.nbi").write_bytes(b"i")
        (cache / f"{stem}.1.nbc").write_bytes(b"c")
    (cache / "other.g-1.py311.nbi").write_bytes(b"i")  # not a kernel: never touched
    return sorted(p.name for p in cache.iterdir())


def test_an_edit_of_any_kernel_source_drops_every_kernel_cache(tmp_path: Path) -> None:
    src, cache = _setup(tmp_path)
    sources = ("a_kernel.py", "layout.py")
    assert drop_stale_caches(src, cache, sources)  # no stamp yet: nothing known about the caches
    before = _cache_files(cache)
    assert not drop_stale_caches(src, cache, sources)  # unchanged sources: caches kept
    assert sorted(p.name for p in cache.iterdir()) == before
    (src / "layout.py").write_text("N = 4\n")  # only the layout changed: the kernel's caches are stale too
    assert drop_stale_caches(src, cache, sources)
    assert sorted(p.name for p in cache.iterdir()) == sorted([STAMP_NAME, "other.g-1.py311.nbi"])
    assert not drop_stale_caches(src, cache, sources)


def test_a_missing_or_read_only_cache_folder_is_not_an_error(tmp_path: Path) -> None:
    src, _ = _setup(tmp_path)
    assert drop_stale_caches(src, tmp_path / "nowhere" / "deeper", ("a_kernel.py",)) is False


def test_the_guard_covers_every_file_that_compiles_kernels() -> None:
    pkg = Path(__file__).resolve().parent.parent / "estimators"
    users = {p.name for p in pkg.glob("*.py") if "numba_shim import" in p.read_text()}
    assert users <= set(KERNEL_SOURCES)
    assert "dffrls_aekf_layout.py" in KERNEL_SOURCES


def test_every_cache_folder_numba_may_use_is_guarded() -> None:
    from estimators import numba_shim

    pkg = Path(numba_shim.__file__).resolve().parent
    dirs = numba_shim.numba_cache_dirs(pkg)
    assert dirs[0] == pkg / "__pycache__"
    if numba_shim.HAVE_NUMBA:  # numba's user-wide fallback, named by numba's own rule for this source folder
        from numba.core import caching

        sub = caching._CacheLocator.get_suitable_cache_subpath(str(pkg / "dffrls_aekf_kernel.py"))
        assert any(d.name == sub for d in dirs[1:])
