"""The merge-event streams are what they say (track_envs.streams.merge_events), and their per-event
scores count what they say (track_envs.streams.merge_scoring) on hand-made track histories."""

from __future__ import annotations

import numpy as np
import pytest

from track_envs.streams.merge_events import (
    MergeEventStream,
    join_stream,
    merge_event_streams,
    missed_pair_stream,
    separation_stream,
)
from track_envs.streams.merge_scoring import TrackHistory, bound_violations, score_events

SIGMA = 3e-5


@pytest.fixture(scope="module")
def streams() -> dict[str, MergeEventStream]:
    return merge_event_streams(np.random.default_rng(0))


def _rows_with(s: MergeEventStream, t: int, particle: int) -> list[list[int]]:
    ids = s.detection_ids[t][s.mask[t] == 1]
    return [r.tolist() for r in ids if particle in r]


def _row_position(s: MergeEventStream, t: int, ids: list[int]) -> np.ndarray:
    live = s.mask[t] == 1
    hit = np.flatnonzero((s.detection_ids[t][live] == ids).all(axis=1))
    assert len(hit) == 1
    return s.detections[t][live][hit[0]].astype(np.float64)


def test_the_sensor_is_the_belt_at_200_hz(streams):
    for s in streams.values():
        spec = s.spec
        assert (spec.dt, spec.dim, spec.noise_std, spec.p_detect, spec.clutter_rate) == (
            0.005,
            2,
            SIGMA,
            1.0,
            0.0,
        )
        assert spec.region_low == (0.0, 0.0) and spec.region_high == (0.40, 0.18)
        obs = s.observation(0)
        assert obs["detections"].dtype == np.float32 and obs["detections"].shape == (spec.max_detections, 2)
        assert obs["mask"].dtype == np.int8
        assert len(s.event_frames) == 20 and len(s) == s.event_frames[-1] + 22
        # never alone: at every event several other particles are in view
        assert s.visible[s.event_frames].sum(axis=1).min() >= 10


def test_a_join_is_one_detection_at_the_midpoint_for_one_frame(streams):
    s = streams["join"]
    merged_rows = int((s.detection_ids[..., 1] >= 0).sum())
    assert merged_rows == len(s.event_frames)  # nothing else merges
    for e, (a, b) in zip(s.event_frames, s.involved, strict=True):
        xa, xb = s.positions[e, a], s.positions[e, b]
        assert abs(xa[1] - xb[1]) == pytest.approx(1.8e-3, abs=1e-12)
        assert abs(xa[0] - xb[0]) <= 2e-4
        z = _row_position(s, e, [a, b])
        assert np.abs(z - (xa + xb) / 2).max() < 5 * SIGMA
        for t in (e - 1, e + 1):
            assert _rows_with(s, t, a) == [[a, -1]] and _rows_with(s, t, b) == [[b, -1]]


def test_a_separation_is_a_blob_for_its_first_frames_then_pieces_either_side(streams):
    s = streams["separation"]
    for e, entry, (a, b) in zip(s.event_frames, s.entry_frames, s.involved, strict=True):
        assert e - entry == 20
        for t in range(entry, e):
            assert _rows_with(s, t, a) == [[a, b]]
        path = _row_position(s, e - 1, [a, b])
        for t in (e, e + 1, e + 20):
            assert _rows_with(s, t, a) == [[a, -1]] and _rows_with(s, t, b) == [[b, -1]]
        lateral = s.positions[e, [a, b], 1] - path[1]
        np.testing.assert_allclose(np.sort(lateral), [-1.5e-3, 1.5e-3], atol=5 * SIGMA + 0.05e-3)


def test_a_missed_pair_gives_no_detection_for_one_frame_and_the_neighbour_stays(streams):
    s = streams["missed-pair"]
    assert int((s.detection_ids[..., 1] >= 0).sum()) == 0
    for e, (a, b) in zip(s.event_frames, s.involved, strict=True):
        assert 2e-3 <= abs(s.positions[e, a, 1] - s.positions[e, b, 1]) <= 3e-3
        assert _rows_with(s, e, a) == [] and _rows_with(s, e, b) == []
        assert _rows_with(s, e, a + 2) == [[a + 2, -1]]  # the neighbour
        for t in (e - 1, e + 1):
            assert len(_rows_with(s, t, a)) == len(_rows_with(s, t, b)) == 1


def test_the_neighbour_lane_is_4_to_6_mm_beside_the_pair(streams):
    for s in streams.values():
        e = s.event_frames
        pair_y = s.positions[e[:, None], s.involved, 1]  # (E, 2)
        neighbour_y = s.positions[e, s.involved[:, 0] + 2, 1]
        nearest = np.abs(neighbour_y[:, None] - pair_y).min(axis=1)
        assert nearest.min() >= 4e-3 - 1e-12 and nearest.max() <= 6e-3 + 1e-12


def test_detections_carry_the_declared_noise(streams):
    s = streams["missed-pair"]
    t, r = np.nonzero(s.mask == 1)
    ids = s.detection_ids[t, r, 0]
    residual = s.detections[t, r].astype(np.float64) - s.positions[t, ids]
    assert residual.std() == pytest.approx(SIGMA, rel=0.05)
    assert abs(residual.mean()) < 3e-6


def test_same_generator_same_stream_and_another_seed_another():
    a = join_stream(np.random.default_rng(3), n_events=4)
    b = join_stream(np.random.default_rng(3), n_events=4)
    c = join_stream(np.random.default_rng(4), n_events=4)
    for field in ("detections", "mask", "detection_ids", "positions", "visible"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    assert not np.array_equal(a.detections, c.detections)


@pytest.mark.parametrize(
    ("make", "kwargs", "name"),
    [
        (join_stream, {"n_events": 0}, "n_events"),
        (join_stream, {"lane_gap": -1e-3}, "lane_gap"),
        (join_stream, {"lane_gap": 5e-3}, "lane_gap"),
        (join_stream, {"window": 70}, "lead_frames \\+ window"),
        (join_stream, {"period": 3}, "period"),
        (join_stream, {"wait": 3}, "wait"),
        (separation_stream, {"piece_offset": 3e-3}, "piece_offset"),
        (separation_stream, {"lead_frames": 6}, "lead_frames"),
        (missed_pair_stream, {"lane_gap": (3e-3, 2e-3)}, "lane_gap"),
        (missed_pair_stream, {"lane_gap": 2e-3}, "lane_gap"),
    ],
)
def test_bad_arguments_are_named(make, kwargs, name):
    with pytest.raises(ValueError, match=name):
        make(np.random.default_rng(0), **kwargs)


def test_a_seed_is_no_generator():
    with pytest.raises(ValueError, match="rng"):
        join_stream(0)  # type: ignore[arg-type]


def _oracle(s: MergeEventStream, swap_at: int | None = None) -> TrackHistory:
    """Every visible particle reported at its true position under its own id, except that a
    blob of the pair is one track (the pair's first particle) at the blob; ``swap_at``: the first
    event's pair exchange ids from that frame on."""
    n = s.visible.shape[1]
    ids = np.where(s.visible, np.arange(n), -1)
    positions = s.positions.copy()
    t, r = np.nonzero(s.detection_ids[..., 1] >= 0)
    a, b = s.detection_ids[t, r, 0], s.detection_ids[t, r, 1]
    ids[t, b] = -1
    positions[t, a] = (s.positions[t, a] + s.positions[t, b]) / 2
    if swap_at is not None:
        a0, b0 = s.involved[0]
        ids[swap_at:, [a0, b0]] = ids[swap_at:, [b0, a0]]
    return TrackHistory(ids, positions)


def test_a_tracker_that_keeps_every_particle_meets_the_bounds(streams):
    for s in streams.values():
        scores = score_events(s, _oracle(s))
        assert scores.resolved.all(), s.kind
        assert scores.switches.sum() == scores.swaps.sum() == scores.lost.sum() == 0
        assert scores.new_tracks.tolist() == [int(s.kind == "separation")] * 20
        assert bound_violations(scores) == []


def test_an_identity_swap_after_a_join_is_counted_as_a_swap(streams):
    s = streams["join"]
    scores = score_events(s, _oracle(s, swap_at=int(s.event_frames[0]) + 3))
    assert scores.swaps.tolist() == [2] + [0] * 19
    assert not scores.resolved[0] and scores.resolved[1:].all()
    assert 1.8e-3 <= scores.max_error[0] <= 1.82e-3  # the track of the other lane
