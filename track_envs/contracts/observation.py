"""Validation of an observation on the agent side (the mirror of the report contract).

Every agent checks what it is handed with [`check_observation`][track_envs.contracts.check_observation] before
it reads a row: an observation is a mapping
``{"detections": (max_detections, *R) float, "mask": (max_detections,) 0/1 integer or bool}``, and its
masked-in rows (mask 1) hold finite detections. A mask value other than 0 and 1 is an error, not "present": an
agent would otherwise turn padding rows into tracks.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
from numpy.typing import NDArray

from track_envs.infra.compiled import njit
from track_envs.values.types import SensorSpec

OBSERVATION_KEYS = ("detections", "mask")

# what _live_detections found (0: a valid observation)
_OK, _BAD_MASK, _NOT_FINITE = range(3)


def check_observation(
    obs: Mapping[str, NDArray], spec: SensorSpec, detection_shape: tuple[int, ...] | None = None
) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
    """Validate an observation; return its masked-in rows and their detections.

    Args:
        obs: ``{"detections": (max_detections, *detection_shape) float, "mask": (max_detections,)
            0/1 integer or bool}``.
        spec: The environment's sensor spec.
        detection_shape: Shape of one detection row: ``(D,)`` for points (the default), ``(17, 3)``
            for keypoint poses.

    Returns:
        ``(rows, detections)``: the masked-in row indices (m,) and their detections as float64
            (m, *detection_shape).

    Raises:
        ValueError: if ``obs`` is not a mapping or lacks a key; naming the key and the expected
            shape or dtype; or naming the rows whose mask is not 0/1 or whose detection holds
            NaN or inf.
    """
    if not isinstance(obs, Mapping):
        raise ValueError(
            f"observation must be a mapping with keys 'detections' and 'mask', got {type(obs).__name__}"
        )
    for key in OBSERVATION_KEYS:
        if key not in obs:
            raise ValueError(f"observation lacks {key!r}; expected keys 'detections' and 'mask'")
    det = obs["detections"]
    det = det if type(det) is np.ndarray else np.asarray(det)
    mask = obs["mask"]
    mask = mask if type(mask) is np.ndarray else np.asarray(mask)
    row_shape = detection_shape or (spec.dim,)
    shape = (spec.max_detections, *row_shape)
    if det.shape != shape or det.dtype.kind != "f":
        raise ValueError(
            f"observation['detections'] must be a float array of shape {shape}, got {det.dtype} {det.shape}"
        )
    if mask.shape != (spec.max_detections,) or mask.dtype.kind not in "iub":
        raise ValueError(
            f"observation['mask'] must be a 0/1 integer array (or bool) of shape ({spec.max_detections},), "
            f"got {mask.dtype} {mask.shape}"
        )
    status, rows, z = _live_detections(mask, det.reshape(spec.max_detections, -1))
    if status == _BAD_MASK:
        bad = np.flatnonzero((mask != 0) & (mask != 1))
        raise ValueError(
            f"observation['mask'] must hold 0 or 1; rows {bad[:10].tolist()} hold {mask[bad[:10]].tolist()}"
        )
    if status == _NOT_FINITE:
        bad = rows[~np.isfinite(z).all(axis=1)][:10].tolist()
        raise ValueError(f"observation['detections']: masked-in detection rows {bad} hold NaN or inf")
    return rows, z.reshape(len(rows), *row_shape)


@njit(cache=True)
def _live_detections(mask: NDArray, flat: NDArray) -> tuple[int, NDArray[np.intp], NDArray[np.float64]]:
    """The masked-in rows of ``flat`` (max_detections, F) as float64, in one pass.

    Returns a status (``_OK``; ``_BAD_MASK`` with empty arrays when a mask value is not 0/1;
    ``_NOT_FINITE`` when a masked-in row holds NaN or inf, with the rows all the same), the
    masked-in row indices and their values.
    """
    n_rows, n_cols = flat.shape
    n = 0
    for r in range(n_rows):
        if mask[r] != 0:
            if mask[r] != 1:
                return _BAD_MASK, np.empty(0, np.intp), np.empty((0, n_cols))
            n += 1
    rows = np.empty(n, np.intp)
    z = np.empty((n, n_cols))
    status = _OK
    k = 0
    for r in range(n_rows):
        if mask[r] != 0:
            rows[k] = r
            for c in range(n_cols):
                value = flat[r, c]
                if not np.isfinite(value):
                    status = _NOT_FINITE
                z[k, c] = value
            k += 1
    return status, rows, z


def pack_observation(detections: NDArray[np.floating], spec: SensorSpec) -> dict[str, NDArray]:
    """Pad one frame's ``m`` detections into an observation of ``spec.max_detections`` rows (the
    twin of [`track_envs.contracts.report.pack_report`][track_envs.contracts.pack_report]).

    The rows keep their order (row ``i`` is ``detections[i]``), as float32, padding rows zero and
    mask 0 — what an environment hands an agent, without the shuffling and clipping.

    Args:
        detections: (m, D) positions (D = ``spec.dim``), finite.
        spec: The sensor spec the agent was reset with.

    Raises:
        ValueError: if ``m > spec.max_detections`` (no detection is dropped silently), the
            shape is not (m, D), or a detection is not finite.
    """
    z = np.asarray(detections)
    if z.ndim != 2 or z.shape[1] != spec.dim:
        raise ValueError(f"detections must have shape (m, {spec.dim}), got {z.shape}")
    m = len(z)
    if m > spec.max_detections:
        raise ValueError(
            f"{m} detections do not fit an observation of max_detections={spec.max_detections}; "
            "raise max_detections in the sensor spec"
        )
    if not np.isfinite(z).all():
        raise ValueError(
            f"detections rows {np.flatnonzero(~np.isfinite(z).all(axis=1))[:10].tolist()} hold NaN or inf"
        )
    packed = np.zeros((spec.max_detections, spec.dim), dtype=np.float32)
    packed[:m] = z
    mask = np.zeros(spec.max_detections, dtype=np.int8)
    mask[:m] = 1
    return {"detections": packed, "mask": mask}
