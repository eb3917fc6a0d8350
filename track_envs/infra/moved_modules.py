"""Deprecated module paths, importable for this release (``track_envs``'s, and those other
packages register).

The modules moved into layers (``infra``, ``values``, ``contracts``, ``io``, ``envs``,
``metrics``). :class:`MovedModuleFinder`, on ``sys.meta_path`` from ``import track_envs``, answers
an old dotted name (``track_envs.track_files``) with the module at its new path
(``track_envs.io.tracks``): the same module object, so every name is the same object, after a
``DeprecationWarning`` that names the new path. Nothing in the project imports an old path.

envs-move: keep-old-paths (this table keeps the old names)
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.machinery
import sys
import warnings
from collections.abc import Sequence
from types import ModuleType

#: Old dotted module name -> its new one.
MOVED: dict[str, str] = {
    "track_envs.arguments": "track_envs.infra.arguments",
    "track_envs.compiled": "track_envs.infra.compiled",
    "track_envs.registry": "track_envs.infra.registry",
    "track_envs.assignment": "track_envs.infra.assignment.lone_pairs",
    "track_envs.metrics.shortest_augmenting_path": "track_envs.infra.assignment.shortest_augmenting_path",
    "track_envs.types": "track_envs.values.types",
    "track_envs.tracks": "track_envs.values.tracks",
    "track_envs.poses": "track_envs.values.poses",
    "track_envs.detections": "track_envs.values.detections",
    "track_envs.observation": "track_envs.contracts.observation",
    "track_envs.report": "track_envs.contracts.report",
    "track_envs.sorting_channel": "track_envs.contracts.sorting_channel",
    "track_envs.csv_table": "track_envs.io.csv_parser",
    "track_envs.track_csv": "track_envs.io.wide_tracks",
    "track_envs.track_files": "track_envs.io.tracks",
    "track_envs.detection_files": "track_envs.io.detections",
    "track_envs.pose_files": "track_envs.io.poses",
    "track_envs.crossing_predictions": "track_envs.io.crossings",
    "track_envs.recording": "track_envs.envs.recording",
    "track_envs.pose_recording": "track_envs.envs.pose_recording",
    "track_envs.sensors": "track_envs.envs.sensors",
    "track_envs.drift": "track_envs.envs.drift",
    "track_envs.rendering": "track_envs.envs.rendering",
    "track_envs.render_window": "track_envs.envs.render_window",
    "track_envs.track_scoring": "track_envs.metrics.track_scoring",
    "track_envs.crossing_check": "track_envs.metrics.crossing_check",
}


#: The moves other packages registered (:func:`register_moved_modules`), old name -> new one.
_MOVED_ELSEWHERE: dict[str, str] = {}


class _AliasLoader(importlib.abc.Loader):
    """Loads an old name as the module at its new path (imported, then put in its place)."""

    def __init__(self, new: str) -> None:
        self.new = new

    def create_module(self, spec: importlib.machinery.ModuleSpec) -> ModuleType:
        warnings.warn(
            f"{spec.name} is deprecated and will be removed: import {self.new} instead",
            DeprecationWarning,
            stacklevel=1,  # attributed to track_envs, which pytest's filter makes an error
        )
        module = importlib.import_module(self.new)
        sys.modules[spec.name] = module
        return module

    def exec_module(self, module: ModuleType) -> None:
        """Nothing to run: the module at the new path is already imported."""


class MovedModuleFinder(importlib.abc.MetaPathFinder):
    """A ``sys.meta_path`` finder for the names in :data:`MOVED` and those registered (only those)."""

    def find_spec(
        self, fullname: str, path: Sequence[str] | None, target: ModuleType | None = None
    ) -> importlib.machinery.ModuleSpec | None:
        new = MOVED.get(fullname) or _MOVED_ELSEWHERE.get(fullname)
        if new is None:
            return None
        return importlib.machinery.ModuleSpec(fullname, _AliasLoader(new))


def register_moved_modules(moved: dict[str, str]) -> None:
    """Alias old dotted module names of another package to their new ones (``agents`` registers
    its moves on import; :data:`MOVED` is ``track_envs``'s own) and install the finder."""
    _MOVED_ELSEWHERE.update(moved)
    install()


def install() -> None:
    """Put one :class:`MovedModuleFinder` first on ``sys.meta_path`` (idempotent)."""
    if not any(isinstance(finder, MovedModuleFinder) for finder in sys.meta_path):
        sys.meta_path.insert(0, MovedModuleFinder())
