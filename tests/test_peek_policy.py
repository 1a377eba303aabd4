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


def test_the_env_is_built_as_the_policy_was_trained_and_the_trace_shows_the_last_steps():
    # trained on 50-300 m tracks with the acceleration action: seed 100000 draws a 198 m track there (218 m on the
    # default tracks, which is what the script ran before it read the run's configuration)
    accel = ROOT / "results" / "rl" / "policies" / "ppo_bare_accel_mix_s1_selected"
    out = subprocess.run([*SCRIPT, str(accel), "--seeds", "100000", "--max-steps", "30", "--trace", "3"],
                         capture_output=True, text=True, check=True, cwd=ROOT).stdout.splitlines()
    assert out[0].startswith("seed 100000: running at 3 s") and "/ 198 m" in out[0]
    assert out[1].split() == ["t_s", "position_m", "to_go_m", "speed_mps", "true_limit_mps", "action", "ending"]
    assert [float(r.split()[0]) for r in out[2:]] == [2.8, 2.9, 3.0]


def test_sampled_actions_are_seeded_and_are_not_the_mean():
    sac = ROOT / "results" / "rl" / "policies" / "sac_bare_accel_mix_s0_selected"
    cmd = [*SCRIPT, str(sac), "--seeds", "100000", "100001", "--max-steps", "30", "--trace", "5"]
    mean = subprocess.run(cmd, capture_output=True, text=True, check=True, cwd=ROOT).stdout
    a, b = (subprocess.run([*cmd, "--sample", "7"], capture_output=True, text=True, check=True, cwd=ROOT).stdout
            for _ in range(2))
    assert a == b and a != mean
    assert a.splitlines()[-1] == "endings: running 2"


def test_a_policy_that_acts_through_a_wrapper_is_refused():
    # a margin schedule: its action is the rule-based controller's margin, not a command the bare env understands
    margin = ROOT / "results" / "rl" / "policies" / "ppo_margin_004_012_300k_s0"
    bad = subprocess.run([*SCRIPT, str(margin), "--seeds", "100000", "--max-steps", "5"],
                         capture_output=True, text=True, cwd=ROOT)
    assert bad.returncode != 0 and "uuom-evaluate" in bad.stderr


def test_the_trace_can_show_observation_entries_and_the_critic():
    sac = ROOT / "results" / "rl" / "policies" / "sac_bare_accel_mix_s1_selected"
    out = subprocess.run([*SCRIPT, str(sac), "--seeds", "100000", "--max-steps", "20", "--trace", "2",
                          "--trace-obs", "speed", "est_mass_std", "--critic"],
                         capture_output=True, text=True, check=True, cwd=ROOT).stdout.splitlines()
    assert out[1].split()[-6:] == ["speed", "est_mass_std", "Q(action)", "Q(-1)", "Q(0)", "Q(+1)"]
    rows = [[float(x) for x in r.split()] for r in out[2:]]
    assert len(rows) == 2 and all(len(r) == 12 for r in rows)  # 'ending' is empty while running
    assert all(abs(r[6] * 2.0 - r[3]) < 0.2 for r in rows)  # observed speed / 2 m/s ~ the step's speed


def test_the_critic_is_refused_for_an_on_policy_learner_and_unknown_names_are_named():
    ppo = ROOT / "results" / "rl" / "policies" / "ppo_bare_accel_mix_s1_selected"
    bad = subprocess.run([*SCRIPT, str(ppo), "--seeds", "100000", "--max-steps", "5", "--trace", "2", "--critic"],
                         capture_output=True, text=True, cwd=ROOT)
    assert bad.returncode != 0 and "SAC/TD3" in bad.stderr and "PPO" in bad.stderr
    bad = subprocess.run([*SCRIPT, str(ppo), "--seeds", "100000", "--max-steps", "5", "--trace", "2",
                          "--trace-obs", "sped"], capture_output=True, text=True, cwd=ROOT)
    assert bad.returncode != 0 and "unknown observation name(s) sped" in bad.stderr
    bad = subprocess.run([*SCRIPT, str(ppo), "--seeds", "100000", "--max-steps", "5", "--trace-obs", "speed"],
                         capture_output=True, text=True, cwd=ROOT)
    assert bad.returncode != 0 and "give --trace N too" in bad.stderr


def test_compare_prints_how_far_another_policy_acts_on_the_same_states():
    """A policy compared with itself is 0 apart; with another seed of its recipe, apart; the episode is the target's
    (the same ending line as without ``--compare``)."""
    a = ROOT / "results" / "rl" / "policies" / "ppo_bc_ceiling_traction_s1"
    b = ROOT / "results" / "rl" / "policies" / "ppo_bc_ceiling_traction_s0"
    base = [*SCRIPT, str(a), "--seeds", "100000", "--max-steps", "200"]
    plain = subprocess.run(base, capture_output=True, text=True, check=True, cwd=ROOT).stdout.splitlines()[0]
    same = subprocess.run([*base, "--compare", str(a)], capture_output=True, text=True, check=True,
                          cwd=ROOT).stdout.splitlines()[0]
    other = subprocess.run([*base, "--compare", str(b / "model.zip")], capture_output=True, text=True, check=True,
                           cwd=ROOT).stdout.splitlines()[0]
    assert same == plain + ", |command - ppo_bc_ceiling_traction_s1's| mean 0.000 max 0.000"
    assert other.startswith(plain + ", |command - ppo_bc_ceiling_traction_s0's| mean ")
    assert float(other.rsplit("max ", 1)[1]) > 0.01
    bad = subprocess.run([*base, "--compare", str(ROOT / "results" / "rl" / "policies" / "ppo_margin_004_012_300k_s0")],
                         capture_output=True, text=True, cwd=ROOT)
    assert bad.returncode != 0 and "uuom-evaluate" in bad.stderr
