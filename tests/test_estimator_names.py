"""Estimator lists on command lines: ``estimators.parse_names`` and ``estimators.cli.names_argument``, and the four
scripts that take ``--estimators`` (an unknown name is a usage error before any work, not a traceback halfway)."""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import pytest

import estimators
from estimators.cli import names_argument

_SCRIPTS = Path(__file__).parents[1] / "scripts"


def _script(name: str):
    spec = importlib.util.spec_from_file_location(name, _SCRIPTS / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_parse_names_splits_on_commas_and_spaces_and_keeps_order() -> None:
    assert estimators.parse_names("fused,dffrls-aekf") == ["fused", "dffrls-aekf"]
    assert estimators.parse_names(["fused, ekf", "rls"]) == ["fused", "ekf", "rls"]
    assert estimators.parse_names("none,rls", also=["none"]) == ["none", "rls"]


@pytest.mark.parametrize("given", ["", " , ", []])
def test_parse_names_without_a_name_is_an_error(given) -> None:
    with pytest.raises(ValueError, match="no estimator name"):
        estimators.parse_names(given)


def test_an_unknown_name_is_named_with_the_choices() -> None:
    with pytest.raises(estimators.UnknownEstimatorError) as exc:
        estimators.parse_names("fused,kalman")
    message = str(exc.value)
    assert "'kalman'" in message and all(n in message for n in estimators.available())
    # the registry's own lookup says the same
    with pytest.raises(estimators.UnknownEstimatorError) as exc2:
        estimators.get_class("kalman")
    assert str(exc2.value) == message
    # a script's extra names are offered too, and are not registered names
    with pytest.raises(estimators.UnknownEstimatorError, match="none"):
        estimators.parse_names("kalman", also=["none"])
    with pytest.raises(estimators.UnknownEstimatorError):
        estimators.parse_names("none")


def test_names_argument_default_and_usage_error(capsys) -> None:
    parser = argparse.ArgumentParser(prog="some_script.py")
    assert names_argument(parser, None, default=["rls"]) == ["rls"]
    assert names_argument(parser, ["rls,ekf"]) == ["rls", "ekf"]
    for bad in ("kalman", ","):
        with pytest.raises(SystemExit) as exc:
            names_argument(parser, bad)
        assert exc.value.code == 2
        err = capsys.readouterr().err
        assert err.startswith("usage: some_script.py") and "--estimators: " in err


@pytest.mark.parametrize("script, argv", [
    ("fault_recovery", ["--estimators", "fused", "kalman"]),
    ("benchmark_estimators", ["--estimators", "fused,kalman", "--quick"]),
    ("bench_estimator_speed", ["--estimators", "fused,kalman", "--repeat", "1"]),
    ("estimator_env_accuracy", ["--estimators", "none,kalman", "--mode", "offline", "--seeds", "0:1"]),
])
def test_each_script_rejects_an_unknown_name_before_any_work(script, argv, capsys) -> None:
    with pytest.raises(SystemExit) as exc:
        _script(script).main(argv)
    assert exc.value.code == 2
    out, err = capsys.readouterr()
    assert "unknown estimator 'kalman'" in err
    assert out == ""  # nothing was run or printed before the check


def test_estimator_env_accuracy_default_list_constructs() -> None:
    """Its default named ``dffrls-aekf@before``, whose options the class had lost: the default run failed."""
    module = _script("estimator_env_accuracy")
    names = estimators.parse_names(module.DEFAULT_ESTIMATORS, also=["none", *(f"{k}@before" for k in module.BEFORE_OPTIONS)])
    for name in names:
        if name != "none":
            base, options = module._split(name)
            assert estimators.make(base, **options) is not None
