"""Benchmark of trace I/O and ``uuom-estimate`` on a long log: wall time and peak memory (RSS).

Every measurement runs in a fresh Python process that reports its own wall time and CPU time (user + system, imports
included; on a shared machine CPU time is the steadier figure) and peak resident memory
(``resource.getrusage(RUSAGE_SELF).ru_maxrss``), so one cannot inherit another's memory.

::

    python scripts/bench_trace_io.py                      # 10^6 rows: reader, exact path, pyarrow, writer
    python scripts/bench_trace_io.py --cli dffrls-aekf    # also the whole command with that estimator
    python scripts/bench_trace_io.py --rows 200000 --json

The trace (synthetic, ``section1``, seed 1, 200 Hz, with a motor-speed column and one column the reader ignores)
is built once and cached in ``--dir``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_PRELUDE = "import json, resource, sys, time\nt0 = time.perf_counter()\n"
_REPORT = ("ru = resource.getrusage(resource.RUSAGE_SELF)\n"
           "print(json.dumps({'wall_s': time.perf_counter() - t0, 'cpu_s': ru.ru_utime + ru.ru_stime, "
           "'peak_rss_mb': ru.ru_maxrss / 1024}))\n")

CASES: dict[str, str] = {
    "read (fast path)": """
        from uuom_core.trace import read_trace_csv
        tr = read_trace_csv(PATH)
        assert len(tr) == ROWS
    """,
    "read (exact path, forced)": """
        from unittest import mock
        import uuom_core.trace as T
        with mock.patch.object(T, "parse_fast", lambda *a, **k: None):
            tr = T.read_trace_csv(PATH)
        assert len(tr) == ROWS
    """,
    "pyarrow streaming, 1 thread (reference)": """
        import numpy as np, pyarrow.csv as pc
        r = pc.open_csv(PATH, read_options=pc.ReadOptions(block_size=4 << 20, use_threads=False),
                        convert_options=pc.ConvertOptions(null_values=[""]))
        parts = {}
        for b in r:
            for name, col in zip(b.schema.names, b.columns):
                parts.setdefault(name, []).append(col.to_numpy(zero_copy_only=False))
        cols = {k: np.concatenate(v) for k, v in parts.items()}
        assert len(cols["t_s"]) == ROWS
    """,
    "write (atomic, 5 columns)": """
        import numpy as np
        from uuom_core.trace import write_csv_atomic
        x = np.random.default_rng(0).normal(26000.0, 100.0, ROWS)
        write_csv_atomic(OUT, ["t_s", "mass_kg", "slope_deg", "mass_std_kg", "slope_std_deg"],
                         [np.arange(ROWS) * 0.005, x, x / 1e4, x / 100, x / 1e6])
    """,
}


def build_trace(path: Path, rows: int) -> None:
    """The benchmark trace (cached): synthetic ``section1`` plus a motor-speed and an ignored column."""
    code = f"""
        import numpy as np
        from uuom_core.synthetic import synthetic_trace
        from uuom_core.trace import write_csv_atomic
        tr = synthetic_trace("section1", seed=1, duration_s={rows} * 0.005)
        cols = dict(tr.columns)
        cols["motor_speed_radps"] = cols["speed_mps"] / 0.17
        cols["logger_counter"] = np.arange(len(tr), dtype=float)
        write_csv_atomic({str(path)!r}, list(cols), list(cols.values()))
    """
    subprocess.run([sys.executable, "-c", textwrap.dedent(code)], cwd=ROOT, check=True)


def measure(code: str, path: Path, rows: int, out: Path) -> dict[str, float]:
    body = textwrap.dedent(code).replace("PATH", repr(str(path))).replace("ROWS", str(rows))
    body = body.replace("OUT", repr(str(out)))
    res = subprocess.run([sys.executable, "-c", _PRELUDE + body + _REPORT], cwd=ROOT, capture_output=True,
                         text=True, env={**os.environ, "OMP_NUM_THREADS": "1"})
    if res.returncode != 0:
        raise SystemExit(f"bench_trace_io: case failed:\n{res.stderr}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--rows", type=int, default=1_000_000)
    p.add_argument("--dir", type=Path, default=Path("/tmp/uuom-bench-trace"))
    p.add_argument("--cli", metavar="ESTIMATOR", action="append", default=[],
                   help="also time `uuom-estimate TRACE --estimator ESTIMATOR --out OUT` (repeatable)")
    p.add_argument("--skip", action="append", default=[], help="leave out cases whose name starts with this")
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    if args.rows < 2:
        p.error("--rows must be >= 2")
    args.dir.mkdir(parents=True, exist_ok=True)
    path = args.dir / f"trace_{args.rows}.csv"
    if not path.exists():
        build_trace(path, args.rows)
    out = args.dir / "out.csv"
    cases = dict(CASES)
    for est in args.cli:
        cases[f"uuom-estimate --estimator {est}"] = f"""
            from estimators.cli import main
            assert main([PATH, "--estimator", {est!r}, "--out", OUT, "--json"]) == 0
        """
    results = {}
    for name, code in cases.items():
        if any(name.startswith(s) for s in args.skip):
            continue
        results[name] = measure(code, path, args.rows, out)
        if not args.json:
            r = results[name]
            print(f"{name:45s} {r['wall_s']:7.2f} s wall {r['cpu_s']:7.2f} s CPU {r['peak_rss_mb']:7.1f} MB peak",
                  flush=True)
    size_mb = path.stat().st_size / 1e6
    if args.json:
        print(json.dumps({"rows": args.rows, "file_mb": size_mb, "results": results}, indent=2))
    else:
        print(f"({args.rows} rows, {size_mb:.1f} MB file {path}; times include Python start-up and imports; "
              f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs at the end)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
