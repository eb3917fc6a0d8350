"""e1 / e2 / e_mean (Pfaff et al. 2017) on hand-built episodes with known answers."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from track_envs.metrics import AssociationErrors, Metric

MAX_DET, MAX_TRACKS, MAX_TARGETS = 6, 5, 4


def frame(sources, tracks):
    """One frame: ``sources`` is the truth id of each detection row (−1 clutter); ``tracks`` maps
    track id -> detection row it was updated with (−1 coasting). Returns the update arguments."""
    detection_ids = np.full(MAX_DET, -1, dtype=np.int64)
    detection_ids[: len(sources)] = sources
    report: dict[str, np.ndarray] = {
        "ids": np.zeros(MAX_TRACKS, np.int64),
        "positions": np.zeros((MAX_TRACKS, 2), np.float32),
        "detection": np.full(MAX_TRACKS, -1, np.int64),
        "mask": np.zeros(MAX_TRACKS, np.int8),
    }
    for k, (tid, row) in enumerate(tracks):
        report["ids"][k], report["detection"][k], report["mask"][k] = tid, row, 1
    truth = {
        "ids": np.full(MAX_TARGETS, -1, np.int64),
        "positions": np.zeros((MAX_TARGETS, 2)),
        "visible": np.zeros(MAX_TARGETS, bool),
    }
    return truth, detection_ids, report


def score(frames):
    metric = AssociationErrors()
    for sources, tracks in frames:
        metric.update(*frame(sources, tracks))
    return metric.compute()


def test_is_a_metric():
    assert isinstance(AssociationErrors(), Metric)


def test_perfect_tracking_has_no_errors():
    frames = [
        ([1, 2, -1], [(10, 0), (11, 1)]),
        ([2, -1, 1], [(10, 2), (11, 0)]),
        ([1, 2], [(10, 0), (11, 1)]),
    ]
    out = score(frames)
    assert out == {"e1": 0.0, "e2": 0.0, "e_mean": 0.0, "n_tracks": 2.0, "n_particles": 2.0}


def test_track_swapping_to_another_particle():
    # track 10 takes particle 1 then particle 2; particle 2 went to tracks 11 and 10
    frames = [([1, 2], [(10, 0), (11, 1)]), ([2], [(10, 0), (11, -1)])]
    out = score(frames)
    assert (out["e1"], out["e2"]) == (0.5, 0.5)
    assert out["e_mean"] == pytest.approx(0.5)


def test_particle_split_across_two_tracks():
    # track 10 is lost and track 12 picks particle 1 up: no track holds two particles
    frames = [([1], [(10, 0)]), ([1], [(10, -1), (12, 0)]), ([1], [(12, 0)])]
    out = score(frames)
    assert (out["e1"], out["e2"], out["e_mean"]) == (0.0, 1.0, 0.0)
    assert (out["n_tracks"], out["n_particles"]) == (2.0, 1.0)


def test_never_associated_particle_is_an_error_of_the_second_kind():
    frames = [([1, 2, 3], [(10, 0), (11, 1)]), ([1, 2], [(10, 0), (11, 1)])]
    out = score(frames)
    assert out["e1"] == 0.0
    assert out["e2"] == pytest.approx(1 / 3)
    assert out["n_particles"] == 3.0


def test_clutter_coasting_and_bad_rows_are_ignored():
    # track 20 only ever uses clutter; track 10 uses particle 1 and clutter; row 5 is padding (−1),
    # row 99 points outside the detections: none of them count
    frames = [([1, -1, -1], [(10, 0), (20, 1)]), ([-1, 1], [(10, 0), (20, 5), (30, 99)])]
    out = score(frames)
    assert out == {"e1": 0.0, "e2": 0.0, "e_mean": 0.0, "n_tracks": 1.0, "n_particles": 1.0}


def test_duplicate_track_ids_in_a_frame_are_one_track():
    out = score([([1, 2], [(10, 0), (10, 1)])])
    assert (out["e1"], out["e2"], out["n_tracks"]) == (1.0, 0.0, 1.0)


def test_e_mean_is_the_harmonic_mean():
    # track 10: particles {1, 2}; track 11: {2}; track 12: {3}; particle 4 never associated
    frames = [([1, 2, 3, 4], [(10, 0), (11, 1), (12, 2)]), ([2], [(10, 0)])]
    out = score(frames)
    e1, e2 = 1 / 3, 2 / 4
    assert out["e1"] == pytest.approx(e1) and out["e2"] == pytest.approx(e2)
    assert out["e_mean"] == pytest.approx(2 * e1 * e2 / (e1 + e2))


def test_empty_episode():
    assert score([]) == {"e1": 0.0, "e2": 0.0, "e_mean": 0.0, "n_tracks": 0.0, "n_particles": 0.0}


def by_sets(frames):
    """The definition, with Python sets (oracle)."""
    particles_of: dict[int, set[int]] = {}
    tracks_of: dict[int, set[int]] = {}
    for sources, tracks in frames:
        for p in sources:
            if p >= 0:
                tracks_of.setdefault(int(p), set())
        for tid, row in tracks:
            if 0 <= row < len(sources) and sources[row] >= 0:
                particles_of.setdefault(tid, set()).add(int(sources[row]))
                tracks_of[int(sources[row])].add(tid)
    e1 = sum(len(v) > 1 for v in particles_of.values()) / max(len(particles_of), 1)
    e2 = sum(len(v) != 1 for v in tracks_of.values()) / max(len(tracks_of), 1)
    return e1, e2, len(particles_of), len(tracks_of)


def test_streaming_matches_set_oracle_and_reset():
    rng = np.random.default_rng(0)
    frames = []
    for _ in range(400):  # mostly right: track 100 + p follows particle p, with a few mistakes
        sources = np.append(rng.choice(8, size=rng.integers(0, 5), replace=False), -1)
        tracks = [
            (100 + int(p) if rng.random() < 0.995 else int(rng.integers(100, 110)), row)
            for row, p in enumerate(sources)
            if rng.random() < 0.9
        ]
        frames.append((sources, tracks))
    metric = AssociationErrors()
    for k, (sources, tracks) in enumerate(frames):
        metric.update(*frame(sources, tracks))
        if k == 123:
            metric.compute()  # reading mid-episode must not disturb the accumulation
    out = metric.compute()
    assert out == score(frames)
    e1, e2, n_tracks, n_particles = by_sets(frames)
    assert (out["e1"], out["e2"], out["n_tracks"], out["n_particles"]) == pytest.approx(
        (e1, e2, n_tracks, n_particles)
    )
    assert 0 < e1 < 1 and 0 < e2 < 1
    metric.reset()
    assert metric.compute()["n_tracks"] == 0.0


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_random_streams_match_the_set_oracle(seed):
    """Clutter, coasting, out-of-range rows, duplicate track ids, reused ids, empty frames."""
    rng = np.random.default_rng(seed)
    frames = []
    for _ in range(rng.integers(0, 40)):
        n_sources = rng.integers(0, MAX_DET + 1)
        sources = np.where(rng.random(n_sources) < 0.2, -1, rng.choice(30, n_sources, replace=False))
        tracks = [
            (int(rng.integers(0, 8)), int(rng.integers(-1, MAX_DET + 3)))
            for _ in range(rng.integers(0, MAX_TRACKS + 1))
        ]
        frames.append((sources, tracks))
    out = score(frames)
    e1, e2, n_tracks, n_particles = by_sets(frames)
    assert (out["e1"], out["e2"], out["n_tracks"], out["n_particles"]) == pytest.approx(
        (e1, e2, n_tracks, n_particles), rel=1e-15
    )
