"""Figures of a pose-tracking run that say it went wrong, and the warnings that name them.

The pose runs' counterpart of [`agents.sensor_model.diagnostics`][agents.sensor_model.diagnostics] (the same
two signs, the same limits), counted over the tracked poses:

* **most poses start a track**: track ids / poses above ``MAX_ID_RATIO`` — a person seen for
  ``L`` frames should give one id, not ``L``; the warning gives the peak number of poses in a
  frame (about the number of people in view) beside it, and the ids per such person;
* **most poses are in tracks 1–2 frames long**: more than ``MAX_SHORT_SHARE`` of the tracked
  poses belong to ids that hold at most two. (Counted over poses, not ids as the point runs do:
  a pose detector's false positives each make a short track of their own, and on a correctly
  tracked KeypointWalkers-v0 episode most *ids* are such — 13 of 20 — while they hold 7% of the
  poses.)
"""

from __future__ import annotations

import numpy as np

from agents.sensor_model.diagnostics import MAX_ID_RATIO, MAX_SHORT_SHARE
from track_envs.values.poses import PoseStream


def pose_run_figures(tracks: PoseStream, detections: PoseStream) -> dict[str, float]:
    """``ids``, ``poses`` (detected), ``peak`` (most poses in a frame), ``ids_per_pose``,
    ``ids_per_person`` (ids / peak) and ``short_track_share`` (the share of tracked poses whose id
    holds at most two)."""
    ids, counts = np.unique(tracks.track_ids, return_counts=True)
    poses = len(detections)
    peak = int(detections.counts.max()) if detections.n_frames else 0
    return {
        "ids": float(len(ids)),
        "poses": float(poses),
        "peak": float(peak),
        "ids_per_pose": len(ids) / poses if poses else 0.0,
        "ids_per_person": len(ids) / peak if peak else 0.0,
        "short_track_share": float(np.sum(counts[counts <= 2]) / len(tracks)) if len(tracks) else 0.0,
    }


def pose_run_warnings(tracks: PoseStream, detections: PoseStream) -> list[str]:
    """The warnings of a pose run whose figures
    ([`pose_run_figures`][track_apps.cli.pose_diagnostics.pose_run_figures]) look wrong, each naming its
    figure."""
    f = pose_run_figures(tracks, detections)
    out = []
    if f["ids_per_pose"] > MAX_ID_RATIO:
        out.append(
            f"most poses start a track: {int(f['ids'])} ids for {int(f['poses'])} poses "
            f"(ids/poses = {f['ids_per_pose']:.2f} > {MAX_ID_RATIO}; {f['ids_per_person']:.1f} ids per "
            f"person for at most {int(f['peak'])} poses in a frame); the tracker's OKS gate is likely far "
            "too narrow for how far these people move a frame (--agent-kwargs area_factor=A widens it)"
        )
    if f["short_track_share"] > MAX_SHORT_SHARE:
        out.append(
            f"most poses are in tracks 1-2 frames long: {100 * f['short_track_share']:.0f}% of the "
            f"{len(tracks)} tracked poses have an id that holds at most two (> {100 * MAX_SHORT_SHARE:.0f}%)"
        )
    return out
