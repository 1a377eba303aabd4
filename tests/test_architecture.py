"""The package layout points one way (docs/ARCHITECTURE.md): a forbidden import edge fails here.

    uuom_core   <- everything (depends on nothing of the project)
    estimators  -> uuom_core only
    uuom_gym    -> uuom_core; uuom_gym.envs -> estimators only through the registry (``estimators`` /
                   ``estimators.registry`` / ``estimators.base``); uuom_gym.sim -> uuom_core only
    agents      -> uuom_core, uuom_gym, estimators
    scripts     -> anything; nothing imports a script (tests neither)

The walk reads every ``import`` statement with ``ast``, including function-local ones, so a hidden edge counts.
"""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("uuom_core", "estimators", "uuom_gym", "agents", "scripts")

# importing module prefix -> the module prefixes it may import (the longest matching key rules).
ALLOWED: dict[str, set[str]] = {
    "uuom_core": {"uuom_core"},
    "estimators": {"uuom_core", "estimators"},
    "uuom_gym.sim": {"uuom_core", "uuom_gym.sim"},
    "uuom_gym": {"uuom_core", "uuom_gym", "estimators"},
    "agents": {"uuom_core", "uuom_gym", "estimators", "agents"},
    "scripts": {"uuom_core", "uuom_gym", "estimators", "agents"},
    "tests": {"uuom_core", "uuom_gym", "estimators", "agents"},
}
# uuom_gym reaches the estimators through these modules only (the observer registry and its types).
ESTIMATOR_ENTRY_POINTS = {"estimators", "estimators.registry", "estimators.base"}


def _module_name(path: Path) -> str:
    rel = path.relative_to(ROOT).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def _imports(path: Path) -> list[tuple[int, str]]:
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    out: list[tuple[int, str]] = []
    module = _module_name(path)
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.extend((node.lineno, alias.name) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative: resolve against this module's package
                base = module.split(".")
                if path.name != "__init__.py":
                    base = base[:-1]
                base = base[: len(base) - (node.level - 1)]
                name = ".".join(base + ([node.module] if node.module else []))
            else:
                name = node.module or ""
            out.append((node.lineno, name))
    return out


def _rule_for(module: str) -> set[str]:
    best = max((k for k in ALLOWED if module == k or module.startswith(k + ".")), key=len)
    return ALLOWED[best]


def _edges():
    for top in (*PACKAGES, "tests"):
        for path in sorted((ROOT / top).rglob("*.py")):
            module = _module_name(path)
            for lineno, name in _imports(path):
                target = name.split(".")[0]
                if target in (*PACKAGES, "tests"):
                    yield path, lineno, module, name, target


def test_no_forbidden_import_edge() -> None:
    bad = []
    for path, lineno, module, name, target in _edges():
        if target == "scripts" or target == "tests" and not module.startswith("tests"):
            bad.append(f"{path.relative_to(ROOT)}:{lineno}: {module} imports {name} (nothing imports a script)")
        elif not any(name == a or name.startswith(a + ".") for a in _rule_for(module)):
            bad.append(f"{path.relative_to(ROOT)}:{lineno}: {module} imports {name}")
        elif module.startswith("uuom_gym") and target == "estimators" and name not in ESTIMATOR_ENTRY_POINTS:
            bad.append(f"{path.relative_to(ROOT)}:{lineno}: {module} imports {name} (use the estimator registry)")
    assert not bad, "forbidden import edges:\n" + "\n".join(bad)


def test_walker_sees_function_local_and_relative_imports(tmp_path: Path) -> None:
    pkg = ROOT / "estimators"
    src = "def f():\n    from uuom_gym.sim import plant\n\nfrom .base import Estimator\n"
    fake = pkg / "_arch_probe_tmp.py"
    fake.write_text(src, encoding="utf-8")
    try:
        names = [n for _, n in _imports(fake)]
    finally:
        fake.unlink()
    assert names == ["uuom_gym.sim", "estimators.base"] or sorted(names) == ["estimators.base", "uuom_gym.sim"]


@pytest.mark.parametrize(
    "package, forbidden",
    [
        ("uuom_core", ("gymnasium", "pymunk", "torch", "estimators", "uuom_gym", "agents")),
        ("estimators", ("gymnasium", "pymunk", "torch", "uuom_gym", "agents", "stable_baselines3")),
    ],
)
def test_import_is_light(package: str, forbidden: tuple[str, ...]) -> None:
    code = (
        f"import sys, {package}\n"
        f"bad = [m for m in {forbidden!r} if m in sys.modules]\n"
        "print(','.join(bad))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "", f"import {package} loaded: {out.stdout.strip()}"
