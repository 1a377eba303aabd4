"""``uuom-estimate`` never loses a file: output paths it must refuse, permissions, interruption and kills.

Run as real processes (``python -m estimators.cli``), since signals, umask and file permissions are what is tested.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import stat
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from uuom_core.atomic_write import remove_stale_temps
from uuom_core.synthetic import synthetic_trace
from uuom_core.trace import write_trace_csv

ROOT = Path(__file__).resolve().parents[1]
PREVIOUS = "t_s,mass_kg\n0.0,1.0\n"
TEMP = re.compile(r"^\..*\.uuom-\d+-[0-9a-f]+\.tmp$")


def _cli(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "estimators.cli", *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=timeout)


def _one_error(res: subprocess.CompletedProcess) -> str:
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("uuom-estimate: error: "), res.stderr
    return lines[0]


def _temps(d: Path) -> list[str]:
    return [f for f in os.listdir(d) if TEMP.match(f)]


@pytest.fixture(scope="module")
def trace(tmp_path_factory) -> Path:
    p = tmp_path_factory.mktemp("safety") / "run.csv"
    write_trace_csv(synthetic_trace("section1", seed=4, duration_s=10.0), p)
    return p


def _plain_trace(path: Path, n: int) -> Path:
    """A long trace made fast (no simulation): what matters here is its length."""
    t = np.arange(n) * 0.005
    speed = 1.0 + 0.1 * np.sin(t)
    cols = {"t_s": t, "torque_nm": 1200.0 + 100.0 * np.sin(0.7 * t), "speed_mps": speed,
            "accel_mps2": 0.1 * np.cos(t) + 0.5, "mass_kg": np.full(n, 26_000.0), "slope_deg": np.full(n, 3.0)}
    write_trace_csv(cols, path)
    return path


def test_output_equal_to_input_is_refused_also_through_links(trace: Path, tmp_path: Path) -> None:
    before = trace.read_bytes()
    assert "output is the input file" in _one_error(_cli(str(trace), "--out", str(trace)))
    hard = tmp_path / "hard.csv"
    os.link(trace, hard)
    assert "output is the input file" in _one_error(_cli(str(trace), "--out", str(hard)))
    via = tmp_path / "via.csv"
    via.symlink_to(trace)
    assert "output is the input file" in _one_error(_cli(str(via), "--out", str(trace)))
    assert trace.read_bytes() == before


def test_symlink_fifo_device_directory_outputs_are_refused(trace: Path, tmp_path: Path) -> None:
    target = tmp_path / "target.csv"
    target.write_text(PREVIOUS)
    link = tmp_path / "link.csv"
    link.symlink_to(target)
    assert "is a symlink" in _one_error(_cli(str(trace), "--out", str(link)))
    assert link.is_symlink() and target.read_text() == PREVIOUS
    fifo = tmp_path / "fifo.csv"
    os.mkfifo(fifo)
    assert "is a FIFO" in _one_error(_cli(str(trace), "--out", str(fifo), timeout=60))
    assert stat.S_ISFIFO(os.lstat(fifo).st_mode)
    assert "is a device" in _one_error(_cli(str(trace), "--out", "/dev/null"))
    assert "is a directory" in _one_error(_cli(str(trace), "--out", str(tmp_path)))
    assert "does not exist" in _one_error(_cli(str(trace), "--out", str(tmp_path / "no" / "o.csv")))


def test_new_output_follows_umask_and_replaced_output_keeps_its_mode(trace: Path, tmp_path: Path) -> None:
    out = tmp_path / "new.csv"
    res = subprocess.run(f"umask 027 && {sys.executable} -m estimators.cli {trace} --estimator rls --out {out}",
                         shell=True, cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert res.returncode == 0, res.stderr
    assert stat.S_IMODE(os.stat(out).st_mode) == 0o640
    os.chmod(out, 0o604)
    assert _cli(str(trace), "--estimator", "rls", "--out", str(out)).returncode == 0
    assert stat.S_IMODE(os.stat(out).st_mode) == 0o604


def _unprivileged() -> list[str]:
    """Command prefix that makes permissions count: none for a user, dropped DAC capabilities for root."""
    if os.getuid() != 0:
        return []
    setpriv = shutil.which("setpriv")
    if setpriv is None:
        pytest.skip("running as root without setpriv: permissions cannot be tested")
    caps = "-dac_override,-dac_read_search"
    return [setpriv, f"--inh-caps={caps}", f"--bounding-set={caps}", "--"]


def test_unwritable_directory_and_read_only_output(trace: Path, tmp_path: Path) -> None:
    prefix = _unprivileged() + [sys.executable, "-m", "estimators.cli", str(trace), "--out"]
    locked = tmp_path / "locked"
    locked.mkdir()
    os.chmod(locked, 0o555)
    res = subprocess.run(prefix + [str(locked / "o.csv")], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert "is not writable" in _one_error(res)
    ro = tmp_path / "o.csv"
    ro.write_text(PREVIOUS)
    os.chmod(ro, 0o444)
    res = subprocess.run(prefix + [str(ro)], cwd=ROOT, capture_output=True, text=True, timeout=120)
    assert "read-only" in _one_error(res)
    assert ro.read_text() == PREVIOUS and os.listdir(locked) == []


def _start(trace: Path, out: Path, estimator: str) -> subprocess.Popen:
    code = ("import sys\nfrom estimators.cli import main\nprint('ready', flush=True)\n"
            f"sys.exit(main([{str(trace)!r}, '--estimator', {estimator!r}, '--out', {str(out)!r}]))\n")
    # a background job inherits SIGINT ignored (and Python then keeps it so): give the child a terminal's default
    proc = subprocess.Popen([sys.executable, "-c", code], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    assert proc.stdout.readline().strip() == "ready"
    return proc


@pytest.fixture(scope="module")
def long_trace(tmp_path_factory) -> Path:
    return _plain_trace(tmp_path_factory.mktemp("long") / "long.csv", 60_000)


@pytest.mark.parametrize("sig, code", [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_interrupt_mid_run_exits_cleanly_and_keeps_the_previous_output(long_trace: Path, tmp_path: Path,
                                                                       sig: int, code: int) -> None:
    out = tmp_path / "est.csv"
    out.write_text(PREVIOUS)
    proc = _start(long_trace, out, "ekf")  # ekf: slow enough (≈ 10 s here) to be interrupted mid-run
    time.sleep(0.5)
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == code, err
    assert err.strip().splitlines() == [f"uuom-estimate: interrupted; {out} not changed"]
    assert out.read_text() == PREVIOUS and _temps(tmp_path) == []


def test_sigkill_while_writing_keeps_the_previous_output_and_the_next_run_cleans_up(tmp_path: Path) -> None:
    trace = _plain_trace(tmp_path / "big.csv", 400_000)
    out = tmp_path / "est.csv"
    out.write_text(PREVIOUS)
    proc = _start(trace, out, "ffrls")
    deadline = time.monotonic() + 300
    while not _temps(tmp_path) and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.002)
    proc.kill()
    proc.communicate()
    assert _temps(tmp_path), "the kill had to land while the output was being written"
    assert out.read_text() == PREVIOUS  # the kill left the temporary file, not a truncated output
    res = _cli(str(tmp_path / "small.csv"), "--out", str(out))  # even a failing next run cleans up first
    assert res.returncode == 2
    assert _temps(tmp_path) == [] and out.read_text() == PREVIOUS


def test_stale_temp_of_a_live_process_is_kept(tmp_path: Path) -> None:
    out = tmp_path / "o.csv"
    mine = tmp_path / f".o.csv.uuom-{os.getppid()}-abcd.tmp"  # the parent is alive
    dead = tmp_path / ".o.csv.uuom-999999999-abcd.tmp"
    other = tmp_path / ".x.csv.uuom-999999999-abcd.tmp"
    for p in (mine, dead, other):
        p.write_text("partial")
    assert remove_stale_temps(out) == [dead]
    assert mine.exists() and other.exists()


@pytest.mark.slow
@pytest.mark.parametrize("seed", range(4))
def test_kill_at_random_points(tmp_path: Path, seed: int) -> None:
    """SIGINT or SIGKILL at a random moment: the output is the previous one or the complete new one."""
    trace = _plain_trace(tmp_path / "t.csv", 100_000)
    reference = tmp_path / "ref.csv"
    assert _cli(str(trace), "--estimator", "ffrls", "--out", str(reference)).returncode == 0
    rng = np.random.default_rng(seed)
    out = tmp_path / "est.csv"
    for _ in range(3):
        out.write_text(PREVIOUS)
        proc = _start(trace, out, "ffrls")
        time.sleep(float(rng.uniform(0.0, 3.0)))
        proc.send_signal(signal.SIGINT if rng.random() < 0.5 else signal.SIGKILL)
        proc.communicate(timeout=120)
        assert out.read_text() in (PREVIOUS, reference.read_text())
        # -SIGINT: the signal came before the interpreter had installed its handler (a loaded machine starts Python
        # slowly), so nothing had been written yet
        assert proc.returncode in (0, 130, -signal.SIGKILL, -signal.SIGINT)
        if proc.returncode >= 0:
            assert _temps(tmp_path) == []
        remove_stale_temps(out)
        assert _temps(tmp_path) == []
