"""Crash-safe training checkpoints: every file is written atomically, every checkpoint is a directory that
appears complete or not at all.

Layout of ``<run>/checkpoints/``::

    step_0000025000/          one complete checkpoint (renamed into place when every file is written)
        model.zip             the SB3 model
        vecnormalize.pkl      observation/reward normalisation (when used)
        replay_buffer.pkl     SAC's replay buffer (only in the newest checkpoint, it is large)
        state.json            step count, best evaluation reward so far, the evaluation history
    .partial-step_.../        a checkpoint being written (removed by :func:`clean_partial` on the next start)

A ``SIGKILL`` at any point therefore leaves the previous checkpoint intact and at most a ``.partial-*`` directory
or a ``.*.tmp`` file, both removed when training starts again.
"""

from __future__ import annotations

import json
import os
import re
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable

STEP_DIR_RE = re.compile(r"step_(\d+)")
PARTIAL_PREFIX = ".partial-"
TMP_SUFFIX = ".tmp"


def atomic_write(path: Path, write: Callable[[Path], None]) -> None:
    """Call ``write(tmp)`` for a temporary file beside ``path``, fsync it, then rename it onto ``path``.

    The temporary name keeps ``path``'s suffix (SB3 appends ``.zip`` to names without one).
    """
    path = Path(path)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}{TMP_SUFFIX}{path.suffix}")
    try:
        write(tmp)
        with open(tmp, "rb") as fh:
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def atomic_write_text(path: Path, text: str) -> None:
    """Write a text file atomically."""
    atomic_write(path, lambda p: p.write_text(text))


@dataclass(frozen=True)
class Checkpoint:
    """A complete checkpoint directory and what it holds."""

    path: Path
    steps: int

    @property
    def model(self) -> Path:
        return self.path / "model.zip"

    @property
    def vecnormalize(self) -> Path | None:
        p = self.path / "vecnormalize.pkl"
        return p if p.exists() else None

    @property
    def replay_buffer(self) -> Path | None:
        p = self.path / "replay_buffer.pkl"
        return p if p.exists() else None

    def state(self) -> dict[str, Any]:
        """``state.json`` (``{}`` for checkpoints written before it existed)."""
        p = self.path / "state.json"
        return json.loads(p.read_text()) if p.exists() else {}


def list_checkpoints(ckpt_dir: Path) -> list[Checkpoint]:
    """Complete checkpoints, oldest first."""
    out = []
    if not Path(ckpt_dir).is_dir():
        return out
    for p in Path(ckpt_dir).iterdir():
        m = STEP_DIR_RE.fullmatch(p.name)
        if m and p.is_dir() and (p / "model.zip").exists():
            out.append(Checkpoint(p, int(m.group(1))))
    return sorted(out, key=lambda c: c.steps)


def latest_checkpoint(ckpt_dir: Path) -> Checkpoint | None:
    """The newest complete checkpoint, or ``None``."""
    cks = list_checkpoints(ckpt_dir)
    return cks[-1] if cks else None


def clean_partial(run_dir: Path) -> list[Path]:
    """Remove what an interrupted write left (``.partial-*`` directories, ``.*.tmp*`` files); return them."""
    removed: list[Path] = []
    run_dir = Path(run_dir)
    if not run_dir.is_dir():
        return removed
    for p in run_dir.rglob("*"):
        if p.name.startswith(PARTIAL_PREFIX) and p.is_dir():
            removed.append(p)
        elif p.name.startswith(".") and TMP_SUFFIX in p.name and p.is_file():
            removed.append(p)
    for p in removed:
        if p.is_dir():
            shutil.rmtree(p, ignore_errors=True)
        elif p.exists():
            p.unlink()
    return removed


def save_checkpoint(model: Any, ckpt_dir: Path, state: dict[str, Any], replay_buffer: bool = False) -> Checkpoint:
    """Write a complete checkpoint of ``model`` at its current step count; return it.

    Everything goes into ``.partial-step_<n>/`` first, which is renamed to ``step_<n>/`` at the end (atomic on
    POSIX). Older checkpoints keep their model and normalisation but lose their replay buffer.
    """
    from stable_baselines3.common.vec_env import VecNormalize

    ckpt_dir = Path(ckpt_dir)
    ckpt_dir.mkdir(parents=True, exist_ok=True)
    steps = int(model.num_timesteps)
    name = f"step_{steps:010d}"
    final = ckpt_dir / name
    partial = ckpt_dir / f"{PARTIAL_PREFIX}{name}"
    if partial.exists():
        shutil.rmtree(partial)
    partial.mkdir()
    model.save(partial / "model.zip")
    env = model.get_env()
    if isinstance(env, VecNormalize):
        env.save(str(partial / "vecnormalize.pkl"))
    if replay_buffer and getattr(model, "replay_buffer", None) is not None:
        model.save_replay_buffer(partial / "replay_buffer.pkl")
    (partial / "state.json").write_text(json.dumps(dict(state, num_timesteps=steps)))
    for f in partial.iterdir():
        with open(f, "rb") as fh:
            os.fsync(fh.fileno())
    if final.exists():  # a second save at the same step (e.g. Ctrl-C right after a periodic checkpoint)
        old = ckpt_dir / f"{PARTIAL_PREFIX}old-{name}"
        os.rename(final, old)
        os.rename(partial, final)
        shutil.rmtree(old, ignore_errors=True)
    else:
        os.rename(partial, final)
    for ck in list_checkpoints(ckpt_dir)[:-1]:
        rb = ck.path / "replay_buffer.pkl"
        if rb.exists():
            rb.unlink()
    return Checkpoint(final, steps)


__all__ = [
    "Checkpoint",
    "atomic_write",
    "atomic_write_text",
    "clean_partial",
    "latest_checkpoint",
    "list_checkpoints",
    "save_checkpoint",
]
