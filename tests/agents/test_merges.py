"""Shared updates of tracks whose particles touch (agents.tracking.merges.share_blobs)."""

from __future__ import annotations

import numpy as np
import pytest

from agents.tracking.merges import share_blobs

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


def _touching_pair_stream(rng: np.random.Generator) -> list[tuple[np.ndarray, float]]:
    """Leader and trailer 6 mm apart in one lane at 1 m/s (200 Hz); for 8 frames they touch
    (centres 4.5–5 mm apart) and the camera reports one centroid, at their midpoint."""
    frames = []
    for t in range(70):
        x = 0.03 + 0.005 * t
        if t < 30 or t > 41:
            gap = 0.006
        elif t < 33:
            gap = 0.006 - 0.0005 * (t - 30)
        elif t <= 38:
            gap = 0.0045
        else:
            gap = 0.0045 + 0.0005 * (t - 38)
        pts = [(x + gap / 2, 0.09), (x - gap / 2, 0.09)] if gap > 0.005 else [(x, 0.09)]
        frames.append((np.array(pts) + rng.normal(0, 3e-5, (len(pts), 2)), gap))
    return frames


def _track_pair(blob_extent: float) -> tuple[dict[int, float], dict[int, float], int]:
    """Ids → x of the reported tracks before the merge (frame 20) and after it (last frame)."""
    from agents.gnn.agent import GnnAgent
    from track_envs.values.types import SensorSpec

    spec = SensorSpec(
        dt=0.005, dim=2, noise_std=3e-5, p_detect=1.0, clutter_rate=0.0,
        region_low=(0.0, 0.0), region_high=(0.4, 0.18), max_detections=8, max_tracks=8,
    )  # fmt: skip
    agent = GnnAgent(predictor="kf-cv", blob_extent=blob_extent, velocity_fallback=np.array([1.0, 0.0]))
    agent.reset(spec, seed=0)
    before: dict[int, float] = {}
    merged = 0
    for t, (pts, _) in enumerate(_touching_pair_stream(np.random.default_rng(0))):
        det = np.zeros((8, 2), np.float32)
        mask = np.zeros(8, np.int8)
        det[: len(pts)], mask[: len(pts)] = pts, 1
        report = agent.act({"detections": det, "mask": mask})
        merged += len(pts) == 1
        live = report["mask"] == 1
        ids, positions = report["ids"][live], report["positions"][live]
        now = {int(i): float(p[0]) for i, p in zip(ids, positions, strict=True)}
        if t == 20:
            before = now
    return before, now, merged


def test_gnn_keeps_both_tracks_through_a_merge_and_does_not_swap_them() -> None:
    before, after, merged = _track_pair(blob_extent=0.004)
    assert merged == 8 and len(before) == 2
    leader = max(before, key=before.get)  # type: ignore[arg-type]
    assert set(after) == set(before)  # both tracks survived the merge, no new track
    # and the leader's track is still on the leader
    assert max(after, key=after.get) == leader  # type: ignore[arg-type]


def test_without_sharing_the_merge_swaps_the_tracks() -> None:
    """The failure the sharing fixes (issue of real sorter recordings): one track is lost in the
    blob and the other ends on the wrong particle."""
    before, after, _ = _track_pair(blob_extent=0.0)
    leader = max(before, key=before.get)  # type: ignore[arg-type]
    assert set(after) != set(before) or max(after, key=after.get) != leader  # type: ignore[arg-type]
