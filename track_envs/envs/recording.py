"""Record simulated belt tracks in the published track-file layout (for BeltReplay-v0)."""

from __future__ import annotations

import os
from typing import Any

import numpy as np

from track_envs.io.wide_tracks import write_track_csv


def record_belt_sorter(
    path: str | os.PathLike[str], n_frames: int, *, seed: int = 0, **env_kwargs: Any
) -> np.ndarray:
    """Run BeltSorter-v0 and write the true centroids of the particles in the window.

    Particles are numbered 0, 1, ... in order of first appearance; the file holds one ``(x, y)``
    column pair per particle, NaN outside the frames in which it is in the window.

    Args:
        path: Output file (``.csv`` or ``.zip``).
        n_frames: Frames to record, >= 1.
        seed: Episode seed.
        **env_kwargs: Passed to ``BeltSorterEnv`` (e.g. ``particle_kind``, ``feed_rate``).

    Returns:
        The recorded positions, (n_frames, n_particles, 2) with NaN where not visible.
    """
    from track_envs.contracts.report import empty_report
    from track_envs.envs.belt_sorter import BeltSorterEnv

    if n_frames < 1:
        raise ValueError(f"n_frames must be >= 1, got {n_frames!r}")
    env = BeltSorterEnv(**env_kwargs)
    _, info = env.reset(seed=seed)
    report = empty_report(env.sensor_spec.max_tracks, (2,))
    frames: list[tuple[np.ndarray, np.ndarray]] = []
    for t in range(n_frames):
        truth = info["truth"]
        live = truth["ids"] >= 0
        frames.append((truth["ids"][live], truth["positions"][live]))
        if t + 1 < n_frames:
            _, _, _, _, info = env.step(report)
    all_ids = np.concatenate([ids for ids, _ in frames])
    first = np.unique(all_ids)
    positions = np.full((n_frames, len(first), 2), np.nan)
    for t, (ids, pos) in enumerate(frames):
        positions[t, np.searchsorted(first, ids)] = pos
    write_track_csv(path, positions)
    return positions
