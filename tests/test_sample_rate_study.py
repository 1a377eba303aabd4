"""``scripts/sample_rate_study.py``: the traces hold the sensors' noise density, and the table has every row."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

_PATH = Path(__file__).resolve().parents[1] / "scripts" / "sample_rate_study.py"
_spec = importlib.util.spec_from_file_location("sample_rate_study", _PATH)
study = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(study)


def test_noise_density_is_held() -> None:
    """At 400 Hz each sample is sqrt(2) times noisier than at 200 Hz (the same sensor read twice as often)."""
    def speed_noise(hz: float) -> float:
        tr = study.record("pm-section1", hz, 0, perfect=False)
        return float(np.std(tr["speed_mps"] - tr["true_speed_mps"]))

    assert 1.25 < speed_noise(400.0) / speed_noise(200.0) < 1.6
    perfect = study.record("pm-section1", 400.0, 0, perfect=True)
    np.testing.assert_array_equal(perfect["speed_mps"], perfect["true_speed_mps"])


def test_table(capsys) -> None:
    assert study.main(["--rates", "200,400", "--seeds", "1", "--perfect", "--scenarios", "pm-steep-empty-climb",
                       "--estimators", "dffrls-aekf"]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| `dffrls-aekf`")]
    assert len(rows) == 4  # two rates x (the trace's step, the 200 Hz settings)
    at_200 = [r.split("|")[4] for r in rows if "| 200 Hz |" in r]
    assert at_200[0] == at_200[1]  # a 200 Hz trace: the two settings are the same
