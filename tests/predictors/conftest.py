"""Small training data shared by the learned-predictor tests (a few seconds to build)."""

from __future__ import annotations

import pytest

from predictors.training.data import TrackSplit, split_tracks, tracks_from_env


@pytest.fixture(scope="session")
def belt_split() -> TrackSplit:
    """True tracks of 120 BeltSorter-v0 frames (cylinders), split by track with seed 0."""
    data = tracks_from_env("BeltSorter-v0", episodes=1, seed=7, steps=120, particle_kind="cylinder")
    return split_tracks(data, seed=0)
