"""A package's public names are the names its ``__init__`` imports (``track_envs.infra.lazy``)."""

from __future__ import annotations

import importlib

import pytest

from track_envs.infra.lazy import declared_exports

SOURCE = """
from __future__ import annotations

from typing import TYPE_CHECKING

from track_envs.infra.lazy import lazy_exports
from pkg.light import Light, light_helper
from pkg.light import _private

if TYPE_CHECKING:
    from pkg.heavy import Heavy
    from .relative import near
    from ..sibling import far

__getattr__, __dir__, __all__ = lazy_exports(__name__, __file__)
"""


def test_the_imports_are_the_public_names_and_the_guarded_ones_are_lazy():
    exports = declared_exports(SOURCE, "pkg.sub")
    assert exports.names == ("Light", "light_helper", "Heavy", "near", "far")
    assert exports.lazy == {"Heavy": "pkg.heavy", "near": "pkg.sub.relative", "far": "pkg.sibling"}


@pytest.mark.parametrize(
    ("source", "says"),
    [
        ("from a import x\nfrom b import x\n", "'x' is imported twice"),
        ("from a import *\n", "a star import"),
    ],
)
def test_an_ambiguous_declaration_is_an_error(source, says):
    with pytest.raises(ValueError, match=says):
        declared_exports(source, "pkg")


def test_a_lazy_name_is_taken_from_its_module_and_kept_in_the_package():
    io = importlib.import_module("track_envs.io")
    vars(io).pop("read_pose_file", None)  # as before its first access
    assert "read_pose_file" in io.__all__ and "read_pose_file" in dir(io)
    from track_envs.io.poses import read_pose_file

    assert io.read_pose_file is read_pose_file
    assert vars(io)["read_pose_file"] is read_pose_file
    with pytest.raises(AttributeError, match="has no attribute 'nothing'"):
        _ = io.nothing
