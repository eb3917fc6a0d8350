"""track_envs.infra.compiled: every project kernel carries the project-wide cache stamp, so a cached
kernel never outlives a change to a compiled function it calls in another module."""

from __future__ import annotations

import importlib
import pkgutil
import subprocess
import sys
import textwrap
from pathlib import Path

import numba
import pytest

import track_envs.infra.compiled as compiled

CALLEE = """
from track_envs.infra.compiled import njit


@njit(cache=True)
def value():
    return {value}
"""
CALLER = """
from track_envs.infra.compiled import njit
from callee import value


@njit(cache=True)
def twice():
    return 2 * value()
"""
RUN = """
import sys
from pathlib import Path
import track_envs.infra.compiled as compiled
compiled.PACKAGE_ROOTS = (*compiled.PACKAGE_ROOTS, Path(sys.argv[1]))
sys.path.insert(0, sys.argv[1])
from caller import twice
print(twice())
"""


def _kernel_modules() -> list[str]:
    names = []
    for root in compiled.PACKAGE_ROOTS:
        for info in pkgutil.walk_packages([str(root)], prefix=f"{root.name}."):
            path = Path(root.parent, *info.name.split(".")).with_suffix(".py")
            marked = path.is_file() and b"from track_envs.infra.compiled import njit" in path.read_bytes()
            if marked and info.name != "track_envs.infra.compiled":
                names.append(info.name)
    return names


def test_the_stamp_is_installed() -> None:
    assert compiled.STAMPED_CACHE


@pytest.mark.parametrize("module", _kernel_modules())
def test_every_cached_project_kernel_uses_the_project_stamp(module: str) -> None:
    mod = importlib.import_module(module)
    kernels = [v for v in vars(mod).values() if isinstance(v, numba.core.registry.CPUDispatcher)]
    assert kernels, f"{module} imports the project's njit but defines no kernel"
    for kernel in kernels:
        if kernel.targetoptions.get("cache"):
            locator = kernel._cache._impl._locator
            assert getattr(type(locator), "_track_envs", False), (module, kernel.__name__)
            assert locator.get_source_stamp()[1] == compiled.project_kernel_digest()


def test_the_digest_follows_every_compiled_module(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    package = tmp_path / "pkg"
    package.mkdir()
    (package / "a.py").write_text("from track_envs.infra.compiled import njit\nA = 1\n")
    (package / "plain.py").write_text("B = 1\n")
    monkeypatch.setattr(compiled, "PACKAGE_ROOTS", (package,))
    compiled.project_kernel_digest.cache_clear()
    try:
        first = compiled.project_kernel_digest()
        (package / "plain.py").write_text("B = 2\n")  # no kernel: not part of the stamp
        compiled.project_kernel_digest.cache_clear()
        assert compiled.project_kernel_digest() == first
        (package / "a.py").write_text("from track_envs.infra.compiled import njit\nA = 2\n")
        compiled.project_kernel_digest.cache_clear()
        assert compiled.project_kernel_digest() != first
    finally:
        compiled.project_kernel_digest.cache_clear()


def test_a_cached_caller_sees_a_changed_callee_in_another_module(tmp_path: Path) -> None:
    """Regression: numba's own stamp covers the caller's file only, so after the callee's module
    changed a cached caller kept returning the old value until its cache was deleted by hand."""
    (tmp_path / "caller.py").write_text(CALLER)
    script = textwrap.dedent(RUN)

    def run(value: int) -> str:
        (tmp_path / "callee.py").write_text(CALLEE.format(value=value))
        done = subprocess.run(
            [sys.executable, "-c", script, str(tmp_path)], capture_output=True, text=True, check=True
        )
        return done.stdout.strip()

    assert run(1) == "2"
    assert run(1) == "2"  # from the cache
    assert list((tmp_path / "__pycache__").glob("caller.twice-*.nbi"))
    assert run(5) == "10"
