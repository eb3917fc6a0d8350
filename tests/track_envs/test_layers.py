"""The layers of track_envs import only downwards, and track_envs imports neither predictors nor agents.

Layers, lowest first: ``infra`` (compiled kernels, registries, argument checks, assignment),
``values`` (value types), ``contracts`` (observation / report), ``io`` (files), ``metrics``,
``wrappers``, ``envs`` (with ``registration``, which only names them), ``streams``, and the
package's own top (``__init__``, ``testing``). Every import is checked, also those
inside functions.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from import_scan import file_imports

import track_envs

ROOT = Path(track_envs.__file__).parent
LAYERS = ("infra", "values", "contracts", "io", "metrics", "wrappers", "envs", "streams", "top")
#: Top-level modules of the package and the layer each belongs to.
TOP_MODULES = {"registration": "envs", "testing": "top", "__init__": "top"}


def layer_of(module: str) -> str:
    """The layer of a dotted ``track_envs`` module name (``track_envs`` itself: the top)."""
    parts = module.split(".")
    if len(parts) == 1:
        return "top"
    if parts[1] in LAYERS:
        return parts[1]
    if parts[1] in TOP_MODULES:
        return TOP_MODULES[parts[1]]
    raise AssertionError(f"{module} is in no layer: put it in one of {LAYERS[:-1]}")


def imports(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every absolute import in ``path`` (``import_scan.file_imports``)."""
    return file_imports(path, ROOT)


MODULES = sorted(ROOT.rglob("*.py"))


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_go_down_the_layers(path):
    name = ".".join(("track_envs", *path.relative_to(ROOT).with_suffix("").parts))
    own = LAYERS.index(layer_of(name))
    for line, module in imports(path):
        top = module.split(".")[0]
        assert top not in ("predictors", "agents"), f"{path}:{line}: track_envs imports {module}"
        if top != "track_envs":
            continue
        other = LAYERS.index(layer_of(module))
        assert other <= own, (
            f"{path.relative_to(ROOT.parent)}:{line} ({LAYERS[own]}) imports {module} ({LAYERS[other]}), "
            f"a higher layer; layers from the bottom: {LAYERS}"
        )


def test_every_module_has_a_layer_and_no_flat_modules_remain():
    flat = sorted(p.stem for p in ROOT.glob("*.py"))
    outside = set(flat) - set(TOP_MODULES)
    assert not outside, f"modules at the top outside a layer: {sorted(outside)}"
    folders = sorted(p.name for p in ROOT.iterdir() if (p / "__init__.py").is_file())
    assert set(folders) <= set(LAYERS), folders
