"""The agents module paths of the earlier release still import, as the moved modules, with a
DeprecationWarning naming the new path (``agents.MOVED_MODULES``)."""

from __future__ import annotations

import importlib
import sys

import pytest

from agents import MOVED_MODULES


def _forget(name: str) -> None:
    sys.modules.pop(name, None)
    parent, _, child = name.rpartition(".")
    if parent in sys.modules and child in vars(sys.modules[parent]):
        delattr(sys.modules[parent], child)


@pytest.mark.parametrize("old", sorted(MOVED_MODULES))
def test_old_agents_path_imports_the_new_module_and_warns(old):
    new = importlib.import_module(MOVED_MODULES[old])
    _forget(old)
    with pytest.warns(DeprecationWarning, match=rf"{old} is deprecated.*import {MOVED_MODULES[old]} instead"):
        module = importlib.import_module(old)
    assert module is new


def test_the_earlier_names_of_the_sensor_model_estimate_are_aliases():
    """In a fresh interpreter (the tests above rebind the old submodule paths' names)."""
    import subprocess

    code = (
        "from agents.sensor_model import SelfCalibration, SensorModelEstimate, calibrate, "
        "estimate_sensor_model\n"
        "assert calibrate is estimate_sensor_model and SelfCalibration is SensorModelEstimate"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_the_project_imports_no_moved_agents_path():
    """Nothing in the project uses an old path (its DeprecationWarning would be an error)."""
    import ast
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    found = []
    for folder in ("agents", "predictors", "track_envs", "examples", "benchmarks", "tests"):
        for path in (root / folder).rglob("*.py"):
            if path.name == "test_moved_modules.py" or path.parts[-2:] == ("agents", "__init__.py"):
                continue
            for node in ast.walk(ast.parse(path.read_text())):
                names = (
                    [node.module or ""]
                    if isinstance(node, ast.ImportFrom)
                    else [a.name for a in node.names]
                    if isinstance(node, ast.Import)
                    else []
                )
                found += [f"{path.relative_to(root)}: {n}" for n in names if n in MOVED_MODULES]
    assert found == []
