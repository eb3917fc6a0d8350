"""Training data for learned motion models: true tracks from an env or a user's track file.

A *track* is the sequence of positions ``(T, D)`` of one target over consecutive frames. Tracks
come from

* [`tracks_from_env`][predictors.training.tracks_from_env]: the truth of any point environment
(``info["truth"]``), run with empty
  reports (the tracker does not influence the targets), or
* [`tracks_from_file`][predictors.training.tracks_from_file]: a recorded track file in the BeltReplay layout
(CSV or zip, one x, y
  column pair per particle, NaN while it is not in view) — a sorting engineer's recordings.

[`split_tracks`][predictors.training.split_tracks] drops tracks shorter than a minimum length (and says how
many) and splits the rest into train / validation / test sets *by track* with a seeded generator, so no track
contributes to two sets. [`pad_tracks`][predictors.training.pad_tracks] stacks tracks of different lengths
into one padded array with a validity mask, which is how the training loop feeds whole tracks at once.
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class TrackSet:
    """Tracks of one data source with the sensor geometry they were recorded in.

    Attributes:
        tracks: Position sequences, each ``(T_i, D)`` float64 with ``T_i >= 1`` and no NaN.
        dt: Frame period in seconds.
        region_low: Lower corner of the observed region (D,).
        region_high: Upper corner of the observed region (D,).
        description: How the tracks were made (env id and kwargs, or the file), for model sidecars.
    """

    tracks: list[FloatArray] = field(repr=False)
    dt: float
    region_low: tuple[float, ...]
    region_high: tuple[float, ...]
    description: Mapping[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.tracks)

    @property
    def dim(self) -> int:
        """Measurement dimension ``D``."""
        return len(self.region_low)

    def with_tracks(self, tracks: list[FloatArray], **description: Any) -> TrackSet:
        """The same geometry with other tracks (and extra description entries)."""
        return TrackSet(
            tracks, self.dt, self.region_low, self.region_high, {**self.description, **description}
        )


def tracks_from_positions(positions: NDArray[np.floating]) -> list[FloatArray]:
    """Split per-frame positions ``(n_frames, n_targets, D)`` (NaN = not seen) into tracks.

    Every maximal run of consecutive frames in which a target's position is finite becomes one
    track, so a target that leaves and re-enters the view gives two.
    """
    pos = np.asarray(positions, dtype=np.float64)
    if pos.ndim != 3:
        raise ValueError(f"positions must have shape (n_frames, n_targets, D), got {pos.shape}")
    seen = np.isfinite(pos).all(axis=2)  # (n_frames, n_targets)
    padded = np.zeros((seen.shape[0] + 2, seen.shape[1]), dtype=np.int8)
    padded[1:-1] = seen
    edges = np.diff(padded, axis=0)  # +1 at a run's first frame, -1 one past its last
    # row-major over (target, frame): the k-th run start and the k-th run stop belong together
    target, start = np.nonzero(edges.T == 1)
    _, stop = np.nonzero(edges.T == -1)
    return [pos[a:b, j].copy() for j, a, b in zip(target, start, stop, strict=True)]


def tracks_from_file(path: str | os.PathLike[str], *, dt: float, region: Any = None) -> TrackSet:
    """Tracks of a recorded track file (BeltReplay layout: CSV or zip).

    Args:
        path: The track file.
        dt: Its frame period in seconds.
        region: ``(low, high)`` corners of the observed region; ``None`` takes the bounding box of
            the recorded positions.
    """
    from track_envs.io.wide_tracks import load_track_csv

    if not (np.isfinite(dt) and dt > 0):
        raise ValueError(f"dt must be a positive number of seconds, got {dt!r}")
    positions = load_track_csv(path)
    if region is None:
        flat = positions.reshape(-1, positions.shape[2])
        flat = flat[np.isfinite(flat).all(axis=1)]
        if len(flat) == 0:
            raise ValueError(f"track file {os.fspath(path)} holds no position")
        low, high = flat.min(axis=0), flat.max(axis=0)
    else:
        low, high = (np.asarray(r, dtype=np.float64) for r in region)
    return TrackSet(
        tracks_from_positions(positions),
        float(dt),
        tuple(map(float, low)),
        tuple(map(float, high)),
        {"source": "file", "path": os.fspath(path), "dt": float(dt)},
    )


def tracks_from_env(
    env_id: str, *, episodes: int, seed: int = 0, steps: int | None = None, **env_kwargs: Any
) -> TrackSet:
    """True tracks of ``episodes`` episodes of a point environment (seeds ``seed, seed + 1, ...``).

    Args:
        env_id: A registered point env, e.g. ``"BeltSorter-v0"``.
        episodes: Number of episodes, >= 1.
        seed: Seed of the first episode.
        steps: Frames per episode (``None``: until the episode ends).
        **env_kwargs: Passed to ``gym.make`` (e.g. ``particle_kind="cylinder"``).
    """
    import gymnasium as gym

    import track_envs  # noqa: F401  (registers the envs)
    from track_envs.contracts.report import empty_report

    if not (isinstance(episodes, int) and episodes >= 1):
        raise ValueError(f"episodes must be an integer >= 1, got {episodes!r}")
    env = gym.make(env_id, **env_kwargs)
    spec = env.unwrapped.sensor_spec  # type: ignore[attr-defined]
    if spec.dim != 2 or env.observation_space["detections"].shape[1:] != (spec.dim,):  # type: ignore[index]
        raise ValueError(f"{env_id} is not a point environment; tracks need (D,) positions")
    tracks: list[FloatArray] = []
    report = empty_report(spec.max_tracks, (spec.dim,))
    for episode in range(episodes):
        _, info = env.reset(seed=seed + episode)
        frame_ids: list[NDArray[np.int64]] = []
        frame_pos: list[FloatArray] = []
        t = 0
        while True:
            truth = info["truth"]
            live = (truth["ids"] >= 0) & truth["visible"]
            frame_ids.append(truth["ids"][live])
            frame_pos.append(truth["positions"][live].astype(np.float64))
            t += 1
            if steps is not None and t >= steps:
                break
            _, _, terminated, truncated, info = env.step(report)
            if terminated or truncated:
                break
        tracks.extend(_tracks_of_frames(frame_ids, frame_pos, spec.dim))
    env.close()
    return TrackSet(
        tracks,
        float(spec.dt),
        tuple(spec.region_low),
        tuple(spec.region_high),
        {
            "source": "env",
            "env_id": env_id,
            "env_kwargs": dict(env_kwargs),
            "episodes": episodes,
            "seed": seed,
        },
    )


def _tracks_of_frames(
    frame_ids: Sequence[NDArray[np.int64]], frame_pos: Sequence[FloatArray], dim: int
) -> list[FloatArray]:
    """Per-frame (ids, positions) lists → tracks, via one dense (frames, targets, D) table."""
    all_ids = np.concatenate(frame_ids) if frame_ids else np.zeros(0, dtype=np.int64)
    unique = np.unique(all_ids)
    table = np.full((len(frame_ids), len(unique), dim), np.nan)
    for t, (ids, pos) in enumerate(zip(frame_ids, frame_pos, strict=True)):
        table[t, np.searchsorted(unique, ids)] = pos
    return tracks_from_positions(table)


@dataclass(frozen=True)
class TrackSplit:
    """Train / validation / test tracks, split by track, and how many were dropped as too short."""

    train: TrackSet
    validation: TrackSet
    test: TrackSet
    dropped: int
    min_length: int

    def summary(self) -> dict[str, int]:
        """Counts for a model sidecar and the training log."""
        return {
            "train_tracks": len(self.train),
            "validation_tracks": len(self.validation),
            "test_tracks": len(self.test),
            "dropped_short_tracks": self.dropped,
            "min_length": self.min_length,
            "train_steps": int(sum(len(t) for t in self.train.tracks)),
        }


def split_tracks(
    data: TrackSet,
    *,
    fractions: tuple[float, float, float] = (0.7, 0.15, 0.15),
    seed: int = 0,
    min_length: int = 5,
    min_tracks: int = 3,
) -> TrackSplit:
    """Drop tracks shorter than ``min_length``; shuffle the rest with ``seed`` and split by track.

    Raises:
        ValueError: for fractions that are not three non-negative numbers summing to 1, or when
            fewer than ``min_tracks`` tracks are left (naming how many there were and how many
            were too short).
    """
    f = np.asarray(fractions, dtype=np.float64)
    if f.shape != (3,) or (f < 0).any() or not np.isclose(f.sum(), 1.0):
        raise ValueError(f"fractions must be three numbers >= 0 that sum to 1, got {fractions!r}")
    if not (isinstance(min_length, int) and min_length >= 2):
        raise ValueError(f"min_length must be an integer >= 2, got {min_length!r}")
    keep = [t for t in data.tracks if len(t) >= min_length]
    dropped = len(data.tracks) - len(keep)
    if len(keep) < min_tracks:
        raise ValueError(
            f"too few tracks to train on: {len(keep)} of {len(data.tracks)} have at least {min_length} "
            f"frames ({dropped} shorter), need at least {min_tracks}; record more data or lower min_length"
        )
    order = np.random.default_rng(seed).permutation(len(keep))
    n_train = max(1, round(f[0] * len(keep)))
    n_val = max(1, round(f[1] * len(keep))) if f[1] > 0 else 0
    n_val = min(n_val, len(keep) - n_train)
    parts = np.split(order, [n_train, n_train + n_val])
    sets = [
        data.with_tracks([keep[i] for i in part], split=name)
        for part, name in zip(parts, ("train", "validation", "test"), strict=True)
    ]
    return TrackSplit(sets[0], sets[1], sets[2], dropped, min_length)


def pad_tracks(tracks: Sequence[NDArray[np.floating]]) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Stack tracks into ``(B, T_max, D)`` (zero-padded) with a validity mask ``(B, T_max)``."""
    if not tracks:
        raise ValueError("pad_tracks needs at least one track")
    dim = np.shape(tracks[0])[1]
    lengths = np.array([len(t) for t in tracks])
    out = np.zeros((len(tracks), int(lengths.max()), dim))
    mask = np.arange(out.shape[1])[None, :] < lengths[:, None]
    out[mask] = np.concatenate([np.asarray(t, dtype=np.float64) for t in tracks])
    return out, mask


def window_tracks(data: TrackSet, length: int, stride: int) -> TrackSet:
    """Every window of ``length`` frames starting every ``stride`` frames of each track.

    Tracks shorter than ``length`` are kept whole.
    """
    if not (isinstance(length, int) and length >= 2):
        raise ValueError(f"window length must be an integer >= 2, got {length!r}")
    if not (isinstance(stride, int) and stride >= 1):
        raise ValueError(f"window stride must be an integer >= 1, got {stride!r}")
    out: list[FloatArray] = []
    for t in data.tracks:
        if len(t) <= length:
            out.append(t)
            continue
        out.extend(t[a : a + length] for a in range(0, len(t) - length + 1, stride))
    return data.with_tracks(out, window=length, stride=stride)


def sine_tracks(periods: float = 25.0, step: float = 0.2) -> TrackSet:
    """The noiseless sine ``x_t = (tΔ, sin tΔ)`` of Jung et al. (2019), eq. (5), as one track."""
    from track_envs.envs.single_target import n_frames_for, sine_trajectory

    if not (np.isfinite(periods) and periods > 0):
        raise ValueError(f"periods must be a number > 0, got {periods!r}")
    if not (np.isfinite(step) and step > 0):
        raise ValueError(f"step must be a number > 0, got {step!r}")
    x = sine_trajectory(n_frames_for(periods, step), step)
    low, high = x.min(axis=0), x.max(axis=0)
    return TrackSet(
        [x],
        1.0,
        tuple(map(float, low)),
        tuple(map(float, high)),
        {"source": "sine", "equation": "x_t = (t*step, sin(t*step))", "periods": periods, "step": step},
    )
