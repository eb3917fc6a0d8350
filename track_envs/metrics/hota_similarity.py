"""Similarities in [0, 1] between truth and tracker rows, as :mod:`track_envs.metrics.hota` takes them.

* Boxes: intersection over union, :func:`box_iou`.
* Points: :func:`point_similarity`, ``max(0, 1 − d/τ)`` for a Euclidean distance ``d`` and a
  distance threshold ``τ`` (the metric's matching threshold). It is 1 at ``d = 0``, falls
  linearly and is 0 from ``d = τ`` on, so a pair is a HOTA true positive at threshold α exactly
  when ``d ≤ (1 − α) τ``: α = 0.05 accepts nearly the whole ``τ``, α = 0.95 only ``τ/20``.
* Poses: object keypoint similarity, :func:`track_envs.metrics.keypoints.pairwise_oks`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

_EPS = float(np.finfo(float).eps)


def box_iou(boxes_a: ArrayLike, boxes_b: ArrayLike, box_format: str = "xywh") -> NDArray[np.float64]:
    """Pairwise intersection over union of axis-aligned boxes.

    .. math::

        \\mathrm{IoU}(a, b) = \\frac{|a \\cap b|}{|a| + |b| - |a \\cap b|},

    set to 0 where either box or the union has an area of at most machine epsilon.

    Args:
        boxes_a: (n, 4) boxes.
        boxes_b: (m, 4) boxes.
        box_format: ``"xywh"`` (left, top, width, height: MOTChallenge's) or ``"xyxy"`` (corners).

    Returns:
        (n, m) IoU in [0, 1].
    """
    a = _corners(boxes_a, box_format, "boxes_a")
    b = _corners(boxes_b, box_format, "boxes_b")
    low = np.maximum(a[:, np.newaxis, :2], b[np.newaxis, :, :2])
    high = np.minimum(a[:, np.newaxis, 2:], b[np.newaxis, :, 2:])
    side = np.maximum(high - low, 0.0)
    intersection = side[..., 0] * side[..., 1]
    area_a = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
    area_b = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    union = area_a[:, np.newaxis] + area_b[np.newaxis, :] - intersection
    valid = (area_a[:, np.newaxis] > _EPS) & (area_b[np.newaxis, :] > _EPS) & (union > _EPS)
    return np.where(valid, intersection / np.where(valid, union, 1.0), 0.0)


def point_similarity(points_a: ArrayLike, points_b: ArrayLike, threshold: float) -> NDArray[np.float64]:
    """Pairwise ``max(0, 1 − ‖a − b‖ / τ)`` between (n, D) and (m, D) points; (n, m) in [0, 1].

    Args:
        points_a: (n, D) points.
        points_b: (m, D) points.
        threshold: τ, the distance at which the similarity reaches 0; > 0 and finite.
    """
    tau = float(threshold)
    if not (np.isfinite(tau) and tau > 0):
        raise ValueError(f"threshold must be > 0 and finite; got {threshold!r}")
    a = np.asarray(points_a, dtype=np.float64)
    b = np.asarray(points_b, dtype=np.float64)
    if a.ndim != 2 or b.ndim != 2 or a.shape[1] != b.shape[1]:
        raise ValueError(f"points must be (n, D) and (m, D) with the same D; got {a.shape} and {b.shape}")
    distance = np.sqrt(np.sum((a[:, np.newaxis, :] - b[np.newaxis, :, :]) ** 2, axis=-1))
    return np.maximum(0.0, 1.0 - distance / tau)


def _corners(boxes: ArrayLike, box_format: str, name: str) -> NDArray[np.float64]:
    """(n, 4) boxes as (x0, y0, x1, y1) float64."""
    array = (
        np.asarray(boxes, dtype=np.float64).reshape(-1, 4)
        if np.size(boxes) == 0
        else np.asarray(boxes, float)
    )
    if array.ndim != 2 or array.shape[1] != 4:
        raise ValueError(f"{name} must be (n, 4); got shape {array.shape}")
    if box_format == "xywh":
        return np.concatenate([array[:, :2], array[:, :2] + array[:, 2:]], axis=1)
    if box_format == "xyxy":
        return array
    raise ValueError(f"box_format must be 'xywh' or 'xyxy'; got {box_format!r}")
