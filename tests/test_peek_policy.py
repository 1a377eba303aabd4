"""scripts/peek_policy.py: a policy is run with its own observation statistics, never silently without them."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHIPPED = ROOT / "results" / "rl" / "policies" / "ppo_bare_traction_ceiling_big_1150k_s0"
SCRIPT = [sys.executable, str(ROOT / "scripts" / "peek_policy.py")]


def test_a_model_zip_is_run_with_the_statistics_beside_it():
    out = subprocess.run([*SCRIPT, str(SHIPPED / "model.zip"), "--seeds", "100000", "--max-steps", "20"],
                         capture_output=True, text=True, check=True, cwd=ROOT).stdout
    assert out.startswith("seed 100000: running at 2 s")


def test_a_model_without_its_statistics_is_refused(tmp_path):
    shutil.copy(SHIPPED / "model.zip", tmp_path / "model.zip")
    bad = subprocess.run([*SCRIPT, str(tmp_path / "model.zip"), "--seeds", "100000", "--max-steps", "20"],
                         capture_output=True, text=True, cwd=ROOT)
    assert bad.returncode != 0 and "no VecNormalize statistics" in bad.stderr
    ok = subprocess.run([*SCRIPT, str(tmp_path / "model.zip"), "--no-normalize", "--seeds", "100000",
                         "--max-steps", "20"], capture_output=True, text=True, cwd=ROOT)
    assert ok.returncode == 0 and "seed 100000:" in ok.stdout
