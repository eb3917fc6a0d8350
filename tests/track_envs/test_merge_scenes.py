"""The pair scenes of track_envs.streams.merge_scenes: geometry, blobs and determinism."""

from __future__ import annotations

import numpy as np
import pytest

from track_envs.streams import merge_scenes as ms


@pytest.mark.parametrize("name", ms.SCENES)
def test_every_scene_is_seeded_and_its_detections_are_its_particles(name: str) -> None:
    a = ms.merge_scene(name, np.random.default_rng(3), n_events=3)
    b = ms.merge_scene(name, np.random.default_rng(3), n_events=3)
    assert np.array_equal(a.detections, b.detections) and np.array_equal(a.detection_ids, b.detection_ids)
    # every visible particle is behind exactly one detection row
    for t in range(len(a)):
        ids = a.detection_ids[t][a.mask[t] == 1]
        behind = np.sort(ids[ids >= 0])
        assert np.array_equal(behind, np.flatnonzero(a.visible[t]))
    # the pair is side by side at its meeting frame
    for (p, q), f in zip(a.involved, a.meet_frames, strict=True):
        assert abs(a.positions[f, p, 0] - a.positions[f, q, 0]) < 1e-9


def test_touching_pairs_are_blobs_at_their_area_weighted_centroid() -> None:
    for name, w in (("touching", 0.5), ("unequal", 0.8)):
        s = ms.merge_scene(name, np.random.default_rng(0), n_events=4)
        t, r = np.nonzero(s.detection_ids[:, :, 1] >= 0)
        assert len(t) > 40  # ≥ 10 frames of blob per encounter
        first, second = s.detection_ids[t, r, 0], s.detection_ids[t, r, 1]
        centroid = w * s.positions[t, first] + (1 - w) * s.positions[t, second]
        assert np.abs(s.detections[t, r] - centroid).max() < 6 * ms.NOISE_STD


def test_a_near_miss_passes_inside_the_merge_extent_without_a_blob() -> None:
    s = ms.merge_scene("near-miss", np.random.default_rng(0), n_events=6)
    assert s.merged_rows() == 0
    closest = [np.linalg.norm(s.positions[:, p] - s.positions[:, q], axis=1).min() for p, q in s.involved]
    assert min(closest) >= 0.005 and max(closest) <= 0.006


def test_bad_arguments_are_named() -> None:
    with pytest.raises(ValueError, match="scene must be one of"):
        ms.merge_scene("crossing", np.random.default_rng(0))
    with pytest.raises(ValueError, match=r"rng must be a numpy\.random\.Generator"):
        ms.merge_scene("touching", 0)  # type: ignore[arg-type]
