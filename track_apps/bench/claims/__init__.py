"""Claims tables of paper reproductions: ``track bench claims SUITE DIR``.

A module ``track_apps.bench.claims.<suite>`` (the suite name with ``-`` as ``_``) that defines
``write_claims(records, out, *, wall_s=None) -> list[Path]`` turns the records of the shipped
suite of the same name into the paper's figures and a claims table (``<out>/<suite>.md``, figures
in ``<out>/figures/<suite>/``). The table is regenerated from the records, never edited by hand.
"""

from __future__ import annotations

import importlib
import pkgutil
from types import ModuleType

__all__ = ["available_claims", "claims_module"]


def available_claims() -> list[str]:
    """Suites that have a claims module."""
    return sorted(
        m.name.replace("_", "-") for m in pkgutil.iter_modules(__path__) if not m.name.startswith("_")
    )


def claims_module(suite: str) -> ModuleType:
    """The claims module of ``suite`` (``ValueError`` listing the suites that have one)."""
    if suite not in available_claims():
        raise ValueError(f"no claims table for suite {suite!r}; suites with one: {available_claims()}")
    return importlib.import_module(f"{__name__}.{suite.replace('-', '_')}")
