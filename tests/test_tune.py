"""uuom-tune: the search space, its checks, and one sweep on both back ends (a local Ray instance) giving the
same numbers."""

from __future__ import annotations

import csv
import json

import pytest

from agents.cli import tune_main
from agents.hyperparameters import load_hyperparams
from agents.training import TrainConfig
from agents.tune import Range, SweepConfig, TuneConfigError, check_sweep, grid, parse_space, sweep

KW = {"action_mode": "speed_target", "speed_target_cap": "station", "speed_tracker": {"integral_clamp_m": 2.0},
      "speed_target_range": [0.8, 1.3], "track_length_m": [50.0, 60.0]}
TINY = ["n_steps=128", "batch_size=64"]


def _base(**kw) -> TrainConfig:
    return TrainConfig(observer="oracle", timesteps=256, n_envs=1, shield=False, residual=0.0, hyperparams=TINY,
                       env_kwargs=dict(KW), checkpoint_freq=0, **kw)


def test_space_grid_and_ranges():
    space = parse_space(["learning_rate=1e-4,3e-4", "seed=0,1,2", "ent_coef=uniform:0:0.02",
                         "observer=oracle,dffrls-aekf"])
    assert space["learning_rate"] == [1e-4, 3e-4]  # numbers, though YAML 1.1 reads "1e-4" as text
    assert space["seed"] == [0, 1, 2] and space["observer"] == ["oracle", "dffrls-aekf"]
    assert space["ent_coef"] == Range("uniform", 0.0, 0.02)
    assert len(grid({k: v for k, v in space.items() if isinstance(v, list)})) == 12


@pytest.mark.parametrize("item, words", [
    ("learning_rate", "KEY=V1"), ("learning_rate=", "KEY=V1"), ("=1", "KEY=V1"),
    ("lr=loguniform:0:1", "LOW > 0"), ("lr=uniform:2:1", "LOW < HIGH"), ("lr=uniform:a:1", "two numbers"),
    ("lr=uniform:0:1:2", "LOW < HIGH"),
])
def test_space_errors_name_the_item(item, words):
    with pytest.raises(TuneConfigError, match=words):
        parse_space([item])
    with pytest.raises(TuneConfigError, match="twice"):
        parse_space(["seed=0", "seed=1"])


@pytest.mark.parametrize("space, kw, words", [
    ({"learning_rat": [1e-4]}, {}, "no hyperparameter 'learning_rat'"),
    ({"learning_rate": ["fast"]}, {}, "learning_rate='fast'"),
    ({"observer": ["kalman"]}, {}, "observer='kalman'"),
    ({"ent_coef": Range("uniform", 0.0, 0.1)}, {}, "needs --search optuna"),
    ({"ent_coef": [0.0]}, {"search": "optuna"}, "add --backend ray"),
    ({"ent_coef": [0.0]}, {"samples": 0}, "samples"),
    ({"ent_coef": [0.0]}, {"failure_ratio": float("nan")}, "failure_ratio"),
    ({"ent_coef": [0.0]}, {"backend": "slurm"}, "unknown backend"),
])
def test_sweep_checked_before_training(tmp_path, space, kw, words):
    with pytest.raises(TuneConfigError, match=words):
        check_sweep(SweepConfig(base=_base(), space=space, out=tmp_path, **kw))
    assert not (tmp_path / "trials").exists()


def test_hyperparameter_numbers_in_exponent_form():
    assert load_hyperparams("ppo", None, ["learning_rate=1e-05"])["learning_rate"] == 1e-5
    with pytest.raises(ValueError, match="learning_rate"):
        load_hyperparams("ppo", None, ["learning_rate=nan"])


def test_cli_bad_space_is_one_line(tmp_path, capsys):
    with pytest.raises(SystemExit) as exc:
        tune_main(["--space", "learning_rate=uniform:1:0", "--out", str(tmp_path)])
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("uuom-tune: error:") and "\n" not in err


def test_sweep_local_and_on_ray_agree(tmp_path):
    """Two trials (learning rates) of a 256-step training, scored on two short validation tracks; the local back
    end and Ray Tune on a local Ray instance run the same trial function and report the same numbers."""
    pytest.importorskip("ray.tune")
    space = {"learning_rate": [1e-4, 3e-3]}
    local = sweep(SweepConfig(base=_base(), space=space, val_episodes=2, out=tmp_path / "local"))
    assert [r["objective"] for r in local] == sorted(r["objective"] for r in local)
    for r in local:
        assert 0.5 < r["objective"] <= 3.0 and 0.0 <= r["success"] <= 1.0
    with open(tmp_path / "local" / "results.csv") as fh:
        assert len(list(csv.DictReader(fh))) == 2
    assert "objective" in (tmp_path / "local" / "summary.md").read_text()
    cfg = json.loads((tmp_path / "local" / "trials" / "trial001_learning_rate-0.003" / "config.json").read_text())
    assert cfg["hyperparams"]["learning_rate"] == "0.003" and cfg["hyperparams"]["n_steps"] == "128"

    import ray

    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        on_ray = sweep(SweepConfig(base=_base(), space=space, val_episodes=2, backend="ray", out=tmp_path / "ray"))
    finally:
        ray.shutdown()

    def by_lr(rows):
        return {r["param.learning_rate"]: (r["objective"], r["success"], r["cost_rate"]) for r in rows}

    assert by_lr(on_ray) == by_lr(local)
