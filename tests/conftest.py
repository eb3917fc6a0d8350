"""Shared fixtures: every test runs headless and with a fixed matplotlib backend."""

from __future__ import annotations

import os

os.environ.setdefault("MPLBACKEND", "Agg")
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")
os.environ.setdefault("SDL_AUDIODRIVER", "dummy")


import pytest


@pytest.fixture
def scoped_registries(monkeypatch):
    """A test (or a docs block, an example) that registers a predictor, an agent or an associator
    keeps it out of the registries the other tests iterate over (the bench's suites expand over
    them)."""
    from agents.base import AGENTS
    from agents.tracking.associator import ASSOCIATOR_REGISTRY
    from predictors.registry import PREDICTORS

    for registry in (AGENTS, PREDICTORS, ASSOCIATOR_REGISTRY):
        monkeypatch.setattr(registry, "_factories", dict(registry._factories))
