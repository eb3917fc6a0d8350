"""Run a pose agent over a recorded pose stream (a pose file), outside a gym loop.

[`run_pose_agent`][agents.run_pose_agent] is [`agents.files.points.run_agent`][agents.run_agent] for poses:
each frame of a [`PoseStream`][track_envs.PoseStream] is packed as KeypointWalkers-v0 observes it
([`pose_observation`][track_envs.values.pose_observation]), handed to ``agent.act``, and the report's live
rows become the frame's tracked poses, a [`PoseStream`][track_envs.PoseStream] with track ids:

* a track updated with detection ``d`` keeps ``d``'s labelled keypoints (their visibility and
  confidence, at the tracker's positions) and ``d``'s pose score; the keypoints ``d`` lacks are
  not written (``v = 0``);
* a coasting track (reported only with ``report_coasting=True``) writes every keypoint of its
  predicted pose with ``v = 1`` and confidence 0, and no pose score.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from agents.files.kinds import check_file_agent
from track_envs.metrics.keypoints import NUM_KEYPOINTS
from track_envs.values.poses import PoseStream, pose_observation
from track_envs.values.types import SensorSpec


def run_pose_agent(agent: Any, stream: PoseStream, spec: SensorSpec, *, seed: int | None = 0) -> PoseStream:
    """Track ``stream`` with a pose agent (``reset(spec, seed=seed)`` first); return the tracks.

    Raises:
        ValueError: an agent that does not track poses or needs truth; a stream whose poses do
            not have the 17 COCO keypoints the pose agents track.
    """
    check_file_agent(agent, "pose", flag="")
    if stream.num_keypoints != NUM_KEYPOINTS:
        raise ValueError(
            f"the pose agents track the {NUM_KEYPOINTS} COCO keypoints; the file's poses have "
            f"{stream.num_keypoints}"
        )
    agent.reset(spec, seed=seed)
    frame_ids, ids, poses, rows = [], [], [], []
    for t in range(stream.n_frames):
        report = agent.act(pose_observation(stream, t, spec))
        live = np.asarray(report["mask"]) == 1
        ids.append(np.asarray(report["ids"], np.int64)[live])
        poses.append(np.asarray(report["positions"], np.float64)[live])
        rows.append(np.asarray(report["detection"], np.int64)[live])
        frame_ids.append(np.full(int(live.sum()), t, np.int64))
    frame = np.concatenate(frame_ids) if frame_ids else np.zeros(0, np.int64)
    det = np.concatenate(rows) if rows else np.zeros(0, np.int64)
    xy = np.concatenate(poses).reshape(-1, NUM_KEYPOINTS, 2) if poses else np.zeros((0, NUM_KEYPOINTS, 2))
    detected = det >= 0
    source = np.where(detected, stream.offsets[frame] + det, 0)  # the detection's row in the stream
    vis = np.where(detected[:, None], stream.visibility[source] if len(stream) else 0, 1).astype(np.int8)
    scores = np.where(detected[:, None], stream.keypoint_scores[source] if len(stream) else 0.0, 0.0)
    pose_scores = np.where(detected, stream.scores[source] if len(stream) else np.nan, np.nan)
    present = vis > 0
    return PoseStream(
        keypoints=np.where(present[..., None], xy, 0.0),
        visibility=vis,
        keypoint_scores=np.where(present, scores, 0.0),
        offsets=np.concatenate([[0], np.cumsum(np.bincount(frame, minlength=stream.n_frames))]),
        image_ids=stream.image_ids,
        file_names=stream.file_names,
        track_ids=np.concatenate(ids) if ids else np.zeros(0, np.int64),
        scores=pose_scores,
        keypoint_names=stream.keypoint_names,
        video_id=stream.video_id,
    )
