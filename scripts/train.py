#!/usr/bin/env python
"""Train a speed controller on ``UUOM-Track-v0`` — the same as the ``uuom-train`` console script.

Example::

    python scripts/train.py --algo ppo --observer dffrls-aekf --timesteps 300000 --seed 0 --n-envs 2
    python scripts/train.py ... --resume        # continue after Ctrl-C (which writes a checkpoint, exit 130)

What a run writes and how the YAML's ``env_wrapper`` sets the default shield/residual: :mod:`agents.training`.
"""

from __future__ import annotations

from agents.cli import train_main

if __name__ == "__main__":
    raise SystemExit(train_main())
