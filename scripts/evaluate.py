#!/usr/bin/env python
"""Compare controllers x observers on the same held-out seeded ``UUOM-Track-v0`` tracks — the same as the
``uuom-evaluate`` console script.

Example::

    python scripts/evaluate.py --controllers oracle rule-based runs/ppo_dffrls-aekf_res_shield_s0 \\
        --observers oracle dffrls-aekf rls-ekf ekf ffrls none --episodes 100 --out results/agents/eval

Metrics, files written and the controller specs (``oracle``, ``rule-based``, ``full-throttle``, a run directory,
``<any>+shield``): :mod:`agents.evaluation`.
"""

from __future__ import annotations

from agents.cli import evaluate_main

if __name__ == "__main__":
    raise SystemExit(evaluate_main(prog="python scripts/evaluate.py"))
