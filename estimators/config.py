"""Turning an estimator's keyword options into its frozen config dataclass.

The larger estimators (``mmae``, ``aupf``) keep their tuning in a frozen, validated dataclass (``MMAEConfig``,
``AUPFConfig``) so that a set-up can be built, checked, printed and compared on its own, and the estimator's
constructor only derives its working constants. The registry, the environment and ``uuom-estimate`` still pass
options as keywords (``estimators.make("mmae", n_models=50)``); :func:`split_options` sorts them into the config's
fields and the rest, which the :class:`~estimators.base.Estimator` base class rejects with a ``TypeError``.
"""

from __future__ import annotations

import dataclasses
from typing import Any, TypeVar

C = TypeVar("C")


def split_options(config_type: type[C], config: C | None, options: dict[str, Any]) -> tuple[C, dict[str, Any]]:
    """Build the config of an estimator from an optional ``config`` object and keyword ``options``.

    Parameters
    ----------
    config_type : type
        The frozen dataclass holding the estimator's tuning; its ``__post_init__`` validates.
    config : config_type or None
        A ready config; ``None`` starts from the defaults.
    options : dict
        Keyword options; those naming a field of ``config_type`` override the config's value.

    Returns
    -------
    config : config_type
        The validated config.
    rest : dict
        The options that are not fields of ``config_type`` (the caller passes them on, so unknown names are
        reported by the base class).
    """
    if config is not None and not isinstance(config, config_type):
        raise TypeError(f"config must be a {config_type.__name__}, got {type(config).__name__}")
    names = {f.name for f in dataclasses.fields(config_type)}  # type: ignore[arg-type]
    mine = {k: v for k, v in options.items() if k in names}
    rest = {k: v for k, v in options.items() if k not in names}
    if config is None:
        return config_type(**mine), rest
    return (dataclasses.replace(config, **mine) if mine else config), rest  # type: ignore[type-var]


__all__ = ["split_options"]
