#!/usr/bin/env python
"""Choose each training run's checkpoint on validation tracks and copy it out as a shippable policy folder
(:mod:`agents.checkpoint_selection`: the tracks, the rule).

Usage::

    python scripts/select_checkpoint.py runs/accel/mix_big_s0 runs/accel/mix_big_s1 --min-step 400000 \\
        --every 200000 --env-kwargs '{"action_mode": "acceleration"}' --allow-env-shift --workers 2 \\
        --out results/rl/acceleration_action/selection --copy-to results/rl/policies --suffix _selected

Writes ``OUT/<run>/`` (the validation evaluation: ``summary.md``, ``episodes.csv``), ``OUT/<run>/selection.md``
(the ranking) and, with ``--copy-to``, ``DIR/<run><suffix>/`` holding the chosen ``model.zip``,
``vecnormalize.pkl`` and the run's ``config.json`` with ``selected_checkpoint`` added.
"""

from __future__ import annotations

import argparse
import json
import shlex
import shutil
import sys
from pathlib import Path

from agents.checkpoint_selection import candidates, rank, ranking_markdown
from agents.evaluation import DEFAULT_SEED_BASE, EvalConfig, controller_label, evaluate, run_config_path
from agents.evaluation_table import read_episodes
from agents.tune import VALIDATION_SEED_BASE


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", type=Path, nargs="+", help="training run directories (with checkpoints/step_<n>)")
    ap.add_argument("--min-step", type=int, default=0, help="ignore checkpoints before this step")
    ap.add_argument("--every", type=int, default=0, help="only checkpoints at multiples of this step (0: all)")
    ap.add_argument("--episodes", type=int, default=50, help="validation tracks per candidate")
    ap.add_argument("--seed-base", type=int, default=VALIDATION_SEED_BASE,
                    help="first validation seed (default: agents.tune's, disjoint from the held-out 100000 on)")
    ap.add_argument("--env-kwargs", type=json.loads, default={}, help="JSON env config of the validation tracks")
    ap.add_argument("--allow-env-shift", action="store_true", help="validate off the runs' training env on purpose")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--out", type=Path, required=True)
    ap.add_argument("--copy-to", type=Path, default=None, help="copy each chosen policy to DIR/<run><suffix>")
    ap.add_argument("--suffix", default="_selected")
    args = ap.parse_args(argv)
    if args.seed_base < VALIDATION_SEED_BASE and args.seed_base + args.episodes > DEFAULT_SEED_BASE:
        ap.error(f"--seed-base {args.seed_base} overlaps the held-out tracks ({DEFAULT_SEED_BASE} on); validate on others")
    for run in args.runs:
        try:
            cands = candidates(run, args.min_step, args.every)
        except (FileNotFoundError, ValueError) as exc:
            ap.error(str(exc))
        observer = json.loads(run_config_path(run).read_text()).get("observer", "dffrls-aekf")
        labels = {controller_label(str(c)): c for c in cands}
        out = args.out / run.name
        evaluate(EvalConfig(controllers=[str(c) for c in cands], observers=[observer], episodes=args.episodes,
                            seed_base=args.seed_base, workers=args.workers, env_kwargs=args.env_kwargs,
                            allow_env_shift=args.allow_env_shift, out=out, quiet=True,
                            command=shlex.join(["python", "scripts/select_checkpoint.py", *sys.argv[1:]])))
        table = rank(read_episodes(out / "episodes.csv"), labels)
        md = (f"Validation seeds {args.seed_base}..{args.seed_base + args.episodes - 1}, observer {observer}; "
              f"rule: agents.checkpoint_selection.\n\n{ranking_markdown(table)}\n")
        (out / "selection.md").write_text(md)
        print(f"{run}: {table[0]['candidate']} ({table[0]['arrived']}/{table[0]['episodes']} arrived, "
              f"{table[0]['trips']} trips)")
        if args.copy_to is not None:
            best = Path(table[0]["folder"])
            dest = args.copy_to / f"{run.name}{args.suffix}"
            dest.mkdir(parents=True, exist_ok=True)
            for name in ("model.zip", "vecnormalize.pkl"):
                if (best / name).is_file():
                    shutil.copy2(best / name, dest / name)
            cfg = json.loads(run_config_path(best).read_text())
            cfg["selected_checkpoint"] = {"step": table[0]["step"], "validation_seeds": [args.seed_base, args.episodes],
                                          "arrived": table[0]["arrived"], "trips": table[0]["trips"]}
            (dest / "config.json").write_text(json.dumps(cfg, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
