"""``scripts/plot_learning_curve.py``: the default panels, ``--tags`` for any other scalar, and a tag no run logs."""

from __future__ import annotations

import csv
import importlib.util
from pathlib import Path

import pytest

_SPEC = importlib.util.spec_from_file_location(
    "plot_learning_curve", Path(__file__).parents[1] / "scripts" / "plot_learning_curve.py")
plot_learning_curve = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(plot_learning_curve)


def _run(tmp_path: Path, name: str, kl: list[float]) -> Path:
    from torch.utils.tensorboard import SummaryWriter

    run = tmp_path / name
    w = SummaryWriter(str(run / "tb" / "PPO_1"))
    for i, v in enumerate(kl):
        w.add_scalar("train/approx_kl", v, (i + 1) * 2048)
        w.add_scalar("uuom/success_rate", i / len(kl), (i + 1) * 2048)
    w.close()
    return run


def test_tags_plot_and_write_the_named_scalars(tmp_path, capsys):
    a, b = _run(tmp_path, "a", [0.01, 0.5, 12.0]), _run(tmp_path, "b", [0.02, 0.03])
    out, table = tmp_path / "kl.png", tmp_path / "kl.csv"
    assert plot_learning_curve.main([str(a), str(b), "--tags", "train/approx_kl", "--out", str(out), "--csv",
                                     str(table), "--print"]) == 0
    assert out.stat().st_size > 1000
    rows = list(csv.DictReader(table.open()))
    assert {r["tag"] for r in rows} == {"train/approx_kl"}
    assert [float(r["value"]) for r in rows if r["run"] == "a"] == [0.01, 0.5, 12.0]
    assert "a @ 6144 steps: train/approx_kl=12" in capsys.readouterr().out


def test_default_panels_skip_what_a_run_does_not_log(tmp_path):
    table = tmp_path / "c.csv"
    assert plot_learning_curve.main([str(_run(tmp_path, "a", [0.1, 0.2])), "--csv", str(table)]) == 0
    assert {r["tag"] for r in csv.DictReader(table.open())} == {"uuom/success_rate"}


def test_a_tag_no_run_logs_is_named_with_the_ones_they_do(tmp_path):
    with pytest.raises(SystemExit, match="no run logs 'train/nope'.*train/approx_kl"):
        plot_learning_curve.main([str(_run(tmp_path, "a", [0.1])), "--tags", "train/nope"])


def test_median_from_summarises_the_points_from_a_step_on(tmp_path, capsys):
    run = _run(tmp_path, "a", [100.0, 1.0, 2.0, 3.0])  # steps 2048, 4096, 6144, 8192
    assert plot_learning_curve.main([str(run), "--tags", "train/approx_kl", "--median-from", "4096"]) == 0
    assert "a train/approx_kl from 4096: median 2 (5-95 % 1.1-2.9), max 3, 3 points" in capsys.readouterr().out
