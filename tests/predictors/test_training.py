"""Training data, the training loop and the belt losses (tiny trainings of a few seconds)."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from predictors.belt_lstm.training import noisy_tracks, train_belt_model
from predictors.training.data import TrackSet, TrackSplit, pad_tracks, split_tracks, tracks_from_positions
from predictors.training.loop import TrainConfig

TINY = TrainConfig(epochs=8, decay_every=4, batch_size=64)


def test_tracks_from_positions_splits_runs_of_visible_frames() -> None:
    nan = np.nan
    pos = np.array(
        [
            [[0, 0], [nan, nan]],
            [[1, 0], [5, 5]],
            [[nan, nan], [6, 5]],
            [[3, 0], [7, 5]],
        ],
        dtype=float,
    )
    tracks = tracks_from_positions(pos)
    got = sorted(t.tolist() for t in tracks)
    assert got == sorted([[[0, 0], [1, 0]], [[3, 0]], [[5, 5], [6, 5], [7, 5]]])


def test_split_drops_short_tracks_and_keeps_tracks_whole() -> None:
    tracks = [np.full((n, 2), float(i)) for i, n in enumerate([2, 3, 6, 7, 8, 9, 10, 11, 12, 13])]
    data = TrackSet(tracks, 0.01, (0.0, 0.0), (1.0, 1.0))
    split = split_tracks(data, seed=3, min_length=5)
    assert split.dropped == 2
    parts = [split.train, split.validation, split.test]
    ids = sorted(int(t[0, 0]) for p in parts for t in p.tracks)
    assert ids == list(range(2, 10))  # every kept track in exactly one part, whole
    assert all(len(t) >= 5 for p in parts for t in p.tracks)
    again = split_tracks(data, seed=3, min_length=5)
    assert [t[0, 0] for t in again.train.tracks] == [t[0, 0] for t in split.train.tracks]


def test_too_small_training_set_is_a_clear_error() -> None:
    data = TrackSet([np.zeros((3, 2)), np.zeros((9, 2))], 0.01, (0.0, 0.0), (1.0, 1.0))
    with pytest.raises(
        ValueError, match=r"too few tracks to train on: 1 of 2 have at least 5 frames \(1 shorter\)"
    ):
        split_tracks(data, min_length=5)


def test_pad_tracks_masks_the_padding() -> None:
    z, mask = pad_tracks([np.ones((2, 2)), np.full((4, 2), 2.0)])
    assert z.shape == (2, 4, 2) and mask.tolist() == [[True, True, False, False], [True] * 4]
    assert np.all(z[0, 2:] == 0) and np.all(z[1] == 2)


def test_noise_range_gives_each_track_its_own_level() -> None:
    data = TrackSet([np.zeros((400, 2)) for _ in range(50)], 0.01, (0.0, 0.0), (1.0, 1.0))
    noisy = noisy_tracks(data, (0.0, 1e-3), seed=0)
    stds = np.array([t.std() for t in noisy.tracks])
    assert 0 < stds.min() < 2e-4 and 8e-4 < stds.max() < 1.1e-3
    with pytest.raises(ValueError, match="noise_std must be"):
        noisy_tracks(data, -1.0, seed=0)


@pytest.mark.parametrize("kind", ["lstm", "nll-lstm", "mc-lstm"])
def test_tiny_training_lowers_the_loss(kind: str, belt_split: TrackSplit) -> None:
    dropout = 0.05 if kind == "mc-lstm" else 0.0
    _, _, history = train_belt_model(kind, belt_split, TINY, dropout=dropout, noise_std=1e-4, progress=False)
    assert history.train_loss[-1] < 0.5 * history.train_loss[0]
    assert history.validation_loss[history.best_epoch] < history.validation_loss[0]


def test_training_is_deterministic_for_a_seed(belt_split: TrackSplit) -> None:
    config = TrainConfig(epochs=2, batch_size=64, seed=5)
    a, _, _ = train_belt_model("mc-lstm", belt_split, config, dropout=0.1, progress=False)
    b, _, _ = train_belt_model("mc-lstm", belt_split, config, dropout=0.1, progress=False)
    for (name, x), (_, y) in zip(a.state_dict().items(), b.state_dict().items(), strict=True):
        assert torch.equal(x, y), name
    c, _, _ = train_belt_model(
        "mc-lstm", belt_split, TrainConfig(epochs=2, batch_size=64, seed=6), dropout=0.1, progress=False
    )
    assert not torch.equal(a.head.weight, c.head.weight)


def test_bad_config_is_named() -> None:
    with pytest.raises(ValueError, match=r"epochs must be an integer >= 1, got 0"):
        TrainConfig(epochs=0)
    with pytest.raises(ValueError, match=r"device must be 'cpu' or 'cuda', got 'tpu'"):
        TrainConfig(device="tpu")
