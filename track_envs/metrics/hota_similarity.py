"""Similarities in [0, 1] between truth and tracker rows, as
[`track_envs.metrics.hota`][track_envs.metrics.hota] takes them.

* Boxes: intersection over union, [`box_iou`][track_envs.metrics.box_iou].
* Points: [`point_similarity`][track_envs.metrics.point_similarity], ``max(0, 1 − d/τ)`` for a Euclidean
distance ``d`` and a
  distance threshold ``τ`` (the metric's matching threshold). It is 1 at ``d = 0``, falls
  linearly and is 0 from ``d = τ`` on, so a pair is a HOTA true positive at threshold α exactly
  when ``d ≤ (1 − α) τ``: α = 0.05 accepts nearly the whole ``τ``, α = 0.95 only ``τ/20``.
* Poses: object keypoint similarity,
[`track_envs.metrics.keypoints.pairwise_oks`][track_envs.metrics.pairwise_oks].
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


def point_similarity_entries(
    points_a: ArrayLike, points_b: ArrayLike, threshold: float
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """The non-zero entries of [`point_similarity`][track_envs.metrics.point_similarity], row-major, at a cost
    linear in the points.

    ``S > 0`` needs ``d < τ``, so every such pair lies in the box ``|a_k − b_k| ≤ τ`` around ``a``
    (a spatial index, [`track_envs.infra.spatial.candidate_pairs`][track_envs.infra.spatial.candidate_pairs],
    with a margin); the similarity is computed on those candidates only, by the same operations, so the values
    are the very floats of the dense matrix. Non-finite coordinates fall back to the dense matrix (whose
    NaN entries the callers reject).

    Returns:
        ``(rows, cols, values)``: ``values = point_similarity(a, b, τ)[rows, cols]``, every non-zero
            entry once, rows ascending and columns ascending within a row.
    """
    tau = float(threshold)
    if not (np.isfinite(tau) and tau > 0):
        raise ValueError(f"threshold must be > 0 and finite; got {threshold!r}")
    a = np.asarray(points_a, dtype=np.float64)
    b = np.asarray(points_b, dtype=np.float64)
    if a.ndim != 2 or b.ndim != 2 or a.shape[1] != b.shape[1]:
        raise ValueError(f"points must be (n, D) and (m, D) with the same D; got {a.shape} and {b.shape}")
    if not len(a) or not len(b) or not (np.isfinite(a).all() and np.isfinite(b).all()):
        return _dense_entries(point_similarity(a, b, tau))
    from track_envs.infra.spatial import candidate_pairs

    ptr, cand = candidate_pairs(a, tau * (1.0 + 1e-9), b, what="truth")
    rows = np.repeat(np.arange(len(a), dtype=np.int64), np.diff(ptr))
    distance = np.sqrt(np.sum((a[rows] - b[cand]) ** 2, axis=-1))
    values = np.maximum(0.0, 1.0 - distance / tau)
    keep = values != 0.0
    return rows[keep], cand[keep], values[keep]


def box_iou_entries(
    boxes_a: ArrayLike, boxes_b: ArrayLike, box_format: str = "xywh"
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """The non-zero entries of ``nan_to_num(box_iou(a, b))``, row-major, linear in the boxes.

    A positive IoU needs the boxes to overlap: their centres are then closer than the sum of
    their half-extents on each axis, at most ``w_a/2 + max w_b/2`` (and the same for heights). The
    finite boxes of ``b`` are indexed by centre
    ([`track_envs.infra.spatial.candidate_pairs`][track_envs.infra.spatial.candidate_pairs]) and each box of
    ``a`` queries that box (with a margin for the rounding of the centres); the IoU is computed on the
    candidates by the same operations as [`box_iou`][track_envs.metrics.box_iou]. A box with a non-finite
    coordinate has IoU 0 (or NaN, which ``nan_to_num`` makes 0) with every box.
    """
    a = _corners(boxes_a, box_format, "boxes_a")
    b = _corners(boxes_b, box_format, "boxes_b")
    empty = np.zeros(0, dtype=np.int64)
    fin_a = np.flatnonzero(np.isfinite(a).all(axis=1))
    fin_b = np.flatnonzero(np.isfinite(b).all(axis=1))
    if not fin_a.size or not fin_b.size:
        return empty, empty.copy(), np.zeros(0)
    from track_envs.infra.spatial import candidate_pairs

    fa, fb = a[fin_a], b[fin_b]
    ca = 0.5 * (fa[:, :2] + fa[:, 2:])
    cb = 0.5 * (fb[:, :2] + fb[:, 2:])
    ext_a = np.maximum(fa[:, 2:] - fa[:, :2], 0.0)
    ext_b = np.maximum(fb[:, 2:] - fb[:, :2], 0.0).max(axis=0)
    scale = max(float(np.abs(fa).max()), float(np.abs(fb).max()), 1.0)
    half = 0.5 * (ext_a + ext_b) * (1.0 + 1e-9) + 16.0 * _EPS * scale
    ptr, cand = candidate_pairs(ca, half, cb, what="box")
    local = np.repeat(np.arange(len(fa), dtype=np.int64), np.diff(ptr))
    pa, pb = fa[local], fb[cand]
    low = np.maximum(pa[:, :2], pb[:, :2])
    high = np.minimum(pa[:, 2:], pb[:, 2:])
    side = np.maximum(high - low, 0.0)
    intersection = side[:, 0] * side[:, 1]
    area_a = (pa[:, 2] - pa[:, 0]) * (pa[:, 3] - pa[:, 1])
    area_b = (pb[:, 2] - pb[:, 0]) * (pb[:, 3] - pb[:, 1])
    union = area_a + area_b - intersection
    valid = (area_a > _EPS) & (area_b > _EPS) & (union > _EPS)
    values = np.where(valid, intersection / np.where(valid, union, 1.0), 0.0)
    keep = values != 0.0
    return fin_a[local[keep]], fin_b[cand[keep]], values[keep]


def _dense_entries(
    similarity: NDArray[np.float64],
) -> tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.float64]]:
    """The non-zero entries of a dense matrix, row-major (NaN entries included)."""
    rows, cols = np.nonzero(similarity)
    return rows.astype(np.int64), cols.astype(np.int64), similarity[rows, cols]
