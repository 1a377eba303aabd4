#!/usr/bin/env python
"""Train one agent per (observer, seed) in parallel: local processes by default, Ray with ``--ray``.

Example (one machine, two trainings at a time)::

    python scripts/sweep.py --algo ppo --observers dffrls-aekf ekf none --seeds 0 1 2 --timesteps 200000 --jobs 2

Every job is ``uuom-train`` (:mod:`agents.cli`) with the same arguments plus its ``--observer`` and ``--seed``
(extra ``uuom-train`` options go after ``--``), single-process inside (``--n-envs 1 --no-subproc`` unless given
after ``--``) so that ``--jobs`` decides the parallelism. An interrupted sweep resumes every run that has a
checkpoint when rerun (``--resume`` is added for those). With ``--ray`` the jobs become Ray tasks
(``pip install -e ".[ray]"``; set ``RAY_ADDRESS`` for a cluster), one CPU each. Then compare them with
``uuom-evaluate --controllers runs/...``.
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def job_command(algo: str, observer: str, seed: int, timesteps: int | None, extra: list[str]) -> list[str]:
    """The ``uuom-train`` command line of one job (``--resume`` when its run directory has a checkpoint)."""
    from agents.checkpoints import latest_checkpoint
    from agents.cli import train_config, train_parser
    from agents.training import plan

    args = ["--algo", algo, "--observer", observer, "--seed", str(seed), "--no-progress"]
    if timesteps is not None:
        args += ["--timesteps", str(timesteps)]
    if "--n-envs" not in extra:
        args += ["--n-envs", "1", "--no-subproc"]
    args += extra
    config = train_config(train_parser().parse_args(args))
    if not config.resume and not config.fresh and latest_checkpoint(plan(config).run_dir / "checkpoints"):
        args.append("--resume")
    return [sys.executable, "-c", "import sys; from agents.cli import train_main; sys.exit(train_main())", *args]


def _run(cmd: list[str]) -> int:
    print("$", " ".join(cmd), flush=True)
    return subprocess.run(cmd, cwd=ROOT).returncode


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    extra: list[str] = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1 :]
    from agents.algos import ALGOS

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--algo", default="ppo", choices=ALGOS)
    ap.add_argument("--observers", nargs="+", default=["dffrls-aekf"])
    ap.add_argument("--seeds", nargs="+", type=int, default=[0])
    ap.add_argument("--timesteps", type=int, default=None)
    ap.add_argument("--jobs", type=int, default=max((os.cpu_count() or 2) // 2, 1), help="parallel trainings")
    ap.add_argument("--ray", action="store_true")
    args = ap.parse_args(argv)
    cmds = [job_command(args.algo, o, s, args.timesteps, extra) for o in args.observers for s in args.seeds]
    if args.ray:
        from agents.ray_support import RayUnavailableError, init_ray

        try:
            ray = init_ray()
        except RayUnavailableError as exc:
            ap.error(str(exc))
        remote = ray.remote(num_cpus=1)(_run)
        codes = ray.get([remote.remote(c) for c in cmds])
    else:
        with ThreadPoolExecutor(max_workers=max(args.jobs, 1)) as pool:
            codes = list(pool.map(_run, cmds))
    failed = [" ".join(c) for c, rc in zip(cmds, codes) if rc != 0]
    for f in failed:
        print("FAILED:", f, file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(main())
