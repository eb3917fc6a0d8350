"""Score tracks from a file against ground truth from a file, with the point envs' metrics.

[`score_tracks`][track_envs.metrics.score_tracks] replays both, frame by frame, into the streaming metrics the
point environments use ([`track_envs.metrics.defaults.point_metrics`][track_envs.metrics.point_metrics]: CLEAR
MOT and IDF1 with match distance ``c``, GOSPA with cut-off ``c``, and the association errors e1 / e2 /
e_mean). The association errors need the truth id behind every detection, which a file has only when it
was written from a simulation (a MOT detection file's id column); without them they are skipped,
with a note saying so. Fed the same truth, reports and detection ids, the figures equal those of
``TrackingMetrics`` in the gym loop, bit for bit.

Boxes: where the tracks and the truth both have boxes
([`Tracks.boxes`][track_envs.values.tracks.Tracks.boxes]: box detections, a MOTChallenge gt), CLEAR MOT and
IDF1 match boxes by overlap instead (``match="iou"``, the default then: a track matches a truth when
``IoU >= min_iou``, 0.5 as MOTChallenge does, at distance ``1 − IoU``;
[`BoxClearMot`][track_envs.metrics.BoxClearMot]), and MOTP is the mean ``1 − IoU``. GOSPA and e1 / e2 stay on
the centres (GOSPA with cut-off ``threshold``).
"""

from __future__ import annotations

import numpy as np

from track_envs.metrics.belt import AssociationErrors
from track_envs.metrics.boxes import BoxClearMot
from track_envs.metrics.clear_mot import ClearMot
from track_envs.metrics.defaults import point_metrics
from track_envs.metrics.hota_stream import BoxHota, Hota
from track_envs.values.detections import Detections
from track_envs.values.tracks import Tracks

#: How CLEAR MOT and IDF1 match tracks to truths: ``auto`` (IoU where both have boxes).
MATCHES = ("auto", "iou", "distance")

#: The note returned when the e1 / e2 metrics are skipped.
NO_DETECTION_IDS = (
    "e1, e2, e_mean skipped: they need the truth id behind every detection, and the detection file has "
    "none (a MOT det.txt id column >= 0 gives them)"
)


def match_kind(tracks_boxed: bool, truth_boxed: bool, match: str = "auto") -> str:
    """``"iou"`` or ``"distance"``: ``match``, or for ``"auto"`` IoU when the tracks and the truth
    both have boxes (``tracks_boxed``, ``truth_boxed``: ``Tracks.boxes is not None``).

    Raises:
        ValueError: an unknown ``match``, or ``"iou"`` when either has no boxes (naming which).
    """
    if match not in MATCHES:
        raise ValueError(f"match must be one of {list(MATCHES)}, got {match!r}")
    boxed = {"tracks": bool(tracks_boxed), "ground truth": bool(truth_boxed)}
    if match == "auto":
        return "iou" if all(boxed.values()) else "distance"
    if match == "iou" and not all(boxed.values()):
        lacking = " and ".join(name for name, has in boxed.items() if not has)
        raise ValueError(
            f"match='iou' (track run: --match iou) needs boxes, and the {lacking} have none (points, or "
            "a MOT file whose boxes are all 0 x 0); use match='distance'"
        )
    return match


def match_line(kind: str, *, threshold: float, min_iou: float) -> str:
    """How CLEAR MOT and IDF1 match with ``kind`` (``"iou"`` or ``"distance"``), in words."""
    if kind == "iou":
        return f"boxes, IoU >= {min_iou:g} (MOTChallenge; MOTP is the mean 1 - IoU of the matches)"
    return f"centres, distance <= {threshold:g} (MOTP is the mean distance of the matches)"


def score_tracks(
    tracks: Tracks,
    truth: Tracks,
    *,
    threshold: float,
    detections: Detections | None = None,
    match: str = "auto",
    min_iou: float = 0.5,
) -> tuple[dict[str, float], list[str]]:
    """The metrics of ``tracks`` against ``truth`` over every frame of either.

    Args:
        tracks: The tracker's tracks (their ``detection`` rows index each frame's detections).
        truth: Ground-truth positions, one row per visible target and frame.
        threshold: ``c``: the CLEAR MOT match distance (``match="distance"``) and the GOSPA
            cut-off, in the files' units.
        detections: The detections that were tracked; with truth ids (``detections.has_ids``)
            the association errors e1 / e2 / e_mean are scored too.
        match: ``"iou"`` (boxes), ``"distance"`` (centres) or ``"auto"``
            (`match_kind`).
        min_iou: The smallest IoU of a CLEAR MOT match with ``match="iou"``.

    Returns:
        ``(metrics, notes)``: one flat dict of floats, and what was skipped and why.
    """
    kind = match_kind(tracks.boxes is not None, truth.boxes is not None, match)
    metrics = point_metrics(threshold)
    if kind == "iou":
        metrics = [BoxClearMot(min_iou) if isinstance(m, ClearMot) else m for m in metrics]
        metrics = [BoxHota() if isinstance(m, Hota) else m for m in metrics]
    notes: list[str] = []
    with_ids = detections is not None and detections.has_ids and tracks.detection is not None
    if not with_ids:
        metrics = [m for m in metrics if not isinstance(m, AssociationErrors)]
        notes.append(NO_DETECTION_IDS)
    n_frames = max(tracks.n_frames, truth.n_frames, detections.n_frames if detections is not None else 0)
    track_offsets, truth_offsets = tracks.with_frames(n_frames).offsets, truth.with_frames(n_frames).offsets
    track_rows = max(int(np.diff(track_offsets).max(initial=0)), 1)
    truth_rows = max(int(np.diff(truth_offsets).max(initial=0)), 1)
    ids_rows = max(detections.max_per_frame, 1) if detections is not None else 1
    for t in range(n_frames):
        report = tracks.padded_frame(int(track_offsets[t]), int(track_offsets[t + 1]), track_rows)
        frame_truth = truth.padded_frame(int(truth_offsets[t]), int(truth_offsets[t + 1]), truth_rows)
        detection_ids = np.full(ids_rows, -1, dtype=np.int64)
        if with_ids and detections is not None and t < detections.n_frames:
            ids = detections.frame_ids(t)
            detection_ids[: len(ids)] = ids
        report.pop("visible")
        for metric in metrics:
            metric.update(frame_truth, detection_ids, report)
    merged: dict[str, float] = {}
    for metric in metrics:
        merged.update({k: float(v) for k, v in metric.compute().items()})
    return merged, notes
