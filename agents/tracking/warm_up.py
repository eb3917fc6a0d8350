"""A tiny synthetic stream that runs every path of a point tracker's frame (its warm-up)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.values.types import SensorSpec


def warm_up_stream(dim: int, sorting: bool = True) -> tuple[SensorSpec, list[dict[str, NDArray]]]:
    """A few frames that run every path of a frame: births, lone and competing pairs, the
    second chance, coasting, deletions and an empty frame (for
    [`agents.tracking.tracker.PointTracker.warm_up`][agents.PointTracker.warm_up]); with ``sorting`` (and
    ``dim >= 2``) the sensor has a nozzle bar, so that the deletions run the sorting roll-out too."""
    dt = 0.01
    spec = SensorSpec(
        dt=dt,
        dim=dim,
        noise_std=1e-4,
        p_detect=1.0,
        clutter_rate=0.0,
        region_low=(0.0,) * dim,
        region_high=(1.0,) * dim,
        max_detections=8,
        max_tracks=16,
        sorting_line=1.05 if sorting and dim >= 2 else None,
    )
    start = np.full((5, dim), 0.1)
    start[:, -1] = [0.1, 0.5, 0.9, 0.3, 0.3003]  # the last two compete for each other's detections
    velocity = np.zeros(dim)
    velocity[0] = 1.0
    frames: list[dict[str, NDArray]] = []
    for t in range(9):
        z = start + t * dt * velocity
        if t == 6:
            z[0, 0] += 0.003  # out of its gate, within the second chance
        if t == 8:
            z = z[:0]
        det = np.zeros((spec.max_detections, dim), np.float32)
        mask = np.zeros(spec.max_detections, np.int8)
        det[: len(z)], mask[: len(z)] = z, 1
        frames.append({"detections": det, "mask": mask})
    frames += [frames[-1]] * (2 + 1)  # coast until deleted, then a frame without tracks
    return spec, frames
