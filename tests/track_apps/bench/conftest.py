"""Shared helpers of the bench tests."""

from __future__ import annotations

import pytest

from track_apps.bench import Cell


@pytest.fixture
def small_cells() -> list[Cell]:
    """Eight fast cells across three envs (point and keypoint, with and without a predictor)."""
    return [
        Cell("SineTarget-v0", "pf", "-", 0, steps=30),
        Cell("SineTarget-v0", "pf", "-", 1, steps=30),
        Cell("SineTarget-v0", "gnn", "kf-cv", 0, (("p_detect", 0.8),), steps=30),
        Cell("SineTarget-v0", "gnn", "kf-cv", 1, (("p_detect", 0.8),), steps=30),
        Cell("BeltSorter-v0", "gnn", "kf-ca", 0, steps=25),
        Cell("BeltSorter-v0", "detections", "-", 1, steps=25),
        Cell("KeypointWalkers-v0", "pose-baseline", "-", 0, steps=15),
        Cell("PiecewiseTarget-v0", "gnn", "random-walk", 2, episodes=2, steps=20),
    ]
