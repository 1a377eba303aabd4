"""Writing result files so that they appear whole or not at all, and never in place of something else.

A file is written to a temporary sibling ``.NAME.uuom-PID-XXXX.tmp`` (same directory, so the final
:func:`os.replace` is atomic on POSIX), flushed and fsynced, then renamed over the target. An interruption
(SIGINT, SIGTERM, an exception) removes the temporary file; after SIGKILL or a power cut it stays, and
:func:`remove_stale_temps` (called before every write) removes the ones whose process is gone. The new file gets the
permissions of the file it replaces, or ``0666 & ~umask`` (what ``open()`` would give), not ``mkstemp``'s 0600.

:func:`check_output_path` refuses targets that a rename would destroy instead of writing through: a symlink
(``--out /dev/stdout``), a FIFO, a device, a directory, and any of the input files (same inode: also through a
hard link or a symlink).
"""

from __future__ import annotations

import os
import re
import secrets
import stat
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Iterator, Sequence


class OutputPathError(ValueError):
    """An output path that cannot or must not be written; the message is one line naming it."""


def _kind(mode: int) -> str:
    if stat.S_ISDIR(mode):
        return "a directory"
    if stat.S_ISFIFO(mode):
        return "a FIFO"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "not a regular file"


def check_output_path(path: str | os.PathLike[str], inputs: Sequence[str | os.PathLike[str]] = ()) -> Path:
    """Check that ``path`` may be replaced by a new regular file; return it.

    Raises
    ------
    OutputPathError
        When ``path`` is a symlink, a directory, a FIFO, a device or a socket, is one of ``inputs`` (compared by
        device and inode), exists read-only, or its directory is missing or not writable.
    """
    p = Path(path)
    try:
        st = os.lstat(p)
    except FileNotFoundError:
        st = None
    except OSError as exc:
        raise OutputPathError(f"{p}: cannot check the output path: {exc.strerror}") from None
    if st is not None:
        if stat.S_ISLNK(st.st_mode):
            raise OutputPathError(f"{p}: output is a symlink; refusing to replace it (give the real path)")
        if not stat.S_ISREG(st.st_mode):
            raise OutputPathError(f"{p}: output is {_kind(st.st_mode)}, not a regular file")
        for src in inputs:
            try:
                s2 = os.stat(src)
            except OSError:
                continue
            if (s2.st_dev, s2.st_ino) == (st.st_dev, st.st_ino):
                raise OutputPathError(f"{p}: output is the input file {src}; refusing to overwrite it")
        if not os.access(p, os.W_OK):
            raise OutputPathError(f"{p}: output exists and is read-only")
    directory = p.parent
    if not directory.is_dir():
        raise OutputPathError(f"{p}: output directory {directory} does not exist")
    if not os.access(directory, os.W_OK | os.X_OK):
        raise OutputPathError(f"{p}: output directory {directory} is not writable")
    return p


_TEMP = re.compile(r"^\.(?P<name>.+)\.uuom-(?P<pid>\d+)-[0-9a-f]+\.tmp$")


def _pid_alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # exists, owned by someone else
    return True


def remove_stale_temps(path: str | os.PathLike[str]) -> list[Path]:
    """Remove temporary files for ``path`` left by writers that no longer run (SIGKILL, power cut)."""
    p = Path(path)
    removed: list[Path] = []
    try:
        entries = os.listdir(p.parent)
    except OSError:
        return removed
    for entry in entries:
        m = _TEMP.match(entry)
        if m and m["name"] == p.name and int(m["pid"]) != os.getpid() and not _pid_alive(int(m["pid"])):
            try:
                os.unlink(p.parent / entry)
                removed.append(p.parent / entry)
            except OSError:
                pass
    return removed


def _new_file_mode(path: Path) -> int:
    try:
        st = os.stat(path)
        if stat.S_ISREG(st.st_mode):
            return stat.S_IMODE(st.st_mode)
    except OSError:
        pass
    umask = os.umask(0)
    os.umask(umask)
    return 0o666 & ~umask


@contextmanager
def atomic_text_writer(path: str | os.PathLike[str]) -> Iterator[IO[str]]:
    """Context manager giving a text file that replaces ``path`` atomically when the block ends without error.

    On any exception (``KeyboardInterrupt`` included) the temporary file is removed and ``path`` is untouched.
    """
    p = Path(path)
    directory = p.parent
    remove_stale_temps(p)
    tmp = directory / f".{p.name}.uuom-{os.getpid()}-{secrets.token_hex(4)}.tmp"
    fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0), 0o600)
    try:
        os.fchmod(fd, _new_file_mode(p))
        with os.fdopen(fd, "w", newline="", encoding="utf-8") as fh:
            yield fh
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, p)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


__all__ = ["OutputPathError", "atomic_text_writer", "check_output_path", "remove_stale_temps"]
