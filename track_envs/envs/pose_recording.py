"""Pose files from a KeypointWalkers-v0 episode: the detector's poses and the PoseTrack ground truth.

[`record_keypoint_walkers`][track_envs.envs.record_keypoint_walkers] runs the environment (with a report of no
tracks) and keeps, per frame, the detected poses and the visible people, as two
[`PoseStream`][track_envs.PoseStream]:

* detections: every detected pose (clutter included); a keypoint with a detector score > 0 is
  written with ``v = 2`` (visible) and the score as its confidence, the pose score the mean of
  its keypoint scores;
* truth: every person with a visible keypoint, id = the person's id, the visible keypoints with
  ``v = 1`` (PoseTrack labels), and a square head box about the mean of the five head keypoints
  whose PoseTrack head size ``0.6 · diagonal`` is the environment's ``head_size``.

Image ids are ``1, 2, …``, file names ``images/<video>/<frame:06d>.jpg``. Write them with
[`track_envs.io.poses.coco_results_json`][track_envs.io.poses.coco_results_json] /
[`write_posetrack`][track_envs.io.write_posetrack].
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from track_envs.values.poses import PoseStream


def record_keypoint_walkers(
    frames: int = 60, *, seed: int = 0, video: str = "000001", **env_kwargs: Any
) -> tuple[PoseStream, PoseStream]:
    """``(detections, truth)`` of ``frames`` frames of KeypointWalkers-v0 (``env_kwargs``), seeded."""
    import gymnasium as gym

    from track_envs.registration import register_envs

    register_envs()  # idempotent: done already by importing track_envs

    env = gym.make("KeypointWalkers-v0", max_episode_steps=frames + 1, **env_kwargs)
    spec = env.unwrapped.sensor_spec  # type: ignore[attr-defined]
    empty = {
        "ids": np.zeros(spec.max_tracks, np.int64),
        "positions": np.zeros((spec.max_tracks, 17, 2), np.float32),
        "detection": np.full(spec.max_tracks, -1, np.int64),
        "mask": np.zeros(spec.max_tracks, np.int8),
    }
    det: list[NDArray] = []
    truth: list[dict[str, NDArray]] = []
    obs, info = env.reset(seed=seed)
    for t in range(frames):
        if t:
            obs, _, _, _, info = env.step(empty)
        det.append(np.asarray(obs["detections"], np.float64)[np.asarray(obs["mask"]) == 1])
        tr = info["truth"]
        keep = (tr["ids"] >= 0) & tr["visible"]
        truth.append({key: np.asarray(value)[keep] for key, value in tr.items()})
    env.close()
    image_ids = np.arange(1, frames + 1, dtype=np.int64)
    names = tuple(f"images/{video}/{t:06d}.jpg" for t in range(frames))
    offsets = np.concatenate([[0], np.cumsum([len(d) for d in det])])
    z = np.concatenate(det).reshape(-1, 17, 3)
    found = z[..., 2] > 0
    detections = PoseStream(
        keypoints=np.where(found[..., None], z[..., :2], 0.0),
        visibility=np.where(found, 2, 0).astype(np.int8),
        keypoint_scores=np.where(found, z[..., 2], 0.0),
        offsets=offsets,
        image_ids=image_ids,
        file_names=names,
        scores=np.where(found.any(axis=1), z[..., 2].sum(axis=1) / np.maximum(found.sum(axis=1), 1), 0.0),
        video_id=video,
    )
    g = {key: np.concatenate([f[key] for f in truth]) for key in truth[0]}
    vis = g["keypoint_visible"].astype(bool)
    side = g["head_size"] / (0.6 * np.sqrt(2.0))
    centre = g["keypoints"][:, :5].mean(axis=1)
    heads = np.column_stack([centre - side[:, None] / 2, side, side])
    gt = PoseStream(
        keypoints=np.where(vis[..., None], g["keypoints"], 0.0),
        visibility=vis.astype(np.int8),
        keypoint_scores=vis.astype(np.float64),
        offsets=np.concatenate([[0], np.cumsum([len(f["ids"]) for f in truth])]),
        image_ids=image_ids,
        file_names=names,
        track_ids=g["ids"],
        head_boxes=heads,
        video_id=video,
    )
    return detections, gt
