"""Merged detections in e1 / e2, CLEAR MOT and the TrackingMetrics wrapper."""

from __future__ import annotations

import numpy as np
import pytest

from track_envs.metrics import AssociationErrors, ClearMot, GospaMetric
from track_envs.metrics.base import MetricTraits
from track_envs.metrics.merged import set_key
from track_envs.wrappers import TrackingMetrics

K, MAX_DET, MAX_TRACKS, MAX_TARGETS = 4, 6, 5, 4


def frame(sources, tracks, truth=(), positions=None):
    """``sources``: per detection row a truth id or a list of merged ids (primary first);
    ``tracks``: (track id, detection row) pairs; ``truth``: (id, (x, y)) pairs."""
    merged = np.full((MAX_DET, K), -1, dtype=np.int64)
    for r, s in enumerate(sources):
        ids = [s] if np.isscalar(s) else list(s)
        merged[r, : len(ids)] = ids
    report = {
        "ids": np.zeros(MAX_TRACKS, np.int64),
        "positions": np.zeros((MAX_TRACKS, 2)),
        "detection": np.full(MAX_TRACKS, -1, np.int64),
        "mask": np.zeros(MAX_TRACKS, np.int8),
    }
    for k, (tid, row) in enumerate(tracks):
        report["ids"][k], report["detection"][k], report["mask"][k] = tid, row, 1
        if positions is not None:
            report["positions"][k] = positions[k]
    t = {
        "ids": np.full(MAX_TARGETS, -1, np.int64),
        "positions": np.zeros((MAX_TARGETS, 2)),
        "visible": np.zeros(MAX_TARGETS, bool),
    }
    for k, (i, x) in enumerate(truth):
        t["ids"][k], t["positions"][k], t["visible"][k] = i, x, True
    return t, merged, report


def errors(frames, plain=False):
    metric = AssociationErrors()
    for f in frames:
        truth, merged, report = frame(*f)
        metric.update(truth, merged[:, 0] if plain else merged, report)
    return metric.compute()


# particle 1 has track 10, particle 2 track 11; in the middle frames they touch and the camera
# reports one blob whose primary (larger) particle is 2
SEPARATE = ([1, 2], [(10, 0), (11, 1)])
MERGED_TO_1 = ([[2, 1]], [(10, 0), (11, -1)])


def test_a_merged_update_of_either_particles_track_is_no_error():
    out = errors([SEPARATE, MERGED_TO_1, MERGED_TO_1, SEPARATE])
    assert (out["e1"], out["e2"], out["n_tracks"], out["n_particles"]) == (0.0, 0.0, 2.0, 2.0)
    # the same stream scored on the primary ids alone: track 10 seems to hold particle 2
    plain = errors([SEPARATE, MERGED_TO_1, MERGED_TO_1, SEPARATE], plain=True)
    assert plain["e1"] == 0.5 and plain["e2"] == 0.5


def test_both_tracks_sharing_the_merged_detection_is_no_error():
    both = ([[2, 1]], [(10, 0), (11, 0)])
    out = errors([SEPARATE, both, both, SEPARATE])
    assert (out["e1"], out["e2"]) == (0.0, 0.0)


def test_merged_update_before_the_tracks_single_measurements_is_no_error():
    # track 10 is born on the blob and follows particle 1 once they separate
    out = errors([MERGED_TO_1, ([1, 2], [(10, 0), (11, 1)])])
    assert (out["e1"], out["e2"]) == (0.0, 0.0)


def test_a_track_fed_only_by_merged_detections_holds_the_primary():
    # track 12 only ever sees the blob: it counts as holding particle 2 (the primary), which
    # therefore went to two tracks; particle 1 is tracked by 10 alone
    out = errors([SEPARATE, ([[2, 1]], [(10, -1), (11, -1), (12, 0)]), SEPARATE])
    assert out["e1"] == 0.0
    assert out["e2"] == 0.5 and out["n_tracks"] == 3.0


def test_a_swap_through_a_merge_is_still_an_error():
    swapped = ([1, 2], [(10, 1), (11, 0)])
    out = errors([SEPARATE, MERGED_TO_1, swapped])
    assert out["e1"] == 1.0 and out["e2"] == 1.0


def test_every_particle_behind_a_merged_detection_counts_as_detected():
    out = errors([([[2, 1, 3]], [(10, 0)])])
    assert out["n_particles"] == 3.0


def test_set_key_ignores_order_and_padding():
    assert set_key(np.array([3, 1, -1, -1])) == set_key(np.array([1, 3, -1, -1]))
    assert set_key(np.array([3, 1, -1, -1])) != set_key(np.array([3, 1, 2, -1]))


def test_width_change_within_an_episode_is_refused():
    metric = AssociationErrors()
    truth, merged, report = frame(*SEPARATE)
    metric.update(truth, merged, report)
    with pytest.raises(ValueError, match="columns"):
        metric.update(truth, merged[:, :2], report)


# -- CLEAR MOT ---------------------------------------------------------------------------------
A, B = np.array([0.100, 0.05]), np.array([0.111, 0.05])  # end-to-end cylinders, centres 11 mm apart
BLOB = 0.5 * (A + B)  # 5.5 mm from each: beyond a 5 mm threshold


def clear_mot(frames, plain=False):
    metric = ClearMot(threshold=0.005)
    for sources, tracks, positions in frames:
        truth, merged, report = frame(sources, tracks, truth=[(1, A), (2, B)], positions=positions)
        metric.update(truth, merged[:, 0] if plain else merged, report)
    return metric.compute()


CM_SEPARATE = ([1, 2], [(10, 0), (11, 1)], [A, B])
CM_MERGED = ([[2, 1]], [(10, 0), (11, -1)], [BLOB, B])  # track 10 moved onto the blob, 11 coasts


def test_clear_mot_matches_a_track_on_the_blob_to_its_particle():
    out = clear_mot([CM_SEPARATE, CM_MERGED, CM_SEPARATE])
    assert (out["num_misses"], out["num_false_positives"], out["id_switches"]) == (0.0, 0.0, 0.0)
    assert out["idf1"] == 1.0
    assert out["motp"] == pytest.approx((4 * 0 + 0.0055) / 6)  # the true distance enters MOTP
    plain = clear_mot([CM_SEPARATE, CM_MERGED, CM_SEPARATE], plain=True)
    assert (plain["num_misses"], plain["num_false_positives"]) == (1.0, 1.0)


def test_clear_mot_does_not_widen_tracks_that_used_no_merged_detection():
    coasting = ([[2, 1]], [(10, -1), (11, -1)], [BLOB, B])
    out = clear_mot([CM_SEPARATE, coasting])
    assert (out["num_misses"], out["num_false_positives"]) == (1.0, 1.0)


# -- the wrapper -------------------------------------------------------------------------------
class Recorder:
    """A metric of the original protocol: it must keep getting one id per detection row."""

    def __init__(self):
        self.shapes = []

    def reset(self):
        self.shapes.clear()

    def update(self, truth, detection_ids, report):
        self.shapes.append(np.shape(detection_ids))

    def compute(self):
        return {}


class MergedRecorder(Recorder):
    traits = MetricTraits(accepts_merged_ids=True)


def test_wrapper_hands_merged_ids_only_to_metrics_that_accept_them():
    import gymnasium as gym

    import track_envs  # noqa: F401
    from track_envs.contracts.report import empty_report

    plain, merged = Recorder(), MergedRecorder()
    env = TrackingMetrics(gym.make("BeltSorter-v0", max_detections=64, max_tracks=8), [plain, merged])
    env.reset(seed=0)
    env.step(empty_report(8, (2,)))
    assert plain.shapes == [(64,)] and merged.shapes[0][0] == 64 and len(merged.shapes[0]) == 2
    # an env without merged ids: every metric gets the plain ids
    env = TrackingMetrics(gym.make("BeltReplay-v0"), [plain, merged])
    env.reset(seed=0)
    env.step(empty_report(env.unwrapped.sensor_spec.max_tracks, (2,)))
    assert len(merged.shapes[0]) == 1


def test_gospa_ignores_merged_ids():
    metric = GospaMetric(c=0.005)
    truth, merged, report = frame(*CM_MERGED[:2], truth=[(1, A), (2, B)], positions=CM_MERGED[2])
    metric.update(truth, merged, report)
    reference = GospaMetric(c=0.005)
    reference.update(truth, merged[:, 0], report)
    assert metric.compute() == reference.compute()
