"""rl-baselines3-zoo style hyperparameter files (``agents/hyperparams/<algo>.yml``) as :mod:`agents.training`
reads them: ``key=value`` overrides checked against the file and the algorithm, the rl-zoo string expressions
(``normalize``, ``policy_kwargs``), rl-zoo's linear schedules (``learning_rate: lin_3e-4``), and the ``env_wrapper``
entry that sets the default shield / residual.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agents.algos import algo_class

ENV_ID = "UUOM-Track-v0"
"""The default env id (the class with its default configuration); ``uuom_gym.registration.ENV_IDS`` lists all."""
HYPERPARAMS_DIR = Path(__file__).resolve().parent / "hyperparams"
SHIELD_WRAPPER = "agents.shield.ShieldWrapper"
RESIDUAL_WRAPPER = "agents.residual.ResidualWrapper"
LINEAR_PREFIX = "lin_"
"""rl-zoo's spelling of a schedule falling linearly to 0: ``lin_3e-4``."""
SCHEDULE_KEYS = ("learning_rate", "clip_range")
"""Hyperparameters SB3 accepts as a schedule (a function of the progress remaining)."""
NOISE_KEYS = ("noise_type", "noise_std")
"""rl-zoo's action-noise entries of an off-policy learner (not constructor arguments: :func:`action_noise`)."""
NOISE_TYPES = ("normal", "ornstein-uhlenbeck")
"""rl-zoo's ``noise_type`` values."""


class TrainConfigError(ValueError):
    """A training input that cannot work (bad count, unknown observer, malformed hyperparameter, ...)."""


def load_hyperparams(algo: str, conf_file: Path | None = None, overrides: list[str] | None = None,
                     env_id: str = ENV_ID, learner: type | None = None) -> dict[str, Any]:
    """The rl-zoo-style YAML entry for ``env_id`` (default ``UUOM-Track-v0``) with ``key=value`` overrides applied.

    An override of a key the file has must keep its kind (number, bool, string; a number of
    :data:`SCHEDULE_KEYS` may become ``lin_<number>``); a new key must be an argument of the algorithm's
    constructor (``learner``'s where training uses a subclass of it, e.g. :class:`agents.ppo_bc.PPOWithDemoBC`).

    Raises
    ------
    TrainConfigError
        Missing file or entry, malformed override, wrong kind or unknown key.
    """
    import yaml

    path = Path(conf_file) if conf_file is not None else HYPERPARAMS_DIR / f"{algo}.yml"
    if not path.is_file():
        raise TrainConfigError(f"hyperparameter file not found: {path}")
    try:
        data = yaml.load(path.read_text(), Loader=yaml.UnsafeLoader)  # rl-zoo files use !!float tags
    except yaml.YAMLError as exc:
        raise TrainConfigError(f"{path}: not valid YAML ({str(exc).splitlines()[0]})") from None
    if not isinstance(data, dict) or env_id not in data:
        keys = ", ".join(map(str, data)) if isinstance(data, dict) else type(data).__name__
        raise TrainConfigError(f"{path} has no '{env_id}' entry (has: {keys})")
    hp = dict(data[env_id])
    accepted = _constructor_args(learner or algo_class(algo))
    for item in overrides or []:
        if "=" not in item:
            raise TrainConfigError(f"--hyperparams expects key=value, got {item!r}")
        key, text = item.split("=", 1)
        try:
            value = parse_value(text)
        except yaml.YAMLError:
            raise TrainConfigError(f"--hyperparams {item!r}: {text!r} is not a YAML value") from None
        if key in hp:
            _check_kind(key, hp[key], value, item)
        elif key not in accepted and key not in ("n_envs", "n_timesteps", "normalize", "policy", "env_wrapper",
                                                 *NOISE_KEYS):
            raise TrainConfigError(f"--hyperparams {item!r}: {algo} has no hyperparameter {key!r}")
        hp[key] = value
    check_hp_ranges(hp)
    return hp


# What each numeric hyperparameter may be: (low, high, integer?) closed, None = open-ended. SB3 checks few of these
# itself; a uuom-train probe (session 59) crashed with a traceback on gamma = 1.5 and gae_lambda = 2 (NaN in the
# networks), n_epochs = 0 (an UnboundLocalError inside SB3) and vf_coef = nan (a string reached torch), and trained
# on clip_range = -0.1 and max_grad_norm = -1 without a word.
HP_RANGES: dict[str, tuple[float | None, float | None, bool]] = {
    "learning_rate": (0.0, 1.0, False), "gamma": (0.0, 1.0, False), "gae_lambda": (0.0, 1.0, False),
    "clip_range": (0.0, 10.0, False), "clip_range_vf": (0.0, 10.0, False), "vf_coef": (0.0, 100.0, False),
    "max_grad_norm": (0.0, None, False), "target_kl": (0.0, None, False), "tau": (0.0, 1.0, False),
    "target_policy_noise": (0.0, 10.0, False), "target_noise_clip": (0.0, 10.0, False),
    "n_steps": (1, None, True), "batch_size": (1, None, True), "n_epochs": (1, None, True),
    "buffer_size": (1, None, True), "learning_starts": (0, None, True), "policy_delay": (1, None, True),
    "sde_sample_freq": (-1, None, True), "gradient_steps": (-1, None, True), "n_envs": (1, None, True),
    "n_timesteps": (1, None, True),
}
_OPEN_LOW = {"learning_rate", "gamma", "clip_range", "clip_range_vf", "max_grad_norm", "target_kl", "tau"}
"""Keys whose low bound is exclusive (a discount or step of 0 is no training)."""


def check_hp_ranges(hp: dict[str, Any]) -> None:
    """Every numeric hyperparameter of :data:`HP_RANGES` a finite number in its range (``lin_<x>`` schedules and
    ``None`` where SB3 takes them are left to their own checks); raises :class:`TrainConfigError` naming the key."""
    for key, (lo, hi, integer) in HP_RANGES.items():
        if key not in hp or hp[key] is None or (isinstance(hp[key], str) and key in SCHEDULE_KEYS):
            continue
        value = hp[key]
        kind = "an integer" if integer else "a number"
        # (an integer key may be written 2e5: rl-zoo files tag such numbers !!float)
        ok = not isinstance(value, bool) and isinstance(value, (int, float)) and math.isfinite(value) \
            and (not integer or float(value).is_integer())
        ok = ok and (lo is None or value > lo or (value == lo and key not in _OPEN_LOW)) \
            and (hi is None or value <= hi)
        if not ok:
            low = "" if lo is None else (f"> {lo}" if key in _OPEN_LOW else f">= {lo}")
            high = "" if hi is None else f"<= {hi}"
            bounds = " and ".join(b for b in (low, high) if b)
            raise TrainConfigError(f"hyperparameter {key} must be {kind} {bounds}, got {value!r}")
    tf = hp.get("train_freq")
    if tf is not None:
        n, unit = (tf[0], tf[1]) if isinstance(tf, (list, tuple)) and len(tf) == 2 else (tf, "step")
        if isinstance(n, bool) or not isinstance(n, int) or n < 1 or unit not in ("step", "episode"):
            raise TrainConfigError(f"hyperparameter train_freq must be an integer >= 1 or [n, 'step' | 'episode'], "
                                   f"got {tf!r}")
    if "gradient_steps" in hp and hp["gradient_steps"] == 0:
        raise TrainConfigError("hyperparameter gradient_steps must be >= 1 or -1, got 0")


def parse_value(text: str) -> Any:
    """A ``key=value`` value: a number as a number (YAML 1.1 alone reads ``1e-4`` as a string), else YAML."""
    import yaml

    for kind in (int, float):
        try:
            value = kind(text)
        except ValueError:
            continue
        # nan / inf stay text, so the kind check rejects them by name instead of training on them
        return value if math.isfinite(value) else text
    return yaml.safe_load(text)


def _constructor_args(cls: type) -> set[str]:
    import inspect

    return {n for c in cls.__mro__ if "__init__" in vars(c) for n in inspect.signature(c.__init__).parameters}


def _check_kind(key: str, old: Any, new: Any, item: str) -> None:
    def kind(v: Any) -> str:
        if isinstance(v, bool):
            return "a bool"
        if isinstance(v, (int, float)):
            return "a number"
        return "a string" if isinstance(v, str) else type(v).__name__

    if kind(old) == "a number" and isinstance(new, str) and key in SCHEDULE_KEYS:
        linear_value(key, new)  # raises unless lin_<finite number>
        return
    if kind(old) != kind(new):
        raise TrainConfigError(f"--hyperparams {item!r}: {key} must be {kind(old)} like {old!r}, got {new!r}")
    if kind(new) == "a number" and not math.isfinite(float(new)):
        raise TrainConfigError(f"--hyperparams {item!r}: {key} must be finite")


def linear_value(key: str, text: str) -> float:
    """The start value of a ``lin_<value>`` schedule of ``key``.

    Raises
    ------
    TrainConfigError
        ``text`` is not ``lin_`` followed by a finite number > 0.
    """
    if not text.startswith(LINEAR_PREFIX):
        raise TrainConfigError(f"hyperparameter {key}: {text!r} is neither a number nor {LINEAR_PREFIX}<number>")
    try:
        value = float(text[len(LINEAR_PREFIX):])
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise TrainConfigError(f"hyperparameter {key}: {text!r} needs a finite number > 0 after {LINEAR_PREFIX!r}")
    return value


@dataclass(frozen=True)
class LinearToZero:
    """A schedule falling linearly from ``value`` to 0 over this run's own steps (rl-zoo's ``lin_<value>``).

    SB3 calls it with the progress remaining, ``1 - steps / total``, counted from step 0 even when a run starts
    from another run's steps (``--init-from``). ``run_share`` is ``(total - first step) / total``: the schedule
    holds ``value`` until this run's first step and reaches 0 at its last, so a curriculum leg gets the whole
    decay, not its tail. A class, not a closure: SB3 pickles the schedule into ``model.zip``.
    """

    value: float
    run_share: float = 1.0

    def __call__(self, progress_remaining: float) -> float:
        return self.value * min(max(progress_remaining, 0.0) / self.run_share, 1.0)


def resolve_schedules(hp: dict[str, Any], first_step: int, total: int) -> dict[str, Any]:
    """``hp`` with every ``lin_<value>`` of :data:`SCHEDULE_KEYS` replaced by a :class:`LinearToZero` over the
    steps ``first_step .. total`` (``0 <= first_step < total``)."""
    out = dict(hp)
    for key in SCHEDULE_KEYS:
        if isinstance(out.get(key), str):
            out[key] = LinearToZero(linear_value(key, out[key]), (total - first_step) / total)
    return out


def action_noise(hp: dict[str, Any], n_actions: int) -> Any:
    """rl-zoo's ``noise_type`` / ``noise_std`` entries of ``hp`` (removed from it) as an SB3 action noise, or None.

    Raises
    ------
    TrainConfigError
        An unknown ``noise_type``, a ``noise_std`` that is not a finite number >= 0, or one key without the other.
    """
    kind, std = (hp.pop(k, None) for k in NOISE_KEYS)
    if kind is None and std is None:
        return None
    if kind is None or std is None:
        raise TrainConfigError("hyperparameters noise_type and noise_std go together (rl-zoo's action noise)")
    if kind not in NOISE_TYPES:
        raise TrainConfigError(f"hyperparameter noise_type: {kind!r} is not one of {', '.join(NOISE_TYPES)}")
    if isinstance(std, bool) or not isinstance(std, (int, float)) or not (math.isfinite(std) and std >= 0):
        raise TrainConfigError(f"hyperparameter noise_std must be a finite number >= 0, got {std!r}")
    import numpy as np
    from stable_baselines3.common.noise import NormalActionNoise, OrnsteinUhlenbeckActionNoise

    cls = NormalActionNoise if kind == "normal" else OrnsteinUhlenbeckActionNoise
    return cls(mean=np.zeros(n_actions), sigma=float(std) * np.ones(n_actions))


def evaluate_str(value: Any, key: str) -> Any:
    # rl-zoo stores policy_kwargs / normalize as Python expressions in strings.
    if not isinstance(value, str):
        return value
    try:
        return eval(value, {"__builtins__": {}, "dict": dict, "True": True, "False": False})  # noqa: S307
    except Exception as exc:  # noqa: BLE001 - any failure is a malformed config entry
        raise TrainConfigError(f"hyperparameter {key}: cannot read {value!r} ({type(exc).__name__}: {exc})") from None


def wrappers_from_env_wrapper(spec: Any) -> tuple[bool, float]:
    """``(shield, residual_scale)`` from an rl-zoo ``env_wrapper`` entry (``None``: the bare policy).

    Only the two wrappers of this project are understood, innermost first as rl-zoo applies them: the shield,
    then the residual (which must sit outside the shield: the shield filters the combined command).
    """
    if spec is None:
        return False, 0.0
    items = spec if isinstance(spec, list) else [spec]
    shield, residual, names = False, 0.0, []
    for item in items:
        name, kwargs = (next(iter(item.items())) if isinstance(item, dict) and len(item) == 1 else (item, {}))
        names.append(name)
        if name == SHIELD_WRAPPER and not kwargs:
            shield = True
        elif name == RESIDUAL_WRAPPER and set(kwargs or {}) <= {"scale"}:
            residual = float((kwargs or {}).get("scale", 0.5))
        else:
            raise TrainConfigError(
                f"env_wrapper entry {item!r} is not supported (use {SHIELD_WRAPPER} and/or "
                f"{RESIDUAL_WRAPPER}: {{scale: x}})"
            )
    if names not in ([], [SHIELD_WRAPPER], [RESIDUAL_WRAPPER], [SHIELD_WRAPPER, RESIDUAL_WRAPPER]):
        raise TrainConfigError(f"env_wrapper {names}: the residual must come after (outside) the shield")
    return shield, residual


__all__ = [
    "HYPERPARAMS_DIR",
    "LINEAR_PREFIX",
    "LinearToZero",
    "NOISE_KEYS",
    "NOISE_TYPES",
    "RESIDUAL_WRAPPER",
    "SCHEDULE_KEYS",
    "SHIELD_WRAPPER",
    "TrainConfigError",
    "action_noise",
    "evaluate_str",
    "load_hyperparams",
    "linear_value",
    "parse_value",
    "resolve_schedules",
    "wrappers_from_env_wrapper",
]
