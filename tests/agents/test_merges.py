"""Shared updates of tracks whose particles touch (agents.merges.share_blobs)."""

from __future__ import annotations

import numpy as np
import pytest

from agents.merges import share_blobs

Y = np.array([[0.100, 0.050], [0.106, 0.050], [0.200, 0.050]])  # two touching, one apart


def test_tracks_inside_a_blob_share_it_as_a_rigid_group():
    z = np.array([[0.1035, 0.0502], [0.2001, 0.05]])  # the blob of tracks 0 and 1, and track 2's
    det = np.array([0, -1, 1])  # the association gave the blob to track 0
    shared, z_tracks = share_blobs(Y, z, det, extent=0.006)
    assert shared.tolist() == [0, 0, 1]
    centre = Y[:2].mean(axis=0)
    np.testing.assert_allclose(z_tracks[:2], z[0] + Y[:2] - centre, rtol=0, atol=1e-15)
    np.testing.assert_array_equal(z_tracks[2], z[1])  # a track alone with its detection: as is
    # the members keep their predicted separation
    np.testing.assert_allclose(z_tracks[1] - z_tracks[0], Y[1] - Y[0], atol=1e-15)


def test_a_track_far_from_every_detection_or_out_of_view_shares_nothing():
    z = np.array([[0.1035, 0.0502]])
    det = np.array([0, -1, -1])
    shared, _ = share_blobs(Y, z, det, extent=0.002)
    assert shared.tolist() == [0, -1, -1]
    low, high = np.array([0.0, 0.0]), np.array([0.105, 0.18])  # track 1 predicted past the window
    shared, _ = share_blobs(Y, z, det, extent=0.006, low=low, high=high)
    assert shared.tolist() == [0, -1, -1]


def test_zero_extent_changes_nothing():
    z = np.array([[0.1035, 0.0502], [0.2001, 0.05]])
    det = np.array([0, -1, 1])
    shared, z_tracks = share_blobs(Y, z, det, extent=0.0)
    assert shared.tolist() == det.tolist()
    np.testing.assert_array_equal(z_tracks[[0, 2]], z)


def test_bad_extent_is_named():
    with pytest.raises(ValueError, match="extent"):
        share_blobs(Y, np.zeros((1, 2)), np.array([0, -1, -1]), extent=-1.0)
