"""Flow statistics of a belt episode, comparable with the authors' DEM figures (Pollithy et al. 2020).

[`belt_statistics`][track_envs.envs.belt_statistics.belt_statistics] runs an environment and summarises the
true motion of the particles in the camera window. Particles already in the window at the first frame or still
in it at the last are left out of the per-particle figures (their passage is cut).

========================= ===================================================== ============
key                       definition                                            DEM figure
========================= ===================================================== ============
entry_speed               median along-belt speed at a particle's first frame   1.00–1.12 m/s
exit_speed                median along-belt speed at its last frame             1.42–1.44 m/s
acceleration              median along-belt acceleration (finite differences)   ≈1.57 m/s²
lateral_speed_p98         98th percentile of |v_y| over all particle frames      0.07–0.09 m/s
frames_seen               median frames a particle is in the window             31–33
new_per_frame             particles entering the window per frame               1.9–2.2
mean_visible              mean particles in the window per frame                58–73
peak_visible              most particles in the window in one frame             140–210
========================= ===================================================== ============
"""

from __future__ import annotations

from typing import Any

import numpy as np

#: The DEM figures (low, high) per statistic, for the three data sets of the authors' belt.
DEM_FIGURES: dict[str, tuple[float, float]] = {
    "entry_speed": (1.00, 1.12),
    "exit_speed": (1.42, 1.44),
    "acceleration": (1.57, 1.57),
    "lateral_speed_p98": (0.07, 0.09),
    "frames_seen": (29.0, 51.0),
    "new_per_frame": (1.9, 2.2),
    "mean_visible": (58.0, 73.0),
    "peak_visible": (140.0, 210.0),
}


def belt_statistics(env: Any, n_frames: int = 1500, seed: int = 0) -> dict[str, float]:
    """Run ``env`` (a belt env, wrapped or not) for ``n_frames`` with empty reports and summarise.

    Args:
        env: An environment whose ``info["truth"]`` has ``ids``, ``positions``, ``velocities``.
        n_frames: Frames to run.
        seed: Reset seed.

    Returns:
        The statistics of the module docstring table.
    """
    from track_envs.contracts.report import empty_report

    spec = env.get_wrapper_attr("sensor_spec")
    report = empty_report(spec.max_tracks, (spec.dim,))
    _, info = env.reset(seed=seed)
    ids, frame, x, v = [], [], [], []
    counts = np.zeros(n_frames, dtype=np.int64)
    for t in range(n_frames):
        truth = info["truth"]
        live = truth["ids"] >= 0
        counts[t] = live.sum()
        ids.append(truth["ids"][live])
        frame.append(np.full(int(live.sum()), t))
        x.append(truth["positions"][live])
        v.append(truth["velocities"][live])
        _, _, terminated, _, info = env.step(report)
        if terminated:
            counts = counts[: t + 1]
            break
    return summarise_passages(
        np.concatenate(ids), np.concatenate(frame), np.concatenate(x), np.concatenate(v), counts, spec.dt
    )


def summarise_passages(
    ids: np.ndarray, frame: np.ndarray, x: np.ndarray, v: np.ndarray, counts: np.ndarray, dt: float
) -> dict[str, float]:
    """The statistics from stacked per-frame truth rows (vectorised over particles)."""
    order = np.lexsort((frame, ids))
    ids, frame, x, v = ids[order], frame[order], x[order], v[order]
    starts = np.flatnonzero(np.r_[True, ids[1:] != ids[:-1]])
    ends = np.r_[starts[1:], len(ids)] - 1
    last_frame = len(counts) - 1
    whole = (frame[starts] > 0) & (frame[ends] < last_frame)
    s, e = starts[whole], ends[whole]
    same = (ids[1:] == ids[:-1]) & (frame[1:] == frame[:-1] + 1)
    accel = (v[1:, 0] - v[:-1, 0])[same] / dt
    in_whole = np.repeat(whole, ends - starts + 1)
    entered = np.count_nonzero(frame[starts] > 0)
    return {
        "entry_speed": float(np.median(v[s, 0])),
        "exit_speed": float(np.median(v[e, 0])),
        "acceleration": float(np.median(accel)),
        "lateral_speed_p98": float(np.quantile(np.abs(v[in_whole, 1]), 0.98)),
        "frames_seen": float(np.median(e - s + 1)),
        "new_per_frame": float(entered / max(last_frame, 1)),
        "mean_visible": float(counts.mean()),
        "peak_visible": float(counts.max()),
    }
