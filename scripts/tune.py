#!/usr/bin/env python
"""Hyperparameter sweep around ``uuom-train`` — the same as the ``uuom-tune`` console script.

Example (Ray Tune on this machine, two trials at a time)::

    python scripts/tune.py --residual 0 --no-shield --timesteps 100000 --space learning_rate=1e-4,3e-4 seed=0,1 \\
        --backend ray --out runs/tune/lr

What a trial is and how it is scored: :mod:`agents.tune`.
"""

from __future__ import annotations

from agents.cli import tune_main

if __name__ == "__main__":
    raise SystemExit(tune_main())
