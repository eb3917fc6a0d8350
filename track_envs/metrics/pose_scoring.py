"""Score tracked poses against PoseTrack-format ground truth: per-joint MOTA (PCKh) and HOTA (OKS).

**Per-joint MOTA** as the PoseTrack benchmark's ``poseval`` tool defines it (Andriluka et al.,
"PoseTrack: A Benchmark for Human Pose Estimation and Tracking", CVPR 2018). Frames are matched
by image id; only frames whose ground truth holds at least one annotation are scored (poseval
drops the others, with the predictions on them). Every joint ``k`` is its own set of point
targets: in a frame, the truths are the annotations with keypoint ``k`` labelled (``v > 0``), the
hypotheses the tracked poses with keypoint ``k`` written (``v > 0``), and a pair may match when
the PCKh criterion holds,

.. math::

    \\lVert x_k - g_k \\rVert \\,/\\, s \\le 0.5, \\qquad
    s = 0.6 \\, \\lVert (w, h)_{\\text{bbox\\_head}} \\rVert,

the head size of the truth's head box (``getHeadSize`` of poseval). The CLEAR MOT events per joint
follow py-motmetrics' rules ([`ClearMot`][track_envs.metrics.ClearMot], as poseval's
``MOTAccumulator``), and

.. math::

    \\mathrm{MOTA}_k = 1 - \\frac{\\mathrm{FN}_k + \\mathrm{FP}_k + \\mathrm{IDSW}_k}{\\mathrm{GT}_k}, \\qquad
    \\mathrm{MOTA} = 1 - \\frac{\\sum_k (\\mathrm{FN}_k + \\mathrm{FP}_k + \\mathrm{IDSW}_k)}
        {\\sum_k \\mathrm{GT}_k}.

Differences from poseval: every keypoint the files name is scored (poseval maps PoseTrack's 17
slots to its 15 joints and drops the ears, which PoseTrack 2018 never labels); a joint that no
truth labels has MOTA NaN and stays out of the total. On a scored frame without predictions
poseval records one phantom miss and one phantom false positive per joint (its placeholder
ids 0, 0 with no distance) instead of the frame's truths; here the frame's truths are misses.

**HOTA** (Luiten et al., "HOTA: A Higher Order Metric for Evaluating Multi-Object Tracking",
IJCV 2021) over the same frames, with the OKS of a tracked pose against a truth pose as the
similarity ([`oks`][track_envs.metrics.oks], the COCO sigmas, over the truth's labelled
keypoints) and the truth's object area ``A = area_factor · max(w, h)²`` of its labelled keypoints'
bounding box (PoseTrack has no segmentation areas; 0.25 × the squared longer side is the area the
pose agents use for detections). Truths and tracks without a labelled keypoint are left out.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from track_envs.metrics.clear_mot import ClearMot
from track_envs.metrics.keypoints import oks
from track_envs.values.poses import PoseStream


def scored_frames(tracks: PoseStream, truth: PoseStream) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
    """The truth frames scored (those with an annotation) and the tracks' frame of each (−1: the
    tracks lack that image id)."""
    frames = np.flatnonzero(truth.counts > 0)
    order = np.argsort(tracks.image_ids, kind="stable")
    pos = np.searchsorted(tracks.image_ids, truth.image_ids[frames], sorter=order)
    pos = np.minimum(pos, max(len(order) - 1, 0))
    hit = (
        tracks.image_ids[order[pos]] == truth.image_ids[frames] if len(order) else np.zeros(len(frames), bool)
    )
    return frames, np.where(hit, order[pos] if len(order) else -1, -1)


def _check(tracks: PoseStream, truth: PoseStream) -> None:
    if tracks.num_keypoints != truth.num_keypoints:
        raise ValueError(
            f"the tracks have {tracks.num_keypoints} keypoints per pose, the ground truth "
            f"{truth.num_keypoints}"
        )
    if np.any(truth.track_ids < 0):
        i = int(np.argmax(truth.track_ids < 0))
        raise ValueError(
            f"ground-truth pose {i} (image id {truth.image_ids[truth.frame_index()[i]]}) has no track_id"
        )
    if np.any(tracks.track_ids < 0):
        raise ValueError("tracked poses need track ids; some have none (-1)")


def per_joint_mota(tracks: PoseStream, truth: PoseStream, *, pckh: float = 0.5) -> dict[str, float]:
    """PoseTrack per-joint MOTA (module docstring).

    Returns:
        ``mota`` (total), ``mota_<keypoint>`` per keypoint name, and the totals ``num_objects``,
            ``num_misses``, ``num_false_positives``, ``id_switches``.

    Raises:
        ValueError: keypoint counts that differ, truths without a track id or without a head box
            (named), tracks without ids.
    """
    if not (np.isfinite(pckh) and pckh > 0):
        raise ValueError(f"pckh must be a positive fraction of the head size, got {pckh!r}")
    _check(tracks, truth)
    k = truth.num_keypoints
    accs = [ClearMot(threshold=1.0) for _ in range(k)]
    head = truth.head_sizes()
    frames, track_frames = scored_frames(tracks, truth)
    for t, u in zip(frames.tolist(), track_frames.tolist(), strict=True):
        g = truth.frame_rows(t)
        if np.any(~np.isfinite(head[g])):
            i = g.start + int(np.argmax(~np.isfinite(head[g])))
            raise ValueError(
                f"ground-truth pose {i} (image id {truth.image_ids[t]}, track {truth.track_ids[i]}) has no "
                "bbox_head: PCKh needs the head size"
            )
        h = tracks.frame_rows(u) if u >= 0 else slice(0, 0)
        gxy, gv, gid = truth.keypoints[g], truth.present[g], truth.track_ids[g]
        hxy, hv, hid = tracks.keypoints[h], tracks.present[h], tracks.track_ids[h]
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.linalg.norm(gxy[:, None] - hxy[None], axis=-1) / head[g][:, None, None]  # (m, n, K)
        d[~(d <= pckh)] = np.nan
        for j, acc in enumerate(accs):
            rows, cols = gv[:, j], hv[:, j]
            acc.update_distances(gid[rows], hid[cols], d[rows][:, cols, j])
    parts = [acc.compute() for acc in accs]
    errors = np.array([p["num_misses"] + p["num_false_positives"] + p["id_switches"] for p in parts])
    gt = np.array([p["num_objects"] for p in parts])
    scored = gt > 0
    out: dict[str, float] = {
        "mota": float(1.0 - errors[scored].sum() / gt[scored].sum()) if scored.any() else np.nan
    }
    for name, p, ok in zip(truth.keypoint_names, parts, scored, strict=True):
        out[f"mota_{name}"] = float(p["mota"]) if ok else np.nan
    for key in ("num_objects", "num_misses", "num_false_positives", "id_switches"):
        out[key] = float(sum(p[key] for p, ok in zip(parts, scored, strict=True) if ok))
    return out


def truth_areas(truth: PoseStream, area_factor: float = 0.25) -> NDArray[np.float64]:
    """(N,) object areas ``area_factor · max(w, h)²`` of the truths' labelled-keypoint boxes
    (0 without a labelled keypoint)."""
    present = truth.present[..., None]
    lo = np.min(np.where(present, truth.keypoints, np.inf), axis=1)
    hi = np.max(np.where(present, truth.keypoints, -np.inf), axis=1)
    span = np.where(np.isfinite(hi - lo), hi - lo, 0.0)
    return area_factor * np.max(span, axis=1) ** 2


def pose_hota(tracks: PoseStream, truth: PoseStream, *, area_factor: float = 0.25) -> dict[str, float]:
    """HOTA with OKS similarity (module docstring), from
    [`track_envs.metrics.hota.HotaAccumulator`][track_envs.metrics.HotaAccumulator]."""
    from track_envs.metrics.hota import HotaAccumulator
    from track_envs.metrics.hota_stream import hota_keys

    _check(tracks, truth)
    acc = HotaAccumulator()
    area = truth_areas(truth, area_factor)
    frames, track_frames = scored_frames(tracks, truth)
    for t, u in zip(frames.tolist(), track_frames.tolist(), strict=True):
        g = truth.frame_rows(t)
        h = tracks.frame_rows(u) if u >= 0 else slice(0, 0)
        gk = truth.present[g].any(axis=1)
        hk = tracks.present[h].any(axis=1)
        sim = oks(
            truth.keypoints[g][gk], truth.present[g][gk], area[g][gk], tracks.keypoints[h][hk]
        )  # (n, m)
        acc.add_frame(truth.track_ids[g][gk], tracks.track_ids[h][hk], sim.T)
    return hota_keys(acc.compute())


def score_poses(
    tracks: PoseStream, truth: PoseStream, *, pckh: float = 0.5, area_factor: float = 0.25
) -> tuple[dict[str, float], list[str]]:
    """Per-joint MOTA and HOTA (OKS) of ``tracks`` against ``truth``, and notes (what was left out)."""
    metrics = per_joint_mota(tracks, truth, pckh=pckh)
    notes: list[str] = []
    hota = pose_hota(tracks, truth, area_factor=area_factor)
    joints = {k: v for k, v in metrics.items() if k.startswith("mota_")}
    totals = {k: v for k, v in metrics.items() if k not in joints}
    metrics = {**totals, **hota, **joints}  # the totals, HOTA, then the joints
    frames, track_frames = scored_frames(tracks, truth)
    if len(frames) < truth.n_frames:
        notes.append(f"{truth.n_frames - len(frames)} ground-truth frames without annotations are not scored")
    if np.any(track_frames < 0):
        notes.append(
            f"{int(np.sum(track_frames < 0))} scored frames are missing from the tracks (scored as empty)"
        )
    return metrics, notes
