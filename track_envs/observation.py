"""Validation of an observation on the agent side (the mirror of the report contract)."""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from track_envs.types import SensorSpec


def check_observation(
    obs: Mapping[str, NDArray], spec: SensorSpec, detection_shape: tuple[int, ...] | None = None
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Validate an observation; return its masked-in rows and their detections.

    Args:
        obs: ``{"detections": (max_detections, *detection_shape) float, "mask": (max_detections,) int}``.
        spec: The environment's sensor spec.
        detection_shape: Shape of one detection row: ``(D,)`` for points (the default), ``(17, 3)``
            for keypoint poses.

    Returns:
        ``(rows, detections)``: the masked-in row indices (m,) and their detections as float64.

    Raises:
        ValueError: naming the key, the expected shape or dtype, or the rows holding NaN or inf.
    """
    for key in ("detections", "mask"):
        if key not in obs:
            raise ValueError(f"observation lacks {key!r}; expected keys 'detections' and 'mask'")
    det = np.asarray(obs["detections"])
    mask = np.asarray(obs["mask"])
    shape = (spec.max_detections, *(detection_shape or (spec.dim,)))
    if det.shape != shape or det.dtype.kind != "f":
        raise ValueError(
            f"observation['detections'] must be a float array of shape {shape}, got {det.dtype} {det.shape}"
        )
    if mask.shape != (spec.max_detections,) or mask.dtype.kind not in "iub":
        raise ValueError(
            f"observation['mask'] must be an integer array of shape ({spec.max_detections},), "
            f"got {mask.dtype} {mask.shape}"
        )
    rows = np.flatnonzero(mask)
    z = det[rows].astype(np.float64)
    finite = np.isfinite(z).all(axis=tuple(range(1, z.ndim)))
    if not finite.all():
        raise ValueError(f"masked-in detection rows {rows[~finite][:10].tolist()} hold NaN or inf")
    return rows, z
