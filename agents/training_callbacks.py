"""Callbacks of :func:`agents.training.train`: crash-safe checkpoints, evaluation with a kept history, Ctrl-C."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.callbacks import BaseCallback, EvalCallback
from stable_baselines3.common.vec_env import VecNormalize

from agents.checkpoints import atomic_write, atomic_write_text, save_checkpoint

HISTORY_KEYS = ("timesteps", "results", "ep_lengths", "successes")


class ActionStdCeiling(BaseCallback):
    """Caps a Gaussian policy's action std by a ceiling falling log-linearly from ``start`` to ``end``.

    Over ``steps`` env steps from ``first_step`` (the step count the run began at), then ``end``. Applied before
    every rollout to the policy's ``log_std`` parameter (``clamp(max=log(ceiling))``): PPO may lower the std further
    but not raise it.

    Why: on the traction action the exploration noise itself drove the train off the start (a brake at rest does
    nothing, a push moves it), so PPO learnt a mean that never had to; held-out, deterministic, that mean stays
    put (docs/rl.md §27). Lowering the noise forces the mean to take over.
    """

    def __init__(self, start: float, end: float, steps: int, first_step: int = 0, verbose: int = 0) -> None:
        super().__init__(verbose)
        self.check(start, end, steps)
        self.log_start, self.log_end = float(np.log(start)), float(np.log(end))
        self.steps, self.first_step = int(steps), int(first_step)

    @staticmethod
    def check(start: float, end: float, steps: float) -> None:
        """``ValueError`` unless ``0 < end <= start`` and ``steps`` is a whole number >= 1."""
        if not (0.0 < end <= start) or int(steps) != steps or steps < 1:
            raise ValueError(f"must be START END STEPS with 0 < END <= START and STEPS a whole number >= 1, "
                             f"got {(start, end, steps)!r}")

    def ceiling(self, num_timesteps: int) -> float:
        """The std ceiling at a step count."""
        frac = min(max((num_timesteps - self.first_step) / self.steps, 0.0), 1.0)
        return float(np.exp(self.log_start + frac * (self.log_end - self.log_start)))

    def _cap(self) -> float:
        import torch

        log_std = getattr(self.model.policy, "log_std", None)
        if log_std is None:
            raise TypeError(f"{type(self.model.policy).__name__} has no log_std to cap (PPO's Gaussian policy has)")
        cap = self.ceiling(self.model.num_timesteps)
        with torch.no_grad():
            log_std.clamp_(max=float(np.log(cap)))
        return cap

    def _on_rollout_start(self) -> None:
        self.logger.record("train/action_std_ceiling", self._cap())

    def _on_training_end(self) -> None:
        self._cap()  # the last update may have raised the std: the saved policy keeps under the ceiling too

    def _on_step(self) -> bool:
        return True


class HistoryEvalCallback(EvalCallback):
    """EvalCallback whose history survives a resume and whose files are written atomically.

    Differences from SB3's: ``evaluations.npz`` is written through a temporary file; the best model, its
    VecNormalize stats and ``best.json`` (the mean reward that made it best, the threshold a later model must
    beat) are written atomically; :meth:`restore` puts back the history and threshold of a checkpoint.
    """

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._npz_path = Path(self.log_path) if self.log_path is not None else None  # ".../evaluations"

    def _init_callback(self) -> None:
        super()._init_callback()
        if self._npz_path is not None:
            # SB3's own np.savez goes to a temporary name; _on_step renames it into place.
            self.log_path = str(self._npz_path.with_name(f".evaluations.{os.getpid()}.tmp"))

    def history(self) -> dict[str, Any]:
        """The evaluation history and best-model threshold (JSON-serialisable)."""
        return {
            "timesteps": [int(t) for t in self.evaluations_timesteps],
            "results": [[float(x) for x in r] for r in self.evaluations_results],
            "ep_lengths": [[int(x) for x in r] for r in self.evaluations_length],
            "successes": [[bool(x) for x in r] for r in self.evaluations_successes],
            "best_mean_reward": float(self.best_mean_reward),
        }

    def restore(self, state: dict[str, Any]) -> None:
        """Take over the history and best threshold of a checkpoint's ``state.json`` (and of ``best.json``)."""
        self.evaluations_timesteps = list(state.get("timesteps", []))
        self.evaluations_results = [list(r) for r in state.get("results", [])]
        self.evaluations_length = [list(r) for r in state.get("ep_lengths", [])]
        self.evaluations_successes = [list(r) for r in state.get("successes", [])]
        best = float(state.get("best_mean_reward", -np.inf))
        if self.best_model_save_path is not None:
            bj = Path(self.best_model_save_path) / "best.json"
            if bj.exists() and (Path(self.best_model_save_path) / "best_model.zip").exists():
                best = max(best, float(json.loads(bj.read_text())["mean_reward"]))
        self.best_mean_reward = best
        self._write_npz()

    def _write_npz(self) -> None:
        if self._npz_path is None or not self.evaluations_timesteps:
            return
        kw = {"successes": self.evaluations_successes} if self.evaluations_successes else {}
        target = self._npz_path.with_suffix(".npz")
        target.parent.mkdir(parents=True, exist_ok=True)
        atomic_write(target, lambda p: np.savez(p, timesteps=self.evaluations_timesteps,
                                                results=self.evaluations_results,
                                                ep_lengths=self.evaluations_length, **kw))

    def _on_step(self) -> bool:
        best_before = self.best_mean_reward
        save_path, self.best_model_save_path = self.best_model_save_path, None  # we save the best model ourselves
        try:
            ok = super()._on_step()
        finally:
            self.best_model_save_path = save_path
        evaluated = self.eval_freq > 0 and self.n_calls % self.eval_freq == 0
        tmp = Path(self.log_path + ".npz") if self.log_path is not None and evaluated else None
        if tmp is not None and tmp.exists():
            os.replace(tmp, self._npz_path.with_suffix(".npz"))
        if self.best_mean_reward > best_before and save_path is not None:
            d = Path(save_path)
            d.mkdir(parents=True, exist_ok=True)
            atomic_write(d / "best_model.zip", lambda p: self.model.save(p))
            env = self.model.get_env()
            if isinstance(env, VecNormalize):
                atomic_write(d / "vecnormalize.pkl", lambda p: env.save(str(p)))
            atomic_write_text(d / "best.json", json.dumps(
                {"mean_reward": float(self.best_mean_reward), "num_timesteps": int(self.num_timesteps)}))
        return ok


class CheckpointEvery(BaseCallback):
    """A complete checkpoint (:func:`agents.checkpoints.save_checkpoint`) every ``save_freq`` calls."""

    def __init__(self, save_freq: int, ckpt_dir: Path, eval_cb: HistoryEvalCallback | None, replay_buffer: bool):
        super().__init__()
        self.save_freq = max(int(save_freq), 1)
        self.ckpt_dir = Path(ckpt_dir)
        self.eval_cb = eval_cb
        self.replay_buffer = replay_buffer

    def state(self) -> dict[str, Any]:
        return self.eval_cb.history() if self.eval_cb is not None else {}

    def save(self) -> Path:
        """Write a checkpoint now; return its directory."""
        return save_checkpoint(self.model, self.ckpt_dir, self.state(), self.replay_buffer).path

    def _on_step(self) -> bool:
        if self.n_calls % self.save_freq == 0:
            self.save()
        return True


class StopFlag(BaseCallback):
    """Ends ``learn()`` cleanly at the next step once :attr:`stop` is set (by the SIGINT handler)."""

    def __init__(self) -> None:
        super().__init__()
        self.stop = False

    def _on_step(self) -> bool:
        return not self.stop


__all__ = ["CheckpointEvery", "HistoryEvalCallback", "StopFlag"]
