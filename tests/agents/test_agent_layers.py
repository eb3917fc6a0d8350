"""The layers of agents import only downwards, and agents imports no application (track_apps).

Layers, lowest first, each a set of modules (a module belongs to the layer of the longest dotted
prefix of its name in `MODULE_LAYERS`):

* ``base`` — the Agent protocol, its declared traits and capabilities, the registry;
* ``trackers`` — the tracker core and its components (``tracking``), the named trackers (gnn,
  jpda, particle, pose, one-step, the detections reference) and the roll-out a tracker reports
  its sorting channel with (``sorting.rollout``);
* ``loops`` — any agent over an env episode (``episode``), a merge-event stream
  (``merge_scoring``) or a detection stream (``files.loop``, ``files.kinds``, the sorting
  channel's collector ``sorting.collect``);
* ``sensor_model`` — the sensor model estimated from a stream (it tracks the stream with trial
  settings: the ``loops``);
* ``files`` — the engine of ``track run``: ``run_agent`` with the estimate (``estimate_sensor_model``), the
  pose stream, the sorting check and the pose run's diagnostics;
* ``top`` — the package itself (``agents/__init__``: the registry's built-ins and the re-exports).

Every import is checked, also those inside functions.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from import_scan import file_imports

import agents

ROOT = Path(agents.__file__).parent
LAYERS = ("base", "trackers", "loops", "sensor_model", "files", "top")
#: Dotted module prefixes and their layer (the longest prefix of a module's name decides).
MODULE_LAYERS = {
    "agents": "top",
    "agents.base": "base",
    "agents.tracking": "trackers",
    "agents.gnn": "trackers",
    "agents.jpda": "trackers",
    "agents.particle": "trackers",
    "agents.pose": "trackers",
    "agents.one_step": "trackers",
    "agents.detections_agent": "trackers",
    "agents.sorting.rollout": "trackers",
    "agents.episode": "loops",
    "agents.merge_scoring": "loops",
    "agents.files.kinds": "loops",
    "agents.files.loop": "loops",
    "agents.sorting.collect": "loops",
    "agents.sensor_model": "sensor_model",
    "agents.files": "files",
    "agents.sorting": "files",
}


def layer_of(module: str) -> str:
    """The layer of a dotted ``agents`` module name."""
    parts = module.split(".")
    for n in range(len(parts), 0, -1):
        prefix = ".".join(parts[:n])
        if prefix in MODULE_LAYERS:
            return MODULE_LAYERS[prefix]
    raise AssertionError(f"{module} is in no layer")


def imports(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every absolute import in ``path`` (``import_scan.file_imports``)."""
    return file_imports(path, ROOT)


def module_name(path: Path) -> str:
    parts = path.relative_to(ROOT.parent).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = sorted(ROOT.rglob("*.py"))


@pytest.mark.parametrize("path", MODULES, ids=lambda p: str(p.relative_to(ROOT)))
def test_imports_go_down_the_layers(path):
    own = LAYERS.index(layer_of(module_name(path)))
    for line, module in imports(path):
        top = module.split(".")[0]
        assert top != "track_apps", f"{path}:{line}: agents imports the application {module}"
        if top != "agents":
            continue
        other = LAYERS.index(layer_of(module))
        assert other <= own, (
            f"{path.relative_to(ROOT.parent)}:{line} ({LAYERS[own]}) imports {module} ({LAYERS[other]}), "
            f"a higher layer; layers from the bottom: {LAYERS}"
        )


def test_every_layer_holds_a_module():
    assert {layer_of(module_name(p)) for p in MODULES} == set(LAYERS)
