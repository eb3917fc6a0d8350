"""Per-track error distribution (track_envs/metrics/track_error.py) against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from track_envs.metrics.track_error import BOX_QUANTILES, TrackErrorDistribution, quantile_key


def test_quantiles_of_known_per_track_means():
    m = TrackErrorDistribution()
    # track 7: errors 1 and 3 (mean 2); track 2: error 4; track 5: errors 0, 0, 3 (mean 1)
    m.update(np.zeros((3, 2)), [[1.0, 0.0], [0.0, 4.0], [0.0, 0.0]], [7, 2, 5])
    m.update(np.zeros((2, 2)), [[3.0, 0.0], [0.0, 0.0]], [7, 5])
    m.update(np.zeros((1, 2)), [[0.0, 3.0]], [5])
    out = m.compute()
    per_track = np.array([4.0, 1.0, 2.0])  # ids 2, 5, 7
    np.testing.assert_allclose(m.per_track(), per_track)
    for q in BOX_QUANTILES:
        assert out[quantile_key(q)] == pytest.approx(np.quantile(per_track, q))
    assert out["track_error_p50"] == pytest.approx(2.0)
    assert out["track_error_mean"] == pytest.approx(7.0 / 3.0)
    assert out["track_error_tracks"] == 3.0
    assert out["prediction_error"] == pytest.approx(7.0 / 3.0)  # the PredictionError keys stay


def test_coasting_rows_are_skipped_and_short_tracks_can_be_dropped():
    m = TrackErrorDistribution(min_predictions=2)
    m.update(np.zeros((2, 2)), [[1.0, 0.0], [np.nan, np.nan]], [0, 1])
    m.update(np.zeros((2, 2)), [[3.0, 0.0], [5.0, 0.0]], [0, 1])
    np.testing.assert_allclose(m.per_track(), [2.0])  # track 1 has one scored prediction
    assert m.compute()["track_error_tracks"] == 1.0


def test_empty_is_nan_and_bad_argument_is_refused():
    out = TrackErrorDistribution().compute()
    assert math.isnan(out["track_error_p50"]) and out["track_error_tracks"] == 0.0
    with pytest.raises(ValueError, match="min_predictions"):
        TrackErrorDistribution(min_predictions=0)
