"""Truth: the visible part with and without the all-in-view promise."""

from __future__ import annotations

import numpy as np

from track_envs.envs.base import Truth
from track_envs.envs.sensors import sense_points


def test_visible_part_masks_unless_everything_is_in_view() -> None:
    ids = np.array([4, 5, 6])
    positions = np.arange(6.0).reshape(3, 2)
    masked = Truth(ids, positions, np.array([True, False, True]))
    got_ids, got_positions = masked.visible_part()
    assert got_ids.tolist() == [4, 6] and got_positions.tolist() == [[0, 1], [4, 5]]
    whole = Truth.all_in_view(ids, positions, {"kinds": np.zeros(3)})
    assert whole.visible.all() and whole.all_visible and "kinds" in whole.extra
    assert whole.visible_part()[1] is positions


def test_certain_detection_draws_only_the_noise() -> None:
    x = np.random.default_rng(0).normal(size=(50, 2))
    ids = np.arange(50)
    kwargs = {"clutter_rate": 0.0, "clutter_low": np.zeros(2), "clutter_high": np.ones(2)}
    rng = np.random.default_rng(1)
    z, source = sense_points(x, ids, rng, noise_std=0.1, p_detect=1.0, **kwargs)
    expected = x + 0.1 * np.random.default_rng(1).standard_normal((50, 2))
    np.testing.assert_array_equal(z, expected)
    np.testing.assert_array_equal(source, ids)
    # the same frame with p_detect < 1 keeps each row with a uniform draw first
    _, source_half = sense_points(x, ids, np.random.default_rng(1), noise_std=0.1, p_detect=0.5, **kwargs)
    kept = np.random.default_rng(1).random(50) < 0.5
    np.testing.assert_array_equal(source_half, ids[kept])
