#!/usr/bin/env python
"""DAgger warm start of a bare PPO policy on UUOM-Track-v0's traction command (:mod:`agents.dagger`).

Usage::

    python scripts/dagger.py --seed 0 --run-dir runs/dagger_s0                      # ~10-15 min on one core
    uuom-evaluate --controllers runs/dagger_s0 --observers dffrls-aekf --episodes 100 --workers 2 --out /tmp/dg
    uuom-train --init-from runs/dagger_s0 --residual 0 --no-shield --seed 0 --timesteps 300000 \\
        --eval-freq 0 --checkpoint-freq 50000 --run-dir runs/dagger_ppo_s0           # PPO continues from it

Writes the run directory (``model.zip``, ``vecnormalize.pkl``, ``config.json``, ``dagger.json`` with every
iteration's validation, ``iterations/<k>/`` each fit as a policy folder).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys

from agents.dagger import KEEP_RULES, DaggerConfig, DaggerError, dagger


def main(argv: list[str] | None = None) -> int:
    defaults = DaggerConfig(run_dir="")
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--run-dir", required=True)
    ap.add_argument("--observer", default=defaults.observer)
    ap.add_argument("--seed", type=int, default=defaults.seed)
    ap.add_argument("--env-kwargs", type=json.loads, default={}, help="JSON env config (traction command only)")
    ap.add_argument("--demonstrator-options", type=json.loads, default=dict(defaults.demonstrator_options),
                    help="JSON keyword arguments of the rule-based controller (default "
                         f"'{json.dumps(defaults.demonstrator_options)}'; '{{}}': the controller as it is)")
    for f in dataclasses.fields(DaggerConfig):
        if f.name in ("run_dir", "observer", "seed", "env_kwargs", "hyperparams", "demonstrator_options"):
            continue
        ap.add_argument("--" + f.name.replace("_", "-"), type=type(getattr(defaults, f.name)),
                        default=getattr(defaults, f.name),
                        **({"choices": KEEP_RULES} if f.name == "keep" else {}))
    ap.add_argument("--hyperparams", nargs="*", default=[], metavar="KEY=VALUE",
                    help="overrides of agents/hyperparams/ppo.yml's UUOM-Track-v0 entry (as uuom-train takes them)")
    args = vars(ap.parse_args(argv))
    args["hyperparams"] = tuple(args["hyperparams"])
    try:
        run_dir = dagger(DaggerConfig(**args))
    except DaggerError as exc:
        print(f"uuom dagger: error: {exc}", file=sys.stderr)
        return 2
    print(f"-> {run_dir}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
